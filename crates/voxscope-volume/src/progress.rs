//! Progress and cancellation of long work (loading, octree builds) shared between the thread
//! doing it and the one watching: a stage name, a fraction, and a cancel flag.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// What a long job reports, and how it is asked to stop. Share it through an `Arc`.
#[derive(Debug, Default)]
pub struct Progress {
    stage: Mutex<&'static str>,
    /// The stage's fraction done, as `f32` bits.
    fraction: AtomicU32,
    cancelled: AtomicBool,
}

/// Returned by work that saw [`Progress::cancel`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled;

impl Progress {
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts a stage (e.g. `building octree`) at fraction 0.
    pub fn begin(&self, stage: &'static str) {
        *self.stage.lock().unwrap_or_else(|e| e.into_inner()) = stage;
        self.set_fraction(0.0);
    }

    /// How far the current stage is, 0…1.
    pub fn set_fraction(&self, fraction: f32) {
        self.fraction
            .store(fraction.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed);
    }

    /// The current stage and its fraction done.
    pub fn get(&self) -> (&'static str, f32) {
        let stage = *self.stage.lock().unwrap_or_else(|e| e.into_inner());
        (stage, f32::from_bits(self.fraction.load(Ordering::Relaxed)))
    }

    /// Asks the work to stop at its next check.
    pub fn cancel(&self) {
        self.cancelled.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancelled.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once [`Self::cancel`] was called: for `?` between steps.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}
