//! The app: what it holds (settings that persist, the volume on screen and its view state,
//! background jobs, the central view) and the one place where [`Command`]s and finished jobs
//! change it. The panels, menus and central view draw themselves in their own modules.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use egui::Ui;

use super::AppGpu;
use super::central::{CentralView, ViewInputs};
use super::channel_list;
use super::command::{Command, CommandQueue};
use super::dialogs::DialogKind;
use super::file_browser::{BrowserOutcome, FileBrowser};
use super::frame_controls::{self, OpenContainer, Playback};
use super::jobs::{JobEvent, Jobs};
use super::label_list::{self, LabelLayers};
use super::menu::{self, NOTICE_DURATION};
use super::movie_panel::{self, MoviePlan, MoviePreview};
use super::octree_panel::{self, OctreeFacts};
use super::overlays;
use super::settings::{AppSettings, DEFAULT_COMPARE_TRANSFER, STORAGE_KEY};
use super::transfer_panel;
use super::url_dialog::{UrlDialog, UrlOutcome};
use super::view_file::ViewFile;
use super::view_state::{Clipping, ViewState};
use voxscope_octree::{Clip, LevelStatistics, OpacityMode, TransferFunction};
use voxscope_render::{Camera, FrameReport, GpuContext, RendererKind, RendererOptions};
use voxscope_scene::{FrameKey, Prefetch};
use voxscope_scene::{Job, Opened, SceneError};
use voxscope_scene::{OctreeColors, Scene, VolumeData, VolumeSource};
use voxscope_scene::{SavedTransfer, TransferChoice, TransferFileError};

mod movie;
mod panels;
mod reading;

/// The voxscope window.
pub struct VoxscopeApp {
    /// What persists between runs.
    pub settings: AppSettings,
    /// The view state of the volume on screen (reset when another opens).
    pub view: ViewState,
    pub(super) gpu: Option<AppGpu>,
    pub(super) scene: Option<Scene>,
    /// Bumped for every new scene, so panes redraw.
    pub(super) scene_serial: u64,
    pub(super) jobs: Jobs,
    pub(super) commands: CommandQueue,
    pub(super) central: CentralView,
    /// The last failure, shown until dismissed.
    pub(super) error: Option<String>,
    /// A short confirmation (screenshot saved), shown a few seconds.
    pub(super) notice: Option<(String, Instant)>,
    /// The app's own file browser, while open.
    pub(super) browser: Option<FileBrowser>,
    /// File ▸ Open URL…'s window, while it is open.
    pub(super) url_dialog: Option<UrlDialog>,
    /// Playing a time series.
    pub(super) playback: Playback,
    /// The next frames of an in-memory time series, loaded ahead.
    pub(super) prefetch: Prefetch,
    /// The desktop could not show a file dialog: use the app's browser from now on.
    pub(super) no_desktop_dialogs: bool,
    /// The clip the first volume opens with (the command line's `--clip-box`, `--clip-plane`).
    pub(super) first_clip: Option<Clip>,
    /// The time point of the scene the 3D views last showed whole.
    pub(super) shown_time: Option<usize>,
    /// The view file saved or opened last in this session: where Ctrl+S saves.
    pub(super) last_view_file: Option<PathBuf>,
    /// The Movie panel's keyframes and output.
    pub movie: MoviePlan,
    /// The movie's camera path playing in the central view.
    pub(super) preview: Option<MoviePreview>,
    /// The scale the screenshot being chosen in a file dialog is saved at.
    pub(super) screenshot_scale: u32,
    /// Screenshots at a scale are drawn in tiles of this side even where the device draws
    /// them whole (tests; `None`: tiles only beyond the device's targets).
    pub screenshot_tile: Option<u32>,
    /// The container (plate, bioformats2raw root) the image on screen is one of.
    pub(super) container: Option<OpenContainer>,
    /// The label images drawn over the image, and their overlay.
    pub(super) labels: LabelLayers,
}

impl VoxscopeApp {
    /// The app in `cc`'s window, opening `source` (the sample when `None`).
    pub fn new(cc: &eframe::CreationContext<'_>, source: Option<VolumeSource>) -> Self {
        Self::starting(cc, Command::Open(source.unwrap_or(VolumeSource::Sample)))
    }

    /// The app in `cc`'s window, opening the view file `view` (`voxscope --view V.ron`): its
    /// data, then the rest of the view. A view that cannot be read, or whose data is missing,
    /// leaves the window empty with one line saying why.
    pub fn with_view(cc: &eframe::CreationContext<'_>, view: PathBuf) -> Self {
        Self::starting(cc, Command::OpenView(view))
    }

