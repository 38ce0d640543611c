//! The shape of a pyramid of bricks: each level's dimensions and brick grid, and the 32-bit key
//! that names a brick in the page table and in the GPU's requests. Also the CPU operations on a
//! whole level held in memory: the 2× reduction to the next level and cutting out one brick.

use rayon::prelude::*;

use voxscope_volume::format_dims;

use crate::{BRICK_SIZE, BrickData, BrickId, PADDED_BRICK_VOXELS};

/// The most levels a pyramid may have. Level 15 is left out: its keys are reserved for the
/// page table's empty entries ([`EMPTY_KEY`]), so levels 0…14 (2¹⁴ voxels per level-14 voxel).
pub const MAX_LEVELS: usize = 15;

/// A key's level sits above this many bits of brick index.
pub const KEY_LEVEL_SHIFT: u32 = 28;

/// The most bricks one level may have, of all its channels together: its bricks' indices fit
/// below [`KEY_LEVEL_SHIFT`] (at 32³ voxels a brick, 2²⁸ bricks is a level of 20 000³ voxels
/// or so, or eight channels of 10 000³).
pub const MAX_LEVEL_BRICKS: u64 = 1 << KEY_LEVEL_SHIFT;

/// The most channels one pyramid streams together (the composite's shown channels).
pub const MAX_STREAMED_CHANNELS: u32 = 8;

/// The key no brick has: level 15, every index bit set.
pub const EMPTY_KEY: u32 = u32::MAX;

/// One level of a pyramid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelShape {
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Bricks along x, y, z (`dims / BRICK_SIZE`, rounded up).
    pub grid: [usize; 3],
    /// Level-0 voxels along each axis that one voxel of this level covers (2^level).
    pub scale: usize,
}

impl LevelShape {
    /// Bricks in the level.
    pub fn brick_count(&self) -> u64 {
        self.grid.iter().map(|&g| g as u64).product()
    }
}

/// Why dimensions make no pyramid the streamer can hold: displays as the rest of a line
/// that names the source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ShapeError {
    /// An axis of no voxels.
    #[error("dimensions {} contain a zero extent", format_dims(*.0))]
    ZeroExtent([usize; 3]),
    /// More halvings than [`MAX_LEVELS`] to reach one voxel.
    #[error("dimensions {} need more than {MAX_LEVELS} pyramid levels", format_dims(*.0))]
    TooManyLevels([usize; 3]),
    /// More bricks at full resolution than [`MAX_LEVEL_BRICKS`].
    #[error(
        "dimensions {} make {finest} bricks of {BRICK_SIZE}³ at full resolution; the streaming renderer holds at most {MAX_LEVEL_BRICKS}",
        format_dims(*dims)
    )]
    TooManyBricks { dims: [usize; 3], finest: u64 },
    /// No channel, or more than are streamed together.
    #[error("{0} channels streamed together (1 to {MAX_STREAMED_CHANNELS})")]
    Channels(u32),
}

/// The levels of a pyramid, finest first, and how many channels of them it holds (each
/// channel the same levels of other values: a composite's channels, streamed together).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PyramidShape {
    pub levels: Vec<LevelShape>,
    /// Channels, 1 to [`MAX_STREAMED_CHANNELS`]: a key names a brick of one of them.
    pub channels: u32,
}

impl PyramidShape {
    /// Level 0 of `dims` and every coarser level, each halving the voxels per axis (rounded
    /// up) down to a single voxel: `ceil(log2(max(dims))) + 1` levels, the octree's depth + 1,
    /// so max level `m` of the octree's slider is pyramid level `depth − m`.
    pub fn new(dims: [usize; 3]) -> Result<Self, ShapeError> {
        if dims.contains(&0) {
            return Err(ShapeError::ZeroExtent(dims));
        }
        let mut levels = Vec::new();
        let mut level_dims = dims;
        loop {
            let scale = 1usize << levels.len();
            let grid = level_dims.map(|d| d.div_ceil(BRICK_SIZE));
            levels.push(LevelShape {
                dims: level_dims,
                grid,
                scale,
            });
            if level_dims.iter().all(|&d| d == 1) {
                break;
            }
            if levels.len() == MAX_LEVELS {
                return Err(ShapeError::TooManyLevels(dims));
            }
            level_dims = level_dims.map(|d| d.div_ceil(2));
        }
        let finest = levels[0].brick_count();
        if finest > MAX_LEVEL_BRICKS {
            return Err(ShapeError::TooManyBricks { dims, finest });
        }
        Ok(Self {
            levels,
            channels: 1,
        })
    }

