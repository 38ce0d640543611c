//! A view's share of the atlas: what a frame's asks come to within the room the view has
//! (`budget.rs`), and, once they do not fit, the view's refinement level by level
//! (`refine.rs`); the bricks that stand for those left out, and the status that says so.

use super::refine::{Marks, ViewCut};
use super::*;

impl Streamer {
    /// The cut of `requests` (the asks the latest frame's request buffer held, `asked` in all
    /// with those beyond it) within the room the atlas has for this view, and what loads now:
    /// never more than can be placed without evicting what the frame drew. A view whose asks
    /// fit loads them all at once (with the coarser bricks above them, coarse first). One
    /// whose asks do not, or that asked beyond the request buffer for more than the room
    /// holds, is under the budget's pressure from then on (while the view stays): it refines
    /// level by level (`refine.rs`), so that the cut it settles on is restricted (neighbours
    /// at most one level apart) and it reads little beyond that cut. `usage`: the frame's usage
    /// marks, read ([`Self::marks_of`]) only by a view under pressure.
    pub(super) fn cut_for_view(
        &mut self,
        requests: &[Request],
        left_out: &[usize],
        usage: &[u32],
        (asked, truncated): (usize, bool),
        view: ViewPoint,
        frame: u32,
    ) -> ViewCut {
        // The view's bricks in the atlas: those its rays wanted, and those standing for
        // bricks left out (drawn in their place).
        let mut committed: KeySet = self.slots.wanted_unpinned_since(frame).collect();
        // Of those, the ones its rays wanted at their own levels (the rest stand in).
        let wanted_in_atlas = committed.len();
        // Under pressure, the bricks placed for the view are kept: theirs too.
        committed.extend(
            self.standing
                .iter()
                .chain(&self.kept)
                .copied()
                .filter(|&key| self.table.get(key).is_some_and(|e| e.is_resident())),
        );
        // The view's share of the atlas decides what the view can have; what loads now is also
        // never more than can be placed without evicting what the frame drew (a passing
        // shortage, while stand-ins are drawn, delays bricks but leaves none out).
        let room = self.budget_slots().saturating_sub(committed.len());
        let available = self.slots.available(frame.max(1));
        let pressed_by_asks = truncated && asked > room;
        let unpressed = match self.pressed {
            Some(_) => None,
            None => {
                self.cut_unpressed(requests, room, available, &committed, view, pressed_by_asks)
            }
        };
        let outcome = match unpressed {
            Some(outcome) => outcome,
            None => {
                if self.pressed.is_none() {
                    self.pressed = Some(view);
                    self.forget_progress();
                }
                let marks = Marks {
                    asks_cut_short: truncated,
                    ..self.marks_of(usage, frame)
                };
                self.refine_level(requests, &marks, (room, available), &committed, view)
            }
        };
        if !self.standing.is_empty() {
            // At their own levels the view needs what its rays wanted in the atlas and what
            // they asked for (as far as the request buffer held the asks: the GPU's count of
            // them counts a key again wherever its deduplicating set lost it).
            let mapped: usize = left_out.iter().sum();
            let needed = wanted_in_atlas + requests.len() + mapped;
            let left_out = mapped + outcome.cut.left_out.len();
            self.note_budget(&outcome.cut, &committed, needed, left_out);
        }
        outcome
    }

    /// The cut of a view not under the budget's pressure: its asks and the coarser bricks
    /// above them within `room`, loaded at once as far as `available` slots allow. `None`
    /// where the view is under pressure from now on: its asks do not fit (or
    /// `pressed_by_asks`: beyond the request buffer, more than fit), or their cut leaves some
    /// out with all it loads in, or bricks have waited for slots that nothing frees
    /// (stalled), or nothing can be placed and nothing is on its way (stuck: every slot holds
    /// a brick the frame drew).
    fn cut_unpressed(
        &mut self,
        requests: &[Request],
        room: usize,
        available: usize,
        committed: &KeySet,
        view: ViewPoint,
        pressed_by_asks: bool,
    ) -> Option<ViewCut> {
        self.note_progress(requests.len());
        // The requests need a slot each (they passed `satisfied` and `known_invisible`);
        // only the coarser bricks a cut brings in, and their ancestors, are looked up.
        let requested: KeySet = requests.iter().map(|r| r.key).collect();
        let need = |key: u32| self.slot_need(key, &requested, committed);
        let rank = self.give_way_rank(view);
        if pressed_by_asks || requests.len() > room {
            return None;
        }
        // The coarser bricks loaded along with the asks take slots until the finer ones are
        // in (the frame's fifth holds them): a cut they overrun leaves groups out only for a
        // while. Once everything it loads is in and it still does, the view is under pressure.
        let cut = cut_ranked(requests, room, &self.shape, &rank, need);
        if !cut.left_out.is_empty() && cut.load.iter().all(|r| self.needs_no_slot(r.key)) {
            return None;
        }
        if available >= room {
            let loads_now = cut.load.clone();
            return Some(ViewCut {
                cut,
                loads_now,
                unresolved: 0,
            });
        }
        // A passing shortage: what can be placed now loads now. Stalled (bricks wait in RAM
        // for slots that nothing frees, or the view lacks no fewer bricks for a while: placed
        // and evicted again in turn), or stuck (nothing can be placed and nothing is on its
        // way): the view is under pressure.
        let now = cut_ranked(requests, available, &self.shape, &rank, need);
        let idle = self.ready.is_empty() && self.queue.counts() == (0, 0);
        let stuck = !now.left_out.is_empty()
            && (self.stalled(true) || (idle && now.load.iter().all(|r| self.needs_no_slot(r.key))));
        if stuck {
            return None;
        }
        Some(ViewCut {
            loads_now: now.load,
            cut,
            unresolved: 0,
        })
    }

