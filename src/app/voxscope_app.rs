//! The app: menu bar, transfer-function and octree panels, the central view (single, level
//! grid or transfer pair), background loading, persistence.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use egui::{Align2, Color32, Rect, RichText, Ui, UiBuilder, vec2};

use super::octree_panel::{self, OctreeFacts};
use super::scene::{self, Job, Scene, VolumeSource, prepare_scene};
use super::settings::{AppSettings, Layout, STORAGE_KEY, TransferChoice, TransferPreset};
use super::transfer_panel;
use super::viewport::{self, DrawKey, Pane};
use crate::octree::{LevelStatistics, OpacityMode, TransferFunction};
use crate::render::{
    FrameProbe, FrameReport, GpuContext, RenderSettings, RendererOptions, read_image,
};
use crate::volume::{Orientation, ValueWindow};

/// The file extensions File ▸ Open offers.
pub const OPEN_EXTENSIONS: [&str; 12] = [
    "nii", "gz", "nrrd", "nhdr", "tif", "tiff", "mrc", "map", "rec", "ccp4", "dcm", "vti",
];

/// The GPU as the app shares it with egui-wgpu.
struct AppGpu {
    context: Arc<GpuContext>,
    render_state: egui_wgpu::RenderState,
}

/// A file dialog running on its own thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DialogKind {
    Open,
    OpenFolder,
    SaveScreenshot,
    SaveTransfer,
    LoadTransfer,
}

/// What a file dialog answered (`None`: nothing chosen) and how long it was open.
type DialogAnswer = (Option<PathBuf>, Duration);

/// The voxscope window.
pub struct VoxscopeApp {
    pub settings: AppSettings,
    gpu: Option<AppGpu>,
    scene: Option<Scene>,
    /// Bumped for every new scene, so panes redraw.
    scene_serial: u64,
    /// The value window of the current volume (data units).
    pub window: ValueWindow,
    /// Deepest level drawn in the single and pair views.
    pub max_level: u32,
    /// One level per pane of the level grid.
    pub grid_levels: Vec<u32>,
    statistics: Vec<LevelStatistics>,
    statistics_for: Option<TransferFunction>,
    statistics_job: Option<Job<(TransferFunction, Vec<LevelStatistics>)>>,
    loading: Option<Job<(Scene, Vec<LevelStatistics>)>>,
    uploading: Option<(RendererOptions, Job<Scene>)>,
    /// The last failure, shown until dismissed.
    error: Option<String>,
    /// A short confirmation (screenshot saved), shown a few seconds.
    notice: Option<(String, Instant)>,
    panes: Vec<Pane>,
    /// Where the panes were laid out last frame, in points, and the central rect.
    pane_rects: Vec<Rect>,
    view_rect: Rect,
    probe: Option<FrameProbe>,
    last_report: Option<FrameReport>,
    draw_times: Vec<Instant>,
    dialog: Option<(DialogKind, Receiver<DialogAnswer>)>,
    /// The text of File ▸ Open path.
    path_text: String,
    /// The scene serial whose first drawing was logged.
    logged_scene: u64,
    /// True while the camera is being moved (drag or wheel), as of the last frame.
    interacting: bool,
}

impl VoxscopeApp {
    /// The app in `cc`'s window, opening `source` (the sample when `None`).
    pub fn new(cc: &eframe::CreationContext<'_>, source: Option<VolumeSource>) -> Self {
        let settings: AppSettings = cc
            .storage
            .and_then(|storage| eframe::get_value(storage, STORAGE_KEY))
            .unwrap_or_default();
        let gpu = cc.wgpu_render_state.as_ref().map(|state| AppGpu {
            context: Arc::new(GpuContext::from_device(
                state.device.clone(),
                state.queue.clone(),
                state.adapter.get_info(),
            )),
            render_state: state.clone(),
        });
        let probe = gpu.as_ref().map(|gpu| FrameProbe::new(&gpu.context));
        let mut app = Self {
            settings,
            gpu,
            scene: None,
            scene_serial: 0,
            window: ValueWindow {
                low: 0.0,
                high: 1.0,
            },
            max_level: 0,
            grid_levels: Vec::new(),
            statistics: Vec::new(),
            statistics_for: None,
            statistics_job: None,
            loading: None,
            uploading: None,
            error: None,
            notice: None,
            panes: Vec::new(),
            pane_rects: Vec::new(),
            view_rect: Rect::NOTHING,
            probe,
            last_report: None,
            draw_times: Vec::new(),
            dialog: None,
            path_text: String::new(),
            logged_scene: 0,
            interacting: false,
        };
        if app.gpu.is_none() {
            app.fail(
                "voxscope needs the wgpu renderer; no GPU device was handed to the app".into(),
            );
        } else {
            app.open(source.unwrap_or(VolumeSource::Sample), &cc.egui_ctx);
        }
        app
    }

