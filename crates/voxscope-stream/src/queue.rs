//! The order bricks are loaded in: what rays lacked before what might be needed soon, coarse
//! levels before fine ones (a whole coarser picture first, then its detail), and near the view's
//! center before the edges. The queue is the latest frame's wants in that order: a new frame's
//! requests replace it, so bricks the view no longer needs are never loaded.

use std::sync::{Condvar, Mutex, MutexGuard};

use super::key_hash::KeySet;
use super::pyramid::MAX_LEVELS;
use crate::BrickId;

/// Why a brick is wanted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Tier {
    /// A ray of the last frame lacked it (or a finer brick it covers).
    Visible,
    /// Beside a visible one: loaded into the RAM cache while nothing visible waits.
    Prefetch,
}

/// A brick's place in the queue: smaller comes first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Priority(u64);

impl Priority {
    /// Tier first, then coarser levels, then the angle from the view's center (`off_center`,
    /// ≥ 0: 1 − cos of it, say).
    pub fn new(tier: Tier, level: u32, off_center: f32) -> Self {
        Self::with_maximum(tier, level, 0, off_center)
    }

    /// As [`Self::new`], bricks of a larger `maximum` value level first within a level (MIP:
    /// the brightest bricks raise the rays' maxima soonest, after which the rays need fewer of
    /// the others; 0 where it is not known or not asked).
    pub fn with_maximum(tier: Tier, level: u32, maximum: u16, off_center: f32) -> Self {
        let tier = (tier == Tier::Prefetch) as u64;
        let coarse_first = (MAX_LEVELS as u64 - 1).saturating_sub(level as u64);
        let brightest_first = u64::from(u16::MAX - maximum);
        // A non-negative float's bits sort as the float does.
        let distance = off_center.max(0.0).to_bits() as u64;
        Self(tier << 56 | coarse_first << 48 | brightest_first << 32 | distance)
    }

    /// The tier it was made with.
    pub fn tier(self) -> Tier {
        if self.0 >> 56 == 0 {
            Tier::Visible
        } else {
            Tier::Prefetch
        }
    }
}

/// A brick to load, with its key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Request {
    pub priority: Priority,
    pub id: BrickId,
    pub key: u32,
}

struct State {
    /// Sorted with the best last (popped first).
    pending: Vec<Request>,
    /// Keys a worker has taken and the streamer has not yet received.
    in_flight: KeySet,
    closed: bool,
}

/// The requests the workers take from, best first; shared by the streamer and its workers.
pub struct RequestQueue {
    state: Mutex<State>,
    ready: Condvar,
}

impl Default for RequestQueue {
    fn default() -> Self {
        Self {
            state: Mutex::new(State {
                pending: Vec::new(),
                in_flight: KeySet::default(),
                closed: false,
            }),
            ready: Condvar::new(),
        }
    }
}

impl RequestQueue {
    fn lock(&self) -> MutexGuard<'_, State> {
        // A worker that panicked mid-update leaves nothing half-written that matters here.
        self.state
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Replaces the queue with `requests` (any order; those already being loaded are left
    /// out). Returns how many are queued. The requests are sorted before the lock is taken:
    /// the loaders wait for it only while those in flight are left out.
    pub fn replace(&self, mut requests: Vec<Request>) -> usize {
        requests.sort_unstable_by_key(|r| std::cmp::Reverse(r.priority));
        requests.dedup_by_key(|r| r.key);
        let mut state = self.lock();
        requests.retain(|r| !state.in_flight.contains(&r.key));
        state.pending = requests;
        let queued = state.pending.len();
        drop(state);
        self.ready.notify_all();
        queued
    }

    /// The best request, marked in flight; waits while there is none. `None` once closed.
    pub fn take(&self) -> Option<Request> {
        let mut state = self.lock();
        loop {
            if state.closed {
                return None;
            }
            if let Some(request) = state.pending.pop() {
                state.in_flight.insert(request.key);
                return Some(request);
            }
            state = self
                .ready
                .wait(state)
                .unwrap_or_else(|poisoned| poisoned.into_inner());
        }
    }

    /// The best request without waiting; `None` once closed.
    pub fn try_take(&self) -> Option<Request> {
        self.try_take_if(|_| true)
    }

    /// The best request without waiting, where `wanted` takes it; `None` once closed.
    pub fn try_take_if(&self, wanted: impl FnOnce(&Request) -> bool) -> Option<Request> {
        let mut state = self.lock();
        if state.closed || !state.pending.last().is_some_and(wanted) {
            return None;
        }
        let request = state.pending.pop()?;
        state.in_flight.insert(request.key);
        Some(request)
    }

    /// The `count` best requests waiting, best first, left in the queue: what the loaders will
    /// take next (what a network source fetches ahead).
    pub fn upcoming(&self, count: usize) -> Vec<BrickId> {
        let state = self.lock();
        state
            .pending
            .iter()
            .rev()
            .take(count)
            .map(|r| r.id)
            .collect()
    }

    /// The streamer has received the result for `key`: it may be queued again.
    pub fn done(&self, key: u32) {
        self.lock().in_flight.remove(&key);
    }

    /// Requests waiting and requests being loaded.
    pub fn counts(&self) -> (usize, usize) {
        let state = self.lock();
        (state.pending.len(), state.in_flight.len())
    }

    /// Whether `key` is being loaded.
    pub fn is_in_flight(&self, key: u32) -> bool {
        self.lock().in_flight.contains(&key)
    }

    /// Wakes every waiting worker and makes [`Self::take`] return `None` from now on.
    pub fn close(&self) {
        self.lock().closed = true;
        self.ready.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(tier: Tier, level: u32, off_center: f32, key: u32) -> Request {
        Request {
            priority: Priority::new(tier, level, off_center),
            id: BrickId {
                level,
                brick: [key, 0, 0],
                channel: 0,
            },
            key,
        }
    }

    #[test]
    fn visible_before_prefetch_coarse_before_fine_center_before_edge() {
        let queue = RequestQueue::default();
        queue.replace(vec![
            request(Tier::Visible, 0, 0.5, 1),
            request(Tier::Prefetch, 5, 0.0, 2),
            request(Tier::Visible, 0, 0.1, 3),
            request(Tier::Visible, 2, 0.9, 4),
            request(Tier::Visible, 1, 0.0, 5),
            request(Tier::Prefetch, 0, 0.0, 6),
        ]);
        let order: Vec<u32> = std::iter::from_fn(|| queue.try_take())
            .map(|r| r.key)
            .collect();
        assert_eq!(order, [4, 5, 3, 1, 2, 6]);
    }

    #[test]
    fn a_new_frame_replaces_the_queue_and_skips_what_is_in_flight() {
        let queue = RequestQueue::default();
        queue.replace(vec![
            request(Tier::Visible, 0, 0.0, 1),
            request(Tier::Visible, 0, 0.2, 2),
        ]);
        let taken = queue.try_take().expect("one");
        assert_eq!(taken.key, 1);
        // The next frame wants 1 (in flight), 3 and 3 again: 2 is dropped (cancelled).
        let queued = queue.replace(vec![
            request(Tier::Visible, 0, 0.0, 1),
            request(Tier::Visible, 0, 0.3, 3),
            request(Tier::Visible, 0, 0.3, 3),
        ]);
        assert_eq!(queued, 1);
        assert_eq!(queue.counts(), (1, 1));
        assert_eq!(queue.try_take().map(|r| r.key), Some(3));
        queue.done(1);
        assert!(!queue.is_in_flight(1));
        queue.close();
        assert_eq!(queue.take(), None);
    }
}