    /// The app in `cc`'s window, carrying out `first` (an open) at once.
    fn starting(cc: &eframe::CreationContext<'_>, first: Command) -> Self {
        let settings: AppSettings = cc
            .storage
            .and_then(|storage| eframe::get_value(storage, STORAGE_KEY))
            .unwrap_or_default();
        let gpu = cc.wgpu_render_state.as_ref().map(|state| AppGpu {
            context: Arc::new(GpuContext::from_device(
                state.device.clone(),
                state.queue.clone(),
                &state.adapter,
            )),
            render_state: state.clone(),
            offscreen: super::OffscreenDevice::new(state.adapter.clone()),
        });
        let central = CentralView::new(gpu.as_ref());
        let mut app = Self {
            settings,
            view: ViewState::default(),
            gpu,
            scene: None,
            scene_serial: 0,
            jobs: Jobs::default(),
            commands: CommandQueue::default(),
            central,
            error: None,
            notice: None,
            browser: None,
            url_dialog: None,
            playback: Playback::default(),
            prefetch: Prefetch::default(),
            no_desktop_dialogs: false,
            first_clip: None,
            shown_time: None,
            last_view_file: None,
            movie: MoviePlan::default(),
            preview: None,
            screenshot_scale: 1,
            screenshot_tile: None,
            container: None,
            labels: LabelLayers::default(),
        };
        if app.gpu.is_none() {
            app.fail("voxscope needs the wgpu renderer; no GPU device was handed to the app");
        } else {
            app.run_command(first, &cc.egui_ctx);
        }
        app
    }

    /// Writes the transfer function, opacity scale and mode as RON.
    pub fn save_transfer(&self, path: &Path) -> Result<(), TransferFileError> {
        SavedTransfer {
            transfer: self.transfer(),
            density: self.settings.density,
            mode: self.settings.mode,
        }
        .write(path)
    }

    /// Reads a transfer function saved by [`Self::save_transfer`].
    pub fn load_transfer(&mut self, path: &Path) -> Result<(), TransferFileError> {
        let preset = SavedTransfer::read(path)?;
        self.settings.transfer = TransferChoice::from(preset.transfer);
        self.view.window = preset.transfer.window;
        self.settings.density = preset.density;
        self.settings.mode = preset.mode;
        self.view.other_mode = None;
        Ok(())
    }

    /// The renderer the volume on screen is to be drawn with: the one its data called for
    /// ([`ViewState::data_renderer`]), else the user's.
    pub(super) fn renderer_options(&self) -> RendererOptions {
        RendererOptions {
            kind: self.view.data_renderer.unwrap_or(self.settings.renderer),
            ..self.chosen_renderer_options()
        }
    }

    /// The renderer the user chose in the Octree panel: what a new volume is opened with.
    pub(super) fn chosen_renderer_options(&self) -> RendererOptions {
        RendererOptions {
            kind: self.settings.renderer,
            brick_size: self.settings.brick_size,
            gpu_memory: self.settings.stream_gpu_memory,
        }
    }

    /// The transfer function a new volume is to open with instead of its own: the one on
    /// screen while the user has pinned it (before any volume is shown, the one pinned when
    /// the app was last closed).
    pub(super) fn pinned_transfer(&self) -> Option<TransferFunction> {
        let pinned = self.settings.pinned_transfer?;
        Some(if self.scene.is_some() {
            self.transfer()
        } else {
            pinned
        })
    }

    pub(super) fn fail(&mut self, message: impl Into<String>) {
        let message = message.into();
        eprintln!("voxscope: error: {message}");
        self.error = Some(message);
    }

    pub(super) fn notify(&mut self, text: impl Into<String>) {
        self.notice = Some((text.into(), Instant::now()));
    }

    /// Names bricks that newly could not be read, once, in the status bar; and wakes the
    /// window when a failed brick is next asked for again (an untouched window draws no frame
    /// otherwise, and the retry happens in a frame).
    fn tell_stream_failures(&mut self, ctx: &egui::Context) {
        let Some(scene) = &self.scene else {
            return;
        };
        let Some(status) = &scene.stream_status else {
            return;
        };
        if let Some(seconds) = status.next_retry_s {
            ctx.request_repaint_after(Duration::from_secs_f64(seconds.max(0.05)));
        }
        if !status.errors.is_empty()
            && let Some(notice) = super::stream_panel::failure_notice(scene)
        {
            self.notify(notice);
        }
    }

