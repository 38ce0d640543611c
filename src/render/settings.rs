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
