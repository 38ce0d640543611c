//! What the streamer counts and reports after each frame's update: per level, the atlas, the
//! RAM cache, reads and uploads (the app's panel, `bench --stream --json`).

/// Per level, what the streamer knows (the app's Octree panel).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct LevelCounters {
    /// Bricks in the level.
    pub total: u64,
    /// In the atlas.
    pub resident: usize,
    /// Known to need no slot (uniform, or skipped under the transfer function when evicted).
    pub empty: usize,
    /// Wanted by the latest frame read back and not on the GPU yet.
    pub requested: usize,
    /// Asked for by the view on screen and left out by the budget: drawn from a coarser level.
    pub left_out: usize,
    /// Bricks read from the source so far (a brick read again after the RAM cache let it go
    /// counts again).
    pub loaded: u64,
    /// Bricks that lost their atlas slot to another so far.
    pub evicted: u64,
}

/// Everything counted, for the app's panel and `bench --stream --json`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct StreamCounters {
    /// Finest first.
    pub levels: Vec<LevelCounters>,
    pub slots: usize,
    pub slots_used: usize,
    /// Slots a ray wanted (not as a stand-in) in the latest frame read back: with the uniform
    /// bricks, what that view needs.
    pub view_slots: usize,
    pub slots_pinned: usize,
    /// Bytes of one atlas slot.
    pub slot_bytes: u64,
    /// Bytes of decoded bricks in the RAM cache, and its capacity: the RAM budget
    /// (`--ram-cache`) less what the source's own caches took ([`Self::source_cache_capacity`]).
    pub ram_bytes: u64,
    pub ram_capacity: u64,
    /// Bytes the source's own caches (decoded chunks, fetched bytes) hold, and may hold.
    pub source_cache_bytes: u64,
    pub source_cache_capacity: u64,
    /// Chunks the source has read and decoded (a chunk decoded again after its cache let it
    /// go counts again; 0 for a source without chunks).
    pub chunks_decoded: u64,
    /// Wanted bricks found in the RAM cache / loaded from the source.
    pub ram_hits: u64,
    pub loads: u64,
    /// Of the loads, those of prefetched bricks (neighbours of wanted ones).
    pub prefetch_loads: u64,
    /// Bytes the source produced (padded bricks in texel size).
    pub bytes_read: u64,
    /// Seconds the loader threads spent reading, decoding and converting bricks, together
    /// (bytes read ÷ this: one thread's rate).
    pub read_seconds: f64,
    pub bytes_uploaded: u64,
    /// Seconds the frames spent putting uploads on their way (copying into the staging ring,
    /// recording the copies): bytes uploaded ÷ this is that step's rate.
    pub upload_seconds: f64,
    /// Where that time went, part by part.
    pub upload_parts: UploadParts,
    /// Bytes a frame may upload now: chosen from the measured upload cost so that a frame
    /// spends at most a few milliseconds on it, within `--upload-budget`.
    pub upload_allowance: u64,
    /// Uploaded over the last second.
    pub upload_bytes_per_s: f64,
    /// Bricks that lost their atlas slot to another.
    pub evictions: u64,
    /// Bricks that could not be read.
    pub failed: usize,
    /// Bricks never read because their known range ([`BrickSource::known_range`]) is
    /// invisible under the transfer function.
    pub skipped_unread: u64,
}

/// The frames' uploads part by part (`bench --stream --json`'s pipeline): bricks through the
/// staging ring and through `Queue::write_texture` (while no ring buffer is mapped, or beyond
/// what one holds), and the seconds of each step.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct UploadParts {
    pub ring_bricks: u64,
    /// Copies the ring's bricks took: one per run of atlas cells along x, or two a frame (the
    /// placements and the bricks) where a dispatch scatters them into their cells.
    pub ring_copies: u64,
    /// Dispatches that wrote the ring's bricks into their cells: one a frame where the atlas
    /// takes its uploads that way (`UploadPath::Scatter`).
    pub scatter_dispatches: u64,
    pub queue_bricks: u64,
    /// Laying bricks out and copying them into mapped ring buffers.
    pub staging_seconds: f64,
    /// Recording the ring's copies, submitting them and mapping the buffer again.
    pub submit_seconds: f64,
    /// `Queue::write_texture` of the rest.
    pub queue_seconds: f64,
    /// Bytes of the ring's uploads the GPU timed (where it has timestamps), and the GPU's
    /// seconds for their copies and scatter: the GPU side's own rate.
    pub copy_timed_bytes: u64,
    pub copy_gpu_seconds: f64,
}

