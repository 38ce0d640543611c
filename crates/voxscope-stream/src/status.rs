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
    pub ram_bytes: u64,
    pub ram_capacity: u64,
    /// Wanted bricks found in the RAM cache / loaded from the source.
    pub ram_hits: u64,
    pub loads: u64,
    /// Of the loads, those of prefetched bricks (neighbours of wanted ones).
    pub prefetch_loads: u64,
    /// Bytes the source produced (padded bricks in texel size).
    pub bytes_read: u64,
    pub bytes_uploaded: u64,
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
    /// Loads waiting and in progress.
    pub queued: usize,
    pub loading: usize,
    /// Levels added to every ray's choice because the atlas cannot hold the view at its own.
    pub lod_bias: u32,
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
}
