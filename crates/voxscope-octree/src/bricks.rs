//! Brick leaves: the octree cut at the level where a node spans `brick_size`³ voxels. Nodes
//! there that still have children become bricks, whose voxels go to a 3D atlas (with a
//! one-voxel apron, so hardware trilinear filtering is seamless across bricks). Inner nodes keep
//! the 8-byte layout, colors and bounds, so empty-space skipping and LOD work as before.
//! Pure CPU: the GPU upload is `render::GpuBricks`.

use rayon::prelude::*;

use super::{LEAF, Node, Octree, ValueBounds};
use voxscope_volume::QuantizedVolume;

/// Set in `first_child` of a brick leaf; the low 31 bits are its atlas slot.
/// (`LEAF` has this bit too: a brick is `first_child != LEAF && first_child & BRICK_FLAG != 0`.)
pub const BRICK_FLAG: u32 = 0x8000_0000;

/// The octree prefix through the brick level, and the brick atlas.
#[derive(Debug, Clone)]
pub struct BrickLayout {
    /// Voxels along a brick's side (a power of two).
    pub brick_size: usize,
    /// Level whose nodes span one brick.
    pub brick_level: u32,
    /// Nodes of levels `0..=brick_level`; brick leaves carry `BRICK_FLAG | slot`.
    pub nodes: Vec<Node>,
    pub bounds: Vec<ValueBounds>,
    /// `level_starts` through `brick_level + 1`.
    pub level_starts: Vec<usize>,
    /// Bricks along x, y, z of the atlas.
    pub atlas_grid: [usize; 3],
    /// Value levels of the atlas, x fastest: `atlas_grid * (brick_size + 2)` per axis.
    pub atlas: Vec<u16>,
    /// First voxel of each brick slot.
    pub brick_origins: Vec<[usize; 3]>,
    /// Brick cells along x, y, z that the volume touches (`dims / brick_size`, rounded up).
    pub grid_dims: [usize; 3],
    /// For each brick cell, x fastest, the node covering it: its brick, or a leaf above the
    /// brick level. What a ray walking the cells reads instead of descending the tree.
    pub grid_leaves: Vec<u32>,
    /// The octree's values are labels ([`Octree::labels`]).
    pub labels: bool,
}

/// Why an octree cannot be cut into bricks: displays as the one line of the renderer's
/// "does not fit".
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum BrickLayoutError {
    /// A brick size that is not a power of two of at least 2.
    #[error("brick size {0} is not a power of two of at least 2")]
    BrickSize(usize),
    /// More bricks than an atlas of the device's largest side holds.
    #[error(
        "{count} bricks do not fit an atlas of {max_atlas_side} texels per side; use larger bricks"
    )]
    AtlasTooSmall { count: usize, max_atlas_side: usize },
}

impl BrickLayout {
    /// Cuts `octree` (built from `volume`) at bricks of `brick_size`³ voxels, with atlas sides
    /// of at most `max_atlas_side` texels.
    pub fn new(
        octree: &Octree,
        volume: &QuantizedVolume,
        brick_size: usize,
        max_atlas_side: usize,
    ) -> Result<Self, BrickLayoutError> {
        if !brick_size.is_power_of_two() || brick_size < 2 {
            return Err(BrickLayoutError::BrickSize(brick_size));
        }
        let brick_level = octree.depth.saturating_sub(brick_size.trailing_zeros());
        let side = octree.side();
        let end = octree.level_starts[brick_level as usize + 1];
        let mut nodes = octree.nodes[..end].to_vec();
        let bounds = octree.bounds[..end].to_vec();

        // Cell coordinates of the brick-level nodes, walking down from the root.
        let mut cells: Vec<[usize; 3]> = vec![[0; 3]];
        for level in 0..brick_level {
            let range = octree.level_range(level);
            let mut next = vec![[0usize; 3]; octree.level_range(level + 1).len()];
            let next_start = octree.level_starts[level as usize + 1];
            for (node, cell) in octree.nodes[range].iter().zip(&cells) {
                if node.is_leaf() {
                    continue;
                }
                for child in 0..8 {
                    let offset = [child & 1, (child >> 1) & 1, child >> 2];
                    next[node.first_child as usize - next_start + child] =
                        std::array::from_fn(|a| 2 * cell[a] + offset[a]);
                }
            }
            cells = next;
        }
        let cell_size = side >> brick_level;
        let mut brick_origins = Vec::new();
        for (index, cell) in octree.level_range(brick_level).zip(&cells) {
            if nodes[index].first_child != LEAF {
                nodes[index].first_child = BRICK_FLAG | brick_origins.len() as u32;
                brick_origins.push(cell.map(|c| c * cell_size));
            }
        }
        let padded = brick_size + 2;
        // The ray caster packs atlas cells in ten bits per axis.
        let per_axis_limit = (max_atlas_side / padded).clamp(1, 1024);
        let count = brick_origins.len().max(1);
        let gx = ((count as f64).cbrt().ceil() as usize).clamp(1, per_axis_limit);
        let gy = count.div_ceil(gx).min(gx).clamp(1, per_axis_limit);
        let gz = count.div_ceil(gx * gy);
        if gz > per_axis_limit {
            return Err(BrickLayoutError::AtlasTooSmall {
                count,
                max_atlas_side,
            });
        }
        let atlas_grid = [gx, gy, gz];
        let atlas_dims = atlas_grid.map(|g| g * padded);
        let mut atlas = vec![0u16; atlas_dims.iter().product()];
        // Fill one z-slab of bricks per task; each brick copies its voxels and a one-voxel apron,
        // clamped at the volume's edge (what a clamp-to-edge sampler would read).
        let dims = volume.dims;
        let slab = atlas_dims[0] * atlas_dims[1] * padded;
        atlas
            .par_chunks_mut(slab)
            .enumerate()
            .for_each(|(bz, slab)| {
                for by in 0..gy {
                    for bx in 0..gx {
                        let slot = bx + gx * (by + gy * bz);
                        let Some(origin) = brick_origins.get(slot) else {
                            continue;
                        };
                        for k in 0..padded {
                            let z = clamp_voxel(origin[2], k, dims[2]);
                            for j in 0..padded {
                                let y = clamp_voxel(origin[1], j, dims[1]);
                                let row = bx * padded
                                    + atlas_dims[0] * (by * padded + j + atlas_dims[1] * k);
                                for i in 0..padded {
                                    let x = clamp_voxel(origin[0], i, dims[0]);
                                    slab[row + i] = volume.levels[x + dims[0] * (y + dims[1] * z)];
                                }
                            }
                        }
                    }
                }
            });
        let grid_dims = dims.map(|d| d.div_ceil(brick_size));
        let grid_leaves = grid_leaves(octree, brick_level, grid_dims);
        Ok(Self {
            brick_size,
            brick_level,
            grid_dims,
            grid_leaves,
            nodes,
            bounds,
            level_starts: octree.level_starts[..brick_level as usize + 2].to_vec(),
            atlas_grid,
            atlas,
            brick_origins,
            labels: octree.labels,
        })
    }

