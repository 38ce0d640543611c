//! Where bricks come from: a [`BrickSource`] is a pyramid of levels (level 0 the finest, each
//! coarser one half as many voxels per axis, rounded up) that hands out one brick of
//! [`super::BRICK_SIZE`]³ value levels at a time, with a one-voxel apron, in a quantization fixed for the
//! whole pyramid. The streamer asks for bricks on worker threads, so a source is `Send + Sync`
//! and may take its time (a disk read, a decode, a procedural evaluation).

use super::pyramid::{PyramidShape, ShapeError};
use super::zarr_source::{MAX_BRICK_READ, MAX_REMOTE_BRICK_CHUNKS};
use super::{BrickData, BrickId, ValueRange};
use voxscope_volume::format_dims;
use voxscope_volume::remote::RemoteStats;
use voxscope_volume::{LoadError, LoadErrorKind, Quantization};

/// Why a brick source could not be made: displays as one line naming the source.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SourceError {
    /// Its dimensions make no pyramid the streamer holds.
    #[error("{name}: {error}")]
    Shape { name: String, error: ShapeError },
    /// Level 0's value levels do not match its dimensions.
    #[error("{name}: {count} value levels for {} voxels", format_dims(*dims))]
    LevelCount {
        name: String,
        count: usize,
        dims: [usize; 3],
    },
    /// A store whose coarsest stored level is too fine to reduce bricks of `level_dims`
    /// from (`read` voxels a brick).
    #[error(
        "{name}: its coarsest level ({}) is too large to stream from: a {}-voxel level would read {read} voxels a brick (at most {MAX_BRICK_READ}); `voxscope convert` writes the coarser levels",
        format_dims(*coarsest),
        format_dims(*level_dims)
    )]
    CoarsestTooLarge {
        name: String,
        coarsest: [usize; 3],
        level_dims: [usize; 3],
        read: u64,
    },
    /// A remote store whose chunks of stored level `level` are so small that one brick
    /// takes `requests` requests.
    #[error(
        "{name}: level {level} is stored in chunks of {}x{}x{} voxels: one brick would take {requests} requests (at most {MAX_REMOTE_BRICK_CHUNKS} over a network); copy the store and `voxscope convert` it to larger chunks",
        chunk[0], chunk[1], chunk[2]
    )]
    ChunksTooSmall {
        name: String,
        level: usize,
        chunk: [usize; 3],
        requests: u64,
    },
    /// Wide or floating-point values without a stored range, and a coarsest level too large
    /// to read for one.
    #[error("{0}: no stored value range, and the coarsest level is too large to read for one")]
    NoValueRange(String),
    /// Channels streamed together whose pyramids differ.
    #[error(
        "{name}: channels of dimensions {} and {} cannot be streamed together (channels need one grid)",
        format_dims(*first),
        format_dims(*other)
    )]
    ChannelShapes {
        name: String,
        first: [usize; 3],
        other: [usize; 3],
    },
    /// The store could not be read.
    #[error(transparent)]
    Load(#[from] LoadError),
}

impl SourceError {
    /// The dimensions of the source called `name` make no pyramid.
    pub fn shape(name: &str) -> impl FnOnce(ShapeError) -> Self + '_ {
        move |error| Self::Shape {
            name: name.to_owned(),
            error,
        }
    }
}

/// Why a brick could not be read. One line, naming the source and the brick; the variant
/// says whether another try may succeed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BrickError {
    /// Its bytes could not be fetched (the disk or the network failed): another try may
    /// succeed.
    #[error("{0}")]
    Fetch(BrickFault),
    /// Its bytes arrived but do not decode (a damaged chunk).
    #[error("{0}")]
    Decode(BrickFault),
    /// Anything else: a brick the pyramid does not have, one of the wrong size, a store that
    /// cannot be read this way, a reader that panicked. Another try reads the same.
    #[error("{0}")]
    Invalid(BrickFault),
}

/// What a [`BrickError`] says: the whole line, and the cause alone (what many bricks failing
/// the same way share, `HTTP 500 Internal Server Error (after 9 tries)`: what a summary groups
/// them by).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrickFault {
    /// The one line: the brick, the source, the chunk, the cause.
    pub message: String,
    /// The cause alone.
    pub cause: String,
}

impl std::fmt::Display for BrickFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl BrickFault {
    fn whole(message: String) -> Self {
        Self {
            cause: message.clone(),
            message,
        }
    }
}

impl BrickError {
    /// A fetch failure whose message is its own cause.
    pub fn fetch(message: impl Into<String>) -> Self {
        Self::Fetch(BrickFault::whole(message.into()))
    }

    /// A decode failure whose message is its own cause.
    pub fn decode(message: impl Into<String>) -> Self {
        Self::Decode(BrickFault::whole(message.into()))
    }

    /// An invalid read whose message is its own cause.
    pub fn invalid(message: impl Into<String>) -> Self {
        Self::Invalid(BrickFault::whole(message.into()))
    }

