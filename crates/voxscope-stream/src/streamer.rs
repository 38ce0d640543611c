//! The CPU half of streaming, one call per frame: read what the last frames' rays lacked and
//! used, decide what to load (in priority order, on worker threads) and what to upload into
//! which atlas slot (within a per-frame budget, evicting the least recently used), keep the page
//! table, and count everything. No GPU calls here: `render::StreamVolume` feeds it the frames'
//! readbacks and carries out its uploads.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::budget::{Cut, SlotNeed, cut_ranked};
use super::failures::Failures;
use super::frame::{Feedback, Upload, ViewPoint};
use super::key_hash::{KeyMap, KeySet};
use super::loader::{AtlasTexels, LoadedBrick, Loader, load_brick};
use super::options::StreamOptions;
use super::page_table::{
    ENTRY_FAILED, ENTRY_RESIDENT, ENTRY_VISIBLE, PageTable, TableEntry, TableFull,
};
use super::pyramid::PyramidShape;
use super::queue::{Priority, Request, RequestQueue, Tier};
use super::ram_cache::RamCache;
use super::slots::SlotPool;
use super::status::{
    BudgetLimit, FullDetailBudget, LevelCounters, StreamCounters, StreamStatus, UpdatePhases,
    UploadParts,
};
use crate::{BRICK_SIZE, BrickId, BrickSource, PADDED_BRICK_VOXELS, ValueRange};

/// What a frame may spend on uploads (the upload allowance follows from it and the measured
/// cost): the CPU's staging and, where the GPU times them, its copies, which a frame waits for
/// before it is drawn. A third of a 16 ms frame.
pub const UPLOAD_SECONDS_PER_FRAME: f64 = 0.0055;

/// What a frame may spend on uploads while the view stands still: two thirds of a 16 ms frame.
/// Nothing on screen moves, so the frame's time shows only as the interface's, and the view
/// completes sooner (a near MIP view's copies move a third of a DVR view's bytes per second).
pub const UPLOAD_SECONDS_STILL: f64 = 0.011;

/// What a frame may upload while the view stands still.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StillUploads {
    /// [`UPLOAD_SECONDS_STILL`]'s worth of the measured cost: frames on a screen, where the
    /// interface's responsiveness counts.
    #[default]
    Paced,
    /// Every brick ready, within the renderer's staging and `--upload-budget`: frames that no
    /// one watches (`refine`: `render`, the benchmarks' stopped views, movies, the Python
    /// module), where only the view's completion counts. On a slow device (lavapipe drew a near
    /// view's frames in 0.8 s) [`Self::Paced`] left a near MIP view coarse for over a minute.
    AllReady,
}

/// Every this many frames, a brick waiting for the upload allowance counts as a use of the
/// RAM cache (`upload_ready`; a different share of the waiting bricks each frame).
const WAITING_TOUCH_FRAMES: u32 = 8;

/// Whether a brick with table entry `entry` needs nothing more: in the atlas, uniform (drawn
/// from its value) or failed.
fn entry_satisfies(entry: &TableEntry) -> bool {
    entry.is_resident()
        || entry.cell & ENTRY_FAILED != 0
        || (entry.range & 0xffff) == (entry.range >> 16)
}

/// Whether a brick with table entry `entry` takes no slot in a view: it needs nothing more
/// ([`entry_satisfies`]) or its range is invisible under the transfer function.
fn entry_needs_no_slot(entry: &TableEntry) -> bool {
    entry_satisfies(entry) || entry.slot & ENTRY_VISIBLE == 0
}

/// A cost's moving average over a few frames (one slow frame does not halve the next
/// allowance), `average` 0 before the first `sample`.
fn moving_average(average: f64, sample: f64) -> f64 {
    if average > 0.0 {
        average * 0.75 + sample * 0.25
    } else {
        sample
    }
}

/// Frames ahead the prefetch follows the camera's motion.
const MOTION_LOOKAHEAD: f64 = 8.0;

/// Prefetch neighbours only when a frame asked for at most this many bricks.
const PREFETCH_AROUND: usize = 1024;

