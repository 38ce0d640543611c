//! What the app remembers between runs (eframe persistence, stored as RON): the transfer
//! function's choices, render settings, camera, layout, renderer, recent files.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use voxscope_octree::{Clip, Colormap, OpacityMode, TransferFunction};
use voxscope_render::{
    Camera, DEFAULT_BRICK_SIZE, RenderMode, RenderSettings, RendererKind, RendererOptions, Shading,
};
use voxscope_scene::TransferChoice;

/// The key under which eframe stores [`AppSettings`].
pub const STORAGE_KEY: &str = "voxscope.settings";

/// Recent files kept in File ▸ Open recent.
pub const RECENT_LIMIT: usize = 10;

/// How the central panel is split.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Layout {
    /// One view.
    Single,
    /// 2–6 panes, one octree level each, same camera (the paper's Figure 3).
    LevelGrid,
    /// Two panes, two transfer functions, same camera.
    TransferPair,
    /// The 3D view beside axial, coronal and sagittal slices, all sharing one cursor.
    Slices,
}

impl Layout {
    pub const ALL: [Self; 4] = [
        Self::Single,
        Self::LevelGrid,
        Self::TransferPair,
        Self::Slices,
    ];

    /// The toolbar's name: `Single`, `Level grid`, `Transfer pair`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Single => "Single",
            Self::LevelGrid => "Level grid",
            Self::TransferPair => "Transfer pair",
            Self::Slices => "Slices",
        }
    }

    /// The View menu's longer name.
    pub fn description(self) -> &'static str {
        match self {
            Self::Single => "Single view",
            Self::LevelGrid => "Level grid (compare levels)",
            Self::TransferPair => "Transfer pair (compare settings)",
            Self::Slices => "Slices (3D, axial, coronal, sagittal)",
        }
    }
}

/// The side panels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Panel {
    /// Left: the transfer function.
    Transfer,
    /// Right: the octree, renderer and numbers.
    Octree,
    /// A window: keyframes and movie export.
    Movie,
}

impl Panel {
    pub const ALL: [Self; 3] = [Self::Transfer, Self::Octree, Self::Movie];

    /// The View menu's name for it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Transfer => "Transfer function panel",
            Self::Octree => "Octree panel",
            Self::Movie => "Movie panel",
        }
    }
}

/// Everything persisted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AppSettings {
    /// The transfer function's choices as the panel shows them (its window is the volume's,
    /// in [`super::ViewState`]).
    pub transfer: TransferChoice,
    /// The transfer function the user pinned ("Keep for the next volumes" in the Transfer
    /// function panel), kept up to date with the panel while pinned: the next volume opens
    /// with it instead of what fits its data. `None`: every volume opens with its own.
    pub pinned_transfer: Option<TransferFunction>,
    /// The second transfer function of [`Layout::TransferPair`].
    pub compare_transfer: TransferChoice,
    pub mode: RenderMode,
    pub density: f32,
    /// Gradient (headlight Blinn-Phong) shading of DVR.
    pub shading: Shading,
    pub pixel_lod: bool,
    pub opacity_correction: bool,
    pub trilinear: bool,
    pub heatmap: bool,
    pub renderer: RendererKind,
    pub brick_size: usize,
    /// GPU memory the streaming renderer may hold, in bytes (its atlas, page table, buffers).
    pub stream_gpu_memory: u64,
    pub camera: Camera,
    pub layout: Layout,
    /// Panes of the level grid, 2…6.
    pub grid_panes: usize,
    /// Where a frame is too slow for one UI frame, show a lower-resolution preview of it while
    /// its full image is drawn band by band (off: the bands alone).
    pub fast_interaction: bool,
    /// Re-render every frame (to watch sustained frame rate) instead of only on change.
    pub continuous: bool,
    pub show_transfer_panel: bool,
    pub show_octree_panel: bool,
    /// The Movie panel (keyframes, preview, export).
    pub show_movie_panel: bool,
    /// What a click in a view does.
    pub tool: Tool,
    /// Slices sample linearly (else the nearest voxel).
    pub slice_linear: bool,
    /// The 3D view of the Slices layout shows the three slice planes in place.
    pub show_slice_planes: bool,
    /// Frames a second when playing a time series.
    pub frame_rate: f32,
    /// Frames of an in-memory time series kept loaded ahead of the one on screen (0 to
    /// [`voxscope_scene::MAX_PREFETCH_FRAMES`]; 0 loads each frame when it is asked for).
    pub prefetch_frames: usize,
    /// Most recent first.
    pub recent: Vec<String>,
    /// The folder of the last screenshot or transfer function saved: save dialogs start there
    /// (the data's folder is where volumes are, not where pictures go).
    pub last_save_folder: Option<PathBuf>,
}

