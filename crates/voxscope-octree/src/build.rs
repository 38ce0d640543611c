//! Building the flat list bottom-up: value bounds for every level from the voxels, kept only
//! for the cells the volume touches (memory in proportion to the voxels, not to the padded
//! cube), then the list top-down, level by level, so that each level's nodes follow their
//! parents' order and each parent's 8 children sit together.

use std::fmt;
use std::time::Instant;

use rayon::prelude::*;

use super::{LEAF, Node, Octree, ValueBounds};
use voxscope_volume::QuantizedVolume;
use voxscope_volume::progress::Progress;

/// Deepest supported octree (a 1024³ cube): cells of every level fit in `u32`.
pub const MAX_DEPTH: u32 = 10;

/// Choices of the build.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuildOptions {
    /// Collapse subtrees whose voxels are all equal (or all padding) into one leaf. Lossless:
    /// such a leaf has the color its voxels would have.
    pub collapse_uniform: bool,
    /// The values are labels ([`crate::DataKind::Labels`]): recorded in [`Octree::labels`].
    pub labels: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            collapse_uniform: true,
            labels: false,
        }
    }
}

/// Why an octree could not be built.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BuildError {
    /// The [`Progress`] was cancelled; nothing is wrong with the volume.
    Cancelled,
    /// The volume's longest axis needs a deeper tree than [`MAX_DEPTH`].
    TooDeep { longest: usize, depth: u32 },
    /// The flat list would need node indices beyond `u32`.
    TooManyNodes,
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cancelled => f.write_str("cancelled"),
            Self::TooDeep { longest, depth } => write!(
                f,
                "a volume {longest} voxels long needs an octree of depth {depth}; the voxel octree supports up to {} voxels per axis (depth {MAX_DEPTH})",
                1 << MAX_DEPTH
            ),
            Self::TooManyNodes => write!(
                f,
                "the octree would have more than {LEAF} nodes; use a smaller volume"
            ),
        }
    }
}

impl std::error::Error for BuildError {}

/// Builds the octree of `volume`. Colors are left at zero: call [`super::recolor`] with a
/// transfer function's lookup table.
pub fn build(volume: &QuantizedVolume, options: BuildOptions) -> Result<Octree, BuildError> {
    build_with_progress(volume, options, &Progress::new())
}