impl UploadParts {
    /// Adds `other`'s bricks and seconds.
    pub fn add(&mut self, other: &UploadParts) {
        self.ring_bricks += other.ring_bricks;
        self.ring_copies += other.ring_copies;
        self.scatter_dispatches += other.scatter_dispatches;
        self.queue_bricks += other.queue_bricks;
        self.staging_seconds += other.staging_seconds;
        self.submit_seconds += other.submit_seconds;
        self.queue_seconds += other.queue_seconds;
        self.copy_timed_bytes += other.copy_timed_bytes;
        self.copy_gpu_seconds += other.copy_gpu_seconds;
    }
}

impl StreamCounters {
    /// Hits ÷ (hits + loads), 0 before anything was wanted.
    pub fn ram_hit_rate(&self) -> f64 {
        let total = self.ram_hits + self.loads;
        if total == 0 {
            0.0
        } else {
            self.ram_hits as f64 / total as f64
        }
    }
}

/// Where streaming stands after a frame's update.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct StreamStatus {
    /// The number of the frame about to be drawn.
    pub frame: u32,
    /// Nothing visible is missing: the latest frame read back ([`Self::judged_frame`]) was
    /// drawn with the current page table and its rays lacked nothing (bricks that failed to
    /// load excepted). After a change of view, wait for a judged frame drawn with the new view.
    pub complete: bool,
    /// The frame `complete` and `missing` are judged on (read back a frame or two after it was
    /// drawn); `None` before the first readback.
    pub judged_frame: Option<u32>,
    /// Visible bricks wanted and not on the GPU (what the status bar's "refining: N" says).
    pub missing: usize,
    /// Bricks read into RAM that wait for an atlas slot (none is free): only frames, whose
    /// feedback frees slots or cuts the view to the budget, move them on.
    pub waiting_for_room: usize,
    /// Loads waiting and in progress.
    pub queued: usize,
    pub loading: usize,
    /// Bricks of the one level every ray wants still to be placed so that frames may walk that
    /// level as the bricks renderer walks its grid (`Streamer`'s level fill, once the view
    /// lacks nothing): those chosen, less those placed, unreadable, or no longer coming; 0 when
    /// none are coming. A window keeps updating while this is above 0.
    pub filling: usize,
    /// What the view needs against what fits, while the budget leaves bricks out (`None`: the
    /// view fits at the levels its rays chose).
    pub budget: Option<BudgetLimit>,
    /// Bricks the rays of the judged frame asked for that could not be read (drawn from the
    /// finest coarser level that could): the view is incomplete while this is above 0, even
    /// when [`Self::complete`] says nothing more is to come.
    pub unreadable: usize,
    /// Seconds until the next failed brick is asked for again (`None`: none will be): a
    /// window that draws only when something changes wakes then.
    pub next_retry_s: Option<f64>,
    /// Whether this update changed the page table (uploads, failures, retries, evictions,
    /// visibility): only then can a new frame differ from the last one drawn.
    pub table_changed: bool,
    /// Uploaded in this update.
    pub uploads: usize,
    pub upload_bytes: u64,
    /// What failed since the last update: a line for the first brick of each cause (further
    /// bricks failing the same way are counted, not repeated: `Streamer::failures`).
    pub errors: Vec<String>,
    pub counters: StreamCounters,
    /// What this update's steps took.
    pub phases: UpdatePhases,
}

/// A frame's update step by step, in seconds (`bench --stream`'s `update_phases_ms`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct UpdatePhases {
    /// Reading the requests and usage marks of drawn frames back from mapped buffers, and
    /// recording the next copy.
    pub readback: f64,
    /// Taking in the loaders' results.
    pub results: f64,
    /// The requests read back: the view's bricks, the cut within the budget, the load queue.
    pub feedback: f64,
    /// Choosing this frame's uploads and their slots.
    pub choose_uploads: f64,
    /// Writing them (staging ring or queue) and the page table's changed entries.
    pub write: f64,
}

impl std::ops::AddAssign for UpdatePhases {
    /// Sums frames' steps (a view's, `bench --stream`'s `frame_parts_s`).
    fn add_assign(&mut self, other: Self) {
        self.readback += other.readback;
        self.results += other.results;
        self.feedback += other.feedback;
        self.choose_uploads += other.choose_uploads;
        self.write += other.write;
    }
}

