//! A view under the budget's pressure refines level by level, the coarsest first, over the
//! whole view, so that the cut it settles on is restricted (face neighbours at most one level
//! apart: uniformly a little coarser rather than sharp here and a blur there) and it reads
//! little beyond that cut.
//!
//! Why: a frame's asks are what the request buffer holds, the first rays' first (the GPU runs
//! the image's top rows first); a near view asks for more bricks than it holds, so for frames
//! the streamer saw only the upper part of the view. Loaded at once, that part took the
//! atlas at its finest levels, bricks the rays wanted were never given up, and the rest of
//! the view, once its asks came through, had no room left: it stood on whatever coarse bricks
//! the atlas held, down to the pinned single-brick levels (issue 54: level 1 above a seam,
//! level 7 below). And fine bricks loaded before the cut knew they did not fit were read for
//! nothing.
//!
//! How: each brick a ray drew in place of a finer one (its usage mark says so, for every ray:
//! the marks are never cut short) is the view's frontier. Each ask the buffer held names the
//! frontier brick above it and the step below that brick towards it; a frontier brick no ask
//! named (its asks were beyond the buffer) steps to each of its children that can show. Only
//! the coarsest steps load, and only as many as the room holds: where not all fit, the least
//! important groups give way to their frontier parents (`budget.rs`, ranked by
//! [`Streamer::give_way_rank`]), which stand once the rest is in; from then on nothing refines
//! more than one level below the coarsest standing brick, and the frontier there stands too.
//! A region is refined further only once no region of the view is coarser, so neighbours end
//! at most one level apart; the bricks read are the cut and the coarser ones above it, and
//! each is read once.

use std::collections::hash_map::Entry;

use super::*;

/// What a view's cut decided in a frame.
#[derive(Debug, Default)]
pub(super) struct ViewCut {
    /// The cut of the view's asks (or steps) within its room.
    pub cut: Cut,
    /// What loads now (with the coarser bricks above each down to the atlas's).
    pub loads_now: Vec<Request>,
    /// Frontier bricks whose finer bricks no ask of the frame named (the rays asked beyond the
    /// request buffer) and that do not stand: the view is not complete while any remain.
    pub unresolved: usize,
}

impl Streamer {
    /// What frame `frame`'s rays drew from the atlas (`usage`: its marks). A slot refilled
    /// since holds another brick, which no ray of that frame saw.
    pub(super) fn marks_of(&self, usage: &[u32], frame: u32) -> Marks {
        let mut marks = Marks::default();
        if frame == 0 {
            return marks;
        }
        for (slot, &mark) in usage.iter().enumerate() {
            let slot = slot as u32;
            let Some(key) = self.slots.key(slot) else {
                continue;
            };
            if self.slots.filled_after(slot, frame) {
                marks.drawn_or_new.insert(key);
            } else if mark >> 1 == frame {
                marks.drawn_or_new.insert(key);
                if mark & 1 == 0 && !self.standing.contains(&key) {
                    marks.frontier.push(key);
                }
            }
        }
        marks
    }

    /// Under the budget's pressure and MIP, the bricks placed for the view stay in the atlas
    /// while it stays (each frame they count as drawn, so none is evicted), until every child
    /// of one in view is in too (or needs no slot): a brick a MIP ray passes over (its maximum
    /// below the ray's so far) carries no mark, and evicted it would leave the ray to draw its
    /// parent again, which would be loaded again, and so on (the near MIP of a 4096² noise
    /// under 32 MiB on lavapipe read 726 bricks for 343 slots). They take their slots of the
    /// view's room (`committed`).
    pub(super) fn keep_placed(&mut self, frame: u32, view: &ViewPoint) {
        let kept: Vec<u32> = self.kept.iter().copied().collect();
        for key in kept {
            let entry = self.table.get(key).filter(|e| e.is_resident());
            let Some((entry, id)) = entry.zip(self.shape.brick_of(key)) else {
                self.kept.remove(&key);
                continue;
            };
            let children: Vec<BrickId> = self.shape.children(id).collect();
            let refined = !children.is_empty()
                && children.into_iter().all(|child| {
                    let child_key = self.shape.key(child).expect("a child is in the pyramid");
                    !self.in_view(child, view)
                        || self.failed.contains(&child_key)
                        || self.satisfied_or_invisible(child_key, child)
                });
            if refined {
                self.kept.remove(&key);
            } else {
                self.slots
                    .mark_used(entry.slot & !ENTRY_VISIBLE, frame, false);
            }
        }
    }