    /// A renderer switch that failed: back to the renderer on screen (or the switch would be
    /// retried forever), and the error shown.
    fn switch_failed(&mut self, error: String) {
        if let Some(scene) = &self.scene {
            self.settings.renderer = scene.options.kind;
            self.settings.brick_size = scene.options.brick_size;
        }
        self.fail(error);
    }

    /// Applies what finished in the background since the last frame.
    pub(super) fn handle_job_events(&mut self, ctx: &egui::Context) {
        for event in self.jobs.poll() {
            match event {
                JobEvent::Opened(opened) => self.show_opened(*opened),
                JobEvent::ViewOpened(opened, view) => self.show_view_opened(*opened, &view),
                JobEvent::ViewFile(ViewFile::Written(path)) => {
                    let notice = self.view_file_done(&path, "view saved");
                    self.notify(notice);
                }
                JobEvent::ViewFile(ViewFile::Read(path, view)) => {
                    self.view_file_done(&path, "view opened");
                    if let Err(message) = self.open_view(*view, ctx) {
                        self.fail(format!("{}: {message}", path.display()));
                    }
                }
                JobEvent::ViewFileFailed(error) => self.fail(error.to_string()),
                JobEvent::MovieExported(exported) => self.notify(format!(
                    "movie written: {} ({} frames in {:.1} s)",
                    exported.output.display(),
                    exported.frames,
                    exported.seconds
                )),
                JobEvent::MovieEnded(SceneError::Cancelled) => {
                    self.notify("writing the movie cancelled")
                }
                JobEvent::MovieEnded(error) => self.fail(error.to_string()),
                JobEvent::ScreenshotSaved(path) => {
                    let notice = self.saved(&path, "screenshot");
                    self.notify(notice);
                }
                JobEvent::ScreenshotFailed(error) => self.fail(error.to_string()),
                JobEvent::OpenEnded(SceneError::Cancelled) => self.notify("opening cancelled"),
                JobEvent::OpenEnded(error) => self.fail(error.to_string()),
                JobEvent::Uploaded(mut scene) => {
                    // A switch for a volume no longer on screen (another opened meanwhile):
                    // dropped; the next frame switches the one on screen if it must.
                    if !self
                        .scene
                        .as_ref()
                        .is_some_and(|on_screen| Arc::ptr_eq(&on_screen.data, &scene.data))
                    {
                        continue;
                    }
                    // The upload recolored nothing (its thread submits nothing to the window's
                    // device), so the octree's colors follow the load's transfer function:
                    // recolored here to the scene's before it is drawn.
                    let recolored = self
                        .gpu
                        .as_ref()
                        .map_or(Ok(()), |gpu| scene.recolor(&gpu.context));
                    if let Err(error) = recolored {
                        self.switch_failed(error.to_string());
                        continue;
                    }
                    // The in-memory composite does not depend on the renderer of one channel: it
                    // stays. A streamed one is drawn by the renderer it came with, which goes.
                    if let Some(old) = self.scene.take()
                        && Arc::ptr_eq(&old.data, &scene.data)
                    {
                        scene.composite = old.composite.filter(|c| !c.is_streamed());
                    }
                    self.scene = Some(*scene);
                    self.scene_serial += 1;
                }
                JobEvent::UploadFailed(error) => self.switch_failed(error.to_string()),
                JobEvent::Counted(counted) => {
                    let (transfer, clip, statistics) = *counted;
                    self.view.statistics = statistics;
                    self.view.statistics_for = Some((transfer, clip));
                }
                JobEvent::DialogClosed(kind, answer) => self.dialog_closed(kind, answer, ctx),
            }
        }
        self.prefetch.poll();
        self.warm_prefetch();
        if let Some(gpu) = &self.gpu {
            let scale = self.scene.as_ref().map_or([1.0; 3], Scene::voxel_scale);
            self.central
                .poll(gpu, &mut self.view, self.settings.tool, scale);
        }
        if self.is_busy() {
            ctx.request_repaint_after(Duration::from_millis(50));
        }
    }

