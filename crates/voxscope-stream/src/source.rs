//! Where bricks come from: a [`BrickSource`] is a pyramid of levels (level 0 the finest, each
//! coarser one half as many voxels per axis, rounded up) that hands out one brick of
//! [`super::BRICK_SIZE`]³ value levels at a time, with a one-voxel apron, in a quantization fixed for the
//! whole pyramid. The streamer asks for bricks on worker threads, so a source is `Send + Sync`
//! and may take its time (a disk read, a decode, a procedural evaluation).

use super::pyramid::PyramidShape;
use super::{BrickData, BrickId, ValueRange};
use voxscope_volume::remote::RemoteStats;
use voxscope_volume::{LoadError, LoadErrorKind, Quantization};

/// Why a brick could not be read. One line, naming the source and the brick; the variant
/// says whether another try may succeed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BrickError {
    /// Its bytes could not be fetched (the disk or the network failed): another try may
    /// succeed.
    #[error("{0}")]
    Fetch(String),
    /// Its bytes arrived but do not decode (a damaged chunk).
    #[error("{0}")]
    Decode(String),
    /// Anything else: a brick the pyramid does not have, one of the wrong size, a store that
    /// cannot be read this way. Another try reads the same.
    #[error("{0}")]
    Invalid(String),
}

impl BrickError {
    /// The error of brick `id` whose read failed with `error`, of the same kind.
    pub fn of_load(id: BrickId, error: &LoadError) -> Self {
        let message = format!("{id}: {error}");
        match error.kind {
            LoadErrorKind::Fetch => Self::Fetch(message),
            LoadErrorKind::Decode => Self::Decode(message),
            LoadErrorKind::Invalid | LoadErrorKind::Unrecognized => Self::Invalid(message),
        }
    }
}

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

    /// Whether the values are labels (categories): the renderer samples them at the nearest
    /// voxel, and the levels the source computes keep each block's most frequent label
    /// ([`crate::Downsampling::Mode`]).
    fn labels(&self) -> bool {
        false
    }
}
