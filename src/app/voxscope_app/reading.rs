//! What the app shows, read from outside the window: the volume, panes, frames and notices
//! the tests and the command line ask about, and the 3D view's image.

use super::*;

impl VoxscopeApp {
    /// Whether the app's file browser is open, and for what.
    pub fn browsing(&self) -> Option<DialogKind> {
        self.browser.as_ref().map(FileBrowser::kind)
    }

    /// Opens the first volume clipped by `clip` (the command line's clip options).
    pub fn clip_first_volume(&mut self, clip: Clip) {
        self.first_clip = clip.is_active().then_some(clip);
    }

    /// Queues `command` to run after this frame's UI (what menu items do).
    pub fn send(&mut self, command: Command) {
        self.commands.send(command);
    }

    /// True while a volume loads, a renderer uploads, statistics are counted, a dialog is
    /// open or a frame's measurement is on its way back.
    pub fn is_busy(&self) -> bool {
        self.jobs.is_busy()
            || self.labels.is_busy()
            || self.prefetch.is_busy()
            || self.central.is_measuring()
            || (self.scene.is_some() && self.central.is_refining())
            || self.browser.as_ref().is_some_and(FileBrowser::is_listing)
    }

    /// Whether a frame or volume is loading (a frame shown from the prefetch is not).
    pub fn is_loading(&self) -> bool {
        self.jobs.opening.is_some()
    }

    /// The frames of the time series held ready ahead of the one on screen.
    pub fn prefetched(&self) -> Vec<FrameKey> {
        self.prefetch.ready()
    }

    /// The container (plate, bioformats2raw root) the image on screen is one of, and the
    /// path of that image in it.
    pub fn container(&self) -> Option<(&voxscope_volume::Container, String)> {
        let open = self.container.as_ref()?;
        Some((open.container.as_ref(), open.container.opened()))
    }

    /// The frame on screen.
    pub fn frame(&self) -> Option<FrameKey> {
        self.scene.as_ref().map(FrameKey::of_scene)
    }

    /// The composite's channels as the 3D views draw them, when the composite is shown.
    pub fn composite_channels(&self) -> Option<Vec<voxscope_scene::ChannelState>> {
        self.scene.as_ref()?.composite.as_ref()?;
        Some(self.view.composite_channels(self.transfer()))
    }

    /// The streaming renderer's latest status, if it draws the volume on screen.
    pub fn stream_status(&self) -> Option<&voxscope_stream::StreamStatus> {
        self.scene.as_ref()?.stream_status.as_ref()
    }

    /// The error shown in the window, if any.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// The notice shown in the status bar, if any is still shown.
    pub fn notice(&self) -> Option<&str> {
        self.notice
            .as_ref()
            .filter(|(_, at)| at.elapsed() < NOTICE_DURATION)
            .map(|(text, _)| text.as_str())
    }

    /// The stage of the open in progress (`building octree`), if any.
    pub fn opening_stage(&self) -> Option<&'static str> {
        self.jobs.open_progress().map(|(_, stage, _)| stage)
    }

    /// The name of the volume on screen and its octree depth.
    pub fn volume(&self) -> Option<(&str, u32)> {
        self.scene
            .as_ref()
            .map(|s| (s.data.volume.name.as_str(), s.depth()))
    }

    /// Pixel sizes of the panes' render targets.
    pub fn pane_sizes(&self) -> Vec<[u32; 2]> {
        self.central.pane_sizes()
    }

    /// Where the central view's panes are, in points, in reading order (the Slices layout:
    /// 3D, axial, coronal, sagittal).
    pub fn pane_rects(&self) -> &[egui::Rect] {
        self.central.pane_rects()
    }

    /// The data of the volume on screen.
    pub fn volume_data(&self) -> Option<&VolumeData> {
        self.scene.as_ref().map(|s| s.data.as_ref())
    }

    /// The renderer drawing the volume on screen.
    pub fn renderer_kind(&self) -> Option<RendererKind> {
        self.scene.as_ref().map(|s| s.options.kind)
    }

    /// The statistics panel's per-level numbers.
    pub fn statistics(&self) -> &[LevelStatistics] {
        &self.view.statistics
    }

    /// The last frame's measured cost.
    pub fn frame_report(&self) -> Option<FrameReport> {
        self.central.frame_report()
    }

    /// What a whole frame of the measured 3D pane costs the GPU, in ms (estimated from its
    /// bands' wall time where a slow device drew it in bands), and in how many bands.
    pub fn frame_cost(&self) -> Option<(f64, u32)> {
        let facts = self.central.frame_facts(self.scene_serial)?;
        Some((facts.frame_ms?, facts.bands))
    }

    /// Whether a frame is on the GPU or a pane's full image is still being drawn in bands.
    pub fn is_drawing(&self) -> bool {
        self.central.is_drawing()
    }

    /// The transfer function of the main view.
    pub fn transfer(&self) -> TransferFunction {
        self.settings.transfer.with_window(self.view.window)
    }

    /// What is drawn: the panes' images composed as laid out, at full pixel resolution, with
    /// the rulers.
    pub fn view_image(&self, pixels_per_point: f32) -> Result<image::RgbaImage, String> {
        let gpu = self.gpu.as_ref().ok_or("no GPU device")?;
        self.central.image(
            gpu,
            pixels_per_point,
            self.scene.as_ref(),
            &self.view,
            false,
        )
    }

    /// Saves [`Self::view_image`] with the axes gizmo as PNG (File ▸ Save screenshot…, 1×).
    pub fn save_screenshot(&self, path: &Path, pixels_per_point: f32) -> Result<(), String> {
        let gpu = self.gpu.as_ref().ok_or("no GPU device")?;
        let image =
            self.central
                .image(gpu, pixels_per_point, self.scene.as_ref(), &self.view, true)?;
        image
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| format!("{}: cannot write the screenshot: {e}", path.display()))
    }
}