/// [`build`], reporting its fraction done to `progress` (stage `building octree`) and stopping
/// with an error between levels once `progress` is cancelled.
pub fn build_with_progress(
    volume: &QuantizedVolume,
    options: BuildOptions,
    progress: &Progress,
) -> Result<Octree, BuildError> {
    let started = Instant::now();
    progress.begin("building octree");
    let dims = volume.dims;
    let longest = dims.iter().copied().max().unwrap_or(1);
    let depth = longest.next_power_of_two().trailing_zeros();
    if depth > MAX_DEPTH {
        return Err(BuildError::TooDeep { longest, depth });
    }
    // Progress: the voxel pass counts as many steps as all other levels together.
    let steps = 3.0 * depth as f32 + 2.0;
    let step_done = |step: f32| -> Result<(), BuildError> {
        progress.set_fraction(step / steps);
        progress.check().map_err(|_| BuildError::Cancelled)
    };
    let grids = bounds_per_level(volume, depth, &step_done)?;
    let side = 1usize << depth;

    // Bounds of a node: from the level grids, or from the voxel itself at the last level.
    // `cell` indexes the level's cubic grid of side 2^level, x fastest.
    let bounds_of = |level: u32, cell: u32| -> ValueBounds {
        let n = 1usize << level;
        let cell = cell as usize;
        let (x, y, z) = (cell % n, (cell / n) % n, cell / (n * n));
        if level < depth {
            return grids[level as usize].get(x, y, z);
        }
        if x < dims[0] && y < dims[1] && z < dims[2] {
            ValueBounds::single(volume.levels[x + dims[0] * (y + dims[1] * z)])
        } else {
            ValueBounds::EMPTY
        }
    };
    // A node is inside the volume when its whole box is; only those may collapse on
    // equal values (a box that is partly padding must stay split).
    let inside = |level: u32, cell: u32| -> bool {
        let n = 1usize << level;
        let size = side >> level;
        let cell = cell as usize;
        let corner = [cell % n, (cell / n) % n, cell / (n * n)];
        (0..3).all(|a| (corner[a] + 1) * size <= dims[a])
    };
    let is_leaf = |level: u32, cell: u32, bounds: ValueBounds| -> bool {
        level == depth
            || (options.collapse_uniform
                && (bounds.is_empty() || (bounds.is_uniform() && inside(level, cell))))
    };

    let mut nodes: Vec<Node> = Vec::new();
    let mut all_bounds: Vec<ValueBounds> = Vec::new();
    let mut level_starts = vec![0usize];
    let mut cells: Vec<u32> = vec![0];
    for level in 0..=depth {
        step_done(2.0 * depth as f32 + 1.0 + level as f32)?;
        let level_start = nodes.len();
        let next_level_start = level_start + cells.len();
        let level_bounds: Vec<ValueBounds> = cells
            .par_iter()
            .map(|&cell| bounds_of(level, cell))
            .collect();
        let leaves: Vec<bool> = cells
            .par_iter()
            .zip(&level_bounds)
            .map(|(&cell, &bounds)| is_leaf(level, cell, bounds))
            .collect();
        let inner = leaves.iter().filter(|&&leaf| !leaf).count();
        if (next_level_start + 8 * inner) as u64 >= LEAF as u64 {
            return Err(BuildError::TooManyNodes);
        }
        let mut rank = 0u32;
        nodes.extend(leaves.iter().map(|&leaf| Node {
            color: 0,
            first_child: if leaf {
                LEAF
            } else {
                rank += 1;
                next_level_start as u32 + 8 * (rank - 1)
            },
        }));
        all_bounds.extend(level_bounds);
        level_starts.push(nodes.len());
        if level == depth {
            break;
        }
        // Children cells of the inner nodes, in their parents' order.
        let parents: Vec<u32> = cells
            .par_iter()
            .zip(&leaves)
            .filter(|&(_, &leaf)| !leaf)
            .map(|(&cell, _)| cell)
            .collect();
        let n = 1u32 << level;
        let next_n = 2 * n;
        let mut next_cells = vec![0u32; parents.len() * 8];
        next_cells
            .par_chunks_mut(8)
            .zip(&parents)
            .for_each(|(children, &cell)| {
                let (x, y, z) = (cell % n, (cell / n) % n, cell / (n * n));
                for (child, slot) in children.iter_mut().enumerate() {
                    let child = child as u32;
                    let (cx, cy, cz) = (
                        2 * x + (child & 1),
                        2 * y + ((child >> 1) & 1),
                        2 * z + (child >> 2),
                    );
                    *slot = cx + next_n * (cy + next_n * cz);
                }
            });
        cells = next_cells;
    }

    progress.set_fraction(1.0);
    Ok(Octree {
        dims,
        depth,
        nodes,
        bounds: all_bounds,
        level_starts,
        quantization: volume.quantization,
        collapsed: options.collapse_uniform,
        labels: options.labels,
        build_seconds: started.elapsed().as_secs_f64(),
    })
}

/// The value bounds of the cells of one level that the volume touches: a grid of
/// `dims[a] / cell side` cells per axis (rounded up), x fastest. Cells beyond it hold only
/// padding and are [`ValueBounds::EMPTY`]; storing only these keeps the build's memory in
/// proportion to the voxels (a 1024×1×1 volume has 512×1×1 cells at its finest level, not
/// the 512³ of the padded cube).
struct LevelGrid {
    dims: [usize; 3],
    bounds: Vec<ValueBounds>,
}

impl LevelGrid {
    /// Bounds of cell (x, y, z) of the level's cubic grid (padding outside the volume).
    #[inline]
    fn get(&self, x: usize, y: usize, z: usize) -> ValueBounds {
        if x < self.dims[0] && y < self.dims[1] && z < self.dims[2] {
            self.bounds[x + self.dims[0] * (y + self.dims[1] * z)]
        } else {
            ValueBounds::EMPTY
        }
    }
}