/// A view larger than the atlas: the least important of its bricks (the finest, farthest from
/// the view's center) are drawn from coarser levels so that the rest fits and the view
/// completes at the resolution the budget allows.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BudgetLimit {
    /// Bricks the view needs at the levels its rays chose ("full detail" for this view).
    pub needed: usize,
    /// Bricks of that kind the atlas holds for a view (the slots less the pinned levels and
    /// the frame's own room).
    pub fit: usize,
    /// Bricks left out, drawn from a coarser level.
    pub left_out: usize,
    /// Bricks the view draws from the atlas (those its rays wanted and those standing for the
    /// bricks left out, the pinned levels aside): the cut it settles on. Against
    /// [`StreamCounters::loads`], what the view read beyond its cut.
    pub drawn: usize,
    /// The finest level drawn.
    pub finest: Option<u32>,
    /// The coarsest level a left-out region is drawn from.
    pub coarsest: Option<u32>,
    /// The GPU budget that would hold the view at full detail (the renderer sizes it).
    pub full_detail: FullDetailBudget,
}

/// The GPU budget whose atlas would hold a budget-limited view at full detail.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FullDetailBudget {
    /// Not sized (the streamer alone does not know how a budget becomes an atlas).
    #[default]
    Unknown,
    /// This many bytes (a power of two, or halfway to the next).
    Bytes(u64),
    /// More than this device's largest atlas holds.
    BeyondDevice,
}

impl BudgetLimit {
    /// `budget-limited: finest level 0, level 2 where least important; the view needs 9 412
    /// bricks at full detail, 6 480 fit` (the caller adds the budget in bytes).
    pub fn describe(&self) -> String {
        let levels = match (self.finest, self.coarsest) {
            (Some(finest), Some(coarsest)) if coarsest > finest => {
                format!("finest level {finest}, level {coarsest} where least important")
            }
            (Some(finest), _) => format!("finest level {finest}"),
            (None, Some(coarsest)) => format!("level {coarsest}"),
            (None, None) => "coarser levels".to_owned(),
        };
        let full_detail = match self.full_detail {
            FullDetailBudget::Unknown => String::new(),
            FullDetailBudget::Bytes(bytes) => {
                format!(" (a GPU budget of {} holds it all)", format_budget(bytes))
            }
            FullDetailBudget::BeyondDevice => " (more than this GPU's largest atlas)".to_owned(),
        };
        format!(
            "budget-limited: {levels}; the view needs {} bricks at full detail{full_detail}, {} fit",
            group_thousands(self.needed),
            group_thousands(self.fit)
        )
    }
}

/// `96 MiB`, `1.5 GiB`: a budget as `--gpu-memory` reads it and the app's GPU budget shows it.
pub fn format_budget(bytes: u64) -> String {
    let (value, unit) = if bytes >= 1 << 30 {
        (bytes as f64 / (1u64 << 30) as f64, "GiB")
    } else {
        (bytes as f64 / (1u64 << 20) as f64, "MiB")
    };
    if value.fract() == 0.0 {
        format!("{value:.0} {unit}")
    } else {
        format!("{value:.1} {unit}")
    }
}

/// `9 412`: thousands apart (a narrow space, as the app's panels write numbers).
fn group_thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_budget_limit_names_the_budget_that_holds_the_view() {
        let limit = BudgetLimit {
            needed: 9412,
            fit: 6480,
            left_out: 2932,
            drawn: 6100,
            finest: Some(0),
            coarsest: Some(2),
            full_detail: FullDetailBudget::Unknown,
        };
        assert_eq!(
            limit.describe(),
            "budget-limited: finest level 0, level 2 where least important; the view needs \
             9 412 bricks at full detail, 6 480 fit"
        );
        let holding = |bytes| {
            BudgetLimit {
                full_detail: FullDetailBudget::Bytes(bytes),
                ..limit
            }
            .describe()
        };
        assert!(holding(96 << 20).contains("full detail (a GPU budget of 96 MiB holds it all), "));
        assert!(holding(1 << 30).contains("(a GPU budget of 1 GiB holds it all)"));
        assert!(holding(3 << 29).contains("(a GPU budget of 1.5 GiB holds it all)"));
        let beyond = BudgetLimit {
            full_detail: FullDetailBudget::BeyondDevice,
            ..limit
        };
        assert!(
            beyond
                .describe()
                .contains("(more than this GPU's largest atlas)")
        );
    }
}