    /// The same levels for `channels` channels (1 to [`MAX_STREAMED_CHANNELS`]), whose keys
    /// all fit below [`KEY_LEVEL_SHIFT`].
    pub fn with_channels(self, channels: u32) -> Result<Self, ShapeError> {
        let dims = self.dims();
        if !(1..=MAX_STREAMED_CHANNELS).contains(&channels) {
            return Err(ShapeError::Channels(channels));
        }
        let finest = self.levels[0].brick_count() * channels as u64;
        if finest > MAX_LEVEL_BRICKS {
            return Err(ShapeError::TooManyBricks { dims, finest });
        }
        Ok(Self { channels, ..self })
    }

    /// Voxels along x, y, z at full resolution.
    pub fn dims(&self) -> [usize; 3] {
        self.levels[0].dims
    }

    /// The octree depth of these dimensions (levels − 1): the max-level slider's range.
    pub fn depth(&self) -> u32 {
        self.levels.len() as u32 - 1
    }

    /// The page-table key of `id` (`level << 28 | c·n + x + gx·(y + gy·z)`, channel `c` of a
    /// level of `n` bricks a channel), if `id` is in the pyramid.
    pub fn key(&self, id: BrickId) -> Option<u32> {
        let level = self.levels.get(id.level as usize)?;
        let [x, y, z] = id.brick.map(|c| c as usize);
        let [gx, gy, gz] = level.grid;
        if x >= gx || y >= gy || z >= gz || id.channel >= self.channels {
            return None;
        }
        let first = id.channel as usize * gx * gy * gz;
        Some(id.level << KEY_LEVEL_SHIFT | (first + x + gx * (y + gy * z)) as u32)
    }

    /// The channel of the brick `key` names (0 for a key that names none).
    pub fn channel_of(&self, key: u32) -> u32 {
        let Some(level) = self.levels.get((key >> KEY_LEVEL_SHIFT) as usize) else {
            return 0;
        };
        let index = (key & ((1 << KEY_LEVEL_SHIFT) - 1)) as u64;
        ((index / level.brick_count()) as u32).min(self.channels - 1)
    }

    /// The brick a key names, if it is one of this pyramid's.
    pub fn brick_of(&self, key: u32) -> Option<BrickId> {
        let level = key >> KEY_LEVEL_SHIFT;
        let shape = self.levels.get(level as usize)?;
        let index = (key & ((1 << KEY_LEVEL_SHIFT) - 1)) as usize;
        let [gx, gy, gz] = shape.grid;
        let count = gx * gy * gz;
        let channel = index / count;
        if channel >= self.channels as usize {
            return None;
        }
        let index = index % count;
        Some(BrickId {
            level,
            brick: [index % gx, (index / gx) % gy, index / (gx * gy)].map(|c| c as u32),
            channel: channel as u32,
        })
    }

    /// The brick of the next coarser level that covers `id`, if there is a coarser level.
    pub fn parent(&self, id: BrickId) -> Option<BrickId> {
        (id.level as usize + 1 < self.levels.len()).then(|| BrickId {
            level: id.level + 1,
            brick: id.brick.map(|c| c / 2),
            channel: id.channel,
        })
    }

