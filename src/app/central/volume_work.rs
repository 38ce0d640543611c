//! A 3D pane's share of a UI frame (`draw.rs`): how much of its out-of-date view fits the
//! budget left ([`VolumeWork`]: the whole frame, a preview at a smaller scale, or the next band
//! of the full image), recorded into the frame's submission and counted against its budget.

use std::time::Duration;

use super::frame::{FrameDrawing, FrameInputs, PassRecorder, VolumeView};
use super::pacing::{FramePacer, Work};
use super::pane::{Banding, Pane};
use super::{CentralView, Measured};
use voxscope_render::{FramePass, ImageRegion, RenderError, RenderTarget, VolumeRenderer};
use voxscope_scene::Scene;

/// The preview's scale (of each side) before any frame was measured: a sixteenth of the pixels.
const FIRST_PREVIEW_SCALE: f64 = 0.25;
/// Previews are at least this scale of each side (a sixty-fourth of the pixels) and at most
/// half: a frame that fits at more is drawn whole, in bands.
const PREVIEW_SCALES: std::ops::RangeInclusive<f64> = 0.125..=0.5;
/// Rows a band has where no cost was measured yet.
const FIRST_BAND_ROWS: u32 = 16;

/// What one UI frame draws of a 3D pane.
#[derive(Debug, Clone, Copy)]
enum VolumeWork {
    /// The whole frame at full resolution.
    Whole,
    /// The whole frame into the preview target at `scale` of each side; with `bands_follow`,
    /// the full image is drawn band by band from the next UI frame on.
    Preview { scale: f64, bands_follow: bool },
    /// Rows `first..first + count` of the full image.
    Band { first: u32, count: u32 },
}

impl VolumeWork {
    /// Whether drawing it completes the full image of `height` rows.
    fn completes(self, height: u32) -> bool {
        match self {
            VolumeWork::Whole => true,
            VolumeWork::Preview { .. } => false,
            VolumeWork::Band { first, count } => first + count >= height,
        }
    }
}

/// What decides how much of a 3D pane's view one UI frame draws.
struct WorkChoice {
    view: VolumeView,
    /// What is left of this UI frame's budget, and the whole budget.
    budget: Duration,
    full_budget: Duration,
    /// The full frame's estimated cost (`None` before a frame was measured).
    estimate: Option<Duration>,
    /// The renderer draws regions alone, and the view is not drawn continuously.
    in_bands: bool,
    /// The camera is being moved.
    interacting: bool,
    /// The streaming renderer still refines the view.
    refining: bool,
    /// The pane is drawn by the streaming renderer.
    streaming: bool,
    /// Slow frames are shown first as a preview (else band by band alone).
    previews: bool,
}

impl WorkChoice {
    /// The work for this UI frame; starts the pane's banding where the full image is to be
    /// drawn band by band without a preview.
    fn choose(&self, pacer: &FramePacer, pane: &mut Pane) -> VolumeWork {
        let (key, size) = (self.view.key, self.view.size);
        let fits = self.estimate.is_some_and(|e| e <= self.budget);
        match pane.banding {
            Some(banding) if banding.key == key && !fits => {
                let rows = pacer
                    .band_rows(size[0], FIRST_BAND_ROWS, self.full_budget)
                    .clamp(1, size[1] - banding.next_row.min(size[1] - 1));
                VolumeWork::Band {
                    first: banding.next_row,
                    count: rows,
                }
            }
            _ if fits => VolumeWork::Whole,
            // Drawn continuously, or a renderer that draws whole frames only: its full
            // frame once the view is still (and, but for the streaming renderer, complete),
            // a preview meanwhile. A streamed view refines on whole frames: its rays ask for
            // the bricks their pixels resolve, and a preview's would judge it complete at a
            // coarser level than the frame shown.
            _ if !(self.in_bands || self.interacting || (self.refining && !self.streaming)) => {
                VolumeWork::Whole
            }
            _ if !self.previews && self.in_bands => {
                // Asked for no previews: the full image, band by band.
                pane.banding = Some(Banding {
                    key,
                    next_row: 0,
                    bands: 0,
                });
                pane.drawn = None;
                VolumeWork::Band {
                    first: 0,
                    count: pacer
                        .band_rows(size[0], FIRST_BAND_ROWS, self.full_budget)
                        .clamp(1, size[1]),
                }
            }
            _ => {
                let scale = self.estimate.map_or(FIRST_PREVIEW_SCALE, |e| {
                    (self.budget.as_secs_f64() / e.as_secs_f64().max(1e-9))
                        .sqrt()
                        .clamp(*PREVIEW_SCALES.start(), *PREVIEW_SCALES.end())
                });
                VolumeWork::Preview {
                    scale,
                    bands_follow: self.in_bands,
                }
            }
        }
    }
}