    /// How readily the group below `parent` gives way within its level (the highest first).
    /// DVR: the farther from the view's center, the sooner (the center is what one looks at,
    /// and the rays nearest it are the ones in front). MIP weighs every pixel alike, whatever
    /// its place: the dimmer the brick (its largest value, known once it was read or from the
    /// store's chunk ranges; unknown counts as dimmest), the sooner, since the picture shows a
    /// ray's brightest sample and a dim brick's detail seldom reaches it.
    pub(super) fn give_way_rank(&self, view: ViewPoint) -> impl Fn(BrickId) -> Option<f32> + '_ {
        let mip = self.max_projection;
        move |parent: BrickId| {
            Some(if mip {
                1.0 - f32::from(self.known_maximum(parent)) / f32::from(u16::MAX)
            } else {
                view.off_center(self.shape.brick_center(parent))
            })
        }
    }

    /// The largest value level of brick `id`, where the table or the source knows it (0 where
    /// neither does).
    fn known_maximum(&self, id: BrickId) -> u16 {
        let Some(key) = self.shape.key(id) else {
            return 0;
        };
        match self.table.get(key) {
            Some(entry) if entry.cell & ENTRY_FAILED == 0 => (entry.range >> 16) as u16,
            _ => self.source.known_range(id).map_or(0, |range| range.max),
        }
    }

    /// The view lacked `measure` (fewer is progress): counted from the first frame it lacked
    /// no more.
    pub(super) fn note_progress(&mut self, measure: usize) {
        if measure < self.fewest_missing {
            self.fewest_missing = measure;
            self.progress_at = (self.frame, Instant::now());
        }
    }

    /// Bricks have waited in RAM for slots that nothing frees ([`STALLED_FRAMES`]), or, where
    /// `pressed`, the view has made no progress for [`NO_PROGRESS_FRAMES`] and
    /// [`NO_PROGRESS_TIME`] (bricks placed and evicted again in turn: waiting longer changes
    /// nothing).
    pub(super) fn stalled(&self, pressed: bool) -> bool {
        let no_progress = pressed
            && self.frame.saturating_sub(self.progress_at.0) >= NO_PROGRESS_FRAMES
            && self.progress_at.1.elapsed() >= NO_PROGRESS_TIME;
        self.no_room_frames >= STALLED_FRAMES || no_progress
    }

    /// Slots a view may fill with bricks at the levels its rays want ([`view_slots`]).
    pub(super) fn budget_slots(&self) -> usize {
        view_slots(self.slots.capacity(), self.slots.pinned())
    }

    /// The brick that stands for `id` in the view on screen (the coarsest of its ancestors
    /// standing for bricks the budget left out), if any.
    pub(super) fn standing_for(&self, id: BrickId) -> Option<(u32, BrickId)> {
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
    pub(super) fn stand_in(&mut self, keys: &[u32], view: ViewPoint) {
        self.no_room_frames = 0;
        self.forget_progress();
        self.standing.extend(keys.iter().copied());
        self.standing_view = Some(view);
        self.changed_frame = self.frame;
    }

    /// What the view needs against what fits, for the status: `needed` bricks at the levels
    /// its rays chose (in the atlas or asked for), `left_out` of them drawn coarser;
    /// `committed`, the bricks the view draws from the atlas (its cut).
    pub(super) fn note_budget(
        &mut self,
        cut: &Cut,
        committed: &KeySet,
        needed: usize,
        left_out: usize,
    ) {
        let level_of = |key: &u32| self.shape.brick_of(*key).map(|id| id.level);
        let finest = committed.iter().filter_map(level_of).min();
        let coarsest = self
            .standing
            .iter()
            .filter_map(level_of)
            .max()
            .max(cut.coarsest);
        self.budget = Some(BudgetLimit {
            needed,
            fit: self.budget_slots(),
            left_out,
            drawn: committed.len(),
            finest,
            coarsest,
            full_detail: FullDetailBudget::Unknown,
        });
    }

    /// Progress is counted from now (a new cut, or one that stands).
    pub(super) fn forget_progress(&mut self) {
        self.fewest_missing = usize::MAX;
        self.progress_at = (self.frame, Instant::now());
    }

    /// A view other than the one bricks stand in, or the one refining level by level, is cut
    /// anew.
    pub(super) fn follow_view(&mut self, view: ViewPoint) {
        let other = |of: Option<ViewPoint>| of.is_some_and(|of| of != view);
        if other(self.standing_view) || other(self.pressed) {
            self.cut_anew();
        }
    }

    /// Forgets what stands for what: rays' asks load again and the next cut decides.
    pub(super) fn cut_anew(&mut self) {
        self.no_room_frames = 0;
        self.forget_progress();
        self.standing.clear();
        for level in &mut self.counters.levels {
            level.left_out = 0;
        }
        self.standing_view = None;
        self.pressed = None;
        self.floor = None;
        self.kept.clear();
        self.budget = None;
        self.changed_frame = self.frame;
    }
}
