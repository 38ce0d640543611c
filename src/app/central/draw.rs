//! Drawing the central view's panes: once a UI frame, and only when the device has finished
//! what the last one gave it (`pacing.rs`), each pane whose image is out of date (or every 3D
//! pane while drawing continuously or while the streaming renderer refines), all in one
//! submission that fits the frame budget. A 3D frame that fits it is drawn whole; one that
//! does not is shown first as a preview at a resolution that fits, then drawn at full
//! resolution band by band, one band a UI frame, and shown once complete
//! (`volume_work.rs`). The frame probe measures one pass a submission for the Octree panel,
//! the picking probe runs after.

use std::time::{Duration, Instant};

use egui::Rect;

use super::super::AppGpu;
use super::super::settings::{AppSettings, Layout};
use super::super::slice_pane;
use super::super::view_state::ViewState;
use super::super::viewport::DrawKey;
use super::frame::{FrameDrawing, FrameInputs, PaneLooks, PassRecorder, VolumeView};
use super::pacing::{FRAME_BUDGET, IDLE_AFTER, IDLE_BUDGET, IN_FLIGHT_POLL, Work};
use super::pane::Pane;
use super::{CentralView, PaneKind, pane_kinds};
use voxscope_render::{GpuContext, RenderError, SliceSettings};
use voxscope_scene::{NetworkState, Scene};
use voxscope_stream::StreamStatus;

/// What the streaming renderer's update at the start of a UI frame says.
struct StreamUpdate {
    /// Its status (`None`: the scene is not streamed).
    status: Option<StreamStatus>,
    /// It still refines the view: more frames are wanted.
    refining: bool,
    /// Its page table changed (or bricks were uploaded): a frame drawn now could differ from
    /// the last one.
    changed: bool,
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
        self.count_finished_band();
        let depth = scene.depth();
        let stream = self.update_stream(context, scene);
        let looks = PaneLooks::apply(context, scene, settings, view);
        let kinds = pane_kinds(settings);
        let frame = FrameInputs {
            settings,
            view,
            serial,
            depth,
            panes: kinds.len(),
            looks,
            stream_frame: stream.status.as_ref().map(|s| s.frame),
            stream_changed: stream.changed,
            full_budget: self.frame_budget(ctx),
        };
        let encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::app_frame"),
            });
        let mut egui_renderer = gpu.render_state.renderer.write();
        let mut drawing = FrameDrawing {
            recorder: PassRecorder {
                context,
                encoder,
                egui_renderer: &mut egui_renderer,
            },
            budget: frame.full_budget,
            pixels: 0,
            band: None,
            drew: false,
            measured: None,
            refining: stream.refining,
        };
        for (index, kind) in kinds.into_iter().enumerate() {
            self.draw_pane(index, kind, &frame, scene, &mut drawing)?;
        }
        let work = drawing.work();
        let FrameDrawing {
            recorder: PassRecorder { encoder, .. },
            drew,
            measured,
            refining,
            ..
        } = drawing;
        drop(egui_renderer);
        if drew {
            self.pacer.submit(context, encoder, work, ctx);
            if measured.is_some()
                && let Some(probe) = self.frame_probe.as_mut()
            {
                probe.submitted();
                self.measuring = measured;
            }
        }
        self.after_submission(gpu, scene, stream.status, drew);
        self.refining = refining;
        let unfinished = self
            .panes
            .iter()
            .any(|pane| pane.banding.is_some() || pane.preview.is_some());
        Ok(if self.pacer.is_in_flight() {
            Some(IN_FLIGHT_POLL)
        } else if (refining && stream.changed) || unfinished {
            Some(Duration::ZERO)
        } else {
            None
        })
    }

    /// A band's time counts to its pane's frame (what the panel says a frame costs).
    fn count_finished_band(&mut self) {
        if let Some((Work::Band { pane, .. }, took)) = self.pacer.take_finished()
            && let Some(spent) = self.band_time.get_mut(pane)
        {
            *spent += took;
        }
    }

    /// Lets the streaming renderer take in what earlier frames' rays asked for and upload
    /// within its budget (it never waits on I/O or the GPU), and says one line for the first
    /// brick of each cause that failed (the panel lists every one).
    fn update_stream(&self, context: &GpuContext, scene: &mut Scene) -> StreamUpdate {
        let status = scene.renderer.update(context);
        let refining = status.as_ref().is_some_and(|s| {
            !s.complete
                || s.uploads > 0
                || s.filling > 0
                || s.judged_frame
                    .is_none_or(|judged| judged < self.stream_view_frame)
        });
        // Only a changed page table can make a frame differ from the last one drawn: while
        // bricks are being fetched and nothing arrived, the panes are not drawn again (the
        // streamer still takes in readbacks and results at every update).
        let changed = status
            .as_ref()
            .is_some_and(|s| s.uploads > 0 || s.table_changed);
        if let Some(status) = &status {
            for error in &status.errors {
                eprintln!("voxscope: {error}");
            }
        }
        StreamUpdate {
            status,
            refining,
            changed,
        }
    }

    /// The frame budget: the small one while input came lately (input waits at most that),
    /// the larger one after a pause.
    fn frame_budget(&mut self, ctx: &egui::Context) -> Duration {
        if ctx.input(|i| !i.events.is_empty() || i.pointer.is_moving() || i.pointer.any_down()) {
            self.last_input = Instant::now();
        }
        if self.last_input.elapsed() >= IDLE_AFTER {
            IDLE_BUDGET
        } else {
            FRAME_BUDGET
        }
    }

    /// Draws pane `index` of `kind` into `drawing` where it is out of date: a slice whole, a
    /// 3D view as much of it as fits the budget left (`volume_work.rs`).
    fn draw_pane(
        &mut self,
        index: usize,
        kind: PaneKind,
        frame: &FrameInputs<'_>,
        scene: &mut Scene,
        drawing: &mut FrameDrawing<'_>,
    ) -> Result<(), RenderError> {
        let (Some(pane), Some(rect)) = (self.panes.get_mut(index), self.pane_rects.get(index))
        else {
            return Ok(());
        };
        let Some(target) = pane.target() else {
            return Ok(());
        };
        let size = [target.width, target.height];
        match kind {
            PaneKind::Volume => {
                let view = frame.volume_view(index, size);
                self.draw_volume_pane(index, view, frame, scene, drawing)
            }
            PaneKind::Slice(axis) => {
                let key = frame.slice_key(scene, axis, *rect, size);
                draw_slice_pane(pane, key, scene, drawing);
                Ok(())
            }
        }
    }

    /// After the submission: the picking probe, the frame rate's clock, the stream's status
    /// and the network's figures for the panels.
    fn after_submission(
        &mut self,
        gpu: &AppGpu,
        scene: &mut Scene,
        stream: Option<StreamStatus>,
        drew: bool,
    ) {
        if let Some(picking) = self.picking.as_mut() {
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
            .streamer()
            .and_then(|s| s.source().remote_stats())
        {
            scene.network = Some(NetworkState::follow(scene.network, stats));
        }
    }
}