/// Frames in a row in which bricks wait in RAM with no slot to go to and nothing is uploaded,
/// after which the view stands on what the atlas holds (complete at the budget) rather than
/// waiting for slots that nothing frees. A slot frees when a brick placed since replaces a
/// stand-in the frame drew, so frames without any placement change nothing; a few frames
/// cover the feedback's latency.
const STALLED_FRAMES: u32 = 8;

/// Frames, and [`NO_PROGRESS_TIME`], during which a view under the budget's pressure lacks no
/// fewer bricks than it once did, after which it stands on what the atlas holds. A view that
/// fits is never cut so (a slow network store only delays it); one whose bricks are placed and
/// evicted again in turn would otherwise refine forever (run 66: once in four near MIP views,
/// 18 bricks missing after 30 s). Well beyond what a view that converges takes (≤ 200 frames
/// and ≤ 4.5 s in runs 60–66) without new bricks.
const NO_PROGRESS_FRAMES: u32 = 90;
const NO_PROGRESS_TIME: Duration = Duration::from_secs(2);

/// Bricks of the coarsest levels that stay in the atlas, so every ray has a fallback: every
/// level of a single brick.
pub(crate) fn pinned_levels(shape: &PyramidShape) -> Vec<u32> {
    (0..shape.levels.len() as u32)
        .filter(|&l| is_pinned_level(shape, l))
        .collect()
}

/// Bricks of the levels [`pinned_levels`] keeps in the atlas (one each, of every channel).
pub fn pinned_level_count(shape: &PyramidShape) -> usize {
    pinned_levels(shape).len() * shape.channels as usize
}

/// Whether level `level` of `shape` is one [`pinned_levels`] keeps in the atlas.
fn is_pinned_level(shape: &PyramidShape, level: u32) -> bool {
    shape.levels[level as usize].brick_count() == 1
}

/// Of an atlas of `slots` with `pinned` of them held by the always-resident levels, the slots a
/// view may fill with bricks at the levels its rays want: the rest of the unpinned ones (a
/// fifth) is the frame's own room, for the coarser stand-ins drawn while finer bricks arrive.
pub fn view_slots(slots: usize, pinned: usize) -> usize {
    let unpinned = slots.saturating_sub(pinned);
    unpinned - unpinned / 5
}

/// Visibility counts of a transfer function: one per value level and one more.
pub const VISIBILITY_COUNTS: usize = (1 << 16) + 1;

