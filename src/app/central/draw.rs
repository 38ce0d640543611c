//! Drawing the central view's panes: once a UI frame, and only when the device has finished
//! what the last one gave it (`pacing.rs`), each pane whose image is out of date (or every 3D
//! pane while drawing continuously or while the streaming renderer refines), all in one
//! submission that fits the frame budget. A 3D frame that fits it is drawn whole; one that
//! does not is shown first as a preview at a resolution that fits, then drawn at full
//! resolution band by band, one band a UI frame, and shown once complete. The frame probe
//! measures one pass a submission for the Octree panel, the picking probe runs after.

use std::time::{Duration, Instant};

use super::super::AppGpu;
use super::super::settings::{AppSettings, Layout};
use super::super::slice_pane;
use super::super::view_state::ViewState;
use super::super::viewport::DrawKey;
use super::pacing::{FRAME_BUDGET, IDLE_AFTER, IDLE_BUDGET, IN_FLIGHT_POLL, Work};
use super::pane::Banding;
use super::{CentralView, Measured, PaneKind, pane_kinds};
use voxscope_render::{FramePass, ImageRegion, RenderError, RenderTarget, SliceSettings};
use voxscope_scene::{NetworkState, Scene};

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
    /// The whole frame into the preview target at this scale of each side.
    Preview(f64),
    /// Rows `first..first + count` of the full image.
    Band { first: u32, count: u32 },
}

