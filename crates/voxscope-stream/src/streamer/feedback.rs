//! A frame's feedback taken in: the usage marks and requests its rays wrote, turned into
//! the cut of what the budget holds, loads in priority order and stand-ins; the level fill
//! and the neighbours fetched ahead.

use super::*;

impl Streamer {
    /// Takes in a frame's `feedback` seen from `view`: marks the slots its rays used, decides
    /// what the budget holds of what they asked for (and what stands in for the rest), and
    /// queues the loads: what the cut loads with the coarser bricks above it, the level's fill
    /// once nothing is missing, then the neighbours ahead of the camera's motion.
    pub(super) fn take_feedback(&mut self, feedback: Feedback<'_>, view: Option<ViewPoint>) {
        for (slot, &mark) in feedback.usage.iter().enumerate() {
            if mark != 0 {
                self.slots.mark_used(slot as u32, mark >> 1, mark & 1 == 1);
            }
        }
        self.feedback_frame = Some(feedback.frame);
        self.max_projection = feedback.max_projection;
        let view = view.unwrap_or(ViewPoint::new([0.0; 3], [0.0, 0.0, 1.0]));
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
        let (requests, left_out) = self.requests_of(&asked, view);
        // Every ray marks the brick it drew in place of a finer one (the request buffer may
        // have held only the first rays' asks). Under pressure, what was placed for the view
        // stays.
        if self.pressed.is_some() {
            self.keep_placed(feedback.frame, &view);
        }
        let truncated = feedback.asked as usize > feedback.requests.len();
        for (counters, &count) in self.counters.levels.iter_mut().zip(&left_out) {
            counters.left_out = count;
        }
        let asks = (feedback.asked as usize, truncated);
        let outcome = self.cut_for_view(
            &requests,
            &left_out,
            feedback.usage,
            asks,
            view,
            feedback.frame,
        );
        // Failed bricks are asked for no more; left-out ones are drawn from what stands for
        // them: what still lacks is what the view misses, with the frontier no ask named.
        self.feedback_missing = requests.len() + outcome.unresolved;
        // Prefetch around a few asks only, and only when the view fits: beyond that the view
        // is far from complete, or the atlas full, and what is visible keeps the workers busy
        // (and the frame's CPU time stays small).
        let prefetch_around = self.options.prefetch
            && asked.len() <= PREFETCH_AROUND
            && self.pressed.is_none()
            && self.standing.is_empty();
        let (wanted, prefetch) =
            self.wanted_with_parents(&outcome.loads_now, view, &ahead, prefetch_around);
        let fill = if requests.is_empty() && self.standing.is_empty() {
            self.level_fill()
        } else {
            Vec::new()
        };
        self.fill = fill.iter().map(|r| (r.key, *r)).collect();
        self.fill_view = Some(view);
        self.queue_loads(wanted, fill, prefetch);
    }

    /// What was `asked` for that can show, each in place of the brick that stands for it
    /// where the budget left it out, with its priority seen from `view`; and how many asked
    /// bricks of each level were left out.
    fn requests_of(&mut self, asked: &[u32], view: ViewPoint) -> (Vec<Request>, Vec<usize>) {
        let mut requests = Vec::with_capacity(asked.len());
        let mut seen = KeySet::default();
        let mut left_out = vec![0usize; self.shape.levels.len()];
        for &key in asked {
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
        (requests, left_out)
    }

    /// What `loads_now` loads, and the coarser bricks above each down to the first one the
    /// GPU has (so the picture refines level by level; an unreadable brick's finest readable
    /// parent in its place); with the neighbours of the asked bricks ahead of the camera
    /// (`ahead`) to prefetch, where `prefetch_around`.
    fn wanted_with_parents(
        &mut self,
        loads_now: &[Request],
        view: ViewPoint,
        ahead: &ViewPoint,
        prefetch_around: bool,
    ) -> (KeyMap<Request>, KeyMap<Request>) {
        let mut wanted: KeyMap<Request> = KeyMap::default();
        wanted.reserve(loads_now.len() + loads_now.len() / 4);
        let mut prefetch: KeyMap<Request> = KeyMap::default();
        for request in loads_now {
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
                    self.add_neighbours(id, ahead, &mut prefetch);
                }
                let Some(parent) = self.shape.parent(id) else {
                    break;
                };
                id = parent;
                key = self.shape.key(id).expect("a parent is in the pyramid");
            }
        }
        (wanted, prefetch)
    }

    /// In one pass: per-level counts; each of `wanted` ready (in RAM: a hit, unless it was
    /// ready already) or to load; then the level's `fill`, then the `prefetch` (as much as
    /// the RAM cache has room for) after them. The loads replace the queue, and the first
    /// ones' requests go out.
    fn queue_loads(
        &mut self,
        wanted: KeyMap<Request>,
        fill: Vec<Request>,
        prefetch: KeyMap<Request>,
    ) {
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
    pub(super) fn level_fill(&self) -> Vec<Request> {
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

    /// The face neighbours of `id` in its level, as prefetch requests, nearest the center of
    /// the view the camera's motion leads to first.
    pub(super) fn add_neighbours(
        &self,
        id: BrickId,
        ahead: &ViewPoint,
        into: &mut KeyMap<Request>,
    ) {
        let grid = self.shape.levels[id.level as usize].grid;
        for axis in 0..3 {
            for step in [-1i64, 1] {
                let c = id.brick[axis] as i64 + step;
                if c < 0 || c >= grid[axis] as i64 {
                    continue;
                }
                let mut brick = id.brick;
                brick[axis] = c as u32;
                let neighbour = BrickId { brick, ..id };
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
}