    /// Opens `source` in the background; the current volume stays until it is ready. The one
    /// path of File ▸ Open, Open recent, Open sample, drops and the command line.
    pub fn open(&mut self, source: VolumeSource, ctx: &egui::Context) {
        let Some(gpu) = &self.gpu else {
            self.fail("no GPU device".into());
            return;
        };
        if let Some(job) = self.loading.take() {
            job.progress.cancel();
        }
        let context = Arc::clone(&gpu.context);
        let choice = self.settings.transfer;
        let options = self.renderer_options();
        let wake_ctx = ctx.clone();
        let title = format!("opening {}", source.spec());
        self.loading = Some(Job::spawn(
            title,
            move || wake_ctx.request_repaint(),
            move |progress| {
                prepare_scene(
                    &source,
                    |window| choice.with_window(window),
                    &context,
                    options,
                    progress,
                )
            },
        ));
    }

    /// True while a volume loads, a renderer uploads or statistics are counted.
    pub fn is_busy(&self) -> bool {
        self.loading.is_some()
            || self.uploading.is_some()
            || self.statistics_job.is_some()
            || self.dialog.is_some()
            || self.probe.as_ref().is_some_and(|p| !p.is_idle())
    }

    /// The error shown in the window, if any.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// The name of the volume on screen and its octree depth.
    pub fn volume(&self) -> Option<(&str, u32)> {
        self.scene
            .as_ref()
            .map(|s| (s.data.volume.name.as_str(), s.data.octree.depth))
    }

    /// Pixel sizes of the panes' render targets.
    pub fn pane_sizes(&self) -> Vec<[u32; 2]> {
        self.panes
            .iter()
            .filter_map(|p| p.target.as_ref().map(|t| [t.width, t.height]))
            .collect()
    }

    /// The renderer drawing the volume on screen.
    pub fn renderer_kind(&self) -> Option<crate::render::RendererKind> {
        self.scene.as_ref().map(|s| s.options.kind)
    }

    /// The statistics panel's per-level numbers.
    pub fn statistics(&self) -> &[LevelStatistics] {
        &self.statistics
    }

    /// The last frame's measured cost.
    pub fn frame_report(&self) -> Option<FrameReport> {
        self.last_report
    }

    /// The transfer function of the main view.
    pub fn transfer(&self) -> TransferFunction {
        self.settings.transfer.with_window(self.window)
    }

    fn renderer_options(&self) -> RendererOptions {
        RendererOptions {
            kind: self.settings.renderer,
            brick_size: self.settings.brick_size,
        }
    }

    fn fail(&mut self, message: String) {
        eprintln!("voxscope: error: {message}");
        self.error = Some(message);
    }

    /// What is drawn: the panes' images composed as laid out, at full pixel resolution.
    pub fn view_image(&self, pixels_per_point: f32) -> Result<image::RgbaImage, String> {
        let gpu = self.gpu.as_ref().ok_or("no GPU device")?;
        let size = viewport::pixel_size(self.view_rect, pixels_per_point);
        let mut canvas =
            image::RgbaImage::from_pixel(size[0], size[1], image::Rgba([0, 0, 0, 255]));
        let mut any = false;
        for (pane, rect) in self.panes.iter().zip(&self.pane_rects) {
            let (Some(target), Some(_)) = (&pane.target, pane.drawn) else {
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
            any = true;
        }
        if !any {
            return Err("nothing is drawn yet".into());
        }
        Ok(canvas)
    }

    /// Saves [`Self::view_image`] as PNG.
    pub fn save_screenshot(&self, path: &Path, pixels_per_point: f32) -> Result<(), String> {
        let image = self.view_image(pixels_per_point)?;
        image
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| format!("{}: cannot write the screenshot: {e}", path.display()))
    }

