//! What reaches the atlas each frame (loaded bricks placed in slots within the upload
//! allowance, which follows the uploads' measured cost), the status a frame reports, and what
//! the budget's cut, the level walk and prefetch ask of the streamer from outside.

use super::*;

impl Streamer {
    /// Bytes a frame may upload: the allowance set from the measured cost
    /// ([`Self::set_upload_cost`]); while the view has not moved since the last frame,
    /// [`UPLOAD_SECONDS_STILL`]'s worth, or all that is ready ([`StillUploads`]); never more
    /// than `--upload-budget` or the renderer's staging holds ([`Self::set_upload_ceiling`]).
    pub(super) fn upload_allowance(&self) -> u64 {
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
    pub(super) fn view_is_still(&self) -> bool {
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
    pub(super) fn set_allowance(&mut self) {
        let per_byte = self.upload_seconds_per_byte + self.upload_gpu_seconds_per_byte;
        if per_byte <= 0.0 {
            return;
        }
        let allowance = (UPLOAD_SECONDS_PER_FRAME / per_byte) as u64;
        self.counters.upload_allowance = allowance
            .min(self.upload_ceiling)
            .max(self.counters.slot_bytes);
    }

    /// Uploads ready bricks in priority order within the frame's byte budget. Returns the
    /// uploads, their bytes, and how many bricks placed can change what a ray draws (not the
    /// level fill's, while the view is the one it was chosen in). A brick that finds no slot
    /// (every slot holds what the last frame drew) waits: the cut keeps the view within the
    /// atlas, so the stand-ins its bricks replace free slots as they arrive.
    pub(super) fn upload_ready(&mut self) -> (Vec<Upload>, u64, usize) {
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
                    if self.pressed.is_some() && self.max_projection && !fill {
                        self.kept.insert(request.key);
                    }
                }
                Ok(None) if !unseen => self.changed_frame = self.frame,
                Ok(None) => {}
                Err(error) => {
                    self.failed.insert(request.key);
                    self.new_errors.push(error.to_string());
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

    pub(super) fn status(&mut self, uploads: usize, upload_bytes: u64) -> StreamStatus {
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