/// What a 3D pane's work drew: into which target, which region of it, and whether that
/// completed the full image.
struct DrawnWork<'p> {
    target: &'p RenderTarget,
    region: ImageRegion,
    complete: bool,
    /// Bands the full image took (0: drawn whole), where this work completed it.
    bands: Option<u32>,
}

/// Records `work` of the pane's `view` with `renderer`, and moves the pane on: a whole frame
/// or a last band makes its full image current, a preview (or a first band) starts drawing
/// it band by band.
fn record_work<'p>(
    work: VolumeWork,
    pane: &'p mut Pane,
    view: &VolumeView,
    renderer: &VolumeRenderer,
    recorder: &mut PassRecorder<'_>,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) -> DrawnWork<'p> {
    let PassRecorder {
        context,
        encoder,
        egui_renderer,
    } = recorder;
    let (key, size) = (view.key, view.size);
    let (camera, settings) = (&view.camera, &view.settings);
    match work {
        VolumeWork::Whole => {
            let target = pane.target().expect("checked above");
            let region = ImageRegion::whole(size[0], size[1]);
            renderer.encode(context, encoder, target, camera, settings, timestamp_writes);
            pane.drawn = Some(key);
            pane.preview = None;
            pane.banding = None;
            DrawnWork {
                target: pane.target().expect("checked above"),
                region,
                complete: true,
                bands: Some(0),
            }
        }
        VolumeWork::Preview {
            scale,
            bands_follow,
        } => {
            let preview_size = size.map(|s| ((s as f64 * scale).round() as u32).max(1));
            let target = pane.preview_target(context, egui_renderer, preview_size, key);
            renderer.encode(context, encoder, target, camera, settings, timestamp_writes);
            pane.banding = bands_follow.then_some(Banding {
                key,
                next_row: 0,
                bands: 0,
            });
            if bands_follow {
                pane.drawn = None;
            }
            let region = ImageRegion::whole(preview_size[0], preview_size[1]);
            DrawnWork {
                target: &pane.preview.as_ref().expect("made above").image.target,
                region,
                complete: false,
                bands: None,
            }
        }
        VolumeWork::Band { first, count } => {
            let target = pane.target().expect("checked above");
            let region = ImageRegion::rows(size[0], size[1], first, count);
            let pass = FramePass {
                target,
                camera,
                settings,
                region,
                timestamp_writes,
            };
            renderer.encode_region(context, encoder, pass);
            let banding = pane.banding.get_or_insert(Banding {
                key,
                next_row: 0,
                bands: 0,
            });
            banding.next_row = first + region.size[1];
            banding.bands += 1;
            let done = banding.next_row >= size[1];
            let bands = banding.bands;
            if done {
                // Complete: the full image replaces the preview.
                pane.drawn = Some(key);
                pane.banding = None;
                pane.preview = None;
            }
            DrawnWork {
                target: pane.target().expect("checked above"),
                region,
                complete: done,
                bands: done.then_some(bands),
            }
        }
    }
}

