//! Frame prefetch for time series: besides the frame on screen, a viewer keeps
//! the next few frames in play direction (a bounded count within a byte cap) loaded,
//! quantized, built and uploaded by background jobs, so the time slider and Play switch to
//! them from memory, without a load. Frames outside the window are dropped (a job loading one
//! is cancelled). A streamed OME-Zarr store prefetches the next time point alone (a streaming
//! renderer of its own: another atlas of the GPU budget): opened like any frame, then its
//! loaders read the bricks of the view on screen into its RAM cache (`warm`), so the frame
//! shows refined from memory instead of fetching its bricks again.

use voxscope_render::RendererOptions;
use voxscope_stream::{PyramidShape, ViewPoint};
use voxscope_volume::Selection;

use crate::{Job, Opened, Scene, SceneError};

/// Frames ahead kept by default.
pub const DEFAULT_PREFETCH_FRAMES: usize = 2;
/// The most frames ahead the panel allows.
pub const MAX_PREFETCH_FRAMES: usize = 4;
/// The most bytes (GPU and memory together) the prefetched frames may hold.
pub const PREFETCH_BYTES: u64 = 1 << 30;

/// Which frame a scene shows: its time point, and its channel (`None`: the composite of
/// every channel).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameKey {
    pub time: usize,
    pub channel: Option<usize>,
}

impl FrameKey {
    /// The frame `scene` shows.
    pub fn of_scene(scene: &Scene) -> Self {
        let selected = scene.data.volume.series.selected;
        Self {
            time: selected.time,
            channel: scene.composite.is_none().then_some(selected.channel),
        }
    }

    /// The frame the loaders read (channel 0 stands for the composite, which reads all).
    pub fn selection(self) -> Selection {
        Selection {
            channel: self.channel.unwrap_or(0),
            time: self.time,
        }
    }
}

/// The `count` frames after `current` in play direction (forward, wrapping at the last of
/// `time_points`), nearest first.
pub fn window(current: FrameKey, time_points: usize, count: usize) -> Vec<FrameKey> {
    (1..=count.min(time_points.saturating_sub(1)))
        .map(|step| FrameKey {
            time: (current.time + step) % time_points,
            ..current
        })
        .collect()
}

/// How many of `wanted` frames of `bytes_per_frame` fit [`PREFETCH_BYTES`].
pub fn frames_within_cap(bytes_per_frame: u64, wanted: usize) -> usize {
    let fit = PREFETCH_BYTES / bytes_per_frame.max(1);
    wanted.min(usize::try_from(fit).unwrap_or(usize::MAX))
}

/// The prefetched frames and the job loading the next one.
#[derive(Default)]
pub struct Prefetch {
    /// Frames ready to show, with the renderer options they were uploaded for.
    ready: Vec<(FrameKey, RendererOptions, Opened)>,
    /// One frame at a time (the machine's cores are the UI's too).
    loading: Option<(FrameKey, RendererOptions, Job<Opened>)>,
    /// Frames whose load failed: not tried again for this volume (showing one reports why).
    failed: Vec<FrameKey>,
    /// Ready streamed frames whose loaders were given the view's bricks ([`Self::warm`]).
    warmed: Vec<FrameKey>,
}

impl Prefetch {
    /// True while a frame is being prefetched.
    pub fn is_busy(&self) -> bool {
        self.loading.is_some()
    }

    /// The frames ready to show, in the order they were loaded.
    pub fn ready(&self) -> Vec<FrameKey> {
        self.ready.iter().map(|(key, _, _)| *key).collect()
    }

    /// Drops every frame and cancels the load in progress (another volume opened).
    pub fn clear(&mut self) {
        if let Some((_, _, job)) = self.loading.take() {
            job.progress.cancel();
        }
        self.ready.clear();
        self.failed.clear();
        self.warmed.clear();
    }