    /// Writes the transfer function, opacity scale and mode as RON.
    pub fn save_transfer(&self, path: &Path) -> Result<(), String> {
        let preset = TransferPreset {
            transfer: self.transfer(),
            density: self.settings.density,
            mode: self.settings.mode,
        };
        let text = ron::ser::to_string_pretty(&preset, ron::ser::PrettyConfig::default())
            .map_err(|e| format!("{}: cannot encode: {e}", path.display()))?;
        std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))
    }

    /// Reads a transfer function saved by [`Self::save_transfer`].
    pub fn load_transfer(&mut self, path: &Path) -> Result<(), String> {
        let metadata = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
        if metadata.len() > 1 << 20 {
            return Err(format!(
                "{}: {} bytes is too large for a transfer function",
                path.display(),
                metadata.len()
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let preset: TransferPreset = ron::from_str(&text).map_err(|e| {
            format!(
                "{}: not a voxscope transfer function: {}",
                path.display(),
                e.to_string().lines().next().unwrap_or_default()
            )
        })?;
        let window = preset.transfer.window;
        let valid = window.low.is_finite()
            && window.high.is_finite()
            && window.high > window.low
            && (0.0..=1.0).contains(&preset.transfer.threshold)
            && preset.density > 0.0
            && preset.density <= 1.0;
        if !valid {
            return Err(format!(
                "{}: the window, threshold or opacity scale is out of range",
                path.display()
            ));
        }
        self.settings.transfer = TransferChoice::from(preset.transfer);
        self.window = window;
        self.settings.density = preset.density;
        self.settings.mode = preset.mode;
        Ok(())
    }

    /// Takes finished background work.
    fn poll_jobs(&mut self, ctx: &egui::Context) {
        if let Some(result) = self.loading.as_ref().and_then(|job| job.try_take()) {
            self.loading = None;
            match result {
                Ok((scene, statistics)) => {
                    if scene.options.kind != self.settings.renderer {
                        self.notice = Some((
                            format!(
                                "the octree does not fit this GPU's buffers; showing it with the {} renderer",
                                scene.options.kind.name()
                            ),
                            Instant::now(),
                        ));
                        self.settings.renderer = scene.options.kind;
                    }
                    self.show_scene(scene, statistics)
                }
                Err(message) if message == "cancelled" => {
                    self.notice = Some(("opening cancelled".into(), Instant::now()));
                }
                Err(message) => self.fail(message),
            }
        }
        if let Some(result) = self.uploading.as_ref().and_then(|(_, job)| job.try_take()) {
            self.uploading = None;
            match result {
                Ok(scene) => {
                    self.scene = Some(scene);
                    self.scene_serial += 1;
                }
                Err(message) => {
                    // Back to the renderer on screen, or the switch would be retried forever.
                    if let Some(scene) = &self.scene {
                        self.settings.renderer = scene.options.kind;
                        self.settings.brick_size = scene.options.brick_size;
                    }
                    self.fail(message);
                }
            }
        }
        if let Some(result) = self.statistics_job.as_ref().and_then(|job| job.try_take()) {
            self.statistics_job = None;
            if let Ok((transfer, statistics)) = result {
                self.statistics = statistics;
                self.statistics_for = Some(transfer);
            }
        }
        if let (Some(probe), Some(gpu)) = (&mut self.probe, &self.gpu)
            && let Some(report) = probe.poll(&gpu.context)
        {
            self.last_report = Some(report);
        }
        if let Some((_, receiver)) = &self.dialog
            && let Ok((path, open_for)) = receiver.try_recv()
        {
            let (kind, _) = self.dialog.take().expect("checked above");
            match path {
                Some(path) => self.dialog_done(kind, path, ctx),
                // Nobody cancels a dialog this fast: none could be shown.
                None if open_for < Duration::from_millis(300) => {
                    self.fail("no file dialog could be shown (is xdg-desktop-portal running?); type a path in File ▸ Open path, or drop the file on the window".into());
                }
                None => {}
            }
        }
        if self.is_busy() {
            ctx.request_repaint_after(Duration::from_millis(50));
        }
    }

    fn show_scene(&mut self, scene: Scene, statistics: Vec<LevelStatistics>) {
        let depth = scene.data.octree.depth;
        self.window = scene.applied_transfer.window;
        self.max_level = depth;
        self.grid_levels = default_grid_levels(depth);
        self.statistics_for = Some(scene.applied_transfer);
        self.statistics = statistics;
        if let VolumeSource::Spec(spec) = &scene.data.source {
            self.settings.remember(spec);
        }
        self.settings.camera.pan = [0.0; 3];
        eprintln!(
            "voxscope: opened {} ({}x{}x{}, octree depth {}, {} nodes) in {:.2} s",
            scene.data.volume.name,
            scene.data.volume.dims[0],
            scene.data.volume.dims[1],
            scene.data.volume.dims[2],
            depth,
            scene.data.octree.nodes.len(),
            scene.data.load_seconds + scene.upload_seconds,
        );
        self.scene = Some(scene);
        self.scene_serial += 1;
        self.error = None;
    }

    fn dialog_done(&mut self, kind: DialogKind, path: PathBuf, ctx: &egui::Context) {
        let result = match kind {
            DialogKind::Open | DialogKind::OpenFolder => {
                self.open(VolumeSource::Spec(path.display().to_string()), ctx);
                Ok(None)
            }
            DialogKind::SaveScreenshot => self
                .save_screenshot(&path, ctx.pixels_per_point())
                .map(|()| Some(format!("saved {}", path.display()))),
            DialogKind::SaveTransfer => self
                .save_transfer(&path)
                .map(|()| Some(format!("saved {}", path.display()))),
            DialogKind::LoadTransfer => self
                .load_transfer(&path)
                .map(|()| Some(format!("loaded {}", path.display()))),
        };
        match result {
            Ok(Some(notice)) => self.notice = Some((notice, Instant::now())),
            Ok(None) => {}
            Err(message) => self.fail(message),
        }
    }

    /// Starts a native file dialog on its own thread (the UI keeps running).
    fn start_dialog(&mut self, kind: DialogKind, ctx: &egui::Context) {
        if self.dialog.is_some() {
            return;
        }
        let (sender, receiver) = mpsc::channel();
        let wake = ctx.clone();
        let directory = self
            .settings
            .recent
            .first()
            .and_then(|spec| Path::new(spec).parent().map(Path::to_path_buf));
        let builder = {
            move || {
                let mut dialog = rfd::FileDialog::new();
                if let Some(directory) = &directory {
                    dialog = dialog.set_directory(directory);
                }
                match kind {
                    DialogKind::Open => dialog
                        .set_title("Open a volume")
                        .add_filter(
                            "Volumes (NIfTI, NRRD, TIFF, MRC, DICOM, VTI)",
                            &OPEN_EXTENSIONS,
                        )
                        .add_filter("All files", &["*"])
                        .pick_file(),
                    DialogKind::SaveScreenshot => dialog
                        .set_title("Save screenshot")
                        .add_filter("PNG image", &["png"])
                        .set_file_name("voxscope.png")
                        .save_file(),
                    DialogKind::OpenFolder => dialog
                        .set_title("Open a folder: a DICOM series or TIFF/PNG slices")
                        .pick_folder(),
                    DialogKind::SaveTransfer => dialog
                        .set_title("Save transfer function")
                        .add_filter("Transfer function (RON)", &["ron"])
                        .set_file_name("transfer.ron")
                        .save_file(),
                    DialogKind::LoadTransfer => dialog
                        .set_title("Load transfer function")
                        .add_filter("Transfer function (RON)", &["ron"])
                        .pick_file(),
                }
            }
        };
        std::thread::spawn(move || {
            let started = Instant::now();
            let path = builder();
            let _ = sender.send((path, started.elapsed()));
            wake.request_repaint();
        });
        self.dialog = Some((kind, receiver));
    }

    fn menu_bar(&mut self, ui: &mut Ui) {
        let ctx = ui.ctx().clone();
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui
                    .add(egui::Button::new("Open…").shortcut_text("Ctrl+O"))
                    .clicked()
                {
                    self.start_dialog(DialogKind::Open, &ctx);
                }
                if ui
                    .button("Open folder…")
                    .on_hover_text("A DICOM series, or a folder of TIFF/PNG slices")
                    .clicked()
                {
                    self.start_dialog(DialogKind::OpenFolder, &ctx);
                }
                ui.menu_button("Open recent", |ui| {
                    if self.settings.recent.is_empty() {
                        ui.label("nothing yet");
                    }
                    let mut chosen = None;
                    for spec in &self.settings.recent {
                        if ui.button(spec).clicked() {
                            chosen = Some(spec.clone());
                        }
                    }
                    if let Some(spec) = chosen {
                        self.open(VolumeSource::from_spec(&spec), &ctx);
                    }
                });
                ui.menu_button("Open path", |ui| {
                    let edit = ui.add(
                        egui::TextEdit::singleline(&mut self.path_text)
                            .hint_text("/path/to/volume.nii.gz or synthetic:sphere:64")
                            .desired_width(360.0),
                    );
                    let entered =
                        edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
                    if (ui.button("Open").clicked() || entered) && !self.path_text.trim().is_empty()
                    {
                        let spec = self.path_text.trim().to_owned();
                        self.open(VolumeSource::Spec(spec), &ctx);
                        ui.close();
                    }
                });
                if ui.button("Open sample").clicked() {
                    self.open(VolumeSource::Sample, &ctx);
                }
                ui.separator();
                if ui
                    .add_enabled(self.scene.is_some(), egui::Button::new("Save screenshot…"))
                    .clicked()
                {
                    self.start_dialog(DialogKind::SaveScreenshot, &ctx);
                }
                if ui.button("Save transfer function…").clicked() {
                    self.start_dialog(DialogKind::SaveTransfer, &ctx);
                }
                if ui.button("Load transfer function…").clicked() {
                    self.start_dialog(DialogKind::LoadTransfer, &ctx);
                }
                ui.separator();
                if ui
                    .add(egui::Button::new("Quit").shortcut_text("Ctrl+Q"))
                    .clicked()
                {
                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("View", |ui| {
                ui.radio_value(&mut self.settings.layout, Layout::Single, "Single view");
                ui.radio_value(
                    &mut self.settings.layout,
                    Layout::LevelGrid,
                    "Level grid (compare levels)",
                );
                ui.radio_value(
                    &mut self.settings.layout,
                    Layout::TransferPair,
                    "Transfer pair (compare settings)",
                );
                ui.separator();
                let camera = self.settings.camera;
                if ui.button("Front").clicked() {
                    self.settings.camera = viewport::preset(&camera, 0.0, 0.0);
                }
                if ui.button("Side").clicked() {
                    self.settings.camera = viewport::preset(&camera, 90.0, 0.0);
                }
                if ui.button("Top").clicked() {
                    self.settings.camera = viewport::preset(&camera, 0.0, 89.0);
                }
                if ui.button("Reset camera").clicked() {
                    self.settings.camera = Default::default();
                }
                ui.separator();
                ui.checkbox(
                    &mut self.settings.show_transfer_panel,
                    "Transfer function panel",
                );
                ui.checkbox(&mut self.settings.show_octree_panel, "Octree panel");
            });
            ui.separator();
            ui.selectable_value(&mut self.settings.layout, Layout::Single, "Single");
            ui.selectable_value(&mut self.settings.layout, Layout::LevelGrid, "Level grid");
            ui.selectable_value(
                &mut self.settings.layout,
                Layout::TransferPair,
                "Transfer pair",
            );
            ui.separator();
            let camera = self.settings.camera;
            for (name, azimuth, elevation) in
                [("Front", 0.0, 0.0), ("Side", 90.0, 0.0), ("Top", 0.0, 89.0)]
            {
                if ui.small_button(name).clicked() {
                    self.settings.camera = viewport::preset(&camera, azimuth, elevation);
                }
            }
        });
    }

    fn status_bar(&mut self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            if let Some(job) = &self.loading {
                let (stage, fraction) = job.progress.get();
                // Fixed-width items first, so Cancel does not move as the text changes.
                ui.spinner();
                if ui.button("Cancel").clicked() {
                    eprintln!("voxscope: cancelling {}", job.title);
                    job.progress.cancel();
                }
                ui.add(
                    egui::ProgressBar::new(fraction)
                        .desired_width(160.0)
                        .show_percentage(),
                );
                ui.label(format!("{}: {stage}", job.title));
                ui.separator();
            } else if let Some((options, _)) = &self.uploading {
                ui.spinner();
                ui.label(format!(
                    "uploading for the {} renderer…",
                    options.kind.name()
                ));
                ui.separator();
            }
            if let Some(scene) = &self.scene {
                let volume = &scene.data.volume;
                ui.label(format!(
                    "{} · {} · {}×{}×{} {} · spacing {:.3}×{:.3}×{:.3} · {}",
                    volume.name,
                    volume.format,
                    volume.dims[0],
                    volume.dims[1],
                    volume.dims[2],
                    volume.data.voxel_type().name(),
                    volume.spacing[0],
                    volume.spacing[1],
                    volume.spacing[2],
                    volume.orientation.describe(),
                ));
            }
            if let Some((notice, at)) = &self.notice
                && at.elapsed() < Duration::from_secs(5)
            {
                ui.separator();
                ui.label(notice);
                ui.ctx().request_repaint_after(Duration::from_millis(500));
            }
        });
    }

    fn central(&mut self, ui: &mut Ui) {
        let view_rect = ui.available_rect_before_wrap();
        self.view_rect = view_rect;
        ui.painter()
            .rect_filled(view_rect, 0.0, Color32::from_gray(12));
        let count = match self.settings.layout {
            Layout::Single => 1,
            Layout::LevelGrid => self.settings.grid_panes.clamp(2, MAX_GRID_PANES),
            Layout::TransferPair => 2,
        };
        let mut area = view_rect;
        if self.settings.layout == Layout::TransferPair {
            let strip = Rect::from_min_size(area.min, vec2(area.width(), 28.0));
            area.min.y += 30.0;
            ui.scope_builder(
                UiBuilder::new().max_rect(strip.shrink2(vec2(6.0, 2.0))),
                |ui| {
                    ui.horizontal(|ui| self.pair_controls(ui));
                },
            );
        } else if self.settings.layout == Layout::LevelGrid {
            let strip = Rect::from_min_size(area.min, vec2(area.width(), 28.0));
            area.min.y += 30.0;
            ui.scope_builder(
                UiBuilder::new().max_rect(strip.shrink2(vec2(6.0, 2.0))),
                |ui| {
                    ui.horizontal(|ui| {
                        let label = ui.label("Panes");
                        ui.add(egui::Slider::new(
                            &mut self.settings.grid_panes,
                            2..=MAX_GRID_PANES,
                        ))
                        .labelled_by(label.id);
                        ui.label("· each pane: its own max level, one linked camera");
                    });
                },
            );
        }
        let rects = grid_rects(area, count, 2.0);
        self.pane_rects = rects.clone();

        // Panes: make targets, paint last images, take camera input.
        let ppp = ui.ctx().pixels_per_point();
        if let Some(gpu) = &self.gpu {
            let mut egui_renderer = gpu.render_state.renderer.write();
            while self.panes.len() > count {
                let mut pane = self.panes.pop().expect("longer than count");
                pane.release(&mut egui_renderer);
            }
            self.panes.resize_with(count, Pane::default);
            // While the camera moves on a slow GPU, draw at half resolution (as ParaView's
            // interactive LOD does); the full image follows when the motion stops.
            let slow = self
                .last_report
                .is_none_or(|r| r.gpu_ms.is_none_or(|ms| ms > 20.0));
            let scale = if self.interacting && slow && self.settings.fast_interaction {
                0.5
            } else {
                1.0
            };
            if self.scene.is_some() {
                for (pane, rect) in self.panes.iter_mut().zip(&rects) {
                    pane.ensure_size(
                        &gpu.context,
                        &mut egui_renderer,
                        viewport::pixel_size(*rect, ppp * scale),
                    );
                }
            }
        }
        let extent = self.scene.as_ref().map(|s| {
            let v = &s.data.volume;
            std::array::from_fn(|a| v.dims[a] as f64 * v.spacing[a])
        });
        let was_interacting = self.interacting;
        self.interacting = false;
        for (index, rect) in rects.iter().enumerate() {
            let response = ui
                .scope_builder(UiBuilder::new().max_rect(*rect), |ui| {
                    viewport::allocate_pane(ui, rect.size())
                })
                .inner;
            if self.scene.is_some() {
                self.panes[index].paint(ui, *rect);
            }
            if let Some(extent) = extent {
                let moved =
                    viewport::control_camera(&mut self.settings.camera, &response, ui, extent);
                self.interacting |= moved || response.dragged();
            }
            self.pane_label(ui, index, *rect);
        }
        if was_interacting && !self.interacting {
            // Motion ended: one more frame draws the full-resolution image.
            ui.ctx().request_repaint();
        }
        if let Some(rect) = rects.first() {
            let oriented = self.scene.as_ref().is_some_and(|s| {
                matches!(s.data.volume.orientation, Orientation::Reoriented { .. })
                    || matches!(s.data.volume.format, "NIfTI-1" | "NRRD")
            });
            let labels = if oriented {
                ["R", "A", "S"]
            } else {
                ["x", "y", "z"]
            };
            if self.scene.is_some() {
                viewport::paint_axis_gizmo(ui, *rect, &self.settings.camera, labels);
            }
        }
        if self.scene.is_none() {
            let text = if self.loading.is_some() {
                "Loading…"
            } else {
                "Open a volume: File ▸ Open…, or drop a file here"
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
        if let Some(message) = self.error.clone() {
            let banner = Rect::from_min_size(
                view_rect.min + vec2(12.0, view_rect.height() - 60.0),
                vec2(view_rect.width() - 24.0, 48.0),
            );
            ui.scope_builder(UiBuilder::new().max_rect(banner), |ui| {
                egui::Frame::new()
                    .fill(Color32::from_rgb(120, 24, 24))
                    .inner_margin(8.0)
                    .corner_radius(4.0)
                    .show(ui, |ui| {
                        ui.horizontal(|ui| {
                            ui.label(
                                RichText::new(format!("Error: {message}")).color(Color32::WHITE),
                            );
                            if ui.button("Dismiss").clicked() {
                                self.error = None;
                            }
                        });
                    });
            });
        }
    }

    fn pane_label(&mut self, ui: &mut Ui, index: usize, rect: Rect) {
        let Some(scene) = &self.scene else { return };
        let depth = scene.data.octree.depth;
        let header =
            Rect::from_min_size(rect.min + vec2(6.0, 4.0), vec2(rect.width() - 12.0, 22.0));
        let text = |level: u32| {
            format!(
                "level {level} · {} nodes",
                octree_panel::group_digits(scene.data.octree.nodes_through_level(level) as u64)
            )
        };
        match self.settings.layout {
            Layout::Single => {
                ui.painter().text(
                    header.left_top(),
                    Align2::LEFT_TOP,
                    text(self.max_level),
                    egui::FontId::proportional(13.0),
                    Color32::from_gray(220),
                );
            }
            Layout::LevelGrid => {
                let slot = grid_slot(index, self.panes.len());
                let nodes = format!(
                    "{} nodes",
                    octree_panel::group_digits(
                        scene
                            .data
                            .octree
                            .nodes_through_level(self.grid_levels[slot].min(depth))
                            as u64
                    )
                );
                ui.scope_builder(UiBuilder::new().max_rect(header), |ui| {
                    ui.horizontal(|ui| {
                        let label = ui.label(RichText::new("level").color(Color32::from_gray(220)));
                        ui.add(egui::DragValue::new(&mut self.grid_levels[slot]).range(0..=depth))
                            .labelled_by(label.id);
                        ui.label(RichText::new(nodes).color(Color32::from_gray(220)));
                    });
                });
            }
            Layout::TransferPair => {
                let choice = if index == 0 {
                    self.settings.transfer
                } else {
                    self.settings.compare_transfer
                };
                let label = format!("{} · {}", ["A", "B"][index], describe_choice(choice));
                ui.painter().text(
                    header.left_top(),
                    Align2::LEFT_TOP,
                    label,
                    egui::FontId::proportional(13.0),
                    Color32::from_gray(220),
                );
            }
        }
    }

    fn pair_controls(&mut self, ui: &mut Ui) {
        ui.label("B:");
        let b = &mut self.settings.compare_transfer;
        ui.selectable_value(&mut b.opacity, OpacityMode::Gray, "Gray");
        ui.selectable_value(&mut b.opacity, OpacityMode::Binary, "Binary");
        if b.opacity == OpacityMode::Binary {
            ui.add(egui::Slider::new(&mut b.threshold, 0.0..=1.0).text("threshold"));
        }
        let colormap_label = ui.label("colormap");
        egui::ComboBox::from_id_salt("compare_colormap")
            .selected_text(b.colormap.name())
            .show_ui(ui, |ui| {
                for colormap in crate::octree::Colormap::ALL {
                    ui.selectable_value(&mut b.colormap, colormap, colormap.name());
                }
            })
            .response
            .labelled_by(colormap_label.id);
        if ui.button("Swap A and B").clicked() {
            std::mem::swap(
                &mut self.settings.transfer,
                &mut self.settings.compare_transfer,
            );
        }
    }

    /// Starts the background work that settings changes call for: another renderer, fresh
    /// statistics.
    fn follow_settings(&mut self, ctx: &egui::Context) {
        let Some(scene) = &self.scene else { return };
        let wanted = self.renderer_options();
        let upload_pending = self
            .uploading
            .as_ref()
            .is_some_and(|(options, _)| *options == wanted);
        if scene.options != wanted && !upload_pending && self.loading.is_none() {
            let data = Arc::clone(&scene.data);
            let context = Arc::clone(&self.gpu.as_ref().expect("a scene has a GPU").context);
            let transfer = self.transfer();
            let wake = ctx.clone();
            self.uploading = Some((
                wanted,
                Job::spawn(
                    format!("{} renderer", wanted.kind.name()),
                    move || wake.request_repaint(),
                    move |progress| scene::upload(data, &context, wanted, transfer, progress),
                ),
            ));
        }
        let transfer = self.transfer();
        if self.statistics_for != Some(transfer) && self.statistics_job.is_none() {
            let wake = ctx.clone();
            self.statistics_job = Some(scene::statistics_job(
                Arc::clone(&scene.data),
                transfer,
                move || wake.request_repaint(),
            ));
        }
    }

    /// Draws every pane whose image is out of date (or all, when drawing continuously).
    fn draw_panes(&mut self) {
        let (Some(gpu), Some(scene)) = (&self.gpu, &mut self.scene) else {
            return;
        };
        let depth = scene.data.octree.depth;
        self.max_level = self.max_level.min(depth);
        let main = self.settings.transfer.with_window(self.window);
        let compare = self.settings.compare_transfer.with_window(self.window);
        let mut drew = false;
        let count = self.panes.len();
        for (index, pane) in self.panes.iter_mut().enumerate() {
            let Some(target) = &pane.target else { continue };
            let (level, transfer) = match self.settings.layout {
                Layout::Single => (self.max_level, main),
                Layout::LevelGrid => {
                    let slot = grid_slot(index, count);
                    (
                        self.grid_levels
                            .get(slot)
                            .copied()
                            .unwrap_or(depth)
                            .min(depth),
                        main,
                    )
                }
                Layout::TransferPair => (self.max_level, if index == 0 { main } else { compare }),
            };
            let settings = RenderSettings {
                mode: self.settings.mode,
                max_level: level,
                pixel_lod: self.settings.pixel_lod,
                opacity_correction: self.settings.opacity_correction,
                density: self.settings.density,
                heatmap: self.settings.heatmap,
                trilinear: self.settings.trilinear,
            };
            let key = DrawKey {
                size: [target.width, target.height],
                camera: self.settings.camera,
                settings,
                transfer,
                scene: self.scene_serial,
            };
            if pane.drawn == Some(key) && !self.settings.continuous {
                continue;
            }
            let mut encoder =
                gpu.context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::app_frame"),
                    });
            if scene.applied_transfer != transfer {
                if let Err(e) =
                    scene
                        .renderer
                        .set_transfer(&gpu.context, &mut encoder, &transfer, None)
                {
                    eprintln!("voxscope: error: {e}");
                    self.error = Some(e.to_string());
                    return;
                }
                scene.applied_transfer = transfer;
            }
            let measure = !drew && self.probe.as_ref().is_some_and(FrameProbe::is_idle);
            let writes = if measure {
                self.probe.as_ref().and_then(FrameProbe::timestamp_writes)
            } else {
                None
            };
            scene.renderer.encode(
                &gpu.context,
                &mut encoder,
                target,
                &key.camera,
                &settings,
                writes,
            );
            if measure && let Some(probe) = &mut self.probe {
                probe.record(&gpu.context, &mut encoder, target);
            }
            gpu.context.queue.submit([encoder.finish()]);
            if measure && let Some(probe) = &mut self.probe {
                probe.submitted();
            }
            pane.drawn = Some(key);
            drew = true;
            if self.logged_scene != self.scene_serial {
                self.logged_scene = self.scene_serial;
                eprintln!(
                    "voxscope: drew {} ({}x{} px, {} renderer, level {level})",
                    scene.data.volume.name,
                    target.width,
                    target.height,
                    scene.options.kind.name()
                );
            }
        }
        let now = Instant::now();
        if drew {
            self.draw_times.push(now);
        }
        self.draw_times
            .retain(|t| now.duration_since(*t) < Duration::from_secs(1));
    }

    fn fps(&self) -> Option<f64> {
        (self.settings.continuous && self.draw_times.len() >= 2).then(|| {
            let span = self
                .draw_times
                .last()
                .expect("two")
                .duration_since(self.draw_times[0]);
            (self.draw_times.len() - 1) as f64 / span.as_secs_f64().max(1e-6)
        })
    }

    fn keyboard_and_drops(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        if ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::O)))
        {
            self.start_dialog(DialogKind::Open, ctx);
        }
        if ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Q)))
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        let dropped = ctx.input(|i| i.raw.dropped_files.first().map(|f| f.path().to_path_buf()));
        if let Some(path) = dropped.filter(|p| !p.as_os_str().is_empty()) {
            self.open(VolumeSource::Spec(path.display().to_string()), ctx);
        }
    }

    fn target_bytes(&self) -> u64 {
        self.panes
            .iter()
            .filter_map(|p| p.target.as_ref())
            .map(|t| t.gpu_bytes())
            .sum()
    }
}