    /// `keys` stand from now on because the budget holds no finer bricks there: nothing of the
    /// view refines more than one level below the coarsest of them.
    fn stand_for_budget(&mut self, keys: KeySet, view: ViewPoint) {
        let coarsest = keys
            .iter()
            .filter_map(|&key| self.shape.brick_of(key))
            .map(|id| id.level)
            .max();
        if let Some(level) = coarsest {
            let floor = level.saturating_sub(1);
            self.floor = Some(self.floor.map_or(floor, |was| was.max(floor)));
        }
        let keys: Vec<u32> = keys.into_iter().collect();
        self.stand_in(&keys, view);
    }

    /// The finest brick above `id` that rays draw from (in the atlas, or uniform), if any.
    fn drawn_above(&self, id: BrickId) -> Option<(u32, BrickId)> {
        let mut up = self.shape.parent(id);
        while let Some(brick) = up {
            let key = self.shape.key(brick)?;
            if self.table.get(key).is_some_and(|entry| {
                entry.is_resident()
                    || (entry.cell & ENTRY_FAILED == 0
                        && (entry.range & 0xffff) == (entry.range >> 16))
            }) {
                return Some((key, brick));
            }
            up = self.shape.parent(brick);
        }
        None
    }

    /// Whether brick `id` may reach into `view`'s frustum.
    fn in_view(&self, id: BrickId, view: &ViewPoint) -> bool {
        let level = &self.shape.levels[id.level as usize];
        let side = BRICK_SIZE * level.scale;
        let low = id.brick.map(|c| (c as usize * side) as f64);
        let dims = self.shape.dims();
        let high: [f64; 3] =
            std::array::from_fn(|a| ((id.brick[a] as usize + 1) * side).min(dims[a]) as f64);
        view.sees(low, high)
    }

    /// A step: brick `id` (`key`) as a visible load seen from `view`.
    fn step(&mut self, key: u32, id: BrickId, view: ViewPoint) -> Request {
        let off_center = view.off_center(self.shape.brick_center(id));
        Request {
            priority: self.visible_priority(key, id, off_center),
            id,
            key,
        }
    }

    /// The brick below `drawn` on the way to `ask` that refines it: the one a level finer,
    /// or, where that one cannot be loaded or shows nothing (unreadable, or its range known to
    /// be invisible: rays pass over it), the first finer one that can.
    fn step_below(&mut self, ask: BrickId, drawn: BrickId) -> Option<(u32, BrickId)> {
        (ask.level..drawn.level).rev().find_map(|level| {
            let id = self.shape.ancestor_at(ask, level);
            let key = self.shape.key(id)?;
            let passed_over = self.failed.contains(&key) || self.satisfied_or_invisible(key, id);
            (!passed_over || level == ask.level).then_some((key, id))
        })
    }

    /// The bricks that refine frontier brick `id` where no ask named any: its children in
    /// `view` that can show (below one whose range is invisible, its own children).
    fn unnamed_steps(&mut self, id: BrickId, view: &ViewPoint) -> Vec<(u32, BrickId)> {
        let mut steps = Vec::new();
        let mut below: Vec<BrickId> = self.shape.children(id).collect();
        while let Some(child) = below.pop() {
            let key = self.shape.key(child).expect("a child is in the pyramid");
            if !self.in_view(child, view) || self.failed.contains(&key) {
                continue;
            }
            if !self.satisfied_or_invisible(key, child) {
                steps.push((key, child));
            } else if !self.satisfied(key) {
                below.extend(self.shape.children(child));
            }
        }
        steps
    }