/// The CPU state of one streamed pyramid.
pub struct Streamer {
    source: Arc<dyn BrickSource>,
    shape: PyramidShape,
    texels: AtlasTexels,
    options: StreamOptions,
    atlas_grid: [usize; 3],
    table: PageTable,
    /// Most entries the table is let hold (a quarter of its capacity: short probes).
    max_entries: usize,
    slots: SlotPool,
    ram: RamCache,
    queue: Arc<RequestQueue>,
    loader: Loader,
    /// The frame about to be drawn.
    frame: u32,
    /// The latest frame read back, and whether its rays lacked anything (failed bricks aside).
    feedback_frame: Option<u32>,
    feedback_missing: usize,
    /// The last frame whose page table differed from the one before.
    changed_frame: u32,
    /// Bricks of the level fill ([`Self::level_fill`]) not placed yet: those the latest
    /// feedback chose, each gone once placed or unreadable.
    fill: KeyMap<Request>,
    /// The view the level fill was chosen in: once the view differs, its placements count as
    /// changes (a brick the new view's rays asked for may be among them).
    fill_view: Option<ViewPoint>,
    /// The latest frame the level walk drew ([`Self::mark_level_walked`]).
    level_walked_at: Option<u32>,
    /// The latest frame's wanted visible bricks, by key.
    wanted: KeyMap<Request>,
    /// Of those, how many are not on the GPU yet.
    missing: usize,
    /// Wanted bricks in RAM and not yet uploaded, best first.
    ready: Vec<Request>,
    /// The latest feedback's rays took the maximum (MIP): requests are ordered brightest first.
    max_projection: bool,
    /// Frames in a row in which ready bricks found no slot and nothing was uploaded: every
    /// slot holds a brick the frame drew, and nothing will free one (see [`STALLED_FRAMES`]).
    no_room_frames: u32,
    /// The fewest bricks the view lacked since it was last cut anew, and the frame and time
    /// it first lacked that few (see [`NO_PROGRESS_FRAMES`]).
    fewest_missing: usize,
    progress_at: (u32, Instant),
    /// Table entries that hold no slot, oldest first (dropped when the table is full).
    metadata: VecDeque<u32>,
    /// Bricks that could not be read (their table entries say so: rays draw a coarser level).
    failed: KeySet,
    /// How each failed, whether and when it is asked for again (failures.rs).
    failures: Failures,
    /// The bricks the rays of the latest frame read back asked for that could not be read.
    unreadable: Vec<u32>,
    new_errors: Vec<String>,
    /// Whether [`Self::load_pinned`] has run.
    pinned_loaded: bool,
    /// Bricks that stand for the finer ones the budget leaves out of the view on screen
    /// ([`crate::cut_within`]): whatever rays ask for below one is drawn from it, not loaded.
    standing: KeySet,
    /// The view they stand in; another view is cut anew.
    standing_view: Option<ViewPoint>,
    /// The view under the budget's pressure, refining level by level (`streamer/refine.rs`);
    /// another view is cut anew.
    pressed: Option<ViewPoint>,
    /// Under pressure, the finest level anything of the view refines to (one below the
    /// coarsest brick standing for the budget), once the budget left something out.
    floor: Option<u32>,
    /// Under pressure, the bricks placed for the view, kept in the atlas while it stays
    /// (`Streamer::keep_placed`).
    kept: KeySet,
    /// What the latest cut came to, while anything is left out.
    budget: Option<BudgetLimit>,
    /// The uploads' measured cost on the CPU, a moving average (0 before the first).
    upload_seconds_per_byte: f64,
    /// The GPU's copies' measured cost, likewise (0 where the GPU does not time them).
    upload_gpu_seconds_per_byte: f64,
    /// The most a frame's uploads take through the renderer's staging at once
    /// ([`Self::set_upload_ceiling`]); `u64::MAX` until it says.
    upload_ceiling: u64,
    /// What a frame uploads while the view stands still.
    still_uploads: StillUploads,
    /// The view of the last frame drawn, and how it moved since the one before.
    last_view: Option<ViewPoint>,
    motion: Option<ViewPoint>,
    /// Per channel, `visible_below[c][i]`: value levels below `i` its transfer function makes
    /// visible ([`VISIBILITY_COUNTS`]): the entries' [`ENTRY_VISIBLE`] bits follow them.
    visible_below: Vec<Vec<u32>>,
    counters: StreamCounters,
    /// Per level: bricks in the atlas, and table entries without a slot.
    resident: Vec<usize>,
    empty: Vec<usize>,
    uploads_recent: VecDeque<(Instant, u64)>,
}

/// Why a streamer could not be made or could not place its always-resident bricks: displays
/// as one line of the renderer's "does not fit".
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StreamError {
    /// The atlas holds too few slots for the always-resident levels and a view.
    #[error(
        "an atlas of {capacity} bricks cannot hold the {pinned_levels} always-resident coarse levels and a view; give the renderer more GPU memory"
    )]
    AtlasTooSmall {
        capacity: usize,
        pinned_levels: usize,
    },
    /// A transfer function's visibility counts that are not one per value level and one more.
    #[error("{0} visibility counts, not 65 537")]
    VisibilityCounts(usize),
    /// An always-resident brick found no room in the page table.
    #[error("{source_name}: the page table has no room for {id}")]
    TableFull { source_name: String, id: BrickId },
}

impl Streamer {
    /// Whether an atlas of `capacity` slots holds the `pinned_levels` bricks of the
    /// always-resident levels ([`pinned_level_count`]) and a view: the error says not.
    pub fn check_capacity(pinned_levels: usize, capacity: usize) -> Result<(), StreamError> {
        if capacity < pinned_levels + 8 {
            return Err(StreamError::AtlasTooSmall {
                capacity,
                pinned_levels,
            });
        }
        Ok(())
    }

