//! A pane's images: its full-resolution render target, shown as an egui texture and drawn
//! again only when what it shows changed; and, where the device is too slow to draw that
//! whole within a UI frame's budget (`pacing.rs`), a smaller preview of the newest view shown
//! while the full image is drawn into the target band by band.

use egui::{Color32, Rect, Ui, pos2};

use super::super::viewport::DrawKey;
use voxscope_render::{GpuContext, RenderTarget};

/// A render target with its egui texture.
pub struct Shown {
    pub target: RenderTarget,
    pub texture: egui::TextureId,
}

impl Shown {
    /// A target of `size` registered with egui-wgpu (replacing `old`'s, reusing its id).
    fn new(
        gpu: &GpuContext,
        egui_renderer: &mut egui_wgpu::Renderer,
        size: [u32; 2],
        old: Option<egui::TextureId>,
    ) -> Self {
        let target = RenderTarget::new(gpu, size[0], size[1]);
        let texture = match old {
            Some(id) => {
                egui_renderer.update_egui_texture_from_wgpu_texture(
                    &gpu.device,
                    &target.view,
                    wgpu::FilterMode::Linear,
                    id,
                );
                id
            }
            None => egui_renderer.register_native_texture(
                &gpu.device,
                &target.view,
                wgpu::FilterMode::Linear,
            ),
        };
        Self { target, texture }
    }
}

/// A lower-resolution image of a view newer than the target's.
pub struct Preview {
    pub image: Shown,
    /// The view it shows (at the full size: the key the full image will have).
    pub key: DrawKey,
}

/// The full image of `key` being drawn into the target, rows `0..next_row` done.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Banding {
    pub key: DrawKey,
    pub next_row: u32,
    /// Bands drawn so far.
    pub bands: u32,
}

/// One pane of the central view.
#[derive(Default)]
pub struct Pane {
    /// The full-resolution image.
    pub full: Option<Shown>,
    /// What `full` holds, complete (`None` while it is being drawn in bands).
    pub drawn: Option<DrawKey>,
    /// Shown instead of `full` while it is newer.
    pub preview: Option<Preview>,
    /// The full image being drawn band by band.
    pub banding: Option<Banding>,
}

impl Pane {
    /// The full-resolution target, if the pane has one.
    pub fn target(&self) -> Option<&RenderTarget> {
        self.full.as_ref().map(|s| &s.target)
    }

    /// Makes sure the full target has `size` pixels and egui knows it; returns true when it
    /// was (re)created (what it showed is gone).
    pub fn ensure_size(
        &mut self,
        gpu: &GpuContext,
        egui_renderer: &mut egui_wgpu::Renderer,
        size: [u32; 2],
    ) -> bool {
        if self
            .full
            .as_ref()
            .is_some_and(|s| [s.target.width, s.target.height] == size)
        {
            return false;
        }
        let old = self.full.take().map(|s| s.texture);
        self.full = Some(Shown::new(gpu, egui_renderer, size, old));
        self.drawn = None;
        self.banding = None;
        true
    }

    /// The preview target at `size`, for `key` (created or resized as needed).
    pub fn preview_target(
        &mut self,
        gpu: &GpuContext,
        egui_renderer: &mut egui_wgpu::Renderer,
        size: [u32; 2],
        key: DrawKey,
    ) -> &RenderTarget {
        let fits = self
            .preview
            .as_ref()
            .is_some_and(|p| [p.image.target.width, p.image.target.height] == size);
        if !fits {
            let old = self.preview.take().map(|p| p.image.texture);
            self.preview = Some(Preview {
                image: Shown::new(gpu, egui_renderer, size, old),
                key,
            });
        }
        let preview = self.preview.as_mut().expect("made above");
        preview.key = key;
        &preview.image.target
    }

    /// The view the pane shows or is drawing: the band's, else the preview's, else the full
    /// image's (what a click in it is about).
    pub fn latest_key(&self) -> Option<DrawKey> {
        self.banding
            .map(|b| b.key)
            .or(self.preview.as_ref().map(|p| p.key))
            .or(self.drawn)
    }

    /// Whether the pane shows `key` at full resolution.
    pub fn shows(&self, key: &DrawKey) -> bool {
        self.drawn.as_ref() == Some(key) && self.preview.is_none()
    }

    /// The image shown: the preview while there is one, else the full image.
    pub fn shown(&self) -> Option<&Shown> {
        self.preview
            .as_ref()
            .map(|p| &p.image)
            .or(self.full.as_ref())
    }

    /// Gives the textures back to egui-wgpu.
    pub fn release(&mut self, egui_renderer: &mut egui_wgpu::Renderer) {
        for shown in [self.full.take(), self.preview.take().map(|p| p.image)]
            .into_iter()
            .flatten()
        {
            egui_renderer.free_texture(&shown.texture);
        }
        self.drawn = None;
        self.banding = None;
    }

    /// Paints the image shown into `rect`. What the targets hold by the time egui renders this
    /// frame is shown: panes are drawn later in the same frame, before egui's render pass.
    pub fn paint(&self, ui: &Ui, rect: Rect) {
        if let Some(shown) = self.shown() {
            let uv = Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0));
            ui.painter().image(shown.texture, rect, uv, Color32::WHITE);
        }
    }
}