impl eframe::App for VoxscopeApp {
    fn ui(&mut self, ui: &mut Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.poll_jobs(&ctx);
        self.keyboard_and_drops(&ctx);

        egui::Panel::top("menu_bar").show(ui, |ui| self.menu_bar(ui));
        egui::Panel::bottom("status_bar").show(ui, |ui| self.status_bar(ui));
        if self.settings.show_transfer_panel {
            egui::Panel::left("transfer_panel")
                .default_size(300.0)
                .show(ui, |ui| {
                    egui::ScrollArea::vertical().show(ui, |ui| {
                        let data = self.scene.as_ref().map(|s| Arc::clone(&s.data));
                        transfer_panel::show(
                            ui,
                            &mut self.settings,
                            &mut self.window,
                            data.as_deref(),
                        );
                    });
                });
        }
        if self.settings.show_octree_panel {
            let facts_statistics = std::mem::take(&mut self.statistics);
            egui::Panel::right("octree_panel")
                .default_size(390.0)
                .show(ui, |ui| {
                    egui::ScrollArea::vertical().show(ui, |ui| {
                        let facts = OctreeFacts {
                            scene: self.scene.as_ref(),
                            statistics: &facts_statistics,
                            statistics_pending: self.statistics_job.is_some()
                                || self.statistics_for != Some(self.transfer()),
                            frame: self.last_report,
                            fps: self.fps(),
                            adapter: self
                                .gpu
                                .as_ref()
                                .map_or("none", |g| g.context.adapter_info.name.as_str()),
                            target_bytes: self.target_bytes(),
                        };
                        let mut max_level = self.max_level;
                        octree_panel::show(ui, &mut self.settings, &mut max_level, &facts);
                        self.max_level = max_level;
                    });
                });
            self.statistics = facts_statistics;
        }
        egui::CentralPanel::no_frame().show(ui, |ui| self.central(ui));

        self.follow_settings(&ctx);
        self.draw_panes();
        if self.settings.continuous {
            ctx.request_repaint();
        }
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, STORAGE_KEY, &self.settings);
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

/// Levels of the six grid panes: the deepest six, ending at the voxels. A grid of `n` panes
/// shows the last `n` (depth 8, four panes: 5, 6, 7, 8, as in the paper's Figure 3).
fn default_grid_levels(depth: u32) -> Vec<u32> {
    (0..MAX_GRID_PANES as u32)
        .map(|i| (depth + i).saturating_sub(MAX_GRID_PANES as u32 - 1))
        .collect()
}

/// The level grid's largest pane count.
const MAX_GRID_PANES: usize = 6;

/// Index into [`VoxscopeApp::grid_levels`] of pane `index` of `count`.
fn grid_slot(index: usize, count: usize) -> usize {
    MAX_GRID_PANES - count + index
}

fn describe_choice(choice: TransferChoice) -> String {
    match choice.opacity {
        OpacityMode::Gray => format!("alpha = gray, {}", choice.colormap.name()),
        OpacityMode::Binary => format!(
            "binary at {:.2}, {}",
            choice.threshold,
            choice.colormap.name()
        ),
    }
}
