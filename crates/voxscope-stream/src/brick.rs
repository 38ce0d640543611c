//! One brick: its size (fixed, [`BRICK_SIZE`]³ with a one-voxel apron), its name in a
//! pyramid ([`BrickId`]) and its voxels as value levels with their range ([`BrickData`]).
//! What a [`super::BrickSource`] hands out and the pyramid's shape cuts levels into.

use std::fmt;

/// Voxels along a brick's side. Fixed: the atlas, the page table and the shader agree on it.
pub const BRICK_SIZE: usize = 32;

/// Voxels along a brick's side in the atlas: the brick and its one-voxel apron either side.
pub const PADDED_BRICK: usize = BRICK_SIZE + 2;

/// Value levels in a padded brick.
pub const PADDED_BRICK_VOXELS: usize = PADDED_BRICK * PADDED_BRICK * PADDED_BRICK;

/// One brick of one level of one channel: `level`, the brick's position in that level's
/// brick grid, and the channel of a pyramid of several ([`crate::PyramidShape::channels`]; 0
/// where it has one).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BrickId {
    pub level: u32,
    pub brick: [u32; 3],
    pub channel: u32,
}

impl BrickId {
    /// Brick `brick` of `level` of channel 0 (a pyramid of one channel's bricks).
    pub fn new(level: u32, brick: [u32; 3]) -> Self {
        Self {
            level,
            brick,
            channel: 0,
        }
    }

    /// The same brick of channel `channel`.
    pub fn of_channel(self, channel: u32) -> Self {
        Self { channel, ..self }
    }
}

impl fmt::Display for BrickId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [x, y, z] = self.brick;
        write!(f, "level {} brick ({x}, {y}, {z})", self.level)?;
        if self.channel > 0 {
            write!(f, " of channel {}", self.channel)?;
        }
        Ok(())
    }
}

/// A brick's voxels as value levels, with their range.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrickData {
    /// [`PADDED_BRICK_VOXELS`] value levels, x fastest: the brick's voxels and a one-voxel
    /// apron copied from its neighbours (clamped at the level's edges, so that trilinear
    /// filtering near the volume's faces equals a clamped texture's). Beyond the level's
    /// dimensions (the last brick of an axis) the edge voxel repeats.
    pub levels: Vec<u16>,
    /// Smallest and largest value level of the brick's own voxels inside the level (not the
    /// apron): what empty-space skipping tests against the transfer function.
    pub range: ValueRange,
}

/// The smallest and largest value level of a brick's voxels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ValueRange {
    pub min: u16,
    pub max: u16,
}

impl ValueRange {
    /// Packed as the shader reads it: the minimum in the low 16 bits, the maximum in the high.
    pub fn packed(self) -> u32 {
        self.min as u32 | (self.max as u32) << 16
    }

    /// Whether every voxel has the same level (the brick needs no atlas slot: it is drawn from
    /// its value alone).
    pub fn is_uniform(self) -> bool {
        self.min == self.max
    }
}

impl BrickData {
    /// A brick of `levels` whose own voxels' range is computed here: the voxels of the
    /// [`PADDED_BRICK`]³ block that lie within `inside` voxels of the brick's first one per axis
    /// (the brick's part inside its level).
    pub fn new(levels: Vec<u16>, inside: [usize; 3]) -> Self {
        debug_assert_eq!(levels.len(), PADDED_BRICK_VOXELS);
        let (mut min, mut max) = (u16::MAX, u16::MIN);
        for z in 0..inside[2].min(BRICK_SIZE) {
            for y in 0..inside[1].min(BRICK_SIZE) {
                let row = 1 + PADDED_BRICK * ((y + 1) + PADDED_BRICK * (z + 1));
                for &level in &levels[row..row + inside[0].min(BRICK_SIZE)] {
                    min = min.min(level);
                    max = max.max(level);
                }
            }
        }
        if min > max {
            (min, max) = (0, 0);
        }
        Self {
            levels,
            range: ValueRange { min, max },
        }
    }
}
