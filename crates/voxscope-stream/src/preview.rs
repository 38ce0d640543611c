//! A coarse level of a pyramid read whole, as a [`QuantizedVolume`]: what the transfer
//! function's defaults (the robust window, the data kind) are taken from when the volume
//! itself is never in memory.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::pyramid::PyramidShape;
use crate::{BRICK_SIZE, BrickData, BrickError, BrickId, BrickSource, PADDED_BRICK};
use voxscope_volume::{Histogram, QuantizedVolume};

/// The level [`preview`] reads: the finest with at most `max_bricks` bricks (the coarsest if
/// none is that small).
pub(crate) fn preview_level(shape: &PyramidShape, max_bricks: u64) -> usize {
    shape
        .levels
        .iter()
        .position(|l| l.brick_count() <= max_bricks)
        .unwrap_or(shape.levels.len() - 1)
}

/// Threads a preview of a source over a network reads its bricks on, at least (as many as a
/// URL's streamer has loaders): each waits on the network most of its time, not on a core.
const REMOTE_READERS: usize = 8;

/// The bricks `ids` read on up to `threads` threads of their own (plain threads: a read that
/// waits for a URL's reader pool waits without running anything else), each taking the next
/// brick when it is done; in `ids`' order. Where no thread can be started, on this one.
fn read_on_threads(
    source: &dyn BrickSource,
    ids: &[BrickId],
    threads: usize,
) -> Vec<(BrickId, Result<BrickData, BrickError>)> {
    let next = AtomicUsize::new(0);
    let work = || {
        let mut read = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(&id) = ids.get(i) else {
                return read;
            };
            read.push((i, (id, source.read_brick(id))));
        }
    };
    let mut read = std::thread::scope(|scope| {
        let readers: Vec<_> = (0..threads.min(ids.len()))
            .map_while(|i| {
                std::thread::Builder::new()
                    .name(format!("voxscope-preview-{i}"))
                    .spawn_scoped(scope, work)
                    .ok()
            })
            .collect();
        // Whatever no reader took (all of it where none started).
        let mut read = work();
        for reader in readers {
            match reader.join() {
                Ok(part) => read.extend(part),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        read
    });
    read.sort_unstable_by_key(|&(i, _)| i);
    read.into_iter().map(|(_, read)| read).collect()
}

/// The finest level of `source` with at most `max_bricks` bricks (the coarsest if none is
/// that small), read whole: its voxels' levels and histogram; and which level it is. A brick
/// that cannot be read is left out of the histogram (its voxels hold the lowest level read):
/// one damaged chunk costs the defaults a little of their data, not the open. Only when no
/// brick can be read is it an error (the first one's).
pub fn preview(
    source: &dyn BrickSource,
    max_bricks: u64,
) -> Result<(QuantizedVolume, usize), BrickError> {
    let shape = source.shape();
    let level = preview_level(shape, max_bricks);
    let info = shape.levels[level];
    let [gx, gy, gz] = info.grid;
    let ids: Vec<BrickId> = (0..gz)
        .flat_map(|z| (0..gy).flat_map(move |y| (0..gx).map(move |x| [x, y, z])))
        .map(|brick| BrickId::new(level as u32, brick.map(|c| c as u32)))
        .collect();
    let read: Vec<(BrickId, Result<BrickData, BrickError>)> = if source.remote_stats().is_some() {
        let threads = REMOTE_READERS.max(rayon::current_num_threads());
        read_on_threads(source, &ids, threads)
    } else {
        ids.par_iter()
            .map(|&id| (id, source.read_brick(id)))
            .collect()
    };
    let mut bricks = Vec::with_capacity(read.len());
    let mut first_error = None;
    for (id, result) in read {
        match result {
            Ok(data) => bricks.push((id, data)),
            Err(error) => {
                first_error.get_or_insert(error);
            }
        }
    }
    if bricks.is_empty()
        && let Some(error) = first_error
    {
        return Err(error);
    }
    let [dx, dy, dz] = info.dims;
    let mut levels = vec![0u16; dx * dy * dz];
    let mut read_voxels = first_error.is_some().then(|| vec![false; levels.len()]);
    for (id, data) in bricks {
        let first = id.brick.map(|c| c as usize * BRICK_SIZE);
        for z in 0..BRICK_SIZE.min(dz - first[2]) {
            for y in 0..BRICK_SIZE.min(dy - first[1]) {
                let row = 1 + PADDED_BRICK * ((y + 1) + PADDED_BRICK * (z + 1));
                let count = BRICK_SIZE.min(dx - first[0]);
                let out = first[0] + dx * ((first[1] + y) + dy * (first[2] + z));
                levels[out..out + count].copy_from_slice(&data.levels[row..row + count]);
                if let Some(read) = &mut read_voxels {
                    read[out..out + count].fill(true);
                }
            }
        }
    }
    let quantization = source.quantization();
    let mut counts = vec![0u64; 1 << 16];
    let (mut low, mut high, mut total) = (u16::MAX, 0u16, 0u64);
    for (i, &l) in levels.iter().enumerate() {
        if read_voxels.as_ref().is_none_or(|read| read[i]) {
            counts[l as usize] += 1;
            (low, high, total) = (low.min(l), high.max(l), total + 1);
        }
    }
    if let Some(read) = &read_voxels {
        for (level, _) in levels.iter_mut().zip(read).filter(|(_, read)| !**read) {
            *level = low;
        }
    }
    let (low, high) = if total == 0 { (0, 0) } else { (low, high) };
    Ok((
        QuantizedVolume {
            dims: info.dims,
            histogram: Histogram {
                counts,
                quantization,
                total,
            },
            levels,
            quantization,
            value_range: [quantization.value(low), quantization.value(high)],
        },
        level,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Downsampling, MemorySource};
    use voxscope_volume::Quantization;

    #[test]
    fn the_preview_is_the_finest_level_that_small_voxel_for_voxel() {
        let dims = [70, 40, 33];
        let levels: Vec<u16> = (0..dims.iter().product::<usize>())
            .map(|i| (i % 997) as u16)
            .collect();
        let quantization = Quantization {
            offset: 0.0,
            step: 1.0,
        };
        let source = MemorySource::from_levels(
            "test",
            levels.clone(),
            dims,
            quantization,
            [1.0; 3],
            Downsampling::Mean,
        )
        .expect("source");
        // Level 0 has 3×2×2 = 12 bricks.
        let (whole, level) = preview(&source, 12).expect("preview");
        assert_eq!((level, whole.dims), (0, dims));
        assert_eq!(whole.levels, levels);
        assert_eq!(whole.histogram.total, levels.len() as u64);
        let (coarse, level) = preview(&source, 11).expect("preview");
        assert_eq!((level, coarse.dims), (1, [35, 20, 17]));
        assert_eq!(coarse.levels, source.level(1).expect("level 1"));
    }
}