    /// A streamer of `source` into an atlas of `atlas_grid` slots (x, y, z) holding texels as
    /// `texels`, with the transfer function's visibility counts `visible_below`
    /// ([`Self::set_visibility`]). Reads nothing, and leaves the source's caches as they are:
    /// [`Self::load_pinned`] does both, once, before the first frame (so that a store's first
    /// chunks may still be on their way into those caches while a renderer makes its atlas).
    pub fn new(
        source: Arc<dyn BrickSource>,
        atlas_grid: [usize; 3],
        texels: AtlasTexels,
        options: StreamOptions,
        visible_below: Vec<u32>,
    ) -> Result<Self, StreamError> {
        if visible_below.len() != VISIBILITY_COUNTS {
            return Err(StreamError::VisibilityCounts(visible_below.len()));
        }
        let shape = source.shape().clone();
        let capacity = atlas_grid.iter().product::<usize>();
        Self::check_capacity(pinned_level_count(&shape), capacity)?;
        let max_entries = capacity * 4;
        let queue = Arc::new(RequestQueue::default());
        let loader = Loader::start(
            Arc::clone(&source),
            Arc::clone(&queue),
            texels,
            options.workers,
        );
        let levels = shape.levels.len();
        Ok(Self {
            table: PageTable::new(max_entries * 4),
            max_entries,
            slots: SlotPool::new(capacity),
            // Its share of the RAM budget once the source's caches have theirs (`load_pinned`).
            ram: RamCache::new(0),
            pinned_loaded: false,
            queue,
            loader,
            frame: 0,
            feedback_frame: None,
            feedback_missing: 0,
            no_room_frames: 0,
            fewest_missing: usize::MAX,
            progress_at: (0, Instant::now()),
            max_projection: false,
            changed_frame: 0,
            fill: KeyMap::default(),
            fill_view: None,
            level_walked_at: None,
            wanted: KeyMap::default(),
            missing: 0,
            ready: Vec::new(),
            metadata: VecDeque::new(),
            failed: KeySet::default(),
            failures: Failures::new(options.retry_after),
            unreadable: Vec::new(),
            new_errors: Vec::new(),
            standing: KeySet::default(),
            standing_view: None,
            pressed: None,
            floor: None,
            kept: KeySet::default(),
            budget: None,
            upload_seconds_per_byte: 0.0,
            upload_gpu_seconds_per_byte: 0.0,
            upload_ceiling: u64::MAX,
            still_uploads: StillUploads::default(),
            last_view: None,
            motion: None,
            visible_below: vec![visible_below; shape.channels as usize],
            counters: StreamCounters {
                levels: shape
                    .levels
                    .iter()
                    .map(|l| LevelCounters {
                        total: l.brick_count() * shape.channels as u64,
                        ..Default::default()
                    })
                    .collect(),
                slots: capacity,
                slot_bytes: (PADDED_BRICK_VOXELS * texels.bytes()) as u64,
                ..Default::default()
            },
            resident: vec![0; levels],
            empty: vec![0; levels],
            uploads_recent: VecDeque::new(),
            source,
            shape,
            texels,
            options,
            atlas_grid,
        })
    }

