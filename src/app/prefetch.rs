//! Driving the frame prefetch ([`voxscope_scene::Prefetch`]) from the app: which frames to
//! keep ahead of the one on screen, and when a streamed series' next time point loads the
//! bricks of the view on screen.

use std::sync::Arc;

use super::voxscope_app::VoxscopeApp;
use voxscope_scene::{
    FrameChange, FrameKey, Job, MAX_PREFETCH_FRAMES, TransferRequest, frames_within_cap,
    prepare_scene, window,
};

impl VoxscopeApp {
    /// Keeps the frames after the one on screen prefetched (an in-memory time series only;
    /// see [`super::prefetch`]).
    pub(super) fn follow_prefetch(&mut self, ctx: &egui::Context) {
        let (Some(scene), Some(gpu)) = (&self.scene, &self.gpu) else {
            return;
        };
        if self.jobs.opening.is_some() {
            // The window moves once the frame being opened is on screen.
            return;
        }
        let series = &scene.data.volume.series;
        let count = if series.time_points < 2 {
            0
        } else if scene.renderer.streamer().is_some() {
            // The next time point alone: another streaming renderer, its own GPU budget.
            self.settings.prefetch_frames.min(1)
        } else {
            frames_within_cap(
                scene.bytes(),
                self.settings.prefetch_frames.min(MAX_PREFETCH_FRAMES),
            )
        };
        let wanted = window(FrameKey::of_scene(scene), series.time_points, count);
        let options = scene.options;
        let source = scene.data.source.clone();
        let context = Arc::clone(&gpu.context);
        // Frame changes keep the transfer functions they carry; nothing else is asked.
        let request = TransferRequest::default();
        let current = self.frame_change(FrameKey::of_scene(scene));
        self.prefetch.plan(&wanted, options, |key| {
            let frame = FrameChange {
                selection: key.selection(),
                composite: key.channel.is_none(),
                ..current
            };
            let wake = ctx.clone();
            Job::spawn(
                format!("time point {} of {} (prefetched)", key.time, source.spec()),
                move || wake.request_repaint(),
                move |progress| {
                    prepare_scene(&source, Some(frame), &request, &context, options, progress)
                },
            )
        });
    }

    /// The next time point of a streamed series loads the bricks of the view on screen once
    /// that view is complete ([`Prefetch::warm`]).
    pub(super) fn warm_prefetch(&mut self) {
        if let Some(scene) = &self.scene
            && let Some(streamer) = scene.renderer.streamer()
            && scene.stream_status.as_ref().is_some_and(|s| s.complete)
        {
            let keys: Vec<u32> = streamer.resident_keys().collect();
            let cut = streamer.budget_cut();
            self.prefetch.warm(streamer.shape(), &keys, cut.as_ref());
        }
    }
}
