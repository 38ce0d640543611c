//! The central view: its panes laid out for the chosen [`Layout`], each a render target drawn
//! again only when what it shows changed, paced so that the device is never given more than
//! it finishes in a UI frame (`central/pacing.rs`, `central/draw.rs`,
//! `central/volume_work.rs`); the strips above the panes (the level grid's pane count, the
//! transfer pair's B), the pane labels, the orientation gizmo, and the measured cost of the
//! last frame.

use std::time::Instant;

use egui::{Align2, Color32, Rect, Ui, UiBuilder, vec2};

use super::AppGpu;
use super::overlays::{draw_axis_gizmo, draw_rulers, paint_overlays_3d};
use super::pane_header::{grid_strip, pair_strip, pane_label};
use super::picking::Picking;
use super::settings::{AppSettings, Layout, Tool};
use super::slice_pane::{self, SlicePane};
use super::view_state::{MAX_GRID_PANES, ViewState};
use super::viewport::{self, DrawKey};
use voxscope_scene::Scene;

mod draw;
mod frame;
mod pacing;
mod pane;
mod volume_work;
use pacing::FramePacer;
use pane::Pane;
use voxscope_render::{FrameProbe, FrameReport, SliceConvention, read_image};

/// Height of the strip of controls above the panes of the level grid and the transfer pair.
const STRIP_HEIGHT: f32 = 30.0;

/// Points between panes.
const PANE_GAP: f32 = 2.0;

/// The central view's panes and what it measured of their drawing.
pub struct CentralView {
    panes: Vec<Pane>,
    /// Where the panes were laid out last frame, in points, and the whole view.
    pane_rects: Vec<Rect>,
    view_rect: Rect,
    /// Times a pass of each submission and counts its nodes per ray.
    frame_probe: Option<FrameProbe>,
    /// The pass the frame probe measures now.
    measuring: Option<Measured>,
    /// The pass of the last report that completed an image (what the panel's numbers are of).
    last_measured: Option<Measured>,
    /// Bands the last full image drawn in bands took (0: drawn whole).
    last_bands: u32,
    /// Per pane, the wall time its current (or last) full image's bands took on the device.
    band_time: Vec<std::time::Duration>,
    /// What the device is doing, and what a pixel costs.
    pacer: FramePacer,
    /// When input last came (the frame budget is larger after a pause).
    last_input: Instant,
    /// Finds the 3D point under the pointer in a 3D pane.
    picking: Option<Picking>,
    last_report: Option<FrameReport>,
    /// When frames were drawn in the last second (frame rate while drawing continuously).
    draw_times: Vec<Instant>,
    /// True while the camera is being moved (drag or wheel), as of the last frame.
    interacting: bool,
    /// The scene serial whose first drawing was logged.
    logged_scene: u64,
    /// The voxel under the pointer in a slice view, as of the last frame.
    hovered_voxel: Option<[usize; 3]>,
    /// The streaming renderer's frame that first drew the current view: its completeness is
    /// judged on a frame read back from then on.
    stream_view_frame: u32,
    /// The streaming renderer wanted another frame, as of the last draw.
    refining: bool,
}

/// A pass the frame probe measured: which pane (of how many), at which level, how many pixels
/// of how many, and whether it completed the pane's image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The scene drawn (its serial): a report of the volume before an open is not this one's.
    pub scene: u64,
    pub pane: usize,
    pub panes: usize,
    /// The pane's max level (a 3D pane).
    pub level: Option<u32>,
    pub pixels: u64,
    pub complete: bool,
    /// The pane's full image's pixels.
    pub full_pixels: u64,
}

/// What the Octree panel says of the last frame: the probe's report, the pane it measured,
/// and its GPU time per whole frame (estimated from a band's where it was drawn in bands).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameFacts {
    pub report: FrameReport,
    pub measured: Measured,
    pub frame_ms: Option<f64>,
    /// Bands the frame took (0: drawn whole).
    pub bands: u32,
}

