//! The atlas's slots: which brick each holds and the last frame a ray used it (the shader marks
//! it; the streamer reads the marks back), told apart by how: a ray that wanted the brick's
//! level, or one that drew it in place of a missing finer brick. A new brick takes a free slot,
//! else the least recently used one, but never one a ray wanted in the latest frame read back,
//! nor one of the pinned coarse levels: so a view that needs more than the atlas holds cannot
//! evict itself frame after frame, while stand-ins make room for the bricks they stand in for.

use super::pyramid::EMPTY_KEY;

/// A slot handed out, and the brick it held before, if any (evicted).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Allocation {
    pub slot: u32,
    pub evicted: Option<u32>,
}

/// The atlas's slots and their last use.
pub struct SlotPool {
    /// Per slot: the brick's key, or [`EMPTY_KEY`].
    keys: Vec<u32>,
    /// Per slot: the last frame a ray wanted it (or it was filled).
    last_used: Vec<u32>,
    /// Per slot: the last frame a ray drew it in place of a finer brick.
    last_stand_in: Vec<u32>,
    pinned: Vec<bool>,
    free: Vec<u32>,
    /// This frame's eviction candidates, the oldest last; made on the first eviction of a frame.
    victims: Option<Vec<u32>>,
}

impl SlotPool {
    /// `capacity` free slots.
    pub fn new(capacity: usize) -> Self {
        Self {
            keys: vec![EMPTY_KEY; capacity],
            last_used: vec![0; capacity],
            last_stand_in: vec![0; capacity],
            pinned: vec![false; capacity],
            free: (0..capacity as u32).rev().collect(),
            victims: None,
        }
    }

    /// Slots in all.
    pub fn capacity(&self) -> usize {
        self.keys.len()
    }

    /// Slots holding a brick.
    pub fn occupied(&self) -> usize {
        self.keys.len() - self.free.len()
    }

    /// The brick in `slot`, if any.
    pub fn key(&self, slot: u32) -> Option<u32> {
        self.keys
            .get(slot as usize)
            .copied()
            .filter(|&k| k != EMPTY_KEY)
    }

    /// Starts a frame: eviction candidates are chosen afresh from the latest marks.
    pub fn new_frame(&mut self) {
        self.victims = None;
    }

    /// A slot for brick `key`, filled at `frame`: a free one, else the least recently used
    /// one not pinned and last wanted before `protect_from` (stand-ins used since go after the
    /// others). `None` when every slot is pinned or wanted since `protect_from` (the atlas
    /// cannot hold more of this view).
    pub fn allocate(&mut self, key: u32, frame: u32, protect_from: u32) -> Option<Allocation> {
        let (slot, evicted) = if let Some(slot) = self.free.pop() {
            (slot, None)
        } else {
            let victims = self.victims.get_or_insert_with(|| {
                let mut candidates: Vec<u32> = (0..self.keys.len() as u32)
                    .filter(|&s| {
                        let s = s as usize;
                        !self.pinned[s]
                            && self.keys[s] != EMPTY_KEY
                            && self.last_used[s] < protect_from
                            && self.last_stand_in[s] < protect_from
                    })
                    .collect();
                // Oldest last: popped first.
                candidates.sort_unstable_by_key(|&s| {
                    let s = s as usize;
                    std::cmp::Reverse((
                        self.last_stand_in[s].max(self.last_used[s]),
                        self.last_used[s],
                    ))
                });
                candidates
            });
            let slot = loop {
                let slot = victims.pop()?;
                // Still a candidate (not refilled earlier this frame).
                if self.last_used[slot as usize] < protect_from
                    && self.last_stand_in[slot as usize] < protect_from
                {
                    break slot;
                }
            };
            (slot, Some(self.keys[slot as usize]))
        };
        self.keys[slot as usize] = key;
        self.last_used[slot as usize] = frame;
        self.last_stand_in[slot as usize] = 0;
        Some(Allocation { slot, evicted })
    }

