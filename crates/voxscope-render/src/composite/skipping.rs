//! The composite's empty-space skipping: per block of [`SKIP_BLOCK`]³ voxels, the value levels
//! a sample there can take, and whether some shown channel is visible within them (DVR rays
//! pass over blocks where none is; composite.wgsl's `empty_block_exit`).

use voxscope_octree::unpack_rgba;
use voxscope_volume::QuantizedVolume;

use super::ChannelLayer;

/// Voxels along a side of an empty-space-skipping block (keep in sync with composite.wgsl).
pub(super) const SKIP_BLOCK: usize = 8;

/// Per block of [`SKIP_BLOCK`]³ voxels, the smallest and largest value level a filtered sample
/// there can round to: the block's and its neighbours' voxels (a trilinear sample reads one
/// voxel beyond its block), as the 16-bit float texture holds them.
pub(super) fn block_ranges(quantized: &QuantizedVolume) -> Vec<[u16; 2]> {
    let dims = quantized.dims;
    let grid = dims.map(|d| d.div_ceil(SKIP_BLOCK));
    let mut own = vec![[u16::MAX, 0u16]; grid.iter().product()];
    let cell = |x: usize, y: usize, z: usize| x + grid[0] * (y + grid[1] * z);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            let row = dims[0] * (y + dims[1] * z);
            for x in 0..dims[0] {
                let stored = half::f16::from_f32(quantized.levels[row + x] as f32).to_f32();
                let range = &mut own[cell(x / SKIP_BLOCK, y / SKIP_BLOCK, z / SKIP_BLOCK)];
                range[0] = range[0].min(stored.floor() as u16);
                range[1] = range[1].max(stored.ceil().min(65535.0) as u16);
            }
        }
    }
    let mut ranges = own.clone();
    for z in 0..grid[2] {
        for y in 0..grid[1] {
            for x in 0..grid[0] {
                let range = &mut ranges[cell(x, y, z)];
                for nz in z.saturating_sub(1)..(z + 2).min(grid[2]) {
                    for ny in y.saturating_sub(1)..(y + 2).min(grid[1]) {
                        for nx in x.saturating_sub(1)..(x + 2).min(grid[0]) {
                            let [low, high] = own[cell(nx, ny, nz)];
                            range[0] = range[0].min(low);
                            range[1] = range[1].max(high);
                        }
                    }
                }
            }
        }
    }
    ranges
}

/// Per block, 1 where some shown layer's table has an opacity above 0 within the block's range
/// of that layer's levels (`ranges[layer]`), else 0.
pub(super) fn visible_blocks(
    layers: &[ChannelLayer<'_>],
    ranges: &[Vec<[u16; 2]>],
    shown: &[bool],
) -> Vec<u32> {
    let blocks = ranges.first().map_or(0, Vec::len);
    let mut visible = vec![0u32; blocks];
    for ((layer, ranges), _) in layers
        .iter()
        .zip(ranges)
        .zip(shown)
        .filter(|(_, shown)| **shown)
    {
        // How many levels below each level are visible: a range's count in O(1).
        let table = layer.transfer.lookup_table(layer.quantized.quantization);
        let mut below = Vec::with_capacity(table.len() + 1);
        below.push(0u32);
        for &packed in &table {
            let last = *below.last().expect("starts with 0");
            below.push(last + (unpack_rgba(packed)[3] > 0) as u32);
        }
        for (flag, &[low, high]) in visible.iter_mut().zip(ranges) {
            if low <= high && below[high as usize + 1] > below[low as usize] {
                *flag = 1;
            }
        }
    }
    visible
}