impl CentralView {
    /// Draws what is out of date, within the frame budget, if the device is free. `serial`
    /// changes with every new scene. A streamed view is drawn again only when the streamer's
    /// page table changed (a frame could not differ otherwise). Returns when another UI frame is
    /// wanted: at once while bands are left to draw or bricks arrived, soon while the device is
    /// busy, `None` otherwise (while bricks are on their way the app's busy pace looks again).
    pub fn draw(
        &mut self,
        ctx: &egui::Context,
        gpu: &AppGpu,
        scene: &mut Scene,
        serial: u64,
        settings: &AppSettings,
        view: &ViewState,
    ) -> Result<Option<Duration>, RenderError> {
        let context = &gpu.context;
        // Nothing more goes to the device while it works on the last batch: egui's drawing
        // would wait behind it.
        if self.pacer.busy() {
            return Ok(Some(IN_FLIGHT_POLL));
        }
        // A band's time counts to its pane's frame (what the panel says a frame costs).
        if let Some((Work::Band { pane, .. }, took)) = self.pacer.take_finished()
            && let Some(spent) = self.band_time.get_mut(pane)
        {
            *spent += took;
        }
        let depth = scene.depth();
        // The streaming renderer takes in what earlier frames' rays asked for and uploads
        // within its budget; it never waits on I/O or the GPU.
        let stream = scene.renderer.update(context);
        let stream_frame = stream.as_ref().map(|s| s.frame);
        let mut refining = stream.as_ref().is_some_and(|s| {
            !s.complete
                || s.uploads > 0
                || s.filling > 0
                || s.judged_frame
                    .is_none_or(|judged| judged < self.stream_view_frame)
        });
        // Only a changed page table can make a frame differ from the last one drawn: while
        // bricks are being fetched and nothing arrived, the panes are not drawn again (the
        // streamer still takes in readbacks and results at every update).
        let stream_changed = stream
            .as_ref()
            .is_some_and(|s| s.uploads > 0 || s.table_changed);
        if let Some(status) = &stream {
            // One line for the first brick of each cause (the panel lists every one).
            for error in &status.errors {
                eprintln!("voxscope: {error}");
            }
        }
        let main = settings.transfer.with_window(view.window);
        let compare = settings.compare_transfer.with_window(view.window);
        // The composite's tables follow the channel list's edits (no reload); its generation
        // tells the panes drawn with older tables.
        let composite_channels = view.composite_channels(main);
        let layers = match &mut scene.composite {
            Some(composite) => composite.apply(context, &composite_channels),
            None => 0,
        };
        // With the composite shown the slices are channel 0's (the renderer of one channel).
        let slice_transfer = match (&scene.composite, composite_channels.first()) {
            (Some(_), Some(first)) => first.transfer,
            _ => main,
        };
        let kinds = pane_kinds(settings);
        let count = kinds.len();
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::app_frame"),
            });
        // Input lately: the small budget (input waits at most that); a pause: the larger one.
        if ctx.input(|i| !i.events.is_empty() || i.pointer.is_moving() || i.pointer.any_down()) {
            self.last_input = Instant::now();
        }
        let full_budget = if self.last_input.elapsed() >= IDLE_AFTER {
            IDLE_BUDGET
        } else {
            FRAME_BUDGET
        };
        let mut budget = full_budget;
        let mut pixels = 0u64;
        let mut band = None;
        let mut drew = false;
        let mut measured = None;
        let mut egui_renderer = gpu.render_state.renderer.write();
        for (index, kind) in kinds.into_iter().enumerate() {
            let (Some(pane), Some(rect)) = (self.panes.get_mut(index), self.pane_rects.get(index))
            else {
                continue;
            };
            let Some(target) = pane.target() else {
                continue;
            };
            let size = [target.width, target.height];
            let (key, level) = match kind {
                PaneKind::Volume => {
                    let (level, transfer) = match settings.layout {
                        Layout::LevelGrid => (view.grid_level(index, count, depth), main),
                        Layout::TransferPair if index == 1 => (view.max_level.min(depth), compare),
                        _ => (view.max_level.min(depth), main),
                    };
                    let key = DrawKey::Volume {
                        size,
                        camera: settings.camera,
                        settings: settings.render_settings(level, view.clipping.clip()),
                        transfer,
                        scene: serial,
                        layers,
                    };
                    (key, Some(level))
                }
                PaneKind::Slice(axis) => {
                    let mut slice_view = view.slice_views[axis];
                    slice_view.index = view.cursor_voxel(scene.data.volume.dims)[axis];
                    let (frame, _) = slice_pane::frame(scene, &slice_view, *rect, size);
                    let key = DrawKey::Slice {
                        settings: SliceSettings {
                            frame,
                            window: slice_transfer.window,
                            colormap: slice_transfer.colormap,
                            nearest: !settings.slice_linear,
                        },
                        size,
                        scene: serial,
                    };
                    (key, None)
                }
            };
            let DrawKey::Volume {
                camera,
                settings: render_settings,
                transfer,
                ..
            } = key
            else {
                // Slices cost a sample a pixel: drawn whole, outside the budget.
                if !pane.shows(&key) {
                    if let (
                        DrawKey::Slice {
                            settings: slice_settings,
                            ..
                        },
                        Some(target),
                    ) = (&key, pane.target())
                    {
                        scene
                            .renderer
                            .encode_slice(context, &mut encoder, target, slice_settings);
                    }
                    pane.drawn = Some(key);
                    pane.preview = None;
                    drew = true;
                }
                continue;
            };
            let redraw = settings.continuous || stream_changed;
            if pane.shows(&key) && !redraw {
                continue;
            }
            if budget.is_zero() {
                // The rest of the panes next frame.
                continue;
            }
            if pane.latest_key() != Some(key)
                && let Some(frame) = stream_frame
            {
                // A new view: wait for a frame drawn with it to be judged.
                self.stream_view_frame = frame;
                refining = true;
            }
            let full_pixels = size[0] as u64 * size[1] as u64;
            let estimate = self.pacer.estimate(full_pixels);
            let fits = estimate.is_some_and(|e| e <= budget);
            let renderer = scene.view_renderer();
            let in_bands = renderer.draws_regions() && !settings.continuous;
            let streaming = renderer.stream().is_some();
            let work = match pane.banding {
                Some(banding) if banding.key == key && !fits => {
                    let rows = self
                        .pacer
                        .band_rows(size[0], FIRST_BAND_ROWS, full_budget)
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
                _ if !(in_bands || self.interacting || (refining && !streaming)) => {
                    VolumeWork::Whole
                }
                _ if !settings.fast_interaction && in_bands => {
                    // Asked for no previews: the full image, band by band.
                    pane.banding = Some(Banding {
                        key,
                        next_row: 0,
                        bands: 0,
                    });
                    pane.drawn = None;
                    VolumeWork::Band {
                        first: 0,
                        count: self
                            .pacer
                            .band_rows(size[0], FIRST_BAND_ROWS, full_budget)
                            .clamp(1, size[1]),
                    }
                }
                _ => {
                    let scale = estimate.map_or(FIRST_PREVIEW_SCALE, |e| {
                        (budget.as_secs_f64() / e.as_secs_f64().max(1e-9))
                            .sqrt()
                            .clamp(*PREVIEW_SCALES.start(), *PREVIEW_SCALES.end())
                    });
                    VolumeWork::Preview(scale)
                }
            };
            // A changed transfer function recolors first, in the same submission.
            if scene.composite.is_none() && scene.applied_transfer != transfer {
                scene
                    .renderer
                    .set_transfer(context, &mut encoder, &transfer, None)?;
                scene.applied_transfer = transfer;
            }
            // Measured: draws that complete the full image (the panel's numbers are of whole
            // images; a banded frame's last band reads back every band's counts).
            let completes = match work {
                VolumeWork::Whole => true,
                VolumeWork::Preview(_) => false,
                VolumeWork::Band { first, count } => first + count >= size[1],
            };
            let measure = completes
                && measured.is_none()
                && self.frame_probe.as_ref().is_some_and(|p| p.is_idle());
            let writes = self
                .frame_probe
                .as_ref()
                .filter(|_| measure)
                .and_then(|p| p.timestamp_writes());
            let renderer = scene.view_renderer();
            let (drawn_to, region, complete): (&RenderTarget, ImageRegion, bool) = match work {
                VolumeWork::Whole => {
                    let target = pane.target().expect("checked above");
                    let region = ImageRegion::whole(size[0], size[1]);
                    renderer.encode(
                        context,
                        &mut encoder,
                        target,
                        &camera,
                        &render_settings,
                        writes,
                    );
                    pane.drawn = Some(key);
                    pane.preview = None;
                    pane.banding = None;
                    self.last_bands = 0;
                    (pane.target().expect("checked above"), region, true)
                }
                VolumeWork::Preview(scale) => {
                    let preview_size = size.map(|s| ((s as f64 * scale).round() as u32).max(1));
                    let target =
                        pane.preview_target(context, &mut egui_renderer, preview_size, key);
                    renderer.encode(
                        context,
                        &mut encoder,
                        target,
                        &camera,
                        &render_settings,
                        writes,
                    );
                    pane.banding = in_bands.then_some(Banding {
                        key,
                        next_row: 0,
                        bands: 0,
                    });
                    if in_bands {
                        pane.drawn = None;
                    }
                    let region = ImageRegion::whole(preview_size[0], preview_size[1]);
                    let target = &pane.preview.as_ref().expect("made above").image.target;
                    (target, region, false)
                }
                VolumeWork::Band { first, count } => {
                    let target = pane.target().expect("checked above");
                    let region = ImageRegion::rows(size[0], size[1], first, count);
                    let pass = FramePass {
                        target,
                        camera: &camera,
                        settings: &render_settings,
                        region,
                        timestamp_writes: writes,
                    };
                    renderer.encode_region(context, &mut encoder, pass);
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
                    if done {
                        self.last_bands = bands;
                    }
                    if first == 0 {
                        if self.band_time.len() <= index {
                            self.band_time.resize(index + 1, Duration::ZERO);
                        }
                        self.band_time[index] = Duration::ZERO;
                    }
                    band = Some(Work::Band {
                        pane: index,
                        rows: region.size[1],
                    });
                    (pane.target().expect("checked above"), region, done)
                }
            };
            if measure && let Some(probe) = self.frame_probe.as_mut() {
                probe.record(context, &mut encoder, drawn_to);
                measured = Some(Measured {
                    scene: serial,
                    pane: index,
                    panes: count,
                    level,
                    pixels: region.pixels(),
                    complete,
                    full_pixels,
                });
            }
            pixels += region.pixels();
            // A band takes the rest of the budget; an image what it is estimated to cost.
            budget = if band.is_some() {
                Duration::ZERO
            } else {
                budget.saturating_sub(self.pacer.estimate(region.pixels()).unwrap_or(full_budget))
            };
            drew = true;
            if self.logged_scene != serial && complete {
                self.logged_scene = serial;
                let how = match &scene.composite {
                    Some(composite) => format!(
                        "composite of {} channels, dense march",
                        composite.channels.len()
                    ),
                    None => format!(
                        "{} renderer, level {}",
                        scene.options.kind.name(),
                        render_settings.max_level
                    ),
                };
                eprintln!(
                    "voxscope: drew {} ({}x{} px, {how})",
                    scene.data.volume.name, size[0], size[1],
                );
            }
        }
        drop(egui_renderer);
        if drew {
            let work = match band {
                Some(band) => band,
                None if pixels > 0 => Work::Images { pixels },
                None => Work::Other,
            };
            self.pacer.submit(context, encoder, work, ctx);
            if measured.is_some()
                && let Some(probe) = self.frame_probe.as_mut()
            {
                probe.submitted();
                self.measuring = measured;
            }
        }
        // The composite has no probe (voxscope-render's composite.rs says why).
        if let Some(picking) = self.picking.as_mut().filter(|_| scene.composite.is_none()) {
            let latest: Vec<Option<DrawKey>> = self.panes.iter().map(|p| p.latest_key()).collect();
            picking.record(gpu, scene, &latest);
        }
        let now = Instant::now();
        if drew {
            self.draw_times.push(now);
        }
        self.draw_times
            .retain(|t| now.duration_since(*t) < Duration::from_secs(1));
        if stream.is_some() {
            scene.stream_status = stream;
        }
        if let Some(stats) = scene
            .renderer
            .stream()
            .and_then(|s| s.streamer().source().remote_stats())
        {
            scene.network = Some(NetworkState::follow(scene.network, stats));
        }
        self.refining = refining;
        let unfinished = self
            .panes
            .iter()
            .any(|pane| pane.banding.is_some() || pane.preview.is_some());
        Ok(if self.pacer.is_in_flight() {
            Some(IN_FLIGHT_POLL)
        } else if (refining && stream_changed) || unfinished {
            Some(Duration::ZERO)
        } else {
            None
        })
    }
}
