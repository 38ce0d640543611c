//! What to draw, besides the camera: mode, level of detail, opacity handling.

use serde::{Deserialize, Serialize};

/// A ray stops once its accumulated opacity reaches this (early ray termination).
/// Keep in sync with `EARLY_TERMINATION_ALPHA` in `raycast.wgsl`.
pub const EARLY_TERMINATION_ALPHA: f32 = 0.99;

/// Direct volume rendering or maximum intensity projection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RenderMode {
    /// Front-to-back compositing of node colors.
    Dvr,
    /// Maximum intensity projection: the largest value along the ray.
    Mip,
}

/// Rendering choices that are not the transfer function or the camera.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    pub mode: RenderMode,
    /// Deepest level a ray descends to: 0 draws the root alone, `depth` the voxels.
    pub max_level: u32,
    /// Also stop where a node's projection is smaller than a pixel (the paper's per-pixel LOD).
    pub pixel_lod: bool,
    /// Correct a node's alpha for the distance the ray travels in it:
    /// `1 − (1 − α)^(length / voxel size)`. Off gives the paper's plain compositing.
    pub opacity_correction: bool,
    /// Global opacity scale, multiplied into every node's alpha.
    pub density: f32,
    /// Draw how many nodes each ray visited instead of the image.
    pub heatmap: bool,
    /// Renderers that sample textures (`dense`) filter trilinearly; off samples the nearest
    /// voxel. The octree always draws whole nodes.
    pub trilinear: bool,
}

impl RenderSettings {
    /// Full detail, opacity correction on, pixel LOD off.
    pub fn full_detail(depth: u32) -> Self {
        Self {
            mode: RenderMode::Dvr,
            max_level: depth,
            pixel_lod: false,
            opacity_correction: true,
            density: 1.0,
            heatmap: false,
            trilinear: true,
        }
    }
}

/// The heat map's color for a ray that visited `work` nodes (or samples): an inferno-like ramp
/// over `log2(1 + work) / 10`, so 0 is black and 1023 or more is pale yellow. The app draws its
/// legend from this; keep in sync with `heat` and `write_pixel` in `ray_common.wgsl`.
pub fn heatmap_color(work: u32) -> [u8; 3] {
    let x = ((1.0 + work as f32).log2() / 10.0).clamp(0.0, 1.0);
    let stops = [
        [0.0, 0.0, 0.02],
        [0.47, 0.07, 0.43],
        [0.93, 0.41, 0.13],
        [0.99, 0.99, 0.64],
    ];
    let (from, to, f) = if x < 0.33 {
        (stops[0], stops[1], x / 0.33)
    } else if x < 0.66 {
        (stops[1], stops[2], (x - 0.33) / 0.33)
    } else {
        (stops[2], stops[3], (x - 0.66) / 0.34)
    };
    std::array::from_fn(|c| ((from[c] + (to[c] - from[c]) * f) * 255.0).round() as u8)
}

/// Work per ray at which the heat map reaches its brightest color.
pub const HEATMAP_SATURATION: u32 = 1023;
