//! What a benchmark measures, as plain values: the volume, the image, the frames per case and
//! the settings every case shares. The command line's `bench` flags map into them.

use std::time::Duration;

use voxscope_octree::{Clip, OpacityMode};
use voxscope_render::{Camera, DEFAULT_BRICK_SIZE, RendererKind};
use voxscope_scene::{OpenOptions, TransferOptions};
use voxscope_stream::StreamOptions;
use voxscope_volume::ValueWindow;

use crate::error::BenchError;

/// What `voxscope bench` measures (the in-memory renderers' benchmark and the streaming
/// renderer's take the same options; each reads the ones that concern it).
#[derive(Debug, Clone, PartialEq)]
pub struct BenchOptions {
    /// The volume to open.
    pub open: OpenOptions,
    /// The image's width and height in pixels.
    pub size: (u32, u32),
    /// Timed frames per case; the azimuth sweeps a full turn over them.
    pub frames: u32,
    /// The cameras' azimuth in degrees (0: from the front): where each in-memory case's turn
    /// starts, and where the streaming benchmark's views look from and its orbits start.
    pub azimuth: f64,
    /// Binary threshold on the windowed value, 0…1.
    pub threshold: f32,
    /// Value window (default: the 0.5–99.5 percentiles).
    pub window: Option<ValueWindow>,
    /// Global opacity scale.
    pub density: f32,
    /// Max level of every in-memory case (default: the voxels).
    pub level: Option<u32>,
    /// Only this in-memory renderer (default: octree, dense and bricks).
    pub renderer: Option<RendererKind>,
    /// Voxels along a brick's side (the bricks renderer).
    pub brick_size: usize,
    /// Every case drawn clipped.
    pub clip: Clip,
    /// The streaming renderer's budgets.
    pub stream: StreamOptions,
    /// The streaming benchmark's orbits drawn at most this many frames a second (0: each as
    /// soon as the last is done).
    pub orbit_fps: f64,
    /// The composite of channels timed for each of these channel counts (1 to 8).
    pub composite_channels: Vec<usize>,
}

impl Default for BenchOptions {
    /// The command line's defaults (the streaming budgets: [`StreamOptions::default`]).
    fn default() -> Self {
        Self {
            open: OpenOptions::default(),
            size: (1024, 768),
            frames: 200,
            azimuth: Camera::default().azimuth_deg,
            threshold: 0.3,
            window: None,
            density: 1.0,
            level: None,
            renderer: None,
            brick_size: DEFAULT_BRICK_SIZE,
            clip: Clip::NONE,
            stream: StreamOptions::default(),
            orbit_fps: 0.0,
            composite_channels: Vec::new(),
        }
    }
}

impl BenchOptions {
    /// The checks both benchmarks make before anything is read.
    pub fn check(&self) -> Result<(), BenchError> {
        if self.frames == 0 {
            return Err(BenchError::NoFrames);
        }
        Ok(())
    }

    /// The camera at `distance` bounding-sphere radii: [`Camera::default`]'s elevation and
    /// field of view, at the options' azimuth.
    pub fn camera(&self, distance: f64) -> Camera {
        Camera {
            azimuth_deg: self.azimuth,
            distance,
            ..Camera::default()
        }
    }

    /// The transfer function the volume opens with: alpha = gray over the window, with the
    /// threshold of the binary cases; nothing else asked.
    pub fn transfer(&self) -> TransferOptions {
        TransferOptions {
            opacity: Some(OpacityMode::Gray),
            threshold: self.threshold,
            window: self.window,
            ..TransferOptions::default()
        }
    }
}

/// How long a stopped view may take to complete before the benchmark says it did not.
pub const MAX_WAIT: Duration = Duration::from_secs(20);

/// The medium camera's distance in bounding-sphere radii: the streaming benchmark's first
/// image, stopped view and orbit.
pub(crate) const MEDIUM: f64 = 3.0;

/// The paper's three cases: near, medium and far, in bounding-sphere radii.
pub(crate) const CAMERAS: [(&str, f64); 3] = [("near", 1.5), ("medium", MEDIUM), ("far", 6.0)];