    /// Where brick `slot` sits in the atlas, in bricks along x, y, z (slots fill x first).
    pub fn atlas_cell(&self, slot: usize) -> [usize; 3] {
        let [gx, gy, _] = self.atlas_grid;
        [slot % gx, (slot / gx) % gy, slot / (gx * gy)]
    }

    /// Texels of the atlas along x, y, z.
    pub fn atlas_dims(&self) -> [usize; 3] {
        self.atlas_grid.map(|g| g * (self.brick_size + 2))
    }
}

/// For each cell of `grid_dims` (x fastest), the node of level ≤ `brick_level` covering it:
/// the descent from the root stops at a leaf or at the brick level.
fn grid_leaves(octree: &Octree, brick_level: u32, grid_dims: [usize; 3]) -> Vec<u32> {
    let mut leaves = Vec::with_capacity(grid_dims.iter().product());
    for z in 0..grid_dims[2] {
        for y in 0..grid_dims[1] {
            for x in 0..grid_dims[0] {
                let mut index = 0usize;
                for level in 0..brick_level {
                    let node = octree.nodes[index];
                    if node.is_leaf() {
                        break;
                    }
                    let shift = brick_level - 1 - level;
                    let octant =
                        ((x >> shift) & 1) | ((y >> shift) & 1) << 1 | ((z >> shift) & 1) << 2;
                    index = node.first_child as usize + octant;
                }
                leaves.push(index as u32);
            }
        }
    }
    leaves
}

/// Voxel coordinate of apron index `i` (0 is the apron before the brick) clamped to the volume.
fn clamp_voxel(origin: usize, i: usize, extent: usize) -> usize {
    (origin + i).saturating_sub(1).min(extent - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BuildOptions, build};
    use voxscope_volume::{Volume, VoxelData};

    #[test]
    fn bricks_hold_their_voxels_and_aprons() {
        let dims = [19, 12, 9];
        let count = dims.iter().product::<usize>();
        let volume = Volume::new(
            "t",
            "test",
            dims,
            [1.0; 3],
            VoxelData::U16((0..count as u16).collect()),
        )
        .unwrap();
        let quantized = QuantizedVolume::new(&volume);
        let octree = build(&quantized, BuildOptions::default()).unwrap();
        let layout = BrickLayout::new(&octree, &quantized, 4, 2048).unwrap();
        assert_eq!(layout.brick_level, octree.depth - 2);
        assert_eq!(
            layout.nodes.len(),
            octree.level_starts[layout.brick_level as usize + 1]
        );
        let atlas_dims = layout.atlas_dims();
        let bricks = layout
            .nodes
            .iter()
            .filter(|n| n.first_child != LEAF && n.first_child & BRICK_FLAG != 0)
            .count();
        assert_eq!(bricks, layout.brick_origins.len());
        // Each brick cell points at its own brick (this volume has no uniform region).
        assert_eq!(layout.grid_dims, [5, 3, 3]);
        let mut cell_index = 0;
        for z in 0..3 {
            for y in 0..3 {
                for x in 0..5 {
                    let node = layout.nodes[layout.grid_leaves[cell_index] as usize];
                    assert!(node.first_child != LEAF && node.first_child & BRICK_FLAG != 0);
                    let slot = (node.first_child & !BRICK_FLAG) as usize;
                    assert_eq!(layout.brick_origins[slot], [x * 4, y * 4, z * 4]);
                    cell_index += 1;
                }
            }
        }
        for (slot, origin) in layout.brick_origins.iter().enumerate() {
            let cell = layout.atlas_cell(slot);
            for k in 0..6 {
                for j in 0..6 {
                    for i in 0..6 {
                        let texel = [cell[0] * 6 + i, cell[1] * 6 + j, cell[2] * 6 + k];
                        let stored = layout.atlas
                            [texel[0] + atlas_dims[0] * (texel[1] + atlas_dims[1] * texel[2])];
                        let voxel = [i, j, k].map(|c| c as i64 - 1);
                        let clamped: [usize; 3] = std::array::from_fn(|a| {
                            (origin[a] as i64 + voxel[a]).clamp(0, dims[a] as i64 - 1) as usize
                        });
                        let expected = quantized.levels
                            [clamped[0] + dims[0] * (clamped[1] + dims[1] * clamped[2])];
                        assert_eq!(stored, expected, "slot {slot} texel {i},{j},{k}");
                    }
                }
            }
        }
    }
}