impl PaneLooks {
    /// The view's transfer functions under its window. The composite's tables follow the
    /// channel list's edits (no reload); their generation tells the panes drawn with older
    /// tables.
    fn apply(
        context: &GpuContext,
        scene: &mut Scene,
        settings: &AppSettings,
        view: &ViewState,
    ) -> Self {
        let main = settings.transfer.with_window(view.window);
        let compare = settings.compare_transfer.with_window(view.window);
        let composite_channels = view.composite_channels(main);
        let layers = match &mut scene.composite {
            // A channel list of another length (a scene being replaced) leaves the tables.
            Some(composite) => composite
                .apply(context, &scene.renderer, &composite_channels)
                .unwrap_or_else(|_| composite.generation()),
            None => 0,
        };
        // With the composite shown the slices are channel 0's (the renderer of one channel).
        let slices = match (&scene.composite, composite_channels.first()) {
            (Some(_), Some(first)) => first.transfer,
            _ => main,
        };
        PaneLooks {
            main,
            compare,
            slices,
            layers,
        }
    }
}

impl FrameInputs<'_> {
    /// What 3D pane `index` of `size` pixels shows: the level grid's panes each at their own
    /// level, the transfer pair's second with the compared transfer function.
    fn volume_view(&self, index: usize, size: [u32; 2]) -> VolumeView {
        let (settings, view, looks) = (self.settings, self.view, &self.looks);
        let (level, transfer) = match settings.layout {
            Layout::LevelGrid => (view.grid_level(index, self.panes, self.depth), looks.main),
            Layout::TransferPair if index == 1 => (view.max_level.min(self.depth), looks.compare),
            _ => (view.max_level.min(self.depth), looks.main),
        };
        let camera = settings.camera;
        let render_settings = settings.render_settings(level, view.clipping.clip());
        let key = DrawKey::Volume {
            size,
            camera,
            settings: render_settings,
            transfer,
            scene: self.serial,
            layers: looks.layers,
        };
        VolumeView {
            key,
            size,
            camera,
            settings: render_settings,
            transfer,
            level,
        }
    }

    /// What the slice pane across `axis`, laid out at `rect`, of `size` pixels shows: the
    /// slice through the cursor.
    fn slice_key(&self, scene: &Scene, axis: usize, rect: Rect, size: [u32; 2]) -> DrawKey {
        let mut slice_view = self.view.slice_views[axis];
        slice_view.index = self.view.cursor_voxel(scene.data.volume.dims)[axis];
        let (frame, _) = slice_pane::frame(scene, &slice_view, rect, size);
        let transfer = self.looks.slices;
        DrawKey::Slice {
            settings: SliceSettings {
                frame,
                window: transfer.window,
                colormap: transfer.colormap,
                nearest: !self.settings.slice_linear,
            },
            size,
            scene: self.serial,
        }
    }
}

/// Draws a slice pane whole where it does not show `key`: slices cost a sample a pixel, so
/// they are drawn outside the budget.
fn draw_slice_pane(pane: &mut Pane, key: DrawKey, scene: &Scene, drawing: &mut FrameDrawing<'_>) {
    if pane.shows(&key) {
        return;
    }
    if let (
        DrawKey::Slice {
            settings: slice_settings,
            ..
        },
        Some(target),
    ) = (&key, pane.target())
    {
        let recorder = &mut drawing.recorder;
        scene.renderer.encode_slice(
            recorder.context,
            &mut recorder.encoder,
            target,
            slice_settings,
        );
    }
    pane.drawn = Some(key);
    pane.preview = None;
    drawing.drew = true;
}
