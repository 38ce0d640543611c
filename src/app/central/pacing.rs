//! Frame pacing: the central view never queues GPU work faster than the device finishes it,
//! and never hands it much more than [`FRAME_BUDGET`] at once. On a slow device (Mesa's
//! software Vulkan takes 0.4–8 s for a frame) a submission runs on the device's one queue
//! ahead of egui's own drawing, and the UI thread waits in egui's submit and present until it
//! is done: the File menu opened seconds after the click, drags lost their end, a double click
//! was two single ones. So each UI frame submits at most one batch of the panes' work, only
//! once the last one has finished, sized by what it was measured to cost: a frame that fits
//! the budget is drawn whole; one that does not is shown first at a resolution that fits,
//! then drawn in bands of rows that each fit it (`draw.rs`).
//!
//! What a submission cost is measured as its wall time on the device: a watcher thread waits
//! for it (`Device::poll` with its submission index; the UI thread never waits) and wakes the
//! UI when it is done. GPU timestamps would be more precise where they are right, but Mesa's
//! software device reported 0.15 ms for a frame that took seconds.

use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use voxscope_render::GpuContext;

/// The GPU time one UI frame's submission is sized for while the user is at work: egui's
/// drawing waits behind it on a device that runs one queue, so this bounds how long input
/// can wait. 40 ms keeps the UI at some 20 frames a second however slow the volume's frame.
pub const FRAME_BUDGET: Duration = Duration::from_millis(40);

/// The budget once no input came for [`IDLE_AFTER`]: larger bands finish a slow frame sooner
/// (each band also costs a UI frame), and the first input after the pause waits at most this.
pub const IDLE_BUDGET: Duration = Duration::from_millis(120);

/// No input for this long, and the idle budget applies.
pub const IDLE_AFTER: Duration = Duration::from_secs(1);

/// Bands are whole rows of workgroups (8×8 pixels, `pipeline.rs`): a band of one row would
/// cost as much as eight.
const BAND_ROW_STEP: u32 = 8;

/// While a submission is on the device the UI looks again this often (the watcher wakes it
/// sooner when the submission ends).
pub const IN_FLIGHT_POLL: Duration = Duration::from_millis(30);

/// The longest a watcher waits for one submission before giving up on it (a lost device).
const WATCH_TIMEOUT: Duration = Duration::from_secs(60);

/// A band's rows grow at most this many times from one band to the next: the rows of an image
/// cost very different amounts (those that miss the volume almost nothing), so a band sized by
/// a cheap one could cost many budgets.
const BAND_GROWTH: f64 = 2.0;

/// What a submission drew.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Work {
    /// Whole images (full or previews) of 3D panes, this many pixels: their average cost.
    Images { pixels: u64 },
    /// A band of `rows` rows of 3D pane `pane`'s full image.
    Band { pane: usize, rows: u32 },
    /// Slices, or nothing costly.
    Other,
}

/// A submission on the device.
struct InFlight {
    /// When the device finished it, once the watcher saw it.
    finished: Arc<Mutex<Option<Instant>>>,
    submitted: Instant,
    work: Work,
}

/// A submission for the watcher thread to wait for.
struct Watch {
    index: wgpu::SubmissionIndex,
    finished: Arc<Mutex<Option<Instant>>>,
    wake: egui::Context,
}

/// Tracks the central view's GPU work and what it costs.
#[derive(Default)]
pub struct FramePacer {
    in_flight: Option<InFlight>,
    /// The watcher thread's queue (started with the first submission).
    watcher: Option<Sender<Watch>>,
    /// Seconds a pixel of a whole 3D image costs on average, as last measured.
    seconds_per_pixel: Option<f64>,
    /// The last band's rows and how long it took.
    last_band: Option<(u32, Duration)>,
    /// The submission [`Self::busy`] last saw finish, and how long it took.
    finished: Option<(Work, Duration)>,
}

impl FramePacer {
    /// Whether the last submission is still on the device; takes in what it cost once it is
    /// done. Never waits.
    pub fn busy(&mut self) -> bool {
        let Some(in_flight) = &self.in_flight else {
            return false;
        };
        let finished = *in_flight
            .finished
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        let Some(finished) = finished else {
            return true;
        };
        let took = finished.saturating_duration_since(in_flight.submitted);
        match in_flight.work {
            Work::Images { pixels } if pixels > 0 => {
                self.seconds_per_pixel = Some(took.as_secs_f64() / pixels as f64);
            }
            Work::Band { rows, .. } => self.last_band = Some((rows, took)),
            _ => {}
        }
        self.finished = Some((in_flight.work, took));
        self.in_flight = None;
        false
    }

    /// The submission that finished at the last [`Self::busy`], and how long it took (once).
    pub fn take_finished(&mut self) -> Option<(Work, Duration)> {
        self.finished.take()
    }

    /// Whether a submission is on the device, as of the last [`Self::busy`].
    pub fn is_in_flight(&self) -> bool {
        self.in_flight.is_some()
    }

