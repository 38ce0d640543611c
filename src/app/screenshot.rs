//! File ▸ Save screenshot at 2× or 4×: the 3D view (the first pane) drawn again at that many
//! times its pixels on a job thread by an [`OffscreenDrawer`], in tiles where the image
//! exceeds what one render target of the device may be, with the rulers and the axes gizmo
//! drawn at the same scale, then written as PNG. (1× saves what the panes show:
//! [`super::VoxscopeApp::save_screenshot`].)

use std::path::PathBuf;

use super::OffscreenDevice;
use voxscope_scene::{ChannelState, Job, SceneError, Shot};

use super::offscreen::{OffscreenDrawer, OffscreenSource};
use super::overlays::{draw_axis_gizmo, draw_ruler};

/// A ruler as the scaled image shows it: its ends in the image's pixels and its length.
pub struct RulerMark {
    pub from: [f32; 2],
    pub to: [f32; 2],
    pub label: String,
}

/// Everything a scaled screenshot needs, owned by its thread.
pub struct ScaledScreenshot {
    pub device: OffscreenDevice,
    pub source: OffscreenSource,
    pub shot: Shot,
    /// The composite's channels (empty for one volume).
    pub channels: Vec<ChannelState>,
    /// The image's size: the 3D view's pixels times `scale`.
    pub size: [u32; 2],
    pub scale: u32,
    pub rulers: Vec<RulerMark>,
    /// The gizmo's names of +x, +y, +z.
    pub axis_labels: [&'static str; 3],
    /// Tiles of this side even where the device draws the image whole (tests).
    pub tile: Option<u32>,
    pub path: PathBuf,
}

/// Draws and writes `shot` on a job thread; its result is the path written.
pub fn spawn(shot: ScaledScreenshot, wake: impl Fn() + Send + 'static) -> Job<PathBuf> {
    let title = format!("screenshot at {}×", shot.scale);
    Job::spawn(title, wake, move |progress| {
        let ScaledScreenshot {
            device,
            source,
            shot,
            channels,
            size,
            scale,
            rulers,
            axis_labels,
            tile,
            path,
        } = shot;
        let context = device.context().map_err(SceneError::failed)?;
        let mut drawer = OffscreenDrawer::new(context, source, shot.transfer, &channels, progress)?;
        progress.begin("drawing");
        let mut image = drawer.draw(&shot, &channels, size, tile)?;
        for ruler in &rulers {
            draw_ruler(&mut image, ruler.from, ruler.to, &ruler.label, scale);
        }
        let whole =
            egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(size[0] as f32, size[1] as f32));
        draw_axis_gizmo(&mut image, whole, &shot.camera, axis_labels, scale as f32);
        image
            .save_with_format(&path, image::ImageFormat::Png)
            .map_err(|e| {
                SceneError::failed(format!(
                    "{}: cannot write the screenshot: {e}",
                    path.display()
                ))
            })?;
        Ok(path)
    })
}

impl super::VoxscopeApp {
    /// Starts drawing the 3D view at `scale` times its pixels into `path` in the background.
    pub(super) fn save_scaled_screenshot(
        &mut self,
        path: PathBuf,
        scale: u32,
        ctx: &egui::Context,
    ) -> Result<(), String> {
        if self.jobs.screenshot.is_some() {
            return Err("a screenshot is being saved already".into());
        }
        let (Some(scene), Some(gpu)) = (&self.scene, &self.gpu) else {
            return Err("no volume is shown: there is nothing to save".into());
        };
        let [width, height] = self
            .central
            .pane_sizes()
            .first()
            .copied()
            .ok_or("nothing is drawn yet")?;
        let scale = scale.clamp(1, 16);
        let size = [width * scale, height * scale];
        if size.iter().any(|&side| side > 65_535) {
            return Err(format!(
                "{}x{} at {scale}× is more than a PNG of 65535 pixels a side",
                width, height
            ));
        }
        let (shot, channels) = self.current_shot();
        let volume = &scene.data.volume;
        let whole =
            egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(size[0] as f32, size[1] as f32));
        let rulers = self
            .view
            .rulers
            .iter()
            .filter_map(|ruler| {
                let project = |p| {
                    super::viewport::project(
                        &shot.camera,
                        volume.extent(),
                        volume.spacing,
                        whole,
                        p,
                    )
                };
                let (from, to) = project(ruler.from).zip(project(ruler.to))?;
                Some(RulerMark {
                    from: [from.x, from.y],
                    to: [to.x, to.y],
                    label: volume.with_unit(format!("{:.1}", ruler.length(volume.spacing))),
                })
            })
            .collect();
        let source = OffscreenSource::of_scene(scene);
        let job = ScaledScreenshot {
            device: gpu.offscreen.clone(),
            source,
            shot,
            channels: if scene.composite.is_some() {
                channels
            } else {
                Vec::new()
            },
            size,
            scale,
            rulers,
            axis_labels: super::central::axis_labels(scene),
            tile: self.screenshot_tile,
            path,
        };
        let wake = ctx.clone();
        self.jobs.screenshot = Some(spawn(job, move || wake.request_repaint()));
        Ok(())
    }
}