    /// Once, after [`Self::new`] and before the first frame: gives the source's caches their
    /// share of the RAM budget (the bricks' cache gets the rest), then reads every brick of the
    /// always-resident coarse levels (on the caller's thread and rayon's) and gives each a
    /// pinned slot; returns their uploads (none when called again). One that cannot be read is
    /// a failed brick like any other (asked for again as its failure allows).
    pub fn load_pinned(&mut self) -> Result<Vec<Upload>, StreamError> {
        if std::mem::replace(&mut self.pinned_loaded, true) {
            return Ok(Vec::new());
        }
        let ram = self.options.ram_cache;
        let source_caches = self.source.reserve_caches(ram).min(ram);
        self.ram = RamCache::new(ram - source_caches);
        self.counters.ram_capacity = ram - source_caches;
        self.counters.source_cache_capacity = source_caches;
        let ids: Vec<BrickId> = (0..self.shape.channels)
            .flat_map(|channel| {
                pinned_levels(&self.shape)
                    .into_iter()
                    .map(move |level| BrickId::new(level, [0; 3]).of_channel(channel))
            })
            .collect();
        let source = &*self.source;
        let texels = self.texels;
        let loaded: Vec<_> = ids
            .par_iter()
            .map(|&id| (id, load_brick(source, id, texels)))
            .collect();
        let mut uploads = Vec::new();
        for (id, (brick, bytes_read)) in loaded {
            let key = self.shape.key(id).expect("a pinned level's brick");
            let brick = match brick {
                Ok(brick) => brick,
                Err(error) => {
                    self.fail(key, id, error);
                    continue;
                }
            };
            self.counters.bytes_read += bytes_read;
            self.counters.loads += 1;
            self.counters.levels[id.level as usize].loaded += 1;
            if let Some(upload) = self.place(key, id, &brick, None)? {
                self.slots.pin(upload.slot);
                uploads.push(upload);
            } else {
                // Uniform: drawn from its value, nothing to pin.
            }
        }
        self.changed_frame = self.frame;
        Ok(uploads)
    }

    /// The pyramid's shape.
    pub fn shape(&self) -> &PyramidShape {
        &self.shape
    }

    /// The source.
    pub fn source(&self) -> &Arc<dyn BrickSource> {
        &self.source
    }

    /// Slots the always-resident coarse levels hold.
    pub fn pinned_slots(&self) -> usize {
        self.slots.pinned()
    }

    /// How the atlas stores texels.
    pub fn texels(&self) -> AtlasTexels {
        self.texels
    }

    /// The options it was made with.
    pub fn options(&self) -> &StreamOptions {
        &self.options
    }

    /// The frame about to be drawn (what rays mark the slots they use with).
    pub fn frame(&self) -> u32 {
        self.frame
    }

    /// The page table (its changed entries go to the GPU with [`PageTable::take_dirty`]).
    pub fn table_mut(&mut self) -> &mut PageTable {
        &mut self.table
    }

    /// The page table.
    pub fn table(&self) -> &PageTable {
        &self.table
    }

    /// Atlas cell of `slot`, packed ten bits per axis (x lowest), as the shader reads it.
    fn packed_cell(&self, slot: u32) -> u32 {
        let [gx, gy, _] = self.atlas_grid.map(|g| g as u32);
        (slot % gx) | ((slot / gx) % gy) << 10 | (slot / (gx * gy)) << 20
    }

    /// Puts a loaded brick on the GPU side: a uniform one as a table entry alone, another in
    /// a slot (`protect_from`: slots used since that frame are not evicted; `None` for the
    /// first, pinned levels). `Ok(None)` for a uniform brick; `Err` only if the table is full
    /// for a pinned brick.
    fn place(
        &mut self,
        key: u32,
        id: BrickId,
        brick: &LoadedBrick,
        protect_from: Option<u32>,
    ) -> Result<Option<Upload>, StreamError> {
        let level = id.level as usize;
        let was = self.table.get(key);
        let Some(texels) = &brick.texels else {
            let entry = TableEntry {
                key,
                cell: 0,
                range: brick.range.packed(),
                slot: 0,
            };
            if self.insert_entry(entry).is_ok() && was.is_none() {
                self.empty[level] += 1;
                self.metadata.push_back(key);
            }
            return Ok(None);
        };
        let protect_from = protect_from.unwrap_or(u32::MAX);
        let Some(allocation) = self.slots.allocate(key, self.frame, protect_from) else {
            return Ok(None);
        };
        if let Some(evicted) = allocation.evicted {
            self.demote(evicted);
        }
        let entry = TableEntry {
            key,
            cell: ENTRY_RESIDENT | self.packed_cell(allocation.slot),
            range: brick.range.packed(),
            slot: allocation.slot,
        };
        if self.insert_entry(entry).is_err() {
            // Found no room within the probe limit: leave the brick out (its region stays
            // coarser) and free the slot again.
            self.slots.release(allocation.slot);
            return Err(StreamError::TableFull {
                source_name: self.source.name().to_owned(),
                id,
            });
        }
        if was.is_some_and(|e| !e.is_resident() && e.cell & ENTRY_FAILED == 0) {
            self.empty[level] = self.empty[level].saturating_sub(1);
        }
        self.resident[level] += 1;
        Ok(Some(Upload {
            slot: allocation.slot,
            texels: Arc::clone(texels),
        }))
    }