    /// Submits `encoder` (which draws `work`), has the watcher wait for it and wake `ctx`'s
    /// UI when it is done.
    pub fn submit(
        &mut self,
        context: &GpuContext,
        encoder: wgpu::CommandEncoder,
        work: Work,
        ctx: &egui::Context,
    ) {
        let finished = Arc::new(Mutex::new(None));
        let submitted = Instant::now();
        let index = context.queue.submit([encoder.finish()]);
        let watch = Watch {
            index,
            finished: Arc::clone(&finished),
            wake: ctx.clone(),
        };
        let watcher = self
            .watcher
            .get_or_insert_with(|| spawn_watcher(context.device.clone()));
        if let Err(mpsc::SendError(watch)) = watcher.send(watch) {
            // No watcher (it ended): the work is taken as done, unmeasured.
            *watch.finished.lock().unwrap_or_else(|p| p.into_inner()) = Some(submitted);
            self.watcher = None;
        }
        self.in_flight = Some(InFlight {
            finished,
            submitted,
            work,
        });
    }

    /// The estimated GPU time of a whole image of `pixels` pixels; `None` until one was
    /// measured.
    pub fn estimate(&self, pixels: u64) -> Option<Duration> {
        self.seconds_per_pixel
            .map(|s| Duration::from_secs_f64(s * pixels as f64))
    }

    /// The rows of an image `width` pixels wide that the next band may have within `budget`:
    /// scaled from the last band's cost, growing at most [`BAND_GROWTH`] times; from the
    /// average cost before any band; `first` before anything was measured. A multiple of
    /// [`BAND_ROW_STEP`], at least one step.
    pub fn band_rows(&self, width: u32, first: u32, budget: Duration) -> u32 {
        let budget = budget.as_secs_f64();
        let rows = match (self.last_band, self.seconds_per_pixel) {
            (Some((rows, took)), _) => {
                let scale = (budget / took.as_secs_f64().max(1e-6)).min(BAND_GROWTH);
                rows as f64 * scale
            }
            (None, Some(seconds)) => budget / (seconds * width.max(1) as f64),
            (None, None) => first as f64,
        };
        let steps = (rows / BAND_ROW_STEP as f64).floor() as u32;
        steps.max(1) * BAND_ROW_STEP
    }
}

/// The thread that waits for each submission in turn, notes when it ended and wakes the UI.
fn spawn_watcher(device: wgpu::Device) -> Sender<Watch> {
    let (sender, receiver) = mpsc::channel::<Watch>();
    std::thread::Builder::new()
        .name("voxscope-frame-watcher".into())
        .spawn(move || {
            for watch in receiver {
                let _ = device.poll(wgpu::PollType::Wait {
                    submission_index: Some(watch.index),
                    timeout: Some(WATCH_TIMEOUT),
                });
                *watch.finished.lock().unwrap_or_else(|p| p.into_inner()) = Some(Instant::now());
                watch.wake.request_repaint();
            }
        })
        .expect("a thread to watch the GPU");
    sender
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured(work: Work, took: Duration) -> FramePacer {
        let submitted = Instant::now();
        let mut pacer = FramePacer {
            in_flight: Some(InFlight {
                finished: Arc::new(Mutex::new(Some(submitted + took))),
                submitted,
                work,
            }),
            ..FramePacer::default()
        };
        assert!(!pacer.busy(), "done");
        assert_eq!(pacer.take_finished(), Some((work, took)));
        pacer
    }

    #[test]
    fn whole_images_set_the_cost_of_a_pixel() {
        assert_eq!(FramePacer::default().estimate(1000), None);
        // 40 ms for 100 000 pixels: 0.4 µs a pixel, 0.4 s for a million.
        let pacer = measured(Work::Images { pixels: 100_000 }, Duration::from_millis(40));
        let estimate = pacer.estimate(1_000_000).expect("measured");
        assert!((estimate.as_secs_f64() - 0.4).abs() < 1e-6, "{estimate:?}");
        // A band of a 1000-pixel row: 100 rows fit 40 ms, 96 in whole workgroups.
        assert_eq!(pacer.band_rows(1000, 16, FRAME_BUDGET), 96);
    }

    #[test]
    fn bands_follow_the_last_one_growing_at_most_twice() {
        // A cheap band (rows that miss the volume) does not make the next one huge.
        let cheap = measured(Work::Band { pane: 0, rows: 16 }, Duration::from_micros(100));
        assert_eq!(cheap.band_rows(700, 16, FRAME_BUDGET), 32);
        // A band that took four budgets is followed by a quarter of its rows.
        let slow = measured(Work::Band { pane: 0, rows: 64 }, Duration::from_millis(160));
        assert_eq!(slow.band_rows(700, 16, FRAME_BUDGET), 16);
        // Never less than a row of workgroups.
        let slower = measured(Work::Band { pane: 0, rows: 8 }, Duration::from_millis(400));
        assert_eq!(slower.band_rows(700, 16, FRAME_BUDGET), 8);
        assert_eq!(FramePacer::default().band_rows(700, 16, FRAME_BUDGET), 16);
    }

    #[test]
    fn a_submission_is_busy_until_it_finished() {
        let mut pacer = FramePacer {
            in_flight: Some(InFlight {
                finished: Arc::new(Mutex::new(None)),
                submitted: Instant::now(),
                work: Work::Other,
            }),
            ..FramePacer::default()
        };
        assert!(pacer.busy());
        assert!(pacer.is_in_flight());
    }
}
