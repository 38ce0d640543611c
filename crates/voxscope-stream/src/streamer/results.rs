//! What the loader threads sent back, and the bricks that failed: taking in loaded bricks,
//! remembering failures and asking again when their time comes, and the checks of what a
//! brick still needs (a slot, a load, nothing) under the transfer function's visibility.

use super::*;

impl Streamer {
    /// Whether some level of `range` (packed) of brick `key` is visible under its channel's
    /// transfer function.
    pub(super) fn range_visible(&self, key: u32, range: u32) -> bool {
        let counts = &self.visible_below[self.shape.channel_of(key) as usize];
        let (low, high) = ((range & 0xffff) as usize, (range >> 16) as usize);
        counts[high + 1] > counts[low]
    }

    /// A new transfer function's visibility counts (`visible_below[i]`: how many value levels
    /// below `i` are visible; 65 537 of them), for every channel: every entry's
    /// [`ENTRY_VISIBLE`] bit follows, the changed entries to be copied to the GPU. Nothing is
    /// reloaded.
    pub fn set_visibility(&mut self, visible_below: Vec<u32>) {
        let channels = vec![visible_below; self.shape.channels as usize];
        self.set_channel_visibility(channels);
    }

    /// [`Self::set_visibility`] per channel: `visible_below[c]` channel c's counts (a hidden
    /// channel's all 0: none of its bricks is asked for, loaded or drawn). Counts of another
    /// length or number are ignored.
    pub fn set_channel_visibility(&mut self, visible_below: Vec<Vec<u32>>) {
        if visible_below.len() != self.shape.channels as usize
            || visible_below.iter().any(|c| c.len() != VISIBILITY_COUNTS)
        {
            return;
        }
        self.visible_below = visible_below;
        // Other values visible: another working set, cut anew.
        self.cut_anew();
        let counts = &self.visible_below;
        let shape = &self.shape;
        self.table.update_each(|entry| {
            let (low, high) = (
                (entry.range & 0xffff) as usize,
                (entry.range >> 16) as usize,
            );
            let counts = &counts[shape.channel_of(entry.key) as usize];
            let visible = counts[high + 1] > counts[low];
            ((entry.slot & ENTRY_VISIBLE != 0) != visible).then_some(TableEntry {
                slot: entry.slot ^ ENTRY_VISIBLE,
                ..*entry
            })
        });
        self.changed_frame = self.frame;
    }

    /// Forgets the failures whose retry time has come: the rays ask for those bricks again.
    pub(super) fn retry_failed(&mut self) {
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
    pub(super) fn fail(&mut self, key: u32, id: BrickId, error: crate::BrickError) {
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

    pub(super) fn receive_results(&mut self) {
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
    pub(super) fn known_invisible(&mut self, key: u32, id: BrickId) -> bool {
        if let Some(entry) = self.table.get(key) {
            // Entered already (read, or known invisible before): its bit says.
            return entry.cell & ENTRY_FAILED == 0 && entry.slot & ENTRY_VISIBLE == 0;
        }
        let Some(range) = self.source.known_range(id) else {
            return false;
        };
        if self.range_visible(key, range.packed()) {
            return false;
        }
        if self.enter_known_range(key, id, range) {
            self.counters.skipped_unread += 1;
        }
        true
    }

    /// [`Self::satisfied`] or [`Self::known_invisible`], with one look in the table.
    pub(super) fn satisfied_or_invisible(&mut self, key: u32, id: BrickId) -> bool {
        match self.table.get(key) {
            Some(entry) => entry_needs_no_slot(&entry),
            None => self.known_invisible(key, id),
        }
    }

    /// Enters brick `key` in the table without a slot, with the range its source knows
    /// without reading it (rays skip it where that range says they may); whether it entered.
    pub(super) fn enter_known_range(&mut self, key: u32, id: BrickId, range: ValueRange) -> bool {
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
    pub(super) fn satisfied(&self, key: u32) -> bool {
        self.table
            .get(key)
            .is_some_and(|entry| entry_satisfies(&entry))
    }

    /// The load priority of the visible brick `key`: coarse first, then (MIP) the brightest
    /// first, then nearest the view's center. Under MIP a brick whose range the source knows
    /// without reading it enters the table with that range (as an evicted brick stays), so
    /// that a ray whose maximum is already above it stops asking for it: once the brightest
    /// bricks are in, most of the rest are never read.
    pub(super) fn visible_priority(&mut self, key: u32, id: BrickId, off_center: f32) -> Priority {
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
    pub(super) fn needs_no_slot(&self, key: u32) -> bool {
        if let Some(entry) = self.table.get(key) {
            return entry_needs_no_slot(&entry);
        }
        self.shape
            .brick_of(key)
            .and_then(|id| self.source.known_range(id))
            .is_some_and(|range| !self.range_visible(key, range.packed()))
    }

    /// What brick `key` takes of a view's room in the atlas ([`crate::cut_within`]): a slot to load
    /// it into where it is `requested` or not in the atlas and visible; none where the room
    /// counts it already (`committed`), or it is pinned, uniform, failed or invisible; its
    /// slot where the atlas holds it for rays that draw it in place of finer bricks.
    pub(super) fn slot_need(&self, key: u32, requested: &KeySet, committed: &KeySet) -> SlotNeed {
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
}