    /// Gives each ready streamed frame not given them yet the bricks `keys` of the view on
    /// screen (a pyramid of `shape`) to load ahead ([`voxscope_stream::Streamer::prefetch`]),
    /// and the view's budget cut (`cut`: what stands for the bricks the budget left out, so the
    /// next frame leaves out the same and loads none of them); frames of another shape are left
    /// alone. Returns the loads queued.
    pub fn warm(
        &mut self,
        shape: &PyramidShape,
        keys: &[u32],
        cut: Option<&(ViewPoint, Vec<u32>)>,
    ) -> usize {
        let mut queued = 0;
        for (key, _, opened) in &mut self.ready {
            if self.warmed.contains(key) {
                continue;
            }
            let Some(streamer) = opened.scene.renderer.streamer_mut() else {
                continue;
            };
            self.warmed.push(*key);
            if streamer.shape() == shape {
                if let Some((view, standing)) = cut {
                    streamer.apply_budget_cut(*view, standing.iter().copied());
                }
                queued += streamer.prefetch(keys.iter().copied());
            }
        }
        queued
    }

    /// Takes frame `key` if it is ready for `options`.
    pub fn take(&mut self, key: FrameKey, options: RendererOptions) -> Option<Opened> {
        let index = self
            .ready
            .iter()
            .position(|(k, o, _)| *k == key && *o == options)?;
        let (key, _, opened) = self.ready.remove(index);
        self.warmed.retain(|k| *k != key);
        Some(opened)
    }

    /// Takes the job loading frame `key` for `options`, if one is (to show its frame when
    /// it ends, rather than load it a second time).
    pub fn take_job(&mut self, key: FrameKey, options: RendererOptions) -> Option<Job<Opened>> {
        match &self.loading {
            Some((k, o, _)) if *k == key && *o == options => {
                self.loading.take().map(|(_, _, job)| job)
            }
            _ => None,
        }
    }

    /// Takes in the frame prefetched since the last call, if any.
    pub fn poll(&mut self) {
        let Some(result) = self.loading.as_ref().and_then(|(_, _, job)| job.try_take()) else {
            return;
        };
        let Some((key, options, _)) = self.loading.take() else {
            return;
        };
        match result {
            Ok(opened) => self.ready.push((key, options, opened)),
            Err(SceneError::Cancelled) => {}
            Err(error) => {
                eprintln!("voxscope: prefetching a frame failed: {error}");
                self.failed.push(key);
            }
        }
    }

    /// Keeps the frames `wanted` (for `options`) and no others: drops the rest, cancels a
    /// load outside them, and starts loading the nearest one missing with `start`.
    pub fn plan(
        &mut self,
        wanted: &[FrameKey],
        options: RendererOptions,
        start: impl FnOnce(FrameKey) -> Job<Opened>,
    ) {
        self.ready
            .retain(|(key, o, _)| *o == options && wanted.contains(key));
        let ready = &self.ready;
        self.warmed
            .retain(|k| ready.iter().any(|(key, _, _)| key == k));
        if let Some((key, o, job)) = &self.loading
            && (*o != options || !wanted.contains(key))
        {
            job.progress.cancel();
            self.loading = None;
        }
        if self.loading.is_some() {
            return;
        }
        let next = wanted
            .iter()
            .copied()
            .find(|key| !self.failed.contains(key) && !self.ready.iter().any(|(k, _, _)| k == key));
        if let Some(key) = next {
            self.loading = Some((key, options, start(key)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_follows_play_direction_and_wraps() {
        let at = |time| FrameKey {
            time,
            channel: None,
        };
        assert_eq!(window(at(3), 5, 2), [at(4), at(0)]);
        assert_eq!(window(at(0), 2, 4), [at(1)], "never the frame on screen");
        assert!(window(at(0), 1, 3).is_empty());
        assert_eq!(frames_within_cap(PREFETCH_BYTES / 2, 4), 2);
        assert_eq!(frames_within_cap(PREFETCH_BYTES * 2, 4), 0);
        assert_eq!(frames_within_cap(1 << 20, 3), 3);
    }
}