    /// This frame's steps (module docs) from the frontier (`marks`) and the bricks drawn above
    /// `requests`; at or above `floor` none: those bricks stand.
    fn steps_of(
        &mut self,
        requests: &[Request],
        marks: &Marks,
        floor: Option<u32>,
        view: ViewPoint,
    ) -> Steps {
        let at_floor = |level: u32| floor.is_some_and(|floor| level <= floor);
        let mut steps = Steps::default();
        let mut named = KeySet::default();
        for request in requests {
            let Some((drawn_key, drawn)) = self.drawn_above(request.id) else {
                continue;
            };
            named.insert(drawn_key);
            if at_floor(drawn.level) {
                steps.stand_now.insert(drawn_key);
                continue;
            }
            if let Some((key, id)) = self.step_below(request.id, drawn)
                && let Entry::Vacant(vacant) = steps.by_key.entry(key)
            {
                vacant.insert((self.step(key, id, view), drawn_key));
            }
        }
        // A MIP ray crosses the whole view and passes over, unmarked, the bricks whose
        // maxima lie below its own so far; their finer bricks may show all the same (a coarser
        // brick's maximum is one of means). Where the asks below them may lie beyond the
        // request buffer, the bricks placed for the view refine as the frontier does.
        let passed_over: Vec<u32> = if self.max_projection && marks.asks_cut_short {
            let unmarked =
                |key: &u32| !marks.drawn_or_new.contains(key) && !self.standing.contains(key);
            self.kept.iter().copied().filter(unmarked).collect()
        } else {
            Vec::new()
        };
        for &key in marks.frontier.iter().chain(&passed_over) {
            let Some(id) = self.shape.brick_of(key) else {
                continue;
            };
            if named.contains(&key) {
                continue;
            }
            if at_floor(id.level) {
                steps.stand_now.insert(key);
                continue;
            }
            let unnamed = self.unnamed_steps(id, &view);
            if unnamed.is_empty() {
                steps.fixed.push(key);
                continue;
            }
            steps.unresolved += 1;
            for (step_key, step_id) in unnamed {
                if let Entry::Vacant(vacant) = steps.by_key.entry(step_key) {
                    vacant.insert((self.step(step_key, step_id, view), key));
                }
            }
        }
        steps
    }

