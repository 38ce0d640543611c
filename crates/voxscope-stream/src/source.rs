//! Where bricks come from: a [`BrickSource`] is a pyramid of levels (level 0 the finest, each
//! coarser one half as many voxels per axis, rounded up) that hands out one brick of
//! [`BRICK_SIZE`]³ value levels at a time, with a one-voxel apron, in a quantization fixed for the
//! whole pyramid. The streamer asks for bricks on worker threads, so a source is `Send + Sync`
//! and may take its time (a disk read, a decode, a procedural evaluation).

use std::fmt;

use super::pyramid::PyramidShape;
use voxscope_volume::Quantization;
use voxscope_volume::remote::RemoteStats;

/// Voxels along a brick's side. Fixed: the atlas, the page table and the shader agree on it.
pub const BRICK_SIZE: usize = 32;

/// Voxels along a brick's side in the atlas: the brick and its one-voxel apron either side.
pub const PADDED_BRICK: usize = BRICK_SIZE + 2;

/// Value levels in a padded brick.
pub const PADDED_BRICK_VOXELS: usize = PADDED_BRICK * PADDED_BRICK * PADDED_BRICK;

/// One brick of one level: `level`, and the brick's position in that level's brick grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BrickId {
    pub level: u32,
    pub brick: [u32; 3],
}

impl fmt::Display for BrickId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [x, y, z] = self.brick;
        write!(f, "level {} brick ({x}, {y}, {z})", self.level)
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

/// Why a brick could not be read. One line, naming the source and the brick.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrickError(pub String);

impl fmt::Display for BrickError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BrickError {}

/// A pyramid of bricks. Level 0 is the finest; level `l` has `ceil(dims₀ / 2^l)` voxels per
/// axis, each voxel covering `2^l` level-0 voxels along each axis ([`PyramidShape`]).
pub trait BrickSource: Send + Sync {
    /// What the source is called in messages (a path, a spec).
    fn name(&self) -> &str;
    /// The levels' dimensions and brick grids.
    fn shape(&self) -> &PyramidShape;
    /// Physical size of a level-0 voxel along x, y, z.
    fn spacing(&self) -> [f64; 3];
    /// What the value levels mean, the same for every brick of every level.
    fn quantization(&self) -> Quantization;
    /// The largest value level any brick may hold: up to 255 the atlas is 8-bit.
    fn max_value_level(&self) -> u16;
    /// Reads brick `id`: its value levels with the apron, and their range. Called from worker
    /// threads, several at once.
    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError>;

    /// A range that holds every value level of brick `id`'s own voxels, if the source knows one
    /// without reading the brick (a store's per-chunk minima and maxima): a brick whose range
    /// the transfer function makes invisible is then never read. Called on the frame's thread:
    /// it must be cheap.
    fn known_range(&self, _id: BrickId) -> Option<ValueRange> {
        None
    }

    /// Requests, bytes and errors of the network store behind the source, if it reads from
    /// one (what the app shows while a URL streams).
    fn remote_stats(&self) -> Option<RemoteStats> {
        None
    }
}