/// Pane B of the transfer pair until the user sets it: binary at 0.3 of the window.
pub const DEFAULT_COMPARE_TRANSFER: TransferChoice = TransferChoice {
    opacity: OpacityMode::Binary,
    threshold: 0.3,
    colormap: Colormap::Grays,
};

/// What a click or drag in a view does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Tool {
    /// Orbit, pan and zoom; a click moves the cursor.
    Navigate,
    /// Drag in a slice, or click two points in the 3D view, to measure a distance.
    Ruler,
}

impl Default for AppSettings {
    fn default() -> Self {
        Self {
            transfer: TransferChoice {
                opacity: OpacityMode::Gray,
                threshold: 0.3,
                colormap: Colormap::Grays,
            },
            pinned_transfer: None,
            compare_transfer: DEFAULT_COMPARE_TRANSFER,
            mode: RenderMode::Dvr,
            density: 1.0,
            shading: Shading::default(),
            pixel_lod: false,
            opacity_correction: true,
            trilinear: true,
            heatmap: false,
            renderer: RendererKind::Octree,
            brick_size: DEFAULT_BRICK_SIZE,
            stream_gpu_memory: RendererOptions::default().gpu_memory,
            camera: Camera::default(),
            layout: Layout::Single,
            grid_panes: 4,
            fast_interaction: true,
            continuous: false,
            show_transfer_panel: true,
            show_octree_panel: true,
            show_movie_panel: false,
            tool: Tool::Navigate,
            slice_linear: false,
            show_slice_planes: true,
            frame_rate: 4.0,
            prefetch_frames: voxscope_scene::DEFAULT_PREFETCH_FRAMES,
            recent: Vec::new(),
            last_save_folder: None,
        }
    }
}

impl AppSettings {
    /// What the 3D views draw with, at level `max_level` clipped by `clip` (those two belong
    /// to the volume on screen, in [`super::ViewState`]).
    pub fn render_settings(&self, max_level: u32, clip: Clip) -> RenderSettings {
        RenderSettings {
            mode: self.mode,
            max_level,
            pixel_lod: self.pixel_lod,
            opacity_correction: self.opacity_correction,
            density: self.density,
            heatmap: self.heatmap,
            trilinear: self.trilinear,
            shading: self.shading,
            clip,
        }
    }

    /// Whether the side panel `panel` is shown.
    pub fn panel_shown(&self, panel: Panel) -> bool {
        match panel {
            Panel::Transfer => self.show_transfer_panel,
            Panel::Octree => self.show_octree_panel,
            Panel::Movie => self.show_movie_panel,
        }
    }

    /// Shows `panel` if hidden, hides it if shown.
    pub fn toggle_panel(&mut self, panel: Panel) {
        match panel {
            Panel::Transfer => self.show_transfer_panel ^= true,
            Panel::Octree => self.show_octree_panel ^= true,
            Panel::Movie => self.show_movie_panel ^= true,
        }
    }

    /// Puts `source` first in the recent list (once), keeping at most [`RECENT_LIMIT`]. A
    /// URL is kept without user name, password or query (nothing secret is saved).
    pub fn remember(&mut self, source: &str) {
        let shown;
        let source = if voxscope_volume::remote::is_url(source) {
            shown = voxscope_volume::remote::redact_url(source);
            shown.as_str()
        } else {
            source
        };
        self.recent.retain(|s| s != source);
        self.recent.insert(0, source.to_owned());
        self.recent.truncate(RECENT_LIMIT);
    }
}
