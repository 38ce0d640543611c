//! Building the flat list bottom-up: value bounds for every level from the voxels (using the
//! paper's sibling arithmetic), then the list top-down, level by level, so that each level's
//! nodes follow their parents' order and each parent's 8 children sit together.

use std::fmt;
use std::time::Instant;

use rayon::prelude::*;

use super::sibling_index::{next_block_start, sibling_indices};
use super::{LEAF, Node, Octree, ValueBounds};
use crate::progress::Progress;
use crate::volume::QuantizedVolume;

/// Deepest supported octree (a 1024³ cube): cells of every level fit in `u32`.
pub const MAX_DEPTH: u32 = 10;

/// Choices of the build.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuildOptions {
    /// Collapse subtrees whose voxels are all equal (or all padding) into one leaf. Lossless:
    /// such a leaf has the color its voxels would have.
    pub collapse_uniform: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            collapse_uniform: true,
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
    let bounds_of = |level: u32, cell: u32| -> ValueBounds {
        if level < depth {
            return grids[level as usize][cell as usize];
        }
        let cell = cell as usize;
        let (x, y, z) = (cell % side, (cell / side) % side, cell / (side * side));
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
        build_seconds: started.elapsed().as_secs_f64(),
    })
}

/// Value bounds of every cell of levels `0..depth` (cubic grids of side `2^level`, x fastest).
/// Level `depth - 1` reads the voxels (padding beyond the volume is empty); each level above
/// merges the 8 siblings of every block of the level below with the paper's listings 1 and 2.
fn bounds_per_level(
    volume: &QuantizedVolume,
    depth: u32,
    step_done: &dyn Fn(f32) -> Result<(), BuildError>,
) -> Result<Vec<Vec<ValueBounds>>, BuildError> {
    if depth == 0 {
        return Ok(Vec::new());
    }
    let dims = volume.dims;
    let mut grids: Vec<Vec<ValueBounds>> = vec![Vec::new(); depth as usize];

    let n = 1usize << (depth - 1);
    let mut finest = vec![ValueBounds::EMPTY; n * n * n];
    finest
        .par_chunks_mut(n * n)
        .enumerate()
        .for_each(|(pz, slice)| {
            for (i, bounds) in slice.iter_mut().enumerate() {
                let (px, py) = (i % n, i / n);
                let mut merged = ValueBounds::EMPTY;
                for child in 0..8 {
                    let x = 2 * px + (child & 1);
                    let y = 2 * py + ((child >> 1) & 1);
                    let z = 2 * pz + (child >> 2);
                    if x < dims[0] && y < dims[1] && z < dims[2] {
                        let level = volume.levels[x + dims[0] * (y + dims[1] * z)];
                        merged = merged.merge(ValueBounds::single(level));
                    }
                }
                *bounds = merged;
            }
        });
    grids[depth as usize - 1] = finest;
    step_done(depth as f32 + 1.0)?;

    for level in (0..depth - 1).rev() {
        let child_grid = &grids[level as usize + 1];
        let m = 1usize << (level + 1); // side of the child grid
        let half = m / 2;
        let mut grid = vec![ValueBounds::EMPTY; half * half * half];
        grid.par_chunks_mut(half * half)
            .enumerate()
            .for_each(|(pz, slice)| {
                let mut start = 2 * pz * m * m;
                for bounds in slice.iter_mut() {
                    *bounds = sibling_indices(start, m)
                        .iter()
                        .fold(ValueBounds::EMPTY, |acc, &i| acc.merge(child_grid[i]));
                    start = next_block_start(start, m);
                }
            });
        grids[level as usize] = grid;
        step_done(2.0 * depth as f32 - level as f32)?;
    }
    Ok(grids)
}
