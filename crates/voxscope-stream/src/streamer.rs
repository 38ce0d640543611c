//! The CPU half of streaming, one call per frame: read what the last frames' rays lacked and
//! used, decide what to load (in priority order, on worker threads) and what to upload into
//! which atlas slot (within a per-frame budget, evicting the least recently used), keep the page
//! table, and count everything. No GPU calls here: `render::StreamVolume` feeds it the frames'
//! readbacks and carries out its uploads.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::budget::{Cut, SlotNeed, cut_within};
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
use crate::{BrickId, BrickSource, PADDED_BRICK_VOXELS, ValueRange};

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

/// Bricks of the levels [`pinned_levels`] keeps in the atlas (one each).
pub fn pinned_level_count(shape: &PyramidShape) -> usize {
    pinned_levels(shape).len()
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
    /// `visible_below[i]`: value levels below `i` the transfer function makes visible (65 537
    /// counts): the entries' [`ENTRY_VISIBLE`] bits follow it.
    visible_below: Vec<u32>,
    counters: StreamCounters,
    /// Per level: bricks in the atlas, and table entries without a slot.
    resident: Vec<usize>,
    empty: Vec<usize>,
    uploads_recent: VecDeque<(Instant, u64)>,
}

impl Streamer {
    /// Whether an atlas of `capacity` slots holds the `pinned_levels` bricks of the
    /// always-resident levels ([`pinned_level_count`]) and a view: the error says not.
    pub fn check_capacity(pinned_levels: usize, capacity: usize) -> Result<(), String> {
        if capacity < pinned_levels + 8 {
            return Err(format!(
                "an atlas of {capacity} bricks cannot hold the {pinned_levels} always-resident coarse levels and a view; give the renderer more GPU memory"
            ));
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
    ) -> Result<Self, String> {
        if visible_below.len() != (1 << 16) + 1 {
            return Err(format!(
                "{} visibility counts, not 65 537",
                visible_below.len()
            ));
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
            budget: None,
            upload_seconds_per_byte: 0.0,
            upload_gpu_seconds_per_byte: 0.0,
            upload_ceiling: u64::MAX,
            still_uploads: StillUploads::default(),
            last_view: None,
            motion: None,
            visible_below,
            counters: StreamCounters {
                levels: shape
                    .levels
                    .iter()
                    .map(|l| LevelCounters {
                        total: l.brick_count(),
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
    pub fn load_pinned(&mut self) -> Result<Vec<Upload>, String> {
        if std::mem::replace(&mut self.pinned_loaded, true) {
            return Ok(Vec::new());
        }
        let ram = self.options.ram_cache;
        let source_caches = self.source.reserve_caches(ram).min(ram);
        self.ram = RamCache::new(ram - source_caches);
        self.counters.ram_capacity = ram - source_caches;
        self.counters.source_cache_capacity = source_caches;
        let ids: Vec<BrickId> = pinned_levels(&self.shape)
            .iter()
            .map(|&level| BrickId {
                level,
                brick: [0; 3],
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

    /// Bytes a frame may upload: the allowance set from the measured cost
    /// ([`Self::set_upload_cost`]); while the view has not moved since the last frame,
    /// [`UPLOAD_SECONDS_STILL`]'s worth, or all that is ready ([`StillUploads`]); never more
    /// than `--upload-budget` or the renderer's staging holds ([`Self::set_upload_ceiling`]).
    fn upload_allowance(&self) -> u64 {
        let allowance = match self.counters.upload_allowance {
            0 => u64::MAX,
            _ if self.view_is_still() && self.still_uploads == StillUploads::AllReady => u64::MAX,
            moving if self.view_is_still() => {
                (moving as f64 * UPLOAD_SECONDS_STILL / UPLOAD_SECONDS_PER_FRAME) as u64
            }
            moving => moving,
        };
        allowance
            .min(self.options.upload_bytes_per_frame)
            .min(self.upload_ceiling)
    }

    /// The most bytes one frame's uploads take through the renderer's staging (its ring
    /// buffer: what does not fit goes a slower way). A frame uploads no more, whether it moves
    /// or stands still; at least one brick.
    pub fn set_upload_ceiling(&mut self, bytes: u64) {
        self.upload_ceiling = bytes.max(self.counters.slot_bytes);
        self.counters.upload_allowance = self.counters.upload_allowance.min(self.upload_ceiling);
    }

    /// Sets what a frame uploads while the view stands still; returns what it was.
    pub fn set_still_uploads(&mut self, still: StillUploads) -> StillUploads {
        std::mem::replace(&mut self.still_uploads, still)
    }

    /// Whether the view is where it was a frame ago (its motion is known and nothing).
    fn view_is_still(&self) -> bool {
        self.motion
            .is_some_and(|m| m.eye == [0.0; 3] && m.forward == [0.0; 3])
    }

    /// What the last frame's uploads cost: `seconds` for `bytes`. The allowance follows, so
    /// that a frame spends about [`UPLOAD_SECONDS_PER_FRAME`] on uploads whatever the device.
    pub fn set_upload_cost(&mut self, bytes: u64, seconds: f64, parts: &UploadParts) {
        self.counters.upload_seconds += seconds;
        self.counters.upload_parts.add(parts);
        if bytes == 0 || seconds <= 0.0 {
            return;
        }
        self.upload_seconds_per_byte =
            moving_average(self.upload_seconds_per_byte, seconds / bytes as f64);
        self.set_allowance();
    }

    /// What the GPU's copies of earlier uploads took: `seconds` for `bytes` (measured by GPU
    /// timestamps a frame or two late). The allowance counts them with the CPU's cost.
    pub fn set_upload_gpu_cost(&mut self, bytes: u64, seconds: f64) {
        self.counters.upload_parts.copy_timed_bytes += bytes;
        self.counters.upload_parts.copy_gpu_seconds += seconds;
        if bytes == 0 || seconds <= 0.0 {
            return;
        }
        self.upload_gpu_seconds_per_byte =
            moving_average(self.upload_gpu_seconds_per_byte, seconds / bytes as f64);
        self.set_allowance();
    }

    /// The allowance from the measured costs per byte: [`UPLOAD_SECONDS_PER_FRAME`] of the
    /// CPU's and the GPU's work together, at least one brick.
    fn set_allowance(&mut self) {
        let per_byte = self.upload_seconds_per_byte + self.upload_gpu_seconds_per_byte;
        if per_byte <= 0.0 {
            return;
        }
        let allowance = (UPLOAD_SECONDS_PER_FRAME / per_byte) as u64;
        self.counters.upload_allowance = allowance
            .min(self.upload_ceiling)
            .max(self.counters.slot_bytes);
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
    ) -> Result<Option<Upload>, String> {
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
            return Err(format!(
                "{}: the page table has no room for {id}",
                self.source.name()
            ));
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

    /// Whether some level of `range` (packed) is visible under the transfer function.
    fn range_visible(&self, range: u32) -> bool {
        let (low, high) = ((range & 0xffff) as usize, (range >> 16) as usize);
        self.visible_below[high + 1] > self.visible_below[low]
    }

    /// A new transfer function's visibility counts (`visible_below[i]`: how many value levels
    /// below `i` are visible; 65 537 of them): every entry's [`ENTRY_VISIBLE`] bit follows, the
    /// changed entries to be copied to the GPU. Nothing is reloaded.
    pub fn set_visibility(&mut self, visible_below: Vec<u32>) {
        if visible_below.len() != self.visible_below.len() {
            return;
        }
        self.visible_below = visible_below;
        // Other values visible: another working set, cut anew.
        self.cut_anew();
        let counts = &self.visible_below;
        self.table.update_each(|entry| {
            let (low, high) = (
                (entry.range & 0xffff) as usize,
                (entry.range >> 16) as usize,
            );
            let visible = counts[high + 1] > counts[low];
            ((entry.slot & ENTRY_VISIBLE != 0) != visible).then_some(TableEntry {
                slot: entry.slot ^ ENTRY_VISIBLE,
                ..*entry
            })
        });
        self.changed_frame = self.frame;
    }

    /// Inserts `entry` (its [`ENTRY_VISIBLE`] bit set from its range), first dropping the
    /// oldest slotless entries while the table is at its limit.
    fn insert_entry(&mut self, mut entry: TableEntry) -> Result<(), TableFull> {
        entry.slot &= !ENTRY_VISIBLE;
        if entry.cell & ENTRY_FAILED == 0 && self.range_visible(entry.range) {
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

    /// Forgets the failures whose retry time has come: the rays ask for those bricks again.
    fn retry_failed(&mut self) {
        let due = self.failures.due(Instant::now());
        if due.is_empty() {
            return;
        }
        for key in due {
            self.failed.remove(&key);
            if self
                .table
                .get(key)
                .is_some_and(|entry| entry.cell & ENTRY_FAILED != 0)
            {
                self.table.remove(key);
            }
        }
        self.changed_frame = self.frame;
    }

    /// Brick `id` (`key`) could not be read: its entry says so (rays draw the finest coarser
    /// level there and ask for it only to say they need it), and its failure is recorded.
    fn fail(&mut self, key: u32, id: BrickId, error: crate::BrickError) {
        self.failures.record(key, id, error, Instant::now());
        self.new_errors.extend(self.failures.take_lines());
        if self.failed.insert(key) {
            let entry = TableEntry {
                key,
                cell: ENTRY_FAILED,
                range: 0,
                slot: 0,
            };
            let _ = self.insert_entry(entry);
            self.changed_frame = self.frame;
        }
    }

    /// The bricks that could not be read: each one's level, brick, cause and whether it is
    /// asked for again (the app's panel lists them).
    pub fn failures(&self) -> &Failures {
        &self.failures
    }

    /// The bricks the latest frame read back needed and could not have (drawn from a coarser
    /// level): what makes a view incomplete (`render` lists them).
    pub fn unreadable(&self) -> impl Iterator<Item = &crate::FailedBrick> + '_ {
        self.unreadable
            .iter()
            .filter_map(|&key| self.failures.get(key))
    }

    fn receive_results(&mut self) {
        for result in self.loader.received() {
            self.queue.done(result.key);
            self.counters.bytes_read += result.bytes_read;
            match result.brick {
                Ok(brick) => {
                    self.counters.read_seconds += result.seconds;
                    self.failures.succeeded(result.key);
                    self.counters.loads += 1;
                    if let Some(id) = self.shape.brick_of(result.key) {
                        self.counters.levels[id.level as usize].loaded += 1;
                    }
                    self.counters.prefetch_loads += result.prefetch as u64;
                    self.ram.insert(result.key, brick);
                    if let Some(request) = self
                        .wanted
                        .get(&result.key)
                        .or_else(|| self.fill.get(&result.key))
                    {
                        self.ready.push(*request);
                    }
                }
                Err(error) => {
                    if self.wanted.contains_key(&result.key) {
                        self.missing = self.missing.saturating_sub(1);
                    }
                    self.fill.remove(&result.key);
                    if let Some(id) = self.shape.brick_of(result.key)
                        && !self.failed.contains(&result.key)
                    {
                        self.fail(result.key, id, error);
                    }
                }
            }
        }
        self.ready.sort_unstable_by_key(|r| r.priority);
        self.ready.dedup_by_key(|r| r.key);
    }

    /// Whether the source knows brick `id`'s range without reading it and the transfer
    /// function makes that range invisible; if so the brick enters the table without a slot
    /// (as an evicted one would), so that rays skip it and nothing is loaded.
    fn known_invisible(&mut self, key: u32, id: BrickId) -> bool {
        if let Some(entry) = self.table.get(key) {
            // Entered already (read, or known invisible before): its bit says.
            return entry.cell & ENTRY_FAILED == 0 && entry.slot & ENTRY_VISIBLE == 0;
        }
        let Some(range) = self.source.known_range(id) else {
            return false;
        };
        if self.range_visible(range.packed()) {
            return false;
        }
        if self.enter_known_range(key, id, range) {
            self.counters.skipped_unread += 1;
        }
        true
    }

    /// [`Self::satisfied`] or [`Self::known_invisible`], with one look in the table.
    fn satisfied_or_invisible(&mut self, key: u32, id: BrickId) -> bool {
        match self.table.get(key) {
            Some(entry) => entry_needs_no_slot(&entry),
            None => self.known_invisible(key, id),
        }
    }

    /// Enters brick `key` in the table without a slot, with the range its source knows
    /// without reading it (rays skip it where that range says they may); whether it entered.
    fn enter_known_range(&mut self, key: u32, id: BrickId, range: ValueRange) -> bool {
        let entry = TableEntry {
            key,
            cell: 0,
            range: range.packed(),
            slot: 0,
        };
        if self.insert_entry(entry).is_err() {
            return false;
        }
        self.empty[id.level as usize] += 1;
        self.metadata.push_back(key);
        self.changed_frame = self.frame;
        true
    }

    /// Whether `key` needs nothing more: in the atlas, uniform (drawn from its value) or failed.
    fn satisfied(&self, key: u32) -> bool {
        self.table
            .get(key)
            .is_some_and(|entry| entry_satisfies(&entry))
    }

    /// The load priority of the visible brick `key`: coarse first, then (MIP) the brightest
    /// first, then nearest the view's center. Under MIP a brick whose range the source knows
    /// without reading it enters the table with that range (as an evicted brick stays), so
    /// that a ray whose maximum is already above it stops asking for it: once the brightest
    /// bricks are in, most of the rest are never read.
    fn visible_priority(&mut self, key: u32, id: BrickId, off_center: f32) -> Priority {
        if !self.max_projection {
            return Priority::new(Tier::Visible, id.level, off_center);
        }
        let maximum = match self.table.get(key) {
            Some(entry) => (entry.range >> 16) as u16,
            None => match self.source.known_range(id) {
                Some(range) => {
                    self.enter_known_range(key, id, range);
                    range.max
                }
                None => 0,
            },
        };
        Priority::with_maximum(Tier::Visible, id.level, maximum, off_center)
    }

    /// Whether `key` takes no slot in a view: [`Self::satisfied`], or its range (known without
    /// reading it, or from when it was last read) is invisible, so that rays skip it. A coarser
    /// brick of a cut may be invisible while the finer ones it stands for are not (a mean of
    /// a thin bright structure falls below the transfer function's visible values): counted as
    /// a slot to load, it would never load, and the cut would never stand.
    fn needs_no_slot(&self, key: u32) -> bool {
        if let Some(entry) = self.table.get(key) {
            return entry_needs_no_slot(&entry);
        }
        self.shape
            .brick_of(key)
            .and_then(|id| self.source.known_range(id))
            .is_some_and(|range| !self.range_visible(range.packed()))
    }

    /// What brick `key` takes of a view's room in the atlas ([`cut_within`]): a slot to load
    /// it into where it is `requested` or not in the atlas and visible; none where the room
    /// counts it already (`committed`), or it is pinned, uniform, failed or invisible; its
    /// slot where the atlas holds it for rays that draw it in place of finer bricks.
    fn slot_need(&self, key: u32, requested: &KeySet, committed: &KeySet) -> SlotNeed {
        if requested.contains(&key) {
            return SlotNeed::Load;
        }
        if committed.contains(&key) {
            return SlotNeed::Nothing;
        }
        let pinned = || {
            self.shape
                .brick_of(key)
                .is_some_and(|id| is_pinned_level(&self.shape, id.level))
        };
        match self.table.get(key) {
            Some(entry) if entry.is_resident() && entry.slot & ENTRY_VISIBLE != 0 => {
                if pinned() {
                    SlotNeed::Nothing
                } else {
                    SlotNeed::Held
                }
            }
            Some(entry) if entry_needs_no_slot(&entry) => SlotNeed::Nothing,
            Some(_) => SlotNeed::Load,
            None if self.needs_no_slot(key) => SlotNeed::Nothing,
            None => SlotNeed::Load,
        }
    }

    fn take_feedback(&mut self, feedback: Feedback<'_>, view: Option<ViewPoint>) {
        for (slot, &mark) in feedback.usage.iter().enumerate() {
            if mark != 0 {
                self.slots.mark_used(slot as u32, mark >> 1, mark & 1 == 1);
            }
        }
        self.feedback_frame = Some(feedback.frame);
        self.max_projection = feedback.max_projection;
        let view = view.unwrap_or(ViewPoint {
            eye: [0.0; 3],
            forward: [0.0, 0.0, 1.0],
        });
        // Where the camera's motion leads: the prefetch loads what it will see first.
        let ahead = self
            .motion
            .map_or(view, |motion| view.ahead(motion, MOTION_LOOKAHEAD));
        let mut asked: Vec<u32> = feedback.requests.to_vec();
        asked.sort_unstable();
        asked.dedup();
        // Asked for and unreadable: drawn from the finest coarser level that can be read.
        self.unreadable = asked
            .iter()
            .copied()
            .filter(|key| self.failed.contains(key))
            .collect();
        // What was asked for that can show, each in place of the brick that stands for it
        // where the budget left it out, within the room the atlas has for this view
        // (`budget.rs`: the least important give way to their parents where it does not fit).
        let mut requests = Vec::with_capacity(asked.len());
        let mut seen = KeySet::default();
        let mut left_out = vec![0usize; self.shape.levels.len()];
        for &key in &asked {
            let Some(id) = self.shape.brick_of(key) else {
                continue;
            };
            let (key, id) = match self.standing_for(id) {
                Some(stand_in) => {
                    left_out[id.level as usize] += 1;
                    stand_in
                }
                None => (key, id),
            };
            if !seen.insert(key) || self.satisfied_or_invisible(key, id) {
                continue;
            }
            let off_center = view.off_center(self.shape.brick_center(id));
            let priority = self.visible_priority(key, id, off_center);
            // Under MIP that entered the range the source knows: a uniform one is drawn from
            // its value and needs nothing (the cut below counts every request as a slot).
            if self.max_projection && self.satisfied(key) {
                continue;
            }
            requests.push(Request { priority, id, key });
        }
        // Failed bricks are asked for no more; left-out ones are drawn from what stands for
        // them: what still lacks is what the view misses.
        self.feedback_missing = requests.len();
        for (counters, &count) in self.counters.levels.iter_mut().zip(&left_out) {
            counters.left_out = count;
        }
        // The view's bricks in the atlas: those its rays wanted, and those standing for
        // bricks left out (drawn in their place).
        let mut committed: KeySet = self.slots.wanted_unpinned_since(feedback.frame).collect();
        // Of those, the ones its rays wanted at their own levels (the rest stand in).
        let wanted_in_atlas = committed.len();
        committed.extend(
            self.standing
                .iter()
                .copied()
                .filter(|&key| self.table.get(key).is_some_and(|e| e.is_resident())),
        );
        // The view's share of the atlas decides what the view can have; what loads now is also
        // never more than can be placed without evicting what the frame drew (a passing
        // shortage, while stand-ins are drawn, delays bricks but leaves none out).
        let room = self.budget_slots().saturating_sub(committed.len());
        if requests.len() < self.fewest_missing {
            self.fewest_missing = requests.len();
            self.progress_at = (self.frame, Instant::now());
        }
        // The requests need a slot each (they passed `satisfied` and `known_invisible` above);
        // only the coarser bricks a cut brings in, and their ancestors, are looked up.
        let requested: KeySet = requests.iter().map(|r| r.key).collect();
        let slot_need = |key: u32| self.slot_need(key, &requested, &committed);
        let cut = cut_within(&requests, room, &self.shape, &view, slot_need);
        let available = self.slots.available(feedback.frame.max(1));
        // Stalled: bricks wait in RAM for slots that nothing will free (the stand-ins frames
        // draw hold more than the fifth of the atlas left to them). What the atlas holds is
        // then the cut, as when stuck below.
        // Or, under the budget's pressure, the view has lacked no fewer bricks for a while:
        // bricks are placed and evicted again in turn (a livelock), and waiting longer
        // changes nothing.
        let pressed = !cut.left_out.is_empty() || available < room;
        let no_progress = pressed
            && self.frame.saturating_sub(self.progress_at.0) >= NO_PROGRESS_FRAMES
            && self.progress_at.1.elapsed() >= NO_PROGRESS_TIME;
        let stalled = self.no_room_frames >= STALLED_FRAMES || no_progress;
        let cut_now = (available < room || stalled).then(|| {
            let room_now = if stalled { 0 } else { available };
            cut_within(&requests, room_now, &self.shape, &view, slot_need)
        });
        let loads_now = cut_now.as_ref().map_or(&cut.load, |now| &now.load).clone();
        // The cut counts every asked brick as a slot; many turn out uniform (no slot) once
        // read. So the cut stands only once everything it loads is in: until then the rest is
        // just not loaded yet, and the next frame's cut knows more.
        if !cut.standing.is_empty() && cut.load.iter().all(|r| self.needs_no_slot(r.key)) {
            self.stand_in(&cut.standing, view);
        } else if let Some(now) = cut_now.filter(|now| {
            // Stuck: every slot holds a brick the frame drew (wanted, or drawn in place of a
            // finer one), nothing can be placed without evicting one, and nothing is on its
            // way. What the atlas holds is the cut: its coarser bricks stand for the rest.
            !now.standing.is_empty()
                && now.load.iter().all(|r| self.needs_no_slot(r.key))
                && (stalled || (self.ready.is_empty() && self.queue.counts() == (0, 0)))
        }) {
            self.stand_in(&now.standing, view);
        }
        if !self.standing.is_empty() {
            let left_out: usize = left_out.iter().sum::<usize>() + cut.left_out.len();
            self.note_budget(&cut, &committed, wanted_in_atlas + requests.len(), left_out);
        }
        // What the cut loads, and the coarser bricks above each down to the first one the GPU
        // has (so the picture refines level by level).
        let mut wanted: KeyMap<Request> = KeyMap::default();
        wanted.reserve(cut.load.len() + cut.load.len() / 4);
        let mut prefetch: KeyMap<Request> = KeyMap::default();
        // Prefetch around a few asks only, and only when the view fits: beyond that the view
        // is far from complete, or the atlas full, and what is visible keeps the workers busy
        // (and the frame's CPU time stays small).
        let prefetch_around = self.options.prefetch
            && asked.len() <= PREFETCH_AROUND
            && cut.left_out.is_empty()
            && self.standing.is_empty();
        for request in &loads_now {
            let mut id = request.id;
            let mut key = request.key;
            let asked_level = id.level;
            loop {
                if self.failed.contains(&key) {
                    // Unreadable: the finest coarser brick that can be read stands in for it.
                    let Some(parent) = self.shape.parent(id) else {
                        break;
                    };
                    id = parent;
                    key = self.shape.key(id).expect("a parent is in the pyramid");
                    continue;
                }
                // In the atlas, uniform, or its range (known without reading it) cannot show:
                // the rays skip it.
                if wanted.contains_key(&key) || self.satisfied_or_invisible(key, id) {
                    break;
                }
                let off_center = view.off_center(self.shape.brick_center(id));
                wanted.insert(
                    key,
                    Request {
                        priority: self.visible_priority(key, id, off_center),
                        id,
                        key,
                    },
                );
                if prefetch_around && id.level == asked_level {
                    self.add_neighbours(id, &ahead, &mut prefetch);
                }
                let Some(parent) = self.shape.parent(id) else {
                    break;
                };
                id = parent;
                key = self.shape.key(id).expect("a parent is in the pyramid");
            }
        }
        let fill = if requests.is_empty() && self.standing.is_empty() {
            self.level_fill()
        } else {
            Vec::new()
        };
        self.fill = fill.iter().map(|r| (r.key, *r)).collect();
        self.fill_view = Some(view);
        // One pass: per-level counts; ready (in RAM: a hit, unless it was ready already) or
        // to load; then the level's fill, then the prefetch after them.
        for level in &mut self.counters.levels {
            level.requested = 0;
        }
        let already: KeySet = self.ready.iter().map(|r| r.key).collect();
        let (mut ready, mut loads) = (Vec::new(), Vec::new());
        for request in wanted.values() {
            self.counters.levels[request.id.level as usize].requested += 1;
            if self.ram.contains(request.key) {
                if !already.contains(&request.key) {
                    self.counters.ram_hits += 1;
                }
                ready.push(*request);
            } else {
                loads.push(*request);
            }
        }
        for request in fill {
            if self.ram.contains(request.key) {
                ready.push(request);
            } else {
                loads.push(request);
            }
        }
        ready.sort_unstable_by_key(|r| r.priority);
        self.ready = ready;
        let room =
            self.ram.capacity().saturating_sub(self.ram.bytes()) / self.counters.slot_bytes.max(1);
        loads.extend(
            prefetch
                .into_values()
                .filter(|r| !wanted.contains_key(&r.key) && !self.ram.contains(r.key))
                .take(room as usize),
        );
        self.queue.replace(loads);
        // The queue's first bricks' requests go out now, in its order (visible before
        // prefetch, coarse before fine, the view's center first), not one brick a loader at
        // a time.
        self.loader.fetch_ahead();
        self.missing = wanted.len();
        self.wanted = wanted;
    }

    /// The bricks that would let frames walk the level (or the two levels) the page table
    /// copies flat (every ray wants it, or one near and the other far: `voxscope-render`'s
    /// stream.rs), loaded once the view lacks nothing: those the table does not know yet, and
    /// visible ones not in the atlas (behind opaque matter, below a MIP ray's maximum, or,
    /// of two levels, where the rays want the other, so never asked for). Then each frame walks
    /// that level's grid as the bricks renderer does, and turning the camera needs nothing
    /// more. None where one
    /// of its bricks is unreadable, or where they might not fit in the atlas's free slots
    /// (nothing is evicted for them), in half the RAM cache on their way, or in the page table
    /// (with an eighth to spare); none from a store over a network, where what a view reads is
    /// what it needs (the link is the bound, and may be metered).
    fn level_fill(&self) -> Vec<Request> {
        if self.source.remote_stats().is_some() {
            return Vec::new();
        }
        let Some(unwalkable) = self.table.level_unwalkable(self.max_projection) else {
            return Vec::new();
        };
        let free = self.slots.capacity() - self.slots.occupied();
        // Held in RAM on their way, with room to spare for what the view asks for next.
        let ram_room = self.ram.capacity() / 2 / self.counters.slot_bytes.max(1);
        // Each brick the table does not know yet takes an entry: they must fit without the
        // table dropping slotless entries (`insert_entry`), the level's own among them.
        let new_entries = self.table.level_unknown().unwrap_or(0);
        let table_room = (self.max_entries - self.max_entries / 8).saturating_sub(self.table.len());
        if unwalkable == 0
            || unwalkable > free
            || unwalkable as u64 > ram_room
            || new_entries > table_room
        {
            return Vec::new();
        }
        let mut fill = Vec::with_capacity(unwalkable);
        for key in self.table.level_unwalkable_keys(self.max_projection) {
            if self.failed.contains(&key) {
                return Vec::new();
            }
            let Some(id) = self.shape.brick_of(key) else {
                continue;
            };
            fill.push(Request {
                priority: Priority::new(Tier::Prefetch, id.level, 0.0),
                id,
                key,
            });
        }
        fill
    }

    /// Slots a view may fill with bricks at the levels its rays want ([`view_slots`]).
    fn budget_slots(&self) -> usize {
        view_slots(self.slots.capacity(), self.slots.pinned())
    }

    /// The brick that stands for `id` in the view on screen (the coarsest of its ancestors
    /// standing for bricks the budget left out), if any.
    fn standing_for(&self, id: BrickId) -> Option<(u32, BrickId)> {
        if self.standing.is_empty() {
            return None;
        }
        let mut found = None;
        let mut ancestor = self.shape.parent(id);
        while let Some(up) = ancestor {
            let key = self.shape.key(up)?;
            if self.standing.contains(&key) {
                found = Some((key, up));
            }
            ancestor = self.shape.parent(up);
        }
        found
    }

    /// `keys` stand for the bricks below them in `view` from now on.
    fn stand_in(&mut self, keys: &[u32], view: ViewPoint) {
        self.no_room_frames = 0;
        self.forget_progress();
        self.standing.extend(keys.iter().copied());
        self.standing_view = Some(view);
        self.changed_frame = self.frame;
    }

    /// What the view needs against what fits, for the status: `wanted` bricks at the levels
    /// its rays chose (in the atlas or asked for, the stand-ins drawn from `committed` aside),
    /// `left_out` more drawn coarser.
    fn note_budget(&mut self, cut: &Cut, committed: &KeySet, wanted: usize, left_out: usize) {
        let level_of = |key: &u32| self.shape.brick_of(*key).map(|id| id.level);
        let finest = committed.iter().filter_map(level_of).min();
        let coarsest = self
            .standing
            .iter()
            .filter_map(level_of)
            .max()
            .max(cut.coarsest);
        self.budget = Some(BudgetLimit {
            needed: wanted + left_out,
            fit: self.budget_slots(),
            left_out,
            finest,
            coarsest,
            full_detail: FullDetailBudget::Unknown,
        });
    }

    /// Progress is counted from now (a new cut, or one that stands).
    fn forget_progress(&mut self) {
        self.fewest_missing = usize::MAX;
        self.progress_at = (self.frame, Instant::now());
    }

    /// A view other than the one bricks stand in is cut anew.
    fn follow_view(&mut self, view: ViewPoint) {
        if self
            .standing_view
            .is_some_and(|standing_for| standing_for != view)
        {
            self.cut_anew();
        }
    }

    /// Forgets what stands for what: rays' asks load again and the next cut decides.
    fn cut_anew(&mut self) {
        self.no_room_frames = 0;
        self.forget_progress();
        self.standing.clear();
        for level in &mut self.counters.levels {
            level.left_out = 0;
        }
        self.standing_view = None;
        self.budget = None;
        self.changed_frame = self.frame;
    }

    /// The face neighbours of `id` in its level, as prefetch requests, nearest the center of
    /// the view the camera's motion leads to first.
    fn add_neighbours(&self, id: BrickId, ahead: &ViewPoint, into: &mut KeyMap<Request>) {
        let grid = self.shape.levels[id.level as usize].grid;
        for axis in 0..3 {
            for step in [-1i64, 1] {
                let c = id.brick[axis] as i64 + step;
                if c < 0 || c >= grid[axis] as i64 {
                    continue;
                }
                let mut brick = id.brick;
                brick[axis] = c as u32;
                let neighbour = BrickId {
                    level: id.level,
                    brick,
                };
                let key = self.shape.key(neighbour).expect("inside the grid");
                if self.satisfied(key) || self.failed.contains(&key) {
                    continue;
                }
                let off_center = ahead.off_center(self.shape.brick_center(neighbour));
                into.entry(key).or_insert(Request {
                    priority: Priority::new(Tier::Prefetch, id.level, off_center),
                    id: neighbour,
                    key,
                });
            }
        }
    }

    /// Uploads ready bricks in priority order within the frame's byte budget. Returns the
    /// uploads, their bytes, and how many bricks placed can change what a ray draws (not the
    /// level fill's, while the view is the one it was chosen in). A brick that finds no slot
    /// (every slot holds what the last frame drew) waits: the cut keeps the view within the
    /// atlas, so the stand-ins its bricks replace free slots as they arrive.
    fn upload_ready(&mut self) -> (Vec<Upload>, u64, usize) {
        let mut uploads = Vec::new();
        let mut asked_for = 0;
        let mut bytes = 0u64;
        let mut overflow = false;
        let protect_from = self.feedback_frame.map_or(u32::MAX, |f| f.max(1));
        let mut waiting = Vec::new();
        let allowance = self.upload_allowance();
        let ready = std::mem::take(&mut self.ready);
        // The level fill's bricks change no ray's samples in the view it was chosen in.
        let fill_unseen = self.fill_view.is_some() && self.fill_view == self.last_view;
        for request in ready {
            if self.satisfied(request.key) || self.failed.contains(&request.key) {
                self.fill.remove(&request.key);
                continue;
            }
            let Some(cost) = self.ram.peek(request.key).map(LoadedBrick::texel_bytes) else {
                // Evicted from RAM since: it will be asked for again (the fill's, by a later
                // feedback's fill).
                self.fill.remove(&request.key);
                continue;
            };
            // Past the budget (at least one brick a frame, whatever the budget) or once the
            // atlas is full, bricks with texels wait; uniform ones cost nothing to place. A
            // waiting brick counts as a use of the RAM cache every few frames, not every frame
            // (thousands may wait), an eighth of them a frame (all at once made run 79's
            // frames slow): enough that bricks uploaded since are evicted before it.
            let over_budget = bytes > 0 && bytes + cost > allowance;
            if cost > 0 && (overflow || over_budget) {
                if request
                    .key
                    .wrapping_add(self.frame)
                    .is_multiple_of(WAITING_TOUCH_FRAMES)
                {
                    self.ram.get(request.key);
                }
                waiting.push(request);
                continue;
            }
            let Some(brick) = self.ram.get(request.key) else {
                continue;
            };
            let placed = self.place(request.key, request.id, &brick, Some(protect_from));
            if matches!(placed, Ok(None)) && cost > 0 {
                // No slot free now.
                overflow = true;
                waiting.push(request);
                continue;
            }
            let fill = self.fill.remove(&request.key).is_some();
            let unseen = fill && fill_unseen;
            if !fill {
                self.missing = self.missing.saturating_sub(1);
            }
            match placed {
                Ok(Some(upload)) => {
                    bytes += cost;
                    uploads.push(upload);
                    asked_for += usize::from(!unseen);
                }
                Ok(None) if !unseen => self.changed_frame = self.frame,
                Ok(None) => {}
                Err(message) => {
                    self.failed.insert(request.key);
                    self.new_errors.push(message);
                }
            }
        }
        self.ready = waiting;
        if !uploads.is_empty() {
            self.no_room_frames = 0;
        } else if overflow {
            self.no_room_frames = self.no_room_frames.saturating_add(1);
        }
        self.counters.bytes_uploaded += bytes;
        let now = Instant::now();
        self.uploads_recent.push_back((now, bytes));
        while self
            .uploads_recent
            .front()
            .is_some_and(|&(at, _)| now.duration_since(at) > Duration::from_secs(1))
        {
            self.uploads_recent.pop_front();
        }
        (uploads, bytes, asked_for)
    }

    fn status(&mut self, uploads: usize, upload_bytes: u64) -> StreamStatus {
        let (queued, loading) = self.queue.counts();
        let missing = self.missing;
        let complete = self.feedback_frame.is_some_and(|f| f >= self.changed_frame)
            && self.feedback_missing == 0;
        for (level, counters) in self.counters.levels.iter_mut().enumerate() {
            counters.resident = self.resident[level];
            counters.empty = self.empty[level];
        }
        self.counters.slots_used = self.slots.occupied();
        self.counters.view_slots = match self.feedback_frame {
            Some(frame) if self.level_walked_at == Some(frame) => self.table.level_slots().count(),
            Some(frame) => self.slots.used_since(frame),
            None => 0,
        };
        self.counters.slots_pinned = self.slots.pinned();
        self.counters.ram_bytes = self.ram.bytes();
        self.counters.source_cache_bytes = self.source.cached_bytes();
        self.counters.chunks_decoded = self.source.chunks_decoded();
        self.counters.failed = self.failed.len();
        let next_retry = self
            .failures
            .next_retry()
            .map(|at| at.saturating_duration_since(Instant::now()).as_secs_f64());
        self.counters.upload_bytes_per_s =
            self.uploads_recent.iter().map(|&(_, b)| b).sum::<u64>() as f64;
        StreamStatus {
            frame: self.frame,
            complete,
            judged_frame: self.feedback_frame,
            missing,
            waiting_for_room: self.ready.len(),
            queued,
            loading,
            filling: self.fill.len(),
            budget: self.budget,
            unreadable: self.unreadable.len(),
            table_changed: self.changed_frame == self.frame,
            next_retry_s: next_retry,
            uploads,
            upload_bytes,
            errors: std::mem::take(&mut self.new_errors),
            counters: self.counters.clone(),
            phases: UpdatePhases::default(),
        }
    }

    /// Frame `frame` was drawn by the level walk, which leaves no usage marks: every brick of
    /// the levels it walked (the table's flat copy) is marked used then as a stand-in is, kept
    /// from eviction as what a ray drew, but not counted as a brick the view wants (most of the
    /// level may lie behind what the rays reach: the budget's room counts what frames drawn
    /// segment by segment marked). A walked frame's `view_slots` are the level's bricks in the
    /// atlas, every one the walk may draw.
    pub fn mark_level_walked(&mut self, frame: u32) {
        self.level_walked_at = Some(frame);
        for slot in self.table.level_slots() {
            self.slots.mark_used(slot, frame, false);
        }
    }

    /// Keys of the bricks in the atlas.
    pub fn resident_keys(&self) -> impl Iterator<Item = u32> + '_ {
        self.slots.keys()
    }

    /// The bricks standing for the finer ones the budget left out of the view on screen, and
    /// that view; `None` while the view fits.
    pub fn budget_cut(&self) -> Option<(ViewPoint, Vec<u32>)> {
        let view = self.standing_view?;
        let mut keys: Vec<u32> = self.standing.iter().copied().collect();
        keys.sort_unstable();
        Some((view, keys))
    }

    /// Takes the cut another streamer of the same pyramid made for `view` (its
    /// [`Self::budget_cut`]): `keys` stand for the bricks below them while the view stays.
    pub fn apply_budget_cut(&mut self, view: ViewPoint, keys: impl IntoIterator<Item = u32>) {
        let keys: Vec<u32> = keys
            .into_iter()
            .filter(|&key| self.shape.brick_of(key).is_some())
            .collect();
        if !keys.is_empty() {
            self.stand_in(&keys, view);
        }
    }

    /// Loads the bricks `keys` name into RAM before any ray asks for them, at prefetch
    /// priority, as far as the RAM cache has room: another view's bricks (the time point on
    /// screen's, for the next one of a series). They are uploaded once a frame of this streamer
    /// asks for them, without waiting on I/O then. Returns how many loads were queued. (The
    /// queue is the loaders': they start at once, whether this streamer draws or not; the
    /// first feedback of a frame it draws replaces what is left of them.)
    pub fn prefetch(&mut self, keys: impl IntoIterator<Item = u32>) -> usize {
        let room =
            self.ram.capacity().saturating_sub(self.ram.bytes()) / self.counters.slot_bytes.max(1);
        let requests: Vec<Request> = keys
            .into_iter()
            .filter(|&key| !self.satisfied(key) && !self.ram.contains(key))
            .filter_map(|key| {
                let id = self.shape.brick_of(key)?;
                Some(Request {
                    priority: Priority::new(Tier::Prefetch, id.level, 0.0),
                    id,
                    key,
                })
            })
            .take(room as usize)
            .collect();
        let queued = self.queue.replace(requests);
        self.loader.fetch_ahead();
        queued
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::NoiseSource;

    /// A streamer of 128³ noise into 8³ slots with one loader and `ram_cache` bytes of RAM,
    /// nothing read yet.
    fn noise_streamer(ram_cache: u64) -> Streamer {
        let source = Arc::new(NoiseSource::new("noise", [128, 128, 128]).expect("a source"));
        let options = StreamOptions {
            workers: 1,
            ram_cache,
            ..StreamOptions::default()
        };
        Streamer::new(
            source,
            [8, 8, 8],
            AtlasTexels::Unorm16,
            options,
            vec![0; (1 << 16) + 1],
        )
        .expect("a streamer")
    }

    #[test]
    fn the_pinned_levels_are_read_once_and_the_ram_budget_shared_then() {
        let mut streamer = noise_streamer(64 << 20);
        assert_eq!(
            streamer.pinned_slots(),
            0,
            "nothing read before load_pinned"
        );
        assert_eq!(streamer.counters.ram_capacity, 0);
        let uploads = streamer.load_pinned().expect("the pinned levels");
        let pinned = streamer.pinned_slots();
        assert!(
            pinned > 0 && uploads.len() == pinned,
            "{pinned} slots, {} uploads",
            uploads.len()
        );
        assert_eq!(
            streamer.counters.ram_capacity + streamer.counters.source_cache_capacity,
            64 << 20
        );
        // Again: nothing more read or pinned.
        assert!(streamer.load_pinned().expect("no error").is_empty());
        assert_eq!(streamer.pinned_slots(), pinned);
    }

    #[test]
    fn the_upload_allowance_counts_the_gpus_copies_with_the_cpus_staging() {
        let mut streamer = noise_streamer(StreamOptions::default().ram_cache);
        streamer.load_pinned().expect("the pinned levels");
        let megabyte = 1u64 << 20;
        // The CPU: 1 ms a megabyte.
        streamer.set_upload_cost(megabyte, 0.001, &UploadParts::default());
        let cpu_only = streamer.counters.upload_allowance;
        let expected = UPLOAD_SECONDS_PER_FRAME / 0.001 * megabyte as f64;
        assert!(
            (cpu_only as f64 - expected).abs() < 2.0,
            "{cpu_only} ≠ {expected}"
        );
        // The GPU's copies take as long again: half the bytes fit.
        streamer.set_upload_gpu_cost(2 * megabyte, 0.002);
        let both = streamer.counters.upload_allowance;
        assert!(
            (both as f64 - expected / 2.0).abs() < 2.0,
            "{both} ≠ {}",
            expected / 2.0
        );
        let parts = streamer.counters.upload_parts;
        assert_eq!(
            (parts.copy_timed_bytes, parts.copy_gpu_seconds),
            (2 * megabyte, 0.002)
        );
        // A copy the GPU did not time leaves the allowance as it was.
        streamer.set_upload_gpu_cost(megabyte, 0.0);
        assert_eq!(streamer.counters.upload_allowance, both);
        // While the view moves, a frame uploads that much; while it stands still, twice that.
        let view = |x: f64| ViewPoint {
            eye: [x, 0.0, -3.0],
            forward: [0.0, 0.0, 1.0],
        };
        streamer.begin_frame(None, Some(view(0.0)));
        streamer.begin_frame(None, Some(view(0.1)));
        assert_eq!(streamer.upload_allowance(), both);
        streamer.begin_frame(None, Some(view(0.1)));
        let still = (both as f64 * UPLOAD_SECONDS_STILL / UPLOAD_SECONDS_PER_FRAME) as u64;
        assert_eq!(streamer.upload_allowance(), still);
        // Frames no one watches: all that is ready while still (within the upload budget),
        // as much as ever while moving.
        assert_eq!(
            streamer.set_still_uploads(StillUploads::AllReady),
            StillUploads::Paced
        );
        assert_eq!(
            streamer.upload_allowance(),
            streamer.options().upload_bytes_per_frame
        );
        streamer.begin_frame(None, Some(view(0.2)));
        assert_eq!(streamer.upload_allowance(), both);
        streamer.begin_frame(None, Some(view(0.2)));
        streamer.set_still_uploads(StillUploads::Paced);
        // Never more than the renderer's staging holds at once, and never less than a brick.
        streamer.set_upload_ceiling(both / 3);
        assert_eq!(streamer.upload_allowance(), both / 3);
        streamer.set_upload_ceiling(1);
        assert_eq!(streamer.upload_allowance(), streamer.counters.slot_bytes);
    }

    /// A streamer of `dims` of mostly zeros (one corner brick of a ramp) in an atlas of
    /// `cells` slots, level 0 copied flat as the renderer copies the level its rays all want.
    fn sparse_streamer(dims: usize, cells: [usize; 3]) -> Streamer {
        let mut values = vec![0u16; dims * dims * dims];
        for z in 0..32 {
            for y in 0..32 {
                for x in 0..32 {
                    values[x + dims * (y + dims * z)] = (x * 100) as u16;
                }
            }
        }
        let quantization = voxscope_volume::Quantization {
            offset: 0.0,
            step: 1.0,
        };
        let source = crate::MemorySource::from_levels(
            "sparse",
            values,
            [dims; 3],
            quantization,
            [1.0; 3],
            crate::Downsampling::Mean,
        )
        .expect("a source");
        let options = StreamOptions {
            workers: 1,
            prefetch: false,
            ..StreamOptions::default()
        };
        let every_level_visible = (0..=(1u32 << 16)).collect();
        let mut streamer = Streamer::new(
            Arc::new(source),
            cells,
            AtlasTexels::Unorm16,
            options,
            every_level_visible,
        )
        .expect("a streamer");
        streamer.load_pinned().expect("the pinned levels");
        let bricks = streamer.shape.levels[0].brick_count() as usize;
        streamer.table_mut().copy_level(Some((0, [bricks, 0])));
        streamer
    }

    /// One update with a readback of the frame before, whose rays asked for `requests`.
    fn step_with(streamer: &mut Streamer, requests: &[u32]) -> StreamStatus {
        let usage = vec![0u32; streamer.slots.capacity()];
        let feedback = Feedback {
            frame: streamer.frame(),
            requests,
            asked: requests.len() as u32,
            usage: &usage,
            max_projection: false,
        };
        streamer.begin_frame(Some(feedback), None).1
    }

    #[test]
    fn the_level_fill_completes_without_readbacks_and_never_outgrows_the_page_table() {
        // 128³: level 0 has 64 bricks, 63 of them zeros; 128 slots hold them. One readback
        // that asks for nothing chooses the fill; later updates without readbacks (a window
        // that draws nothing new) place it as its loads arrive.
        let mut streamer = sparse_streamer(128, [8, 4, 4]);
        step_with(&mut streamer, &[]);
        assert_eq!(streamer.fill.len(), 64, "every brick of level 0 chosen");
        let started = Instant::now();
        loop {
            let (_, status) = streamer.begin_frame(None, None);
            if status.filling == 0 {
                break;
            }
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "the fill stalled: {status:?}"
            );
            std::thread::sleep(Duration::from_millis(2));
        }
        assert_eq!(streamer.table().level_unwalkable(false), Some(0));
        assert_eq!(
            streamer.resident_keys().count(),
            1 + streamer.slots.pinned()
        );

        // 256³ in 120 slots: the table keeps 480 entries, level 0 has 512 bricks, nearly all
        // uniform (entries without slots). Once a view has made the table hold what it can,
        // no fill starts: it would drop entries the table holds to make room for others.
        let mut streamer = sparse_streamer(256, [10, 12, 1]);
        let keys: Vec<u32> = (0..512).collect();
        let started = Instant::now();
        while streamer.table.len() + 8 < streamer.max_entries {
            for batch in keys.chunks(64) {
                step_with(&mut streamer, batch);
            }
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "the table never filled: {} entries",
                streamer.table.len()
            );
            std::thread::sleep(Duration::from_millis(2));
        }
        for _ in 0..20 {
            let status = step_with(&mut streamer, &[]);
            assert_eq!(status.filling, 0, "no fill beyond the table's room");
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}
