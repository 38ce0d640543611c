//! The streamer's bricks that could not be read: how often each failed, whether and when it is
//! asked for again, and how failures are told. A brick whose fetch failed (the network, the
//! disk) is asked for again after [`StreamOptions::retry_after`](crate::StreamOptions), twice
//! as long each time, and given up after [`MAX_BRICK_ATTEMPTS`] tries; a brick that does not
//! decode or is invalid is given up at once (another try reads the same). Either way it stays
//! drawn from the finest coarser level that can be read until the view no longer needs it.
//!
//! Told once: the first brick failing with a cause gets a line (for stderr, the app's log);
//! every further one is counted ([`Failures::groups`]: one summary per cause) and listed
//! ([`Failures::bricks`]), never repeated.

use std::collections::HashSet;
use std::time::{Duration, Instant};

use super::key_hash::KeyMap;
use crate::{BrickError, BrickId};

/// Tries of a brick whose fetch fails, at most (then it stays unreadable).
pub const MAX_BRICK_ATTEMPTS: u32 = 6;

/// The longest wait before a failed brick is asked for again.
const MAX_RETRY_DELAY: Duration = Duration::from_secs(300);

/// One brick that could not be read (and has not been read since).
#[derive(Debug, Clone, PartialEq)]
pub struct FailedBrick {
    /// Its page-table key.
    pub key: u32,
    pub id: BrickId,
    /// Its last failure.
    pub error: BrickError,
    /// How often it failed.
    pub attempts: u32,
    /// When it is asked for again; `None`: never (it does not decode, or its tries are
    /// spent).
    pub retry_at: Option<Instant>,
    /// Whether it is being asked for again now (its retry time came).
    pub retrying: bool,
}

/// Bricks failing with one cause: what one summary line says.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct FailureGroup {
    /// The cause they share.
    pub cause: String,
    /// How many bricks.
    pub bricks: usize,
    /// Per pyramid level, how many (levels with none left out).
    pub per_level: Vec<(u32, usize)>,
    /// The first brick's whole line (its level, brick, chunk and cause).
    pub example: String,
}

/// The failed bricks of one streamer.
#[derive(Debug, Default)]
pub struct Failures {
    retry_after: Duration,
    bricks: KeyMap<FailedBrick>,
    /// Keys in the order they first failed (the list's order).
    order: Vec<u32>,
    /// Causes a line was written for.
    told: HashSet<String>,
    /// Lines not yet taken.
    lines: Vec<String>,
}

impl Failures {
    /// Failed fetches are asked for again after `retry_after`, doubling.
    pub fn new(retry_after: Duration) -> Self {
        Self {
            retry_after,
            ..Self::default()
        }
    }

    /// Brick `id` (page-table key `key`) failed with `error`; `now` is when.
    pub fn record(&mut self, key: u32, id: BrickId, error: BrickError, now: Instant) {
        let first = !self.bricks.contains_key(&key);
        let entry = self.bricks.entry(key).or_insert_with(|| FailedBrick {
            key,
            id,
            error: error.clone(),
            attempts: 0,
            retry_at: None,
            retrying: false,
        });
        entry.attempts += 1;
        entry.retrying = false;
        entry.retry_at =
            (error.may_pass_later() && entry.attempts < MAX_BRICK_ATTEMPTS).then(|| {
                now + self
                    .retry_after
                    .saturating_mul(1 << (entry.attempts - 1).min(16))
                    .min(MAX_RETRY_DELAY)
            });
        entry.error = error;
        if first {
            self.order.push(key);
        }
        let cause = entry.error.cause().to_owned();
        if self.told.insert(cause) {
            self.lines
                .push(format!("{} (drawn from a coarser level)", entry.error));
        }
    }

    /// Brick `key` was read: it is no failure any more.
    pub fn succeeded(&mut self, key: u32) {
        if self.bricks.remove(&key).is_some() {
            self.order.retain(|&k| k != key);
        }
    }

    /// The bricks whose retry time has come by `now`: they are asked for again (and listed as
    /// retrying until they load or fail again).
    pub fn due(&mut self, now: Instant) -> Vec<u32> {
        let mut due = Vec::new();
        for brick in self.bricks.values_mut() {
            if !brick.retrying && brick.retry_at.is_some_and(|at| at <= now) {
                brick.retrying = true;
                due.push(brick.key);
            }
        }
        due
    }

    /// When the next failed brick is asked for again, if any will be.
    pub fn next_retry(&self) -> Option<Instant> {
        self.bricks
            .values()
            .filter(|b| !b.retrying)
            .filter_map(|b| b.retry_at)
            .min()
    }

    /// The bricks failed now (not being asked for again), in the order they first failed.
    pub fn bricks(&self) -> impl Iterator<Item = &FailedBrick> {
        self.order
            .iter()
            .filter_map(|key| self.bricks.get(key))
            .filter(|b| !b.retrying)
    }

    /// Brick `key`'s failure, if it is failed now.
    pub fn get(&self, key: u32) -> Option<&FailedBrick> {
        self.bricks.get(&key).filter(|b| !b.retrying)
    }

