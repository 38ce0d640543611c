//! A box of a pyramid's finest level read for `convert` ([`super::SlabSource`]): in one
//! region read where it is small enough, else in bands of whole chunk rows along y, each
//! read at the slab's full depth (so no chunk is decoded twice) and interleaved plane by
//! plane. A band holds at most [`BAND_VOXELS`] voxels and [`BAND_CHUNKS`] chunks, well inside
//! what one region read allows (2³² voxels; over a network, 16 384 requests).

use crate::error::Problem;
use crate::ome_zarr::Pyramid;
use crate::{Scalar, VoxelData, with_voxel_slice};

/// The most voxels one band reads.
const BAND_VOXELS: usize = 1 << 31;
/// The most chunks one band reads.
const BAND_CHUNKS: usize = 8192;

/// The box `origin .. origin + size` (x, y, z) of `pyramid`'s level 0, x fastest.
pub(super) fn read(
    pyramid: &Pyramid,
    origin: [usize; 3],
    size: [usize; 3],
) -> Result<VoxelData, Problem> {
    let [x0, y0, z0] = origin;
    let [width, height, count] = size;
    let rows = band_rows([width, height, count], pyramid.levels[0].chunk, count);
    let region = |y: usize, rows: usize| {
        pyramid
            .read_region(0, [x0, y, z0], [width, rows, count])
            .map_err(|e| e.problem)
    };
    if rows >= height {
        return region(y0, height);
    }
    let mut bands = Vec::new();
    for y in (y0..y0 + height).step_by(rows) {
        let band = rows.min(y0 + height - y);
        bands.push((band, region(y, band)?));
    }
    Ok(interleaved(&bands, width, count))
}

/// Rows of a band: whole chunk rows, as many as [`BAND_VOXELS`] and [`BAND_CHUNKS`] allow
/// (at least one chunk row).
fn band_rows(dims: [usize; 3], chunk: [usize; 3], count: usize) -> usize {
    let [cx, cy, cz] = chunk.map(|c| c.max(1));
    let row_voxels = dims[0].saturating_mul(count).max(1);
    let chunk_row_chunks = dims[0].div_ceil(cx).saturating_mul(count.div_ceil(cz) + 1);
    let by_voxels = BAND_VOXELS / row_voxels / cy;
    let by_chunks = BAND_CHUNKS / chunk_row_chunks.max(1);
    by_voxels.min(by_chunks).max(1).saturating_mul(cy)
}

/// Bands (each `height` rows of `count` planes, `width` voxels a row) as one slab: for each
/// plane, every band's rows of it in turn.
fn interleaved(bands: &[(usize, VoxelData)], width: usize, count: usize) -> VoxelData {
    fn part<T: Scalar>(values: &[T], from: usize, to: usize) -> VoxelData {
        T::wrap(values[from..to].to_vec())
    }
    let mut slab: Option<VoxelData> = None;
    for z in 0..count {
        for (height, band) in bands {
            let plane = width * height;
            let rows = with_voxel_slice!(band, values => part(values, z * plane, (z + 1) * plane));
            match &mut slab {
                None => slab = Some(rows),
                // Every band is read from one level: one type.
                Some(slab) => slab.append(rows).expect("bands of one level share a type"),
            }
        }
    }
    slab.unwrap_or_else(|| VoxelData::U8(Vec::new()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_are_whole_chunk_rows_within_the_bounds() {
        // A 4096² plane of 64³ chunks, 64 planes: the whole slab in one band.
        assert_eq!(band_rows([4096, 4096, 640], [64, 64, 64], 64), 4096);
        // 20 000² planes: bands of whole chunk rows under 2³¹ voxels.
        let rows = band_rows([20_000, 20_000, 640], [64, 64, 64], 64);
        assert!(
            rows.is_multiple_of(64) && rows * 20_000 * 64 <= BAND_VOXELS,
            "{rows}"
        );
        // Thin chunks: bounded by the chunk count.
        let rows = band_rows([4096, 4096, 64], [32, 32, 1], 64);
        assert_eq!(rows, 32);
    }

    #[test]
    fn bands_interleave_plane_by_plane() {
        // Two planes of 2 x 3 voxels read as a band of 2 rows and one of 1.
        let top = VoxelData::U8(vec![0, 1, 2, 3, 6, 7, 8, 9]);
        let bottom = VoxelData::U8(vec![4, 5, 10, 11]);
        let slab = interleaved(&[(2, top), (1, bottom)], 2, 2);
        assert_eq!(slab, VoxelData::U8((0..12).collect()));
    }
}