    /// One frame of a view under the budget's pressure (module docs): the steps from its
    /// frontier (`marks`, and the bricks drawn above `requests`), the coarsest of them cut
    /// within `room` (what loads now within `available`), and what stands from now on.
    pub(super) fn refine_level(
        &mut self,
        requests: &[Request],
        marks: &Marks,
        (room, available): (usize, usize),
        committed: &KeySet,
        view: ViewPoint,
    ) -> ViewCut {
        let Steps {
            by_key: steps,
            mut fixed,
            mut stand_now,
            unresolved,
        } = self.steps_of(requests, marks, self.floor, view);
        // The coarsest steps are this frame's; the rest wait, their frontier bricks drawn as
        // they are meanwhile (each holding its slot).
        let level = steps.values().map(|(step, _)| step.id.level).max();
        let mut targets = Vec::new();
        for (step, parent) in steps.values() {
            if Some(step.id.level) == level {
                targets.push(*step);
            } else {
                fixed.push(*parent);
            }
        }
        self.note_progress(level.map_or(0, |level| (level as usize) << 32) | targets.len());
        let requested: KeySet = targets.iter().map(|r| r.key).collect();
        let held: KeySet = fixed
            .iter()
            .chain(&stand_now)
            .copied()
            .filter(|&key| self.slot_need(key, &requested, committed) != SlotNeed::Nothing)
            .collect();
        // (Drawn, the held bricks are no part of what can be placed without evicting.)
        let room = room.saturating_sub(held.len());
        // A group some of whose bricks were read already (or are being read) gives way last:
        // the cut changes as the frontier reveals more steps, and its bricks would have been
        // read for nothing.
        let started: KeySet = targets
            .iter()
            .filter(|step| self.ram.contains(step.key) || self.queue.is_in_flight(step.key))
            .map(|step| steps[&step.key].1)
            .collect();
        let (cut, loads_now) = {
            let need = |key: u32| self.slot_need(key, &requested, committed);
            let by_view = self.give_way_rank(view);
            let shape = &self.shape;
            // Only the steps give way, to the frontier bricks they refine: those are drawn
            // (a group of them giving way in turn would free no slot).
            let rank = |parent: BrickId| {
                if level.is_none_or(|level| parent.level > level + 1) {
                    return None;
                }
                let started = shape.key(parent).is_some_and(|key| started.contains(&key));
                Some(by_view(parent)? - if started { 4.0 } else { 0.0 })
            };
            let cut = cut_ranked(&targets, room, shape, rank, need);
            // What loads now: no more bricks than can be placed without evicting what the
            // frame drew (the cut's load order: the most important first).
            let mut slots = available;
            let loads_now: Vec<Request> = cut
                .load
                .iter()
                .filter(|r| {
                    let takes = need(r.key) == SlotNeed::Load;
                    let fits = !takes || slots > 0;
                    slots -= usize::from(takes && fits);
                    fits
                })
                .copied()
                .collect();
            (cut, loads_now)
        };
        let nothing_to_load = loads_now.iter().all(|r| self.needs_no_slot(r.key));
        let idle = self.ready.is_empty() && self.queue.counts() == (0, 0);
        if self.stalled(true) || (!targets.is_empty() && nothing_to_load && idle) {
            // Stalled or stuck: what the atlas holds is the cut. Every brick drawn in place of
            // finer ones stands (they are at most one level apart: the coarsest steps were all
            // that loaded).
            stand_now.extend(marks.frontier.iter().copied());
            stand_now.extend(steps.values().map(|&(_, parent)| parent));
            self.stand_for_budget(stand_now, view);
            return ViewCut {
                cut,
                loads_now: Vec::new(),
                unresolved: 0,
            };
        }
        // The cut stands once everything it loads is in (until then many steps may still turn
        // out uniform and need no slot: the next frame's cut knows more).
        if !cut.standing.is_empty() && cut.load.iter().all(|r| self.needs_no_slot(r.key)) {
            stand_now.extend(cut.standing.iter().copied());
        }
        if !stand_now.is_empty() {
            self.stand_for_budget(stand_now, view);
        }
        ViewCut {
            cut,
            loads_now,
            unresolved,
        }
    }
}

/// A frame's steps ([`Streamer::steps_of`]).
#[derive(Debug, Default)]
struct Steps {
    /// Each step, with the drawn brick it refines.
    by_key: KeyMap<(Request, u32)>,
    /// Frontier bricks drawn as they are this frame (no step refines them).
    fixed: Vec<u32>,
    /// Bricks at the floor: they stand from now on.
    stand_now: KeySet,
    /// Frontier bricks refined by steps no ask named.
    unresolved: usize,
}

/// What a frame's rays drew from the atlas ([`Streamer::marks_of`]).
#[derive(Debug, Default)]
pub(super) struct Marks {
    /// Bricks drawn in place of missing finer ones, standing for nothing: the frontier.
    pub frontier: Vec<u32>,
    /// Every brick drawn (either way), and those placed since (no ray of the frame saw them).
    pub drawn_or_new: KeySet,
    /// The frame's rays asked for more bricks than its request buffer held.
    pub asks_cut_short: bool,
}