    /// The bricks of the next finer level that `id` covers (up to eight; fewer at the level's
    /// far edges), none at level 0.
    pub fn children(&self, id: BrickId) -> impl Iterator<Item = BrickId> + '_ {
        let finer = id
            .level
            .checked_sub(1)
            .and_then(|level| Some((level, self.levels.get(level as usize)?.grid)));
        (0..8u32).filter_map(move |corner| {
            let (level, grid) = finer?;
            let brick: [u32; 3] = std::array::from_fn(|a| 2 * id.brick[a] + (corner >> a & 1));
            (0..3)
                .all(|a| (brick[a] as usize) < grid[a])
                .then_some(BrickId {
                    level,
                    brick,
                    channel: id.channel,
                })
        })
    }

    /// The brick of level `level` (at or above `id`'s) that covers `id`.
    pub fn ancestor_at(&self, id: BrickId, level: u32) -> BrickId {
        let up = level.saturating_sub(id.level);
        BrickId {
            level: id.level + up,
            brick: id.brick.map(|c| c >> up),
            channel: id.channel,
        }
    }

    /// The center of brick `id` in level-0 voxel space.
    pub fn brick_center(&self, id: BrickId) -> [f64; 3] {
        let side = (BRICK_SIZE * self.levels[id.level as usize].scale) as f64;
        id.brick.map(|c| (c as f64 + 0.5) * side)
    }
}

/// How a level is reduced to the next coarser one: each voxel from the 2×2×2 it covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Downsampling {
    /// Their mean, rounded (intensities).
    Mean,
    /// Their largest level (a store that says its levels were made so).
    Max,
    /// Their most frequent level, ties to the larger (label volumes, whose values are names,
    /// not amounts: a mean of two labels is a third, and the largest label wins every block it
    /// touches, growing small labels over large ones level by level).
    Mode,
}

impl Downsampling {
    /// The reduction for values that are labels (the mode) or amounts (the mean).
    pub fn of_values(labels: bool) -> Self {
        if labels { Self::Mode } else { Self::Mean }
    }
}

/// The most frequent of up to eight levels, ties to the larger.
fn mode_of(values: &[u32]) -> u32 {
    let mut best = (0usize, 0u32);
    for &value in values {
        let count = values.iter().filter(|&&v| v == value).count();
        if (count, value) > best {
            best = (count, value);
        }
    }
    best.1
}

/// The next coarser level of `levels` (`dims`, x fastest): `ceil(dims / 2)` voxels, each the
/// mean (rounded), the maximum or the mode of the 2×2×2 voxels it covers; at an odd edge the
/// last voxel stands in for the missing one (as a clamped texture would).
pub fn downsample(levels: &[u16], dims: [usize; 3], how: Downsampling) -> (Vec<u16>, [usize; 3]) {
    let half = dims.map(|d| d.div_ceil(2));
    let [dx, dy, _] = dims;
    let at = |x: usize, y: usize, z: usize| levels[x + dx * (y + dy * z)] as u32;
    let mut out = vec![0u16; half[0] * half[1] * half[2]];
    out.par_chunks_mut(half[0] * half[1])
        .enumerate()
        .for_each(|(z, plane)| {
            let zs = [2 * z, (2 * z + 1).min(dims[2] - 1)];
            for y in 0..half[1] {
                let ys = [2 * y, (2 * y + 1).min(dims[1] - 1)];
                for x in 0..half[0] {
                    let xs = [2 * x, (2 * x + 1).min(dims[0] - 1)];
                    let (mut sum, mut max) = (0u32, 0u32);
                    let mut block = [0u32; 8];
                    let mut n = 0;
                    for &z in &zs {
                        for &y in &ys {
                            for &x in &xs {
                                let v = at(x, y, z);
                                sum += v;
                                max = max.max(v);
                                block[n] = v;
                                n += 1;
                            }
                        }
                    }
                    plane[x + half[0] * y] = match how {
                        Downsampling::Mean => (sum + 4) / 8,
                        Downsampling::Max => max,
                        Downsampling::Mode => mode_of(&block),
                    } as u16;
                }
            }
        });
    (out, half)
}

/// Levels 1 to `count` of the pyramid whose level 0 is `levels` (`dims`, x fastest), each
/// reduced from the one before by `how` ([`downsample`]), with their dims: what the dense and
/// bricks renderers draw at max levels finer than their nodes, and a [`super::MemorySource`]'s
/// levels.
pub fn coarser_levels(
    levels: &[u16],
    dims: [usize; 3],
    how: Downsampling,
    count: usize,
) -> Vec<(Vec<u16>, [usize; 3])> {
    let mut coarser: Vec<(Vec<u16>, [usize; 3])> = Vec::with_capacity(count);
    for _ in 0..count {
        let (finer, finer_dims) = coarser
            .last()
            .map_or((levels, dims), |(l, d)| (l.as_slice(), *d));
        coarser.push(downsample(finer, finer_dims, how));
    }
    coarser
}

