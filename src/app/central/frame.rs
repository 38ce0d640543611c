//! What one UI frame of the central view is drawn from and into: its inputs (settings, view,
//! the panes' transfer functions), the pass recorder and the budget as it is spent
//! (`draw.rs` fills them; `volume_work.rs` records a 3D pane's share), and a 3D pane's view.

use std::time::Duration;

use super::super::settings::AppSettings;
use super::super::view_state::ViewState;
use super::super::viewport::DrawKey;
use super::Measured;
use super::pacing::Work;
use voxscope_octree::TransferFunction;
use voxscope_render::{Camera, GpuContext, RenderSettings};

/// The transfer functions of a UI frame's panes.
pub(super) struct PaneLooks {
    /// The 3D panes' (but the transfer pair's second).
    pub main: TransferFunction,
    /// The transfer pair's second pane's.
    pub compare: TransferFunction,
    /// The slices': channel 0's while the composite is shown.
    pub slices: TransferFunction,
    /// The composite's table generation (0 when one channel is drawn).
    pub layers: u64,
}

/// What every pane of one UI frame is drawn from.
pub(super) struct FrameInputs<'a> {
    pub settings: &'a AppSettings,
    pub view: &'a ViewState,
    /// The scene's serial (it changes with every new scene) and depth.
    pub serial: u64,
    pub depth: u32,
    /// Panes in the layout.
    pub panes: usize,
    pub looks: PaneLooks,
    /// The streaming renderer's frame, where the scene is streamed.
    pub stream_frame: Option<u32>,
    /// The stream's page table changed: every 3D pane is drawn again.
    pub stream_changed: bool,
    /// The whole UI frame's budget.
    pub full_budget: Duration,
}

/// Where a UI frame's passes are recorded: the device, the frame's one command encoder, and
/// egui's renderer (which registers the preview targets' textures).
pub(super) struct PassRecorder<'a> {
    pub context: &'a GpuContext,
    pub encoder: wgpu::CommandEncoder,
    pub egui_renderer: &'a mut egui_wgpu::Renderer,
}

/// A UI frame's drawing as it goes from pane to pane: its passes, the budget left, and what
/// it drew and measured.
pub(super) struct FrameDrawing<'a> {
    pub recorder: PassRecorder<'a>,
    /// What is left of the frame budget.
    pub budget: Duration,
    /// Pixels drawn of whole frames and previews.
    pub pixels: u64,
    /// The band drawn, if one was.
    pub band: Option<Work>,
    /// Anything was drawn.
    pub drew: bool,
    /// The pass the frame probe measures.
    pub measured: Option<Measured>,
    /// The streaming renderer still refines the view (or a pane shows a new view of it).
    pub refining: bool,
}

impl FrameDrawing<'_> {
    /// Counts a pass of `pixels` drawn, which the pacer estimates to take `estimate`: a band
    /// takes the rest of the budget, an image what it is estimated to cost (the whole budget
    /// where nothing was measured yet).
    pub fn count(&mut self, pixels: u64, estimate: Option<Duration>, full_budget: Duration) {
        self.pixels += pixels;
        self.budget = if self.band.is_some() {
            Duration::ZERO
        } else {
            self.budget.saturating_sub(estimate.unwrap_or(full_budget))
        };
        self.drew = true;
    }

    /// What the pacer is told the submission holds.
    pub fn work(&self) -> Work {
        match self.band {
            Some(band) => band,
            None if self.pixels > 0 => Work::Images {
                pixels: self.pixels,
            },
            None => Work::Other,
        }
    }
}

/// A 3D pane's view: its key, and the key's parts the drawing reads.
#[derive(Debug, Clone, Copy)]
pub struct VolumeView {
    pub key: DrawKey,
    /// The full image's pixel size.
    pub size: [u32; 2],
    pub camera: Camera,
    pub settings: RenderSettings,
    pub transfer: TransferFunction,
    /// The pane's max level.
    pub level: u32,
}

impl VolumeView {
    /// Pixels of the full image.
    pub fn full_pixels(&self) -> u64 {
        self.size[0] as u64 * self.size[1] as u64
    }
}