impl CentralView {
    /// Draws what fits of 3D pane `index`'s `view` into `drawing`, if the pane does not show
    /// it yet (or the view is drawn continuously, or the stream's page table changed) and
    /// budget is left; recolors first where the transfer function changed.
    pub(super) fn draw_volume_pane(
        &mut self,
        index: usize,
        view: VolumeView,
        frame: &FrameInputs<'_>,
        scene: &mut Scene,
        drawing: &mut FrameDrawing<'_>,
    ) -> Result<(), RenderError> {
        let Some(pane) = self.panes.get_mut(index) else {
            return Ok(());
        };
        let redraw = frame.settings.continuous || frame.stream_changed;
        if pane.shows(&view.key) && !redraw {
            return Ok(());
        }
        if drawing.budget.is_zero() {
            // The rest of the panes next frame.
            return Ok(());
        }
        if pane.latest_key() != Some(view.key)
            && let Some(stream_frame) = frame.stream_frame
        {
            // A new view: wait for a frame drawn with it to be judged.
            self.stream_view_frame = stream_frame;
            drawing.refining = true;
        }
        let renderer = scene.view_renderer();
        let choice = WorkChoice {
            view,
            budget: drawing.budget,
            full_budget: frame.full_budget,
            estimate: self.pacer.estimate(view.full_pixels()),
            in_bands: renderer.draws_regions() && !frame.settings.continuous,
            interacting: self.interacting,
            refining: drawing.refining,
            streaming: renderer.streamer().is_some(),
            previews: frame.settings.fast_interaction,
        };
        let work = choice.choose(&self.pacer, pane);
        // A changed transfer function recolors first, in the same submission.
        if scene.composite.is_none() && scene.applied_transfer != view.transfer {
            let recorder = &mut drawing.recorder;
            scene.renderer.set_transfer(
                recorder.context,
                &mut recorder.encoder,
                &view.transfer,
                None,
            )?;
            scene.applied_transfer = view.transfer;
        }
        // Measured: draws that complete the full image (the panel's numbers are of whole
        // images; a banded frame's last band reads back every band's counts).
        let measure = work.completes(view.size[1])
            && drawing.measured.is_none()
            && self.frame_probe.as_ref().is_some_and(|p| p.is_idle());
        let writes = self
            .frame_probe
            .as_ref()
            .filter(|_| measure)
            .and_then(|p| p.timestamp_writes());
        let renderer = scene.view_renderer();
        let drawn = record_work(work, pane, &view, renderer, &mut drawing.recorder, writes);
        if let Some(bands) = drawn.bands {
            self.last_bands = bands;
        }
        if let VolumeWork::Band { first, .. } = work {
            if first == 0 {
                if self.band_time.len() <= index {
                    self.band_time.resize(index + 1, Duration::ZERO);
                }
                self.band_time[index] = Duration::ZERO;
            }
            drawing.band = Some(Work::Band {
                pane: index,
                rows: drawn.region.size[1],
            });
        }
        if measure && let Some(probe) = self.frame_probe.as_mut() {
            let recorder = &mut drawing.recorder;
            probe.record(recorder.context, &mut recorder.encoder, drawn.target);
            drawing.measured = Some(Measured {
                scene: frame.serial,
                pane: index,
                panes: frame.panes,
                level: Some(view.level),
                pixels: drawn.region.pixels(),
                complete: drawn.complete,
                full_pixels: view.full_pixels(),
            });
        }
        let (region, complete) = (drawn.region, drawn.complete);
        drawing.count(
            region.pixels(),
            self.pacer.estimate(region.pixels()),
            frame.full_budget,
        );
        if complete {
            self.log_first_drawing(scene, frame.serial, &view);
        }
        Ok(())
    }

    /// Says once per scene how its first complete 3D image was drawn.
    fn log_first_drawing(&mut self, scene: &Scene, serial: u64, view: &VolumeView) {
        if self.logged_scene == serial {
            return;
        }
        self.logged_scene = serial;
        let how = match &scene.composite {
            Some(composite) => format!(
                "composite of {} channels, {}",
                composite.channels.len(),
                if composite.is_streamed() {
                    "streamed"
                } else {
                    "dense march"
                }
            ),
            None => format!(
                "{} renderer, level {}",
                scene.options.kind.name(),
                view.settings.max_level
            ),
        };
        eprintln!(
            "voxscope: drew {} ({}x{} px, {how})",
            scene.data.volume.name, view.size[0], view.size[1],
        );
    }
}