/// What a frame of the central view reads and edits.
pub struct ViewInputs<'a> {
    pub gpu: Option<&'a AppGpu>,
    pub scene: Option<&'a Scene>,
    pub settings: &'a mut AppSettings,
    pub view: &'a mut ViewState,
    /// A volume is being opened (the empty view says "Loading…").
    pub opening: bool,
}

impl CentralView {
    /// An empty view on `gpu` (measuring frames and picking points where there is one).
    pub fn new(gpu: Option<&AppGpu>) -> Self {
        Self {
            panes: Vec::new(),
            pane_rects: Vec::new(),
            view_rect: Rect::NOTHING,
            frame_probe: gpu.map(|gpu| FrameProbe::new(&gpu.context)),
            measuring: None,
            last_measured: None,
            last_bands: 0,
            band_time: Vec::new(),
            pacer: FramePacer::default(),
            last_input: Instant::now(),
            picking: gpu.map(Picking::new),
            last_report: None,
            draw_times: Vec::new(),
            interacting: false,
            logged_scene: 0,
            hovered_voxel: None,
            stream_view_frame: 0,
            refining: false,
        }
    }

    /// The whole central view's rect, in points, as laid out last frame.
    pub fn rect(&self) -> Rect {
        self.view_rect
    }

    /// Where the panes were laid out last frame, in points, in reading order.
    pub fn pane_rects(&self) -> &[Rect] {
        &self.pane_rects
    }

    /// Pixel sizes of the images the panes show (a preview's while a slow frame is drawn).
    pub fn pane_sizes(&self) -> Vec<[u32; 2]> {
        self.panes
            .iter()
            .filter_map(|p| p.shown().map(|s| [s.target.width, s.target.height]))
            .collect()
    }

    /// Whether every 3D pane shows the scene `serial` at full resolution, its drawing handed
    /// to the device (what a time series' playback waits for before the next frame).
    pub fn shows_scene(&self, serial: u64) -> bool {
        !self.pacer.is_in_flight()
            && self.panes.iter().all(|pane| match pane.drawn {
                Some(DrawKey::Volume { scene, .. }) => scene == serial && pane.preview.is_none(),
                Some(DrawKey::Slice { .. }) => true,
                None => false,
            })
    }

    /// True while a frame is on the device or a pane's full image is still being drawn.
    pub fn is_drawing(&self) -> bool {
        self.pacer.is_in_flight()
            || self
                .panes
                .iter()
                .any(|pane| pane.banding.is_some() || pane.preview.is_some())
    }

    /// The voxel under the pointer, as of the last frame: in a slice view, or where a 3D
    /// view's ray under it reaches half opacity (the maximum, in MIP), as last picked.
    pub fn hovered_voxel(&self, dims: [usize; 3]) -> Option<[usize; 3]> {
        self.hovered_voxel.or_else(|| {
            let point = self.picking.as_ref()?.hovered()?;
            Some(std::array::from_fn(|a| {
                (point[a].max(0.0) as usize).min(dims[a].saturating_sub(1))
            }))
        })
    }

    /// The last measured frame.
    pub fn frame_report(&self) -> Option<FrameReport> {
        self.last_report
    }

    /// The last measured frame of scene `serial` with the pane it was measured on; `None`
    /// until a frame of that scene was measured (the volume before an open has other numbers).
    pub fn frame_facts(&self, serial: u64) -> Option<FrameFacts> {
        let (report, measured) = (self.last_report?, self.last_measured?);
        if measured.scene != serial {
            return None;
        }
        let frame_ms = if self.last_bands > 0 {
            self.band_time
                .get(measured.pane)
                .map(|spent| spent.as_secs_f64() * 1e3)
        } else {
            report.gpu_ms
        };
        Some(FrameFacts {
            report,
            measured,
            frame_ms,
            bands: self.last_bands,
        })
    }

