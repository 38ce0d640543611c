//! Streaming: volumes of any size drawn from a pyramid of bricks kept in a fixed GPU budget.
//!
//! A [`BrickSource`] hands out bricks of a multiresolution pyramid: an in-memory volume's
//! ([`MemorySource`], its coarser levels computed here), a procedural one ([`NoiseSource`]),
//! an OME-Zarr file's, read region by region ([`ZarrSource`]). The [`Streamer`] is the CPU half of the streaming renderer
//! (`render::StreamVolume` the GPU half): each frame it reads what the rays lacked and used,
//! loads what is wanted on worker threads into a RAM cache (coarse before fine, visible before
//! prefetch, near the view's center first), uploads within a per-frame budget into atlas slots
//! (evicting the least recently used), and keeps the [`PageTable`] the rays look bricks up in.
//!
//! Module direction: volume → stream → render. Nothing here touches the GPU.

mod brick;
mod budget;
mod channels;
mod failures;
mod frame;
mod key_hash;
mod loader;
mod memory;
mod options;
mod page_table;
mod preview;
mod procedural;
mod pyramid;
mod queue;
mod ram_cache;
mod slots;
mod source;
mod status;
mod streamer;
mod zarr_source;

pub use brick::{BRICK_SIZE, BrickData, BrickId, PADDED_BRICK, PADDED_BRICK_VOXELS, ValueRange};
pub use budget::{Cut, SlotNeed, cut_ranked, cut_within};
pub use channels::ChannelSources;
pub use failures::{FailedBrick, FailureGroup, Failures, MAX_BRICK_ATTEMPTS, group};
pub use frame::{Feedback, Upload, ViewPoint};
pub use key_hash::{KeyHasher, KeyMap, KeySet};
pub use loader::{AtlasTexels, LoadResult, LoadedBrick, Loader, load_brick};
pub use memory::MemorySource;
pub use options::{AtlasZero, StreamOptions, UploadPath};
pub use page_table::{
    ENTRY_FAILED, ENTRY_RESIDENT, ENTRY_VISIBLE, MAX_PROBES, PageTable, TableEntry, TableFull,
    table_hash,
};
pub use preview::preview;
pub use procedural::NoiseSource;
pub use pyramid::{
    Downsampling, EMPTY_KEY, KEY_LEVEL_SHIFT, LevelShape, MAX_LEVELS, MAX_STREAMED_CHANNELS,
    PyramidShape, ShapeError, coarser_levels, cut_brick, cut_padded_block, downsample,
};
pub use queue::{Priority, Request, RequestQueue, Tier};
pub use ram_cache::RamCache;
pub use slots::{Allocation, SlotPool};
pub use source::{BrickError, BrickFault, BrickSource, SourceError};
pub use status::{
    BudgetLimit, FullDetailBudget, LevelCounters, StreamCounters, StreamStatus, UpdatePhases,
    UploadParts, format_budget,
};
pub use streamer::{
    StillUploads, StreamError, Streamer, UPLOAD_SECONDS_PER_FRAME, UPLOAD_SECONDS_STILL,
    VISIBILITY_COUNTS, pinned_level_count, view_slots,
};
pub use zarr_source::{MAX_BRICK_READ, MAX_REMOTE_BRICK_CHUNKS, ZarrSource};
