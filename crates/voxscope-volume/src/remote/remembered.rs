//! Objects that failed after their retries, remembered per store: asked for again within a
//! while they answer with the same failure at once, without a request (a dead chunk that many
//! bricks share, read by each, would otherwise be fetched again for every one of them). A
//! transient failure is remembered for [`Timing::remember_failure`], doubling each time the
//! object fails again up to [`Timing::max_remembered`]; a permanent one for the store's life.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::Instant;

use super::fault::{Failure, Persistence, Timing};

/// Failed objects remembered at most (beyond, new failures are not remembered).
const MAX_REMEMBERED: usize = 1 << 20;

struct Entry {
    failure: Failure,
    /// Until when it is answered from here; `None`: for good.
    until: Option<Instant>,
    /// How often it failed in a row.
    count: u32,
}

/// The failed objects of one store.
#[derive(Default)]
pub(crate) struct Remembered {
    entries: Mutex<HashMap<String, Entry>>,
}

impl Remembered {
    /// The failure `key` answers with now, if it is remembered.
    pub(crate) fn get(&self, key: &str) -> Option<Failure> {
        let entries = self.entries.lock().ok()?;
        let entry = entries.get(key)?;
        entry
            .until
            .is_none_or(|until| until > Instant::now())
            .then(|| entry.failure.clone())
    }

    /// The last failure of `key`, remembered or not any more (what a message about it says).
    pub(crate) fn last(&self, key: &str) -> Option<Failure> {
        Some(self.entries.lock().ok()?.get(key)?.failure.clone())
    }

    /// `key` failed with `failure` after its retries.
    pub(crate) fn remember(&self, key: &str, failure: &Failure, timing: &Timing) {
        let Ok(mut entries) = self.entries.lock() else {
            return;
        };
        if entries.len() >= MAX_REMEMBERED && !entries.contains_key(key) {
            return;
        }
        let entry = entries.entry(key.to_owned()).or_insert(Entry {
            failure: failure.clone(),
            until: None,
            count: 0,
        });
        entry.count += 1;
        entry.failure = failure.clone();
        entry.until = match failure.persistence {
            Persistence::Permanent => None,
            Persistence::Transient | Persistence::Silent => Some(
                Instant::now()
                    + timing
                        .remember_failure
                        .saturating_mul(1 << (entry.count - 1).min(16))
                        .min(timing.max_remembered),
            ),
        };
    }

    /// `key` was read: its failures are forgotten.
    pub(crate) fn forget(&self, key: &str) {
        if let Ok(mut entries) = self.entries.lock() {
            entries.remove(key);
        }
    }

    /// Forgets every transient failure (what was learned while opening, before the store's
    /// reading deadlines apply).
    pub(crate) fn forget_transient(&self) {
        if let Ok(mut entries) = self.entries.lock() {
            entries.retain(|_, e| e.failure.persistence == Persistence::Permanent);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failures_are_answered_at_once_for_a_doubling_while_and_permanent_ones_for_good() {
        let timing = Timing {
            remember_failure: std::time::Duration::from_millis(40),
            ..Timing::default()
        };
        let remembered = Remembered::default();
        let failure = Failure::transient("HTTP 500 Internal Server Error", true);
        remembered.remember("c/0/0/0", &failure, &timing);
        assert_eq!(remembered.get("c/0/0/0"), Some(failure.clone()));
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert_eq!(remembered.get("c/0/0/0"), None);
        assert_eq!(remembered.last("c/0/0/0"), Some(failure.clone()));
        // Twice: 80 ms.
        remembered.remember("c/0/0/0", &failure, &timing);
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert!(remembered.get("c/0/0/0").is_some());
        remembered.forget("c/0/0/0");
        assert_eq!(remembered.get("c/0/0/0"), None);
        let denied = Failure::denied();
        remembered.remember("zarr.json", &denied, &timing);
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert_eq!(remembered.get("zarr.json"), Some(denied));
    }
}