    /// Bytes of the panes' render targets (previews included).
    pub fn target_bytes(&self) -> u64 {
        self.panes
            .iter()
            .flat_map(|p| {
                [
                    p.target(),
                    p.preview.as_ref().map(|preview| &preview.image.target),
                ]
            })
            .flatten()
            .map(|t| t.gpu_bytes())
            .sum()
    }

    /// True while a frame's measurement or a picked point is on its way back from the GPU, or
    /// a frame is being drawn.
    pub fn is_measuring(&self) -> bool {
        self.is_drawing()
            || self.frame_probe.as_ref().is_some_and(|p| !p.is_idle())
            || self.picking.as_ref().is_some_and(Picking::is_busy)
    }

    /// Whether the streaming renderer was still refining the view at the last draw.
    pub fn is_refining(&self) -> bool {
        self.refining
    }

    /// Takes what the GPU has delivered since the last frame: an earlier frame's measurement,
    /// and a picked point, which for a click moves the cursor (or, with the Ruler tool, ends
    /// or starts a ruler in `view`). `scale` takes the renderer's voxel space to the view's
    /// ([`Scene::voxel_scale`]).
    pub fn poll(&mut self, gpu: &AppGpu, view: &mut ViewState, tool: Tool, scale: [f64; 3]) {
        if let Some(report) = self.frame_probe.as_mut().and_then(|p| p.poll(&gpu.context))
            && let Some(measured) = self.measuring.take()
        {
            // The panel's numbers are of whole images (a band's visits are partly stale).
            if measured.complete {
                self.last_report = Some(report);
                self.last_measured = Some(measured);
            }
        }
        if let Some(picking) = &mut self.picking {
            picking.poll(gpu, view, tool, scale);
        }
    }

    /// Frames per second over the last second, while drawing every frame.
    pub fn fps(&self, continuous: bool) -> Option<f64> {
        let (first, last) = (self.draw_times.first()?, self.draw_times.last()?);
        (continuous && self.draw_times.len() >= 2).then(|| {
            let span = last.duration_since(*first).as_secs_f64().max(1e-6);
            (self.draw_times.len() - 1) as f64 / span
        })
    }