/// Value bounds of the cells of levels `0..depth` (level `l` has cells of `2^(depth - l)`
/// voxels per side), each level holding only the cells the volume touches. Level `depth - 1`
/// reads 2×2×2 voxel blocks (padding beyond the volume is empty); each level above merges the
/// 8 children of each of its cells, one z-slab of cells per rayon task.
fn bounds_per_level(
    volume: &QuantizedVolume,
    depth: u32,
    step_done: &dyn Fn(f32) -> Result<(), BuildError>,
) -> Result<Vec<LevelGrid>, BuildError> {
    if depth == 0 {
        return Ok(Vec::new());
    }
    let dims = volume.dims;
    let voxel = |x: usize, y: usize, z: usize| -> ValueBounds {
        if x < dims[0] && y < dims[1] && z < dims[2] {
            ValueBounds::single(volume.levels[x + dims[0] * (y + dims[1] * z)])
        } else {
            ValueBounds::EMPTY
        }
    };
    let merge_children =
        |grid_dims: [usize; 3], child: &(dyn Fn(usize, usize, usize) -> ValueBounds + Sync)| {
            let mut bounds = vec![ValueBounds::EMPTY; grid_dims.iter().product()];
            bounds
                .par_chunks_mut(grid_dims[0] * grid_dims[1])
                .enumerate()
                .for_each(|(pz, slab)| {
                    for (i, cell) in slab.iter_mut().enumerate() {
                        let (px, py) = (i % grid_dims[0], i / grid_dims[0]);
                        *cell = (0..8).fold(ValueBounds::EMPTY, |merged, octant| {
                            merged.merge(child(
                                2 * px + (octant & 1),
                                2 * py + ((octant >> 1) & 1),
                                2 * pz + (octant >> 2),
                            ))
                        });
                    }
                });
            LevelGrid {
                dims: grid_dims,
                bounds,
            }
        };

    let mut grids: Vec<LevelGrid> = Vec::with_capacity(depth as usize);
    grids.push(merge_children(dims.map(|d| d.div_ceil(2)), &voxel));
    step_done(depth as f32 + 1.0)?;
    for level in (0..depth - 1).rev() {
        let children = grids.last().expect("the finer level was just built");
        let grid = merge_children(children.dims.map(|d| d.div_ceil(2)), &|x, y, z| {
            children.get(x, y, z)
        });
        grids.push(grid);
        step_done(2.0 * depth as f32 - level as f32)?;
    }
    // Built finest first; index by level.
    grids.reverse();
    Ok(grids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use voxscope_volume::{Volume, VoxelData};

    /// Every node's bounds are the min and max of the voxels in its box (empty for padding),
    /// found by brute force, for thin and odd-sized volumes where most of the cube is padding.
    #[test]
    fn node_bounds_equal_their_voxels_in_thin_and_odd_volumes() {
        for dims in [[37, 1, 1], [1, 13, 5], [9, 17, 3], [64, 2, 1], [5, 5, 33]] {
            let count: usize = dims.iter().product();
            let values: Vec<u8> = (0..count).map(|i| (i * 37 % 11) as u8).collect();
            let volume = Volume::new("t", "test", dims, [1.0; 3], VoxelData::U8(values)).unwrap();
            let quantized = QuantizedVolume::new(&volume);
            for collapse_uniform in [false, true] {
                let options = BuildOptions {
                    collapse_uniform,
                    ..BuildOptions::default()
                };
                let octree = build(&quantized, options).unwrap();
                // Walk down from the root with each node's corner and side in voxels.
                let mut stack = vec![(0usize, [0usize; 3], octree.side())];
                let mut visited = 0;
                while let Some((index, corner, size)) = stack.pop() {
                    visited += 1;
                    let mut expected = ValueBounds::EMPTY;
                    for z in corner[2]..(corner[2] + size).min(dims[2]) {
                        for y in corner[1]..(corner[1] + size).min(dims[1]) {
                            for x in corner[0]..(corner[0] + size).min(dims[0]) {
                                let level = quantized.levels[x + dims[0] * (y + dims[1] * z)];
                                expected = expected.merge(ValueBounds::single(level));
                            }
                        }
                    }
                    assert_eq!(
                        octree.bounds[index], expected,
                        "{dims:?} node {index} at {corner:?} size {size}"
                    );
                    let node = octree.nodes[index];
                    if node.first_child != LEAF {
                        let half = size / 2;
                        for child in 0..8 {
                            let offset = [child & 1, (child >> 1) & 1, child >> 2];
                            stack.push((
                                node.first_child as usize + child,
                                std::array::from_fn(|a| corner[a] + offset[a] * half),
                                half,
                            ));
                        }
                    }
                }
                assert_eq!(visited, octree.nodes.len(), "{dims:?}");
            }
        }
    }
}
