//! Stored values to the pyramid's value levels: the store's quantization, values turned into
//! levels, and a brick's padded voxels gathered from a stored level or reduced from a finer
//! one (mean, or the mode for labels).

use super::*;

/// A quantization for every brick of the pyramid: 8- and 16-bit integers keep their values
/// (one level each); wider and floating-point data spread the range that the stored chunk
/// ranges, the `omero` window's range or the coarsest level give over 65 536 levels (values
/// outside it clamp).
pub(super) fn quantization_of(pyramid: &Pyramid) -> Result<(Quantization, u16), SourceError> {
    let exact = |offset: f64, max: u16| Ok((Quantization { offset, step: 1.0 }, max));
    match pyramid.voxel_type {
        VoxelType::U8 => return exact(0.0, u8::MAX as u16),
        VoxelType::I8 => return exact(i8::MIN as f64, u8::MAX as u16),
        VoxelType::U16 => return exact(0.0, u16::MAX),
        VoxelType::I16 => return exact(i16::MIN as f64, u16::MAX),
        _ => {}
    }
    let from_chunks = pyramid.chunk_ranges(0)?.and_then(|ranges| {
        let finite = ranges
            .iter()
            .filter(|r| r[0].is_finite() && r[1].is_finite());
        finite.fold(None, |acc: Option<[f64; 2]>, r| {
            Some(acc.map_or(*r, |a| [a[0].min(r[0]), a[1].max(r[1])]))
        })
    });
    let from_omero = || {
        pyramid
            .omero
            .get(pyramid.selected.channel)
            .and_then(|c| c.range)
    };
    let range = match from_chunks.or_else(from_omero) {
        Some(range) => range,
        None => {
            let coarsest = pyramid.levels.len() - 1;
            if pyramid.levels[coarsest].voxel_count() > MAX_BRICK_READ {
                return Err(SourceError::NoValueRange(pyramid.source.clone()));
            }
            let data = pyramid.read_level(coarsest)?;
            with_voxel_slice!(&data, values => values.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |r, v| {
                let v = v.to_f64();
                if v.is_finite() { [r[0].min(v), r[1].max(v)] } else { r }
            }))
        }
    };
    let [min, max] = if range[0] <= range[1] {
        range
    } else {
        [0.0, 0.0]
    };
    let span = max - min;
    let step = if span <= 0.0 || (pyramid.voxel_type.is_integer() && span <= u16::MAX as f64) {
        1.0
    } else {
        span / u16::MAX as f64
    };
    Ok((Quantization { offset: min, step }, u16::MAX))
}

/// The pyramid voxels of a padded brick whose first own voxel is `first`, clamped to the
/// level's `dims`, per axis.
pub(super) fn padded_voxels(first: [usize; 3], dims: [usize; 3]) -> [Vec<usize>; 3] {
    std::array::from_fn(|a| {
        (0..PADDED_BRICK)
            .map(|i| (first[a] + i).saturating_sub(1).min(dims[a] - 1))
            .collect()
    })
}

/// The padded brick of the pyramid voxels `voxels` (x, y, z), each the mean, max or mode
/// (`how`) of the `ratio` stored voxels per axis it covers within the stored level's `dims`,
/// from `stored`, the stored region `[origin, origin + size)` that [`stored_region`] gave.
pub(super) fn reduce_padded(
    stored: &[u16],
    origin: [usize; 3],
    size: [usize; 3],
    voxels: &[Vec<usize>; 3],
    ratio: [usize; 3],
    stored_dims: [usize; 3],
    how: Downsampling,
) -> Vec<u16> {
    // Each distinct pyramid voxel (the apron and the part past the level's end repeat the
    // edge ones): the mean (or max) of the stored voxels it covers, computed once.
    let distinct: [Vec<usize>; 3] = std::array::from_fn(|a| {
        let mut values = voxels[a].clone();
        values.dedup();
        values
    });
    let boxes: [Vec<(usize, usize)>; 3] = std::array::from_fn(|a| {
        distinct[a]
            .iter()
            .map(|&c| {
                let (lo, hi) = covered(c, c, ratio[a], stored_dims[a]);
                (lo - origin[a], hi - origin[a])
            })
            .collect()
    });
    let [sx, sy, _] = size;
    let mut reduced = Vec::with_capacity(boxes.iter().map(Vec::len).product());
    for &(z0, z1) in &boxes[2] {
        for &(y0, y1) in &boxes[1] {
            for &(x0, x1) in &boxes[0] {
                let (mut sum, mut max, mut count) = (0u64, 0u16, 0u64);
                let mut block = Vec::new();
                for z in z0..=z1 {
                    for y in y0..=y1 {
                        let row = sx * (y + sy * z);
                        for &v in &stored[row + x0..=row + x1] {
                            sum += v as u64;
                            max = max.max(v);
                            count += 1;
                            if how == Downsampling::Mode {
                                block.push(v);
                            }
                        }
                    }
                }
                reduced.push(match how {
                    Downsampling::Mean => ((sum + count / 2) / count) as u16,
                    Downsampling::Max => max,
                    Downsampling::Mode => mode_of_block(&mut block),
                });
            }
        }
    }
    // Where each padded voxel's pyramid voxel sits among the distinct ones.
    let index: [Vec<usize>; 3] = std::array::from_fn(|a| {
        voxels[a]
            .iter()
            .map(|c| distinct[a].partition_point(|d| d < c))
            .collect()
    });
    let [dx, dy] = [distinct[0].len(), distinct[1].len()];
    let mut levels = Vec::with_capacity(PADDED_BRICK_VOXELS);
    for &k in &index[2] {
        for &j in &index[1] {
            for &i in &index[0] {
                levels.push(reduced[i + dx * (j + dy * k)]);
            }
        }
    }
    levels
}