    /// Lays out the panes, paints their last images and takes the camera input.
    pub fn ui(&mut self, ui: &mut Ui, inputs: ViewInputs<'_>) {
        let ViewInputs {
            gpu,
            scene,
            settings,
            view,
            opening,
        } = inputs;
        let view_rect = ui.available_rect_before_wrap();
        self.view_rect = view_rect;
        ui.painter()
            .rect_filled(view_rect, 0.0, Color32::from_gray(12));
        let kinds = pane_kinds(settings);
        let count = kinds.len();
        let mut area = view_rect;
        if matches!(settings.layout, Layout::LevelGrid | Layout::TransferPair) {
            let strip = Rect::from_min_size(area.min, vec2(area.width(), STRIP_HEIGHT - 2.0));
            area.min.y += STRIP_HEIGHT;
            ui.scope_builder(
                UiBuilder::new().max_rect(strip.shrink2(vec2(6.0, 2.0))),
                |ui| {
                    ui.horizontal(|ui| match settings.layout {
                        Layout::LevelGrid => {
                            grid_strip(ui, settings, view, scene.map_or(0, Scene::depth))
                        }
                        _ => pair_strip(ui, settings, view.window),
                    });
                },
            );
        }
        let rects = grid_rects(area, count, PANE_GAP);
        self.pane_rects = rects.clone();
        if let Some(gpu) = gpu {
            self.fit_targets(gpu, scene.is_some(), &rects, ui.ctx().pixels_per_point());
        }

        let was_interacting = self.interacting;
        self.interacting = false;
        self.hovered_voxel = None;
        let mut volume_hovered = false;
        for (index, (rect, kind)) in rects.iter().zip(&kinds).enumerate() {
            let response = ui
                .scope_builder(UiBuilder::new().max_rect(*rect), |ui| {
                    viewport::allocate_pane(ui, rect.size())
                })
                .inner;
            let Some(scene) = scene else { continue };
            self.panes[index].paint(ui, *rect);
            match *kind {
                PaneKind::Volume => {
                    let extent = scene.data.volume.extent();
                    let moved =
                        viewport::control_camera(&mut settings.camera, &response, ui, extent);
                    self.interacting |= moved || response.dragged();
                    volume_hovered |= response.hovered();
                    let target = self.panes[index].target().map(|t| [t.width, t.height]);
                    if let (Some(picking), Some(target)) = (&mut self.picking, target) {
                        picking.want(&response, ui, index, *rect, target);
                    }
                    pane_label(ui, scene, settings, view, index, count, *rect);
                    paint_overlays_3d(ui, *rect, scene, settings, view);
                }
                PaneKind::Slice(axis) => {
                    let target = self.panes[index]
                        .target()
                        .map_or([1, 1], |t| [t.width, t.height]);
                    let pane = SlicePane {
                        axis,
                        rect: *rect,
                        target,
                    };
                    if let Some(voxel) =
                        slice_pane::interact(ui, &response, &pane, scene, settings, view)
                    {
                        self.hovered_voxel = Some(voxel);
                    }
                    if !scene.renderer.has_slices() {
                        ui.painter().text(
                            rect.center(),
                            egui::Align2::CENTER_CENTER,
                            "Slices come from the in-memory renderers:\nchoose octree, dense or bricks",
                            egui::FontId::proportional(13.0),
                            egui::Color32::from_gray(200),
                        );
                    }
                }
            }
        }
        if !volume_hovered && let Some(picking) = &mut self.picking {
            picking.clear_hover();
        }
        if was_interacting && !self.interacting {
            // Motion ended: one more frame draws the full-resolution image.
            ui.ctx().request_repaint();
        }
        if let (Some(scene), Some(rect)) = (scene, rects.first()) {
            viewport::paint_axis_gizmo(ui, *rect, &settings.camera, axis_labels(scene));
        }
        if scene.is_none() {
            let text = if opening {
                "Loading…"
            } else {
                "Open a volume: File > Open…, or drop a file here"
            };
            ui.painter().text(
                view_rect.center(),
                Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(18.0),
                Color32::GRAY,
            );
        }
        if ui.ctx().input(|i| !i.raw.hovered_files.is_empty()) {
            ui.painter()
                .rect_filled(view_rect, 0.0, Color32::from_black_alpha(160));
            ui.painter().text(
                view_rect.center(),
                Align2::CENTER_CENTER,
                "Drop to open",
                egui::FontId::proportional(24.0),
                Color32::WHITE,
            );
        }
    }

    /// Gives every pane a target of its rect's pixel size (a slow device shows a smaller
    /// preview meanwhile: `central/draw.rs`), and drops the panes the layout no longer has.
    fn fit_targets(
        &mut self,
        gpu: &AppGpu,
        has_scene: bool,
        rects: &[Rect],
        pixels_per_point: f32,
    ) {
        let mut egui_renderer = gpu.render_state.renderer.write();
        while self.panes.len() > rects.len() {
            if let Some(mut pane) = self.panes.pop() {
                pane.release(&mut egui_renderer);
            }
        }
        self.panes.resize_with(rects.len(), Pane::default);
        if has_scene {
            for (pane, rect) in self.panes.iter_mut().zip(rects) {
                pane.ensure_size(
                    &gpu.context,
                    &mut egui_renderer,
                    viewport::pixel_size(*rect, pixels_per_point),
                );
            }
        }
    }