/// The `side`³ block of a level held whole in memory (`levels`, `dims`, x fastest) whose first
/// voxel is `first`, with a one-voxel apron, every voxel clamped to the level's edges (as a
/// clamped texture reads them): `(side + 2)³` value levels, x fastest, appended to `out`.
pub fn cut_padded_block(
    levels: &[u16],
    dims: [usize; 3],
    first: [usize; 3],
    side: usize,
    out: &mut Vec<u16>,
) {
    // The level's voxel at offset `i` − 1 from the block's first along `axis`, clamped.
    let clamped = |axis: usize, i: usize| (first[axis] + i).saturating_sub(1).min(dims[axis] - 1);
    let xs: Vec<usize> = (0..side + 2).map(|i| clamped(0, i)).collect();
    for k in 0..side + 2 {
        let z = clamped(2, k);
        for j in 0..side + 2 {
            let row = dims[0] * (clamped(1, j) + dims[1] * z);
            out.extend(xs.iter().map(|&x| levels[row + x]));
        }
    }
}

/// Brick `brick` of a level held whole in memory (`levels`, `dims`, x fastest), with its
/// one-voxel apron clamped to the level's edges.
pub fn cut_brick(levels: &[u16], dims: [usize; 3], brick: [u32; 3]) -> BrickData {
    let first = brick.map(|c| c as usize * BRICK_SIZE);
    let mut out = Vec::with_capacity(PADDED_BRICK_VOXELS);
    cut_padded_block(levels, dims, first, BRICK_SIZE, &mut out);
    debug_assert_eq!(out.len(), PADDED_BRICK_VOXELS);
    let inside = std::array::from_fn(|a| dims[a].saturating_sub(first[a]));
    BrickData::new(out, inside)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PADDED_BRICK;

    #[test]
    fn levels_halve_down_to_one_voxel_as_the_octree_depth_says() {
        let shape = PyramidShape::new([197, 233, 189]).expect("shape");
        assert_eq!(shape.depth(), 8); // ceil(log2(233))
        let dims: Vec<[usize; 3]> = shape.levels.iter().map(|l| l.dims).collect();
        assert_eq!(dims[1], [99, 117, 95]);
        assert_eq!(*dims.last().expect("a level"), [1, 1, 1]);
        assert_eq!(shape.levels[0].grid, [7, 8, 6]);
        assert_eq!(shape.levels[3].scale, 8);
        // 16384³: 2²⁷ bricks at level 0, fifteen levels.
        let big = PyramidShape::new([16384; 3]).expect("16384³ fits");
        assert_eq!(big.levels.len(), 15);
        assert_eq!(big.levels[0].brick_count(), 1 << 27);
        assert!(PyramidShape::new([32768; 3]).is_err());
        assert!(PyramidShape::new([0, 4, 4]).is_err());
    }

    #[test]
    fn keys_name_bricks_one_to_one() {
        let shape = PyramidShape::new([100, 70, 40]).expect("shape");
        let mut seen = std::collections::HashSet::new();
        for (level, info) in shape.levels.iter().enumerate() {
            for z in 0..info.grid[2] as u32 {
                for y in 0..info.grid[1] as u32 {
                    for x in 0..info.grid[0] as u32 {
                        let id = BrickId {
                            level: level as u32,
                            brick: [x, y, z],
                            channel: 0,
                        };
                        let key = shape.key(id).expect("in the pyramid");
                        assert_ne!(key, EMPTY_KEY);
                        assert!(seen.insert(key));
                        assert_eq!(shape.brick_of(key), Some(id));
                    }
                }
            }
        }
        let outside = BrickId {
            level: 0,
            brick: [4, 0, 0],
            channel: 0,
        };
        assert_eq!(shape.key(outside), None);
        assert_eq!(shape.brick_of(EMPTY_KEY), None);
        let parent = shape.parent(BrickId {
            level: 0,
            brick: [3, 2, 1],
            channel: 0,
        });
        assert_eq!(
            parent,
            Some(BrickId {
                level: 1,
                brick: [1, 1, 0],
                channel: 0,
            })
        );
    }

    #[test]
    fn downsampling_means_or_maxes_each_block_and_clamps_odd_edges() {
        // 3×1×1: [0, 10, 20] → [5, 20] (the last voxel pairs with itself).
        let (mean, dims) = downsample(&[0, 10, 20], [3, 1, 1], Downsampling::Mean);
        assert_eq!((mean, dims), (vec![5, 20], [2, 1, 1]));
        let (max, _) = downsample(&[0, 10, 20], [3, 1, 1], Downsampling::Max);
        assert_eq!(max, vec![10, 20]);
        // A 2×2×2 block of 1…8 averages to 4.5, rounded to 5.
        let (mean, _) = downsample(&[1, 2, 3, 4, 5, 6, 7, 8], [2, 2, 2], Downsampling::Mean);
        assert_eq!(mean, vec![5]);
        // Labels: the most frequent, not the mean (3) nor the largest (9); ties to the larger.
        let labels = [2, 2, 2, 9, 0, 0, 2, 9];
        let (mode, _) = downsample(&labels, [2, 2, 2], Downsampling::Mode);
        assert_eq!(mode, vec![2]);
        let (tie, _) = downsample(&[0, 0, 0, 0, 5, 5, 5, 5], [2, 2, 2], Downsampling::Mode);
        assert_eq!(tie, vec![5]);
        // At an odd edge the last voxel counts twice, as for the mean.
        let (edge, _) = downsample(&[1, 4, 4], [3, 1, 1], Downsampling::Mode);
        assert_eq!(edge, vec![4, 4]);
    }

    #[test]
    fn a_cut_brick_has_a_clamped_apron_and_its_own_range() {
        let dims = [40, 3, 2];
        let levels: Vec<u16> = (0..40 * 3 * 2).map(|i| (i % 40) as u16).collect();
        let first = cut_brick(&levels, dims, [0, 0, 0]);
        // Apron before x = 0 repeats voxel 0; after x = 31 comes voxel 32 of the next brick.
        let row = PADDED_BRICK * (1 + PADDED_BRICK);
        assert_eq!(first.levels[row], 0);
        assert_eq!(first.levels[row + 1], 0);
        assert_eq!(first.levels[row + 32], 31);
        assert_eq!(first.levels[row + 33], 32);
        assert_eq!((first.range.min, first.range.max), (0, 31));
        // The second brick holds x = 32…39; beyond, the edge voxel repeats; its range is its own.
        let second = cut_brick(&levels, dims, [1, 0, 0]);
        assert_eq!(second.levels[row], 31);
        assert_eq!(second.levels[row + 8], 39);
        assert_eq!(second.levels[row + 20], 39);
        assert_eq!((second.range.min, second.range.max), (32, 39));
    }

    #[test]
    fn a_brick_s_children_are_the_bricks_whose_parent_it_is() {
        // 100×64×40: level 0 has 4×2×2 bricks, level 1 2×1×1.
        let shape = PyramidShape::new([100, 64, 40]).expect("a pyramid");
        let parent = BrickId {
            level: 1,
            brick: [1, 0, 0],
            channel: 0,
        };
        let children: Vec<BrickId> = shape.children(parent).collect();
        assert_eq!(children.len(), 8);
        assert!(children.iter().all(|&c| shape.parent(c) == Some(parent)));
        // At level 2 (1×1×1) the one brick's children are level 1's two.
        let root = BrickId {
            level: 2,
            brick: [0; 3],
            channel: 0,
        };
        assert_eq!(shape.children(root).count(), 2);
        assert_eq!(shape.children(children[0]).count(), 0, "none below level 0");
        let deep = BrickId {
            level: 0,
            brick: [3, 1, 1],
            channel: 0,
        };
        assert_eq!(shape.ancestor_at(deep, 1), parent);
        assert_eq!(shape.ancestor_at(deep, 0), deep);
        assert_eq!(shape.ancestor_at(deep, 2), root);
    }
}