/// The padded brick of the pyramid voxels `voxels` (x, y, z; each clamped to the stored
/// level's `dims`) where each is one stored voxel, from `stored`, the stored region `[origin,
/// origin + size)` that [`stored_region`] gave for them: x rows copied where they are
/// contiguous (every brick but the level's first and last along x).
pub(super) fn gather_padded(
    stored: Vec<u16>,
    origin: [usize; 3],
    size: [usize; 3],
    voxels: &[Vec<usize>; 3],
    dims: [usize; 3],
) -> Vec<u16> {
    let local: [Vec<usize>; 3] = std::array::from_fn(|a| {
        voxels[a]
            .iter()
            .map(|&c| c.min(dims[a] - 1) - origin[a])
            .collect()
    });
    let [xs, ys, zs] = &local;
    if size == [PADDED_BRICK; 3]
        && local
            .iter()
            .all(|axis| axis.iter().enumerate().all(|(i, &c)| i == c))
    {
        // The region is the padded brick (every brick inside the level).
        return stored;
    }
    let contiguous = xs.windows(2).all(|pair| pair[1] == pair[0] + 1);
    let mut levels = Vec::with_capacity(PADDED_BRICK_VOXELS);
    for &z in zs {
        for &y in ys {
            let row = &stored[size[0] * (y + size[1] * z)..][..size[0]];
            if contiguous {
                levels.extend_from_slice(&row[xs[0]..=xs[xs.len() - 1]]);
            } else {
                levels.extend(xs.iter().map(|&x| row[x]));
            }
        }
    }
    levels
}

/// The stored voxels (origin and size) that the pyramid voxels `voxels` cover, `ratio`
/// stored voxels each along each axis, within the stored level's `dims`.
pub(super) fn stored_region(
    voxels: &[Vec<usize>; 3],
    ratio: [usize; 3],
    dims: [usize; 3],
) -> ([usize; 3], [usize; 3]) {
    let spans: [(usize, usize); 3] = std::array::from_fn(|a| {
        let (c0, c1) = (voxels[a][0], voxels[a][PADDED_BRICK - 1]);
        covered(c0, c1, ratio[a], dims[a])
    });
    (
        spans.map(|(first, _)| first),
        std::array::from_fn(|a| spans[a].1 - spans[a].0 + 1),
    )
}

/// Each stored value's level (non-finite values as level 0), in the values' own buffer where
/// they are 16-bit (a chunk's half a megabyte neither allocated nor copied again).
pub(super) fn to_levels(data: VoxelData, quantization: Quantization) -> Vec<u16> {
    // Integers one level apart: each level is the value less the offset, in integers (what
    // the rounding below gives them, at a fraction of its cost).
    let data = if quantization.step == 1.0
        && quantization.offset.fract() == 0.0
        && quantization.offset.abs() <= i32::MAX as f64
    {
        let offset = quantization.offset as i64;
        match data {
            // Already the levels.
            VoxelData::U16(values) if offset == 0 => return values,
            // In 32 bits where the values fit (four times as many a vector instruction).
            VoxelData::U8(values) => return narrow_integer_levels(values, offset),
            VoxelData::I8(values) => return narrow_integer_levels(values, offset),
            VoxelData::U16(values) => return narrow_integer_levels(values, offset),
            VoxelData::I16(values) => return narrow_integer_levels(values, offset),
            VoxelData::U32(values) => return integer_levels(values, offset),
            VoxelData::I32(values) => return integer_levels(values, offset),
            data @ (VoxelData::F32(_) | VoxelData::F64(_)) => data,
        }
    } else {
        data
    };
    with_voxel_slice!(&data, values => values
        .iter()
        .map(|v| {
            let value = v.to_f64();
            if value.is_finite() { quantization.level(value) } else { 0 }
        })
        .collect())
}

/// [`integer_levels`] of values of at most 16 bits (16-bit values' levels written over them:
/// the collect reuses their buffer).
pub(super) fn narrow_integer_levels<T: Copy + Into<i32>>(values: Vec<T>, offset: i64) -> Vec<u16> {
    // An offset beyond ±2²⁰ leaves every level of a 16-bit value at one end, as beyond it.
    let offset = offset.clamp(-(1 << 20), 1 << 20) as i32;
    values
        .into_iter()
        .map(|v| (v.into() - offset).clamp(0, u16::MAX as i32) as u16)
        .collect()
}

/// Integer values' levels at step 1: the value less `offset`, clamped to the 16-bit range.
pub(super) fn integer_levels<T: Copy + Into<i64>>(values: Vec<T>, offset: i64) -> Vec<u16> {
    values
        .into_iter()
        .map(|v| (v.into() - offset).clamp(0, u16::MAX as i64) as u16)
        .collect()
}

/// The most frequent value of `block` (ties to the larger), sorting it.
pub(super) fn mode_of_block(block: &mut [u16]) -> u16 {
    block.sort_unstable();
    let mut best = (0usize, 0u16);
    for run in block.chunk_by(|a, b| a == b) {
        if (run.len(), run[0]) > best {
            best = (run.len(), run[0]);
        }
    }
    best.1
}