    pub(super) fn show_opened(
        &mut self,
        Opened {
            mut scene,
            statistics,
            frame_change,
            channels,
            notice,
        }: Opened,
    ) {
        // The open job recolored nothing on the GPU (its thread submits nothing to the
        // window's device). The octree's CPU colors follow the transfer function uploaded, but
        // the bricks renderer's coarse colors are the GPU recolor's (it averages a brick's
        // voxels, the CPU its children): recolored here before it is drawn, as a switch's is.
        if let Some(gpu) = &self.gpu
            && let Err(error) = scene.recolor(&gpu.context)
        {
            self.fail(error.to_string());
            return;
        }
        if let Some(notice) = notice {
            self.notify(notice);
        }
        if frame_change && self.scene.is_some() {
            // The user's channel settings stay; a composite seen for the first time takes
            // the file's.
            if scene.composite.is_some() && self.view.channels.len() != channels.len() {
                self.view.channels = channels;
                self.view.active_channel = 0;
            }
            // Another channel or time point: the camera, transfer function, level, cursor,
            // clipping and rulers stay; the statistics are the new frame's (the clip's count
            // follows, as after any clip edit).
            self.view.statistics = statistics;
            self.view.statistics_for = Some((scene.applied_transfer, Clip::NONE));
            self.scene = Some(scene);
            self.scene_serial += 1;
            self.error = None;
            return;
        }
        // A renderer the data called for is not the user's choice: it holds for this volume
        // alone (ViewState::data_renderer), and the next opens with the user's.
        let data_renderer = (scene.options.kind != self.settings.renderer).then(|| {
            self.notify(data_renderer_notice(&scene));
            scene.options.kind
        });
        let depth = scene.depth();
        // The volume may open with its own transfer function (a CT preset, labels): the
        // panel shows and edits that one.
        self.settings.transfer = TransferChoice::from(scene.applied_transfer);
        self.view = ViewState::new(
            scene.data.volume.dims,
            depth,
            scene.applied_transfer,
            statistics,
        );
        self.view.channels = channels;
        self.view.data_renderer = data_renderer;
        self.prefetch.clear();
        if let Some(clip) = self.first_clip.take() {
            self.view.clipping = Clipping::from(clip);
        }
        if let VolumeSource::Spec(spec) = &scene.data.source {
            self.settings.remember(spec);
        }
        self.container = OpenContainer::follow(
            self.container.take(),
            &scene.data.source,
            &scene.data.volume.series,
        );
        // The distance is in units of this volume's size, and a zoom chosen for another
        // volume's detail means nothing here: the direction stays, zoom and pan do not.
        self.settings.camera.pan = [0.0; 3];
        self.settings.camera.distance = Camera::default().distance;
        // Pane B's curve, like A's, was in the last volume's units.
        if matches!(
            self.settings.compare_transfer.opacity,
            OpacityMode::Points(_)
        ) && self.settings.pinned_transfer.is_none()
        {
            self.settings.compare_transfer = DEFAULT_COMPARE_TRANSFER;
        }
        let volume = &scene.data.volume;
        // A streamed store: its own size, then the level held for the panels.
        let streamed = scene.renderer.streamer().map(|s| s.shape().dims());
        let dims = voxscope_volume::format_dims(streamed.unwrap_or(volume.dims));
        let panels = match streamed {
            Some(dims) if dims != volume.dims => {
                format!(
                    ", streamed; panels at {}",
                    voxscope_volume::format_dims(volume.dims)
                )
            }
            _ => String::new(),
        };
        eprintln!(
            "voxscope: opened {} ({dims}{panels}, octree depth {depth}, {} nodes) in {:.2} s",
            volume.name,
            scene.data.octree.nodes.len(),
            scene.data.load_seconds + scene.upload_seconds,
        );
        self.scene = Some(scene);
        self.scene_serial += 1;
        self.error = None;
    }

    /// Plays a time series: the next time point once the one on screen is drawn (a slow
    /// device slows playback rather than skipping frames it never showed), before the panels
    /// are built, so that the time they show is the frame being drawn.
    fn step_playback(&mut self, ctx: &egui::Context) {
        let Some(scene) = &self.scene else { return };
        let series = &scene.data.volume.series;
        let loading = self.jobs.open_progress().is_some();
        let shown = self.central.shows_scene(self.scene_serial);
        if let Some(next) = self
            .playback
            .next(series, self.settings.frame_rate, loading || !shown)
        {
            self.run_command(Command::ShowTime(next), ctx);
        }
        if self.playback.playing {
            ctx.request_repaint_after(self.playback.wait(self.settings.frame_rate));
        }
    }