    /// Inserts `entry` (its [`ENTRY_VISIBLE`] bit set from its range), first dropping the
    /// oldest slotless entries while the table is at its limit.
    fn insert_entry(&mut self, mut entry: TableEntry) -> Result<(), TableFull> {
        entry.slot &= !ENTRY_VISIBLE;
        if entry.cell & ENTRY_FAILED == 0 && self.range_visible(entry.key, entry.range) {
            entry.slot |= ENTRY_VISIBLE;
        }
        while self.table.len() >= self.max_entries {
            let Some(oldest) = self.metadata.pop_front() else {
                break;
            };
            if let Some(old) = self.table.get(oldest)
                && !old.is_resident()
                && old.cell & ENTRY_FAILED == 0
            {
                self.table.remove(oldest);
                if let Some(id) = self.shape.brick_of(oldest) {
                    self.empty[id.level as usize] = self.empty[id.level as usize].saturating_sub(1);
                }
            }
        }
        self.table.insert(entry)
    }

    /// The brick `key` lost its slot: it stays in the table without one (its range still lets
    /// rays skip it) while the table has room.
    fn demote(&mut self, key: u32) {
        let Some(id) = self.shape.brick_of(key) else {
            return;
        };
        self.resident[id.level as usize] = self.resident[id.level as usize].saturating_sub(1);
        self.counters.evictions += 1;
        self.counters.levels[id.level as usize].evicted += 1;
        if let Some(entry) = self.table.get(key) {
            let demoted = TableEntry {
                cell: 0,
                slot: 0,
                ..entry
            };
            if self.insert_entry(demoted).is_ok() {
                self.empty[id.level as usize] += 1;
                self.metadata.push_back(key);
            }
        }
    }

    /// Starts frame `frame() + 1`: takes in the workers' results and, if a frame was read back,
    /// its requests and usage marks; decides loads and this frame's uploads. `view` orders the
    /// loads (near its center first). The table's changes are then in [`Self::table_mut`].
    pub fn begin_frame(
        &mut self,
        feedback: Option<Feedback<'_>>,
        view: Option<ViewPoint>,
    ) -> (Vec<Upload>, StreamStatus) {
        let mut phases = UpdatePhases::default();
        let mut step = Instant::now();
        let mut lap = |into: &mut f64| {
            let now = Instant::now();
            *into = (now - step).as_secs_f64();
            step = now;
        };
        self.frame += 1;
        self.slots.new_frame();
        self.retry_failed();
        self.receive_results();
        lap(&mut phases.results);
        if let Some(view) = view {
            self.follow_view(view);
            self.motion = self.last_view.map(|last| view.since(&last));
            self.last_view = Some(view);
        }
        if let Some(feedback) = feedback {
            self.take_feedback(feedback, view);
        }
        lap(&mut phases.feedback);
        let (uploads, upload_bytes, asked_for) = self.upload_ready();
        // Nothing more is coming for the level fill once nothing is queued, loading or ready
        // (a load its queue dropped, or one evicted from RAM, waits for a later feedback's fill).
        if self.queue.counts() == (0, 0) && self.ready.is_empty() {
            self.fill.clear();
        }
        // A brick only the level fill wants changes no ray's samples (no ray reached it, or
        // one skipped it): the view stays complete.
        if asked_for > 0 {
            self.changed_frame = self.frame;
        }
        let mut status = self.status(uploads.len(), upload_bytes);
        lap(&mut phases.choose_uploads);
        status.phases = phases;
        (uploads, status)
    }
}

mod cut;
mod feedback;
mod refine;
mod results;
mod uploads;

#[cfg(test)]
mod tests;