    /// Empties `slot` (its brick could not be entered in the page table).
    pub fn release(&mut self, slot: u32) {
        if let Some(key) = self.keys.get_mut(slot as usize)
            && *key != EMPTY_KEY
        {
            *key = EMPTY_KEY;
            self.free.push(slot);
        }
    }

    /// Keeps `slot`'s brick forever (the coarsest levels, which every ray can fall back to).
    pub fn pin(&mut self, slot: u32) {
        self.pinned[slot as usize] = true;
    }

    /// Pinned slots.
    pub fn pinned(&self) -> usize {
        self.pinned.iter().filter(|&&p| p).count()
    }

    /// Records that a ray used `slot` in `frame`: `wanted` its level, or in place of a finer
    /// brick.
    pub fn mark_used(&mut self, slot: u32, frame: u32, wanted: bool) {
        let marks = if wanted {
            &mut self.last_used
        } else {
            &mut self.last_stand_in
        };
        if let Some(last) = marks.get_mut(slot as usize) {
            *last = (*last).max(frame);
        }
    }

    /// Slots holding a brick wanted (or filled) at `frame` or later.
    pub fn used_since(&self, frame: u32) -> usize {
        self.keys
            .iter()
            .zip(&self.last_used)
            .filter(|&(&k, &used)| k != EMPTY_KEY && used >= frame)
            .count()
    }

    /// Slots a brick can be placed in without evicting anything a ray used at `protect_from`
    /// or later (wanted or in place of a finer brick): the free ones and the unused ones.
    pub fn available(&self, protect_from: u32) -> usize {
        (0..self.keys.len())
            .filter(|&s| {
                self.keys[s] == EMPTY_KEY
                    || (!self.pinned[s]
                        && self.last_used[s] < protect_from
                        && self.last_stand_in[s] < protect_from)
            })
            .count()
    }

    /// The keys of the unpinned slots holding a brick wanted at `frame` or later: the part of
    /// a view the atlas holds at the levels its rays chose.
    pub fn wanted_unpinned_since(&self, frame: u32) -> impl Iterator<Item = u32> + '_ {
        self.keys
            .iter()
            .zip(&self.last_used)
            .zip(&self.pinned)
            .filter(move |&((&k, &used), &pinned)| k != EMPTY_KEY && used >= frame && !pinned)
            .map(|((&k, _), _)| k)
    }

    /// Whether `slot` was filled after frame `frame` (`frame` being the latest frame whose
    /// marks were read back: its marks are another brick's).
    pub fn filled_after(&self, slot: u32, frame: u32) -> bool {
        self.last_used
            .get(slot as usize)
            .is_some_and(|&used| used > frame)
    }

    /// The key of every occupied slot.
    pub fn keys(&self) -> impl Iterator<Item = u32> + '_ {
        self.keys.iter().copied().filter(|&k| k != EMPTY_KEY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_slots_first_then_the_least_recently_used_slot_no_ray_drew_lately() {
        let mut pool = SlotPool::new(4);
        for key in 0..4 {
            let a = pool.allocate(key, 1, 1).expect("free");
            assert_eq!(a.evicted, None);
        }
        pool.pin(0); // key 0 pinned
        pool.mark_used(1, 5, true); // key 1 wanted at frame 5
        pool.mark_used(2, 3, true); // key 2 at frame 3; key 3 last at frame 1
        pool.mark_used(3, 5, false); // key 3 stood in for a finer brick at frame 5
        pool.new_frame();
        // Protect what frame 5 drew, wanted or in place of a finer brick: the victim is 2
        // (frame 3) alone.
        assert_eq!(pool.available(5), 1);
        let first = pool.allocate(10, 6, 5).expect("a victim");
        assert_eq!((first.slot, first.evicted), (2, Some(2)));
        // Only the pinned slot and frame 5's (and this frame's) remain: no room.
        assert_eq!(pool.allocate(11, 6, 5), None);
        assert_eq!(pool.available(5), 0);
        assert_eq!(pool.occupied(), 4);
        assert_eq!(pool.used_since(5), 2);
        assert_eq!(pool.key(2), Some(10));
    }
}