    /// The time point whose picture the 3D views last showed whole: the scene's, or while a
    /// slow device draws a new one, the one before (`None` before the first).
    pub fn shown_time(&self) -> Option<usize> {
        self.shown_time
    }

    /// Starts the background work that settings changes call for: another renderer, fresh
    /// statistics.
    pub(super) fn follow_settings(&mut self, ctx: &egui::Context) {
        let (Some(scene), Some(gpu)) = (&self.scene, &self.gpu) else {
            return;
        };
        let wanted = self.renderer_options();
        let upload_pending = self
            .jobs
            .uploading
            .as_ref()
            .is_some_and(|(options, _)| *options == wanted);
        // A streamed composite under another budget: its channels are opened again (the
        // renderer of one channel would draw the first alone).
        let streamed_composite = scene.composite.as_ref().is_some_and(|c| c.is_streamed());
        if streamed_composite
            && scene.options != wanted
            && wanted.kind == scene.options.kind
            && self.jobs.opening.is_none()
            && let Some(key) = self.frame()
        {
            let frame = self.frame_change(key);
            let source = scene.data.source.clone();
            self.open(source, Some(frame), ctx);
            return;
        }
        if scene.options != wanted && !upload_pending && self.jobs.opening.is_none() {
            let data = Arc::clone(&scene.data);
            let context = Arc::clone(&gpu.context);
            let transfer = self.transfer();
            let wake = ctx.clone();
            self.jobs.uploading = Some((
                wanted,
                Job::spawn(
                    format!("{} renderer", wanted.kind.name()),
                    move || wake.request_repaint(),
                    // (Recolored when it arrives, by the UI thread.)
                    move |progress| {
                        let colors = OctreeColors::Uploaded;
                        voxscope_scene::upload_colored(
                            data, &context, wanted, transfer, colors, progress,
                        )
                    },
                ),
            ));
        }
        let transfer = self.transfer();
        // The composite has no octree to count (the panel says what it can of it).
        if scene.composite.is_none()
            && !self.view.statistics_current(&transfer)
            && self.jobs.counting.is_none()
        {
            let wake = ctx.clone();
            self.jobs.counting = Some(voxscope_scene::statistics_job(
                Arc::clone(&scene.data),
                transfer,
                self.view.clipping.clip(),
                move || wake.request_repaint(),
            ));
        }
        self.follow_prefetch(ctx);
    }
}

impl eframe::App for VoxscopeApp {
    fn ui(&mut self, ui: &mut Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.handle_job_events(&ctx);
        self.step_playback(&ctx);
        self.step_preview(&ctx);

        self.show_bars(ui);
        if self.settings.show_transfer_panel {
            self.show_transfer_panel(ui);
        }
        if self.settings.show_octree_panel {
            self.show_octree_panel(ui);
        }
        self.show_central_panel(ui);
        self.show_windows(&ctx);
        self.run_queued_commands(&ctx);
        self.follow_settings(&ctx);
        self.draw_panes(&ctx);
        if self.settings.continuous {
            ctx.request_repaint();
        }
        if self.settings.pinned_transfer.is_some() && self.scene.is_some() {
            self.settings.pinned_transfer = Some(self.transfer());
        }
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, STORAGE_KEY, &self.settings);
    }
}

/// Why `scene` is drawn with another renderer than the one chosen, in a line short enough for
/// the status bar: a store above the voxels opened whole streams from its files, a volume
/// longer than the octree holds streams from a pyramid in memory, an octree larger than the
/// GPU's buffers is drawn with bricks.
fn data_renderer_notice(scene: &Scene) -> String {
    let volume = &scene.data.volume;
    let name = Path::new(&volume.name)
        .file_name()
        .map_or_else(|| volume.name.clone(), |n| n.to_string_lossy().into_owned());
    let panel_dims = voxscope_volume::format_dims(volume.dims);
    match scene.options.kind {
        RendererKind::Stream => {
            let dims = scene
                .renderer
                .streamer()
                .map(|s| voxscope_volume::format_dims(s.shape().dims()))
                .unwrap_or_default();
            if scene.data.pyramid.is_some() {
                format!(
                    "{name}: {dims} is longer than the octree's 1024 voxels a side; streamed from a pyramid in memory (panels: {panel_dims})"
                )
            } else {
                format!(
                    "{name}: {dims} is more than the 512³ voxels opened whole; streamed from the store (panels: {panel_dims})"
                )
            }
        }
        kind => format!(
            "{name}: the octree does not fit this GPU's buffers; drawn with {}",
            kind.name()
        ),
    }
}
