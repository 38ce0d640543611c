//! Drawing the central view's panes: once a frame, each pane whose image is out of date (or
//! every one while drawing continuously or while the streaming renderer refines), with the
//! frame probe's measurement on the first and the picking probe after them.

use std::time::{Duration, Instant};

use super::super::AppGpu;
use super::super::settings::{AppSettings, Layout};
use super::super::slice_pane;
use super::super::view_state::ViewState;
use super::super::viewport::DrawKey;
use super::{CentralView, PaneKind, pane_kinds};
use voxscope_render::{FrameProbe, RenderError, RenderSettings, SliceSettings};
use voxscope_scene::{NetworkState, Scene};

impl CentralView {
    /// Draws every pane whose image is out of date (or all, when drawing continuously, or
    /// when the streaming renderer's page table changed). `serial` changes with every new
    /// scene. Returns whether another frame is wanted: the streaming renderer has bricks to
    /// load or upload, or has not yet judged the current view complete
    /// ([`CentralView::stream_changed`] says whether it is wanted at once).
    pub fn draw(
        &mut self,
        gpu: &AppGpu,
        scene: &mut Scene,
        serial: u64,
        settings: &AppSettings,
        view: &ViewState,
    ) -> Result<bool, RenderError> {
        let depth = scene.depth();
        // The streaming renderer takes in what earlier frames' rays asked for and uploads
        // within its budget; it never waits on I/O or the GPU.
        let stream = scene.renderer.update(&gpu.context);
        let stream_frame = stream.as_ref().map(|s| s.frame);
        let mut refining = stream.as_ref().is_some_and(|s| {
            !s.complete
                || s.uploads > 0
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
            Some(composite) => composite.apply(&gpu.context, &composite_channels),
            None => 0,
        };
        // With the composite shown the slices are channel 0's (the renderer of one channel).
        let slice_transfer = match (&scene.composite, composite_channels.first()) {
            (Some(_), Some(first)) => first.transfer,
            _ => main,
        };
        let kinds = pane_kinds(settings);
        let count = kinds.len();
        let mut drew = false;
        for (index, (pane, kind)) in self.panes.iter_mut().zip(kinds).enumerate() {
            let (Some(target), Some(rect)) = (&pane.target, self.pane_rects.get(index)) else {
                continue;
            };
            let size = [target.width, target.height];
            let key = match kind {
                PaneKind::Volume => {
                    let (level, transfer) = match settings.layout {
                        Layout::LevelGrid => (view.grid_level(index, count, depth), main),
                        Layout::TransferPair if index == 1 => (view.max_level.min(depth), compare),
                        _ => (view.max_level.min(depth), main),
                    };
                    DrawKey::Volume {
                        size,
                        camera: settings.camera,
                        settings: RenderSettings {
                            mode: settings.mode,
                            max_level: level,
                            pixel_lod: settings.pixel_lod,
                            opacity_correction: settings.opacity_correction,
                            density: settings.density,
                            heatmap: settings.heatmap,
                            trilinear: settings.trilinear,
                            shading: settings.shading,
                            clip: view.clipping.clip(),
                        },
                        transfer,
                        scene: serial,
                        layers,
                    }
                }
                PaneKind::Slice(axis) => {
                    let mut slice_view = view.slice_views[axis];
                    slice_view.index = view.cursor_voxel(scene.data.volume.dims)[axis];
                    let (frame, _) = slice_pane::frame(scene, &slice_view, *rect, size);
                    DrawKey::Slice {
                        settings: SliceSettings {
                            frame,
                            window: slice_transfer.window,
                            colormap: slice_transfer.colormap,
                            nearest: !settings.slice_linear,
                        },
                        size,
                        scene: serial,
                    }
                }
            };
            let volume_pane = matches!(key, DrawKey::Volume { .. });
            if pane.drawn == Some(key) && !settings.continuous && !(stream_changed && volume_pane) {
                continue;
            }
            if volume_pane
                && pane.drawn != Some(key)
                && let Some(frame) = stream_frame
            {
                // A new view: wait for a frame drawn with it to be judged.
                self.stream_view_frame = frame;
                refining = true;
            }
            let mut encoder =
                gpu.context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::app_frame"),
                    });
            match &key {
                DrawKey::Volume {
                    camera,
                    settings: render_settings,
                    transfer,
                    ..
                } => {
                    if scene.composite.is_none() && scene.applied_transfer != *transfer {
                        scene
                            .renderer
                            .set_transfer(&gpu.context, &mut encoder, transfer, None)?;
                        scene.applied_transfer = *transfer;
                    }
                    let measure =
                        !drew && self.frame_probe.as_ref().is_some_and(FrameProbe::is_idle);
                    let probe = self.frame_probe.as_mut().filter(|_| measure);
                    let writes = probe.as_ref().and_then(|p| p.timestamp_writes());
                    scene.view_renderer().encode(
                        &gpu.context,
                        &mut encoder,
                        target,
                        camera,
                        render_settings,
                        writes,
                    );
                    if let Some(probe) = probe {
                        probe.record(&gpu.context, &mut encoder, target);
                        gpu.context.queue.submit([encoder.finish()]);
                        probe.submitted();
                    } else {
                        gpu.context.queue.submit([encoder.finish()]);
                    }
                    if self.logged_scene != serial {
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
                            scene.data.volume.name, target.width, target.height,
                        );
                    }
                }
                DrawKey::Slice {
                    settings: slice_settings,
                    ..
                } => {
                    scene
                        .renderer
                        .encode_slice(&gpu.context, &mut encoder, target, slice_settings);
                    gpu.context.queue.submit([encoder.finish()]);
                }
            }
            pane.drawn = Some(key);
            drew = true;
        }
        // The composite has no probe (voxscope-render's composite.rs says why).
        if let Some(picking) = self.picking.as_mut().filter(|_| scene.composite.is_none()) {
            let drawn: Vec<Option<DrawKey>> = self.panes.iter().map(|p| p.drawn).collect();
            picking.record(gpu, scene, &drawn);
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
        self.stream_changed = stream_changed;
        Ok(refining)
    }
}