    /// How many bricks are failed now.
    pub fn count(&self) -> usize {
        self.bricks().count()
    }

    /// The failed bricks grouped by cause, the largest group first.
    pub fn groups(&self) -> Vec<FailureGroup> {
        group(self.bricks())
    }

    /// The lines written since the last call: one for the first brick of each cause.
    pub fn take_lines(&mut self) -> Vec<String> {
        std::mem::take(&mut self.lines)
    }
}

/// `bricks` grouped by cause, the largest group first (ties: the cause first met).
pub fn group<'a>(bricks: impl Iterator<Item = &'a FailedBrick>) -> Vec<FailureGroup> {
    let mut groups: Vec<FailureGroup> = Vec::new();
    for brick in bricks {
        let cause = brick.error.cause();
        let index = match groups.iter().position(|g| g.cause == cause) {
            Some(index) => index,
            None => {
                groups.push(FailureGroup {
                    cause: cause.to_owned(),
                    bricks: 0,
                    per_level: Vec::new(),
                    example: brick.error.to_string(),
                });
                groups.len() - 1
            }
        };
        let group = &mut groups[index];
        group.bricks += 1;
        match group
            .per_level
            .iter_mut()
            .find(|(l, _)| *l == brick.id.level)
        {
            Some((_, count)) => *count += 1,
            None => group.per_level.push((brick.id.level, 1)),
        }
    }
    for group in &mut groups {
        group.per_level.sort_unstable();
    }
    // Stable: equal counts keep the order their causes were first met.
    groups.sort_by_key(|g| std::cmp::Reverse(g.bricks));
    groups
}

impl FailureGroup {
    /// One line: `3 bricks unreadable (level 0: 2, level 2: 1): CAUSE; the first: LINE`.
    pub fn describe(&self) -> String {
        let levels: Vec<String> = self
            .per_level
            .iter()
            .map(|(level, count)| format!("level {level}: {count}"))
            .collect();
        if self.bricks == 1 {
            format!("1 brick unreadable: {}", self.example)
        } else {
            format!(
                "{} bricks unreadable ({}): {}; the first: {}",
                self.bricks,
                levels.join(", "),
                self.cause,
                self.example
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(level: u32, x: u32) -> BrickId {
        BrickId::new(level, [x, 0, 0])
    }

    #[test]
    fn fetches_are_retried_with_backoff_that_stops_and_damage_is_given_up_at_once() {
        let mut failures = Failures::new(Duration::from_secs(1));
        let t0 = Instant::now();
        let fetch = BrickError::fetch("level 0 brick (1, 0, 0): x: HTTP 500");
        failures.record(1, id(0, 1), fetch.clone(), t0);
        failures.record(
            2,
            id(0, 2),
            BrickError::decode("level 0 brick (2, 0, 0): damaged"),
            t0,
        );
        assert_eq!(failures.count(), 2);
        assert_eq!(failures.next_retry(), Some(t0 + Duration::from_secs(1)));
        assert!(failures.due(t0).is_empty());
        let mut at = t0;
        for attempt in 1..MAX_BRICK_ATTEMPTS {
            at += Duration::from_secs(1 << (attempt - 1));
            assert_eq!(failures.due(at), vec![1], "attempt {attempt}");
            assert_eq!(failures.count(), 1, "a retrying brick is not listed");
            failures.record(1, id(0, 1), fetch.clone(), at);
        }
        // Tries spent: never again.
        assert_eq!(failures.next_retry(), None);
        assert!(failures.due(at + Duration::from_secs(3600)).is_empty());
        assert_eq!(failures.count(), 2);
        failures.succeeded(1);
        assert_eq!(failures.count(), 1);
        // One line per cause, however often the brick failed.
        assert_eq!(failures.take_lines().len(), 2);
        assert!(failures.take_lines().is_empty());
    }

    #[test]
    fn many_bricks_failing_the_same_way_are_one_group() {
        let mut failures = Failures::new(Duration::from_secs(1));
        let now = Instant::now();
        for x in 0..5 {
            let error = BrickError::Fetch(crate::BrickFault {
                message: format!("level {} brick ({x}, 0, 0): u: connection refused", x % 2),
                cause: "connection refused".to_owned(),
            });
            failures.record(x, id(x % 2, x), error, now);
        }
        failures.record(
            9,
            id(3, 0),
            BrickError::decode("level 3 brick (0, 0, 0): bad"),
            now,
        );
        let groups = failures.groups();
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].bricks, 5);
        assert_eq!(groups[0].per_level, vec![(0, 3), (1, 2)]);
        assert_eq!(
            groups[0].describe(),
            "5 bricks unreadable (level 0: 3, level 1: 2): connection refused; the first: level 0 brick (0, 0, 0): u: connection refused"
        );
        assert_eq!(
            groups[1].describe(),
            "1 brick unreadable: level 3 brick (0, 0, 0): bad"
        );
        assert_eq!(failures.take_lines().len(), 2);
    }
}