    /// The error of brick `id` whose read failed with `error`, of the same kind and cause.
    pub fn of_load(id: BrickId, error: &LoadError) -> Self {
        let fault = BrickFault {
            message: format!("{id}: {error}"),
            cause: error.cause().to_owned(),
        };
        match error.kind {
            LoadErrorKind::Fetch => Self::Fetch(fault),
            LoadErrorKind::Decode => Self::Decode(fault),
            LoadErrorKind::Invalid | LoadErrorKind::Unrecognized => Self::Invalid(fault),
        }
    }

    /// The line and the cause.
    pub fn fault(&self) -> &BrickFault {
        match self {
            Self::Fetch(fault) | Self::Decode(fault) | Self::Invalid(fault) => fault,
        }
    }

    /// The cause alone ([`BrickFault::cause`]).
    pub fn cause(&self) -> &str {
        &self.fault().cause
    }

    /// Whether another try may succeed (a failed fetch; not a damaged or invalid brick).
    pub fn may_pass_later(&self) -> bool {
        matches!(self, Self::Fetch(_))
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
    /// What the value levels mean, the same for every brick of every level (of channel 0,
    /// where the pyramid has several: [`Self::channel_quantization`]).
    fn quantization(&self) -> Quantization;
    /// Whether its channels are drawn as a composite (each its own table and color), even one
    /// ([`crate::ChannelSources`]).
    fn composite(&self) -> bool {
        false
    }
    /// What channel `channel`'s value levels mean (a pyramid of one channel: its one).
    fn channel_quantization(&self, _channel: u32) -> Quantization {
        self.quantization()
    }
    /// The largest value level any brick may hold: up to 255 the atlas is 8-bit.
    fn max_value_level(&self) -> u16;
    /// Reads brick `id`: its value levels with the apron, and their range. Called from worker
    /// threads, several at once.
    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError>;

    /// [`Self::read_brick`], unless it would wait for another reader (another loader
    /// decoding a chunk the brick needs): then `None`, after doing what it could meanwhile,
    /// so that the loader reads another brick before it asks again. A source without such
    /// waits reads.
    fn read_brick_unless_busy(&self, id: BrickId) -> Option<Result<BrickData, BrickError>> {
        Some(self.read_brick(id))
    }

    /// A range that holds every value level of brick `id`'s own voxels, if the source knows one
    /// without reading the brick (a store's per-chunk minima and maxima): a brick whose range
    /// the transfer function makes invisible is then never read. Called on the frame's thread:
    /// it must be cheap.
    fn known_range(&self, _id: BrickId) -> Option<ValueRange> {
        None
    }

    /// Starts fetching, without waiting, what reading the bricks `ids` will need from a
    /// network or a disk (the first soonest): the load queue's next bricks, asked for while
    /// the loaders still decode what came before, so that enough requests are in flight to
    /// fill the link or the disk's queue. Called on the frame's thread and by loaders: it
    /// must return at once. A source in memory does nothing.
    fn fetch_ahead(&self, _ids: &[BrickId]) {}

    /// Whether [`Self::fetch_ahead`] may start anything now (its store has room for more
    /// fetches under way): cheap, asked before the load queue's next bricks are looked up.
    /// A source that never fetches ahead says no.
    fn can_fetch_ahead(&self) -> bool {
        false
    }

    /// Requests, bytes and errors of the network store behind the source, if it reads from
    /// one (what the app shows while a URL streams).
    fn remote_stats(&self) -> Option<RemoteStats> {
        None
    }

    /// Takes the source's own caches (decoded chunks, fetched bytes) out of `ram`, the
    /// streamer's whole RAM budget (`--ram-cache`), and returns the bytes they may hold: the
    /// RAM cache of bricks gets the rest. A source that keeps nothing between reads (a volume
    /// in memory, procedural data) takes nothing.
    fn reserve_caches(&self, ram: u64) -> u64 {
        self.reserve_decoded_caches(ram) + self.reserve_fetch_cache(ram)
    }

    /// The decoded part of [`Self::reserve_caches`] (chunks, faces): the source's own.
    fn reserve_decoded_caches(&self, _ram: u64) -> u64 {
        0
    }

    /// The fetched part of [`Self::reserve_caches`]: the bytes the network store behind the
    /// source keeps, sized from `ram` (none for a folder's store). Sources of one store
    /// ([`Self::fetch_store`]) share it.
    fn reserve_fetch_cache(&self, _ram: u64) -> u64 {
        0
    }

    /// Which network store's fetch cache the source sets, where sources may share one (the
    /// channels of one store): equal for sources of the same store.
    fn fetch_store(&self) -> Option<usize> {
        None
    }

    /// Bytes the source's own caches hold now (at most what [`Self::reserve_caches`] took).
    fn cached_bytes(&self) -> u64 {
        0
    }

    /// Chunks the source has read and decoded so far, each time it did (0 for a source
    /// without chunks).
    fn chunks_decoded(&self) -> u64 {
        0
    }

    /// Whether the values are labels (categories): the renderer samples them at the nearest
    /// voxel, and the levels the source computes keep each block's most frequent label
    /// ([`crate::Downsampling::Mode`]).
    fn labels(&self) -> bool {
        false
    }
}