    /// What is drawn: the panes' images composed as laid out, at full pixel resolution, with
    /// the rulers (and their lengths) drawn in.
    pub fn image(
        &self,
        gpu: &AppGpu,
        pixels_per_point: f32,
        scene: Option<&Scene>,
        view: &ViewState,
        with_gizmo: bool,
    ) -> Result<image::RgbaImage, String> {
        let size = viewport::pixel_size(self.view_rect, pixels_per_point);
        let mut canvas =
            image::RgbaImage::from_pixel(size[0], size[1], image::Rgba([0, 0, 0, 255]));
        let mut any = false;
        for (pane, rect) in self.panes.iter().zip(&self.pane_rects) {
            let (Some(target), Some(drawn)) = (pane.target(), pane.drawn) else {
                continue;
            };
            let image = read_image(&gpu.context, target).map_err(|e| e.to_string())?;
            let offset = (rect.min - self.view_rect.min) * pixels_per_point;
            image::imageops::overlay(
                &mut canvas,
                &image,
                offset.x.round() as i64,
                offset.y.round() as i64,
            );
            if let Some(scene) = scene {
                let in_canvas = Rect::from_min_size(
                    offset.to_pos2(),
                    vec2(target.width as f32, target.height as f32),
                );
                draw_rulers(&mut canvas, in_canvas, &drawn, scene, view);
                // The window paints the gizmo over the first pane.
                if let (true, false, DrawKey::Volume { camera, .. }) = (with_gizmo, any, drawn) {
                    draw_axis_gizmo(
                        &mut canvas,
                        in_canvas,
                        &camera,
                        axis_labels(scene),
                        pixels_per_point,
                    );
                }
            }
            any = true;
        }
        if !any {
            return Err("nothing is drawn yet".into());
        }
        Ok(canvas)
    }
}

/// What a pane of the central view shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaneKind {
    /// The volume in 3D.
    Volume,
    /// The slice across this axis (0, 1, 2: x, y, z) through the cursor.
    Slice(usize),
}

/// The panes of the layout, in reading order: one 3D view; the level grid's 2–6; the pair's
/// two; or the 3D view beside the axial, coronal and sagittal slices (3D Slicer's four-up).
pub fn pane_kinds(settings: &AppSettings) -> Vec<PaneKind> {
    match settings.layout {
        Layout::Single => vec![PaneKind::Volume],
        Layout::LevelGrid => {
            vec![PaneKind::Volume; settings.grid_panes.clamp(2, MAX_GRID_PANES)]
        }
        Layout::TransferPair => vec![PaneKind::Volume; 2],
        Layout::Slices => vec![
            PaneKind::Volume,
            PaneKind::Slice(2),
            PaneKind::Slice(1),
            PaneKind::Slice(0),
        ],
    }
}

/// The gizmo's names for +x, +y, +z: `R A S` for patient data (the slices' rule).
pub fn axis_labels(scene: &Scene) -> [&'static str; 3] {
    match SliceConvention::of_volume(&scene.data.volume) {
        SliceConvention::Radiological => ["R", "A", "S"],
        SliceConvention::Image => ["x", "y", "z"],
    }
}

/// `count` panes over `area`, in as square a grid as fits, `gap` points apart.
fn grid_rects(area: Rect, count: usize, gap: f32) -> Vec<Rect> {
    let count = count.max(1);
    let columns = if area.width() >= area.height() {
        (count as f32).sqrt().ceil() as usize
    } else {
        count.div_ceil((count as f32).sqrt().ceil() as usize)
    }
    .max(1);
    let columns = if count <= 3 && area.width() >= area.height() {
        count
    } else {
        columns
    };
    let rows = count.div_ceil(columns);
    let width = (area.width() - gap * (columns - 1) as f32) / columns as f32;
    let height = (area.height() - gap * (rows - 1) as f32) / rows as f32;
    (0..count)
        .map(|i| {
            let (column, row) = (i % columns, i / columns);
            Rect::from_min_size(
                area.min + vec2(column as f32 * (width + gap), row as f32 * (height + gap)),
                vec2(width.max(1.0), height.max(1.0)),
            )
        })
        .collect()
}
