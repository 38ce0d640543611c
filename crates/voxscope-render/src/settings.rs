//! What to draw, besides the camera: mode, level of detail, opacity handling, shading and
//! clipping.

use serde::{Deserialize, Serialize};

use voxscope_octree::Clip;

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
    /// Headlight Blinn-Phong shading of DVR (MIP is never shaded).
    #[serde(default)]
    pub shading: Shading,
    /// The crop box and clip plane every renderer and mode honors.
    #[serde(default)]
    pub clip: Clip,
}

/// Headlight Blinn-Phong shading for DVR: the light and the eye both lie along the ray, so the
/// half vector is the light direction and a surface facing the viewer is lit fully. Normals are
/// the gradient of the filtered volume (central differences half a voxel either side, `dense` and
/// `bricks`) or the face of the octree's node the ray enters through (`octree`, as the paper's
/// voxel cubes would be lit), two-sided. A sample's color `c` becomes
/// `mix(c, c · (ambient + diffuse · cos) + specular · cos^shininess, w)`, `cos` = |n · l|, where
/// the weight `w` = min(|∇v| / [`GRADIENT_FOR_FULL_SHADING`], 1) grows with the gradient's
/// magnitude, so homogeneous regions (noise around a constant, whose gradient has a random
/// direction) keep their plain color instead of speckle. docs/octree.md, "Shading", has the
/// exact rule.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Shading {
    /// Off draws the transfer function's colors as they are (the paper's picture).
    pub enabled: bool,
    /// The color's share that does not depend on the normal (0…1).
    pub ambient: f32,
    /// Lambert's share, times |n · l| (0…1).
    pub diffuse: f32,
    /// The white highlight's strength (0…1).
    pub specular: f32,
    /// The highlight's exponent: larger is smaller and sharper.
    pub shininess: f32,
}

/// The gradient magnitude at and above which a sample is shaded fully: 0.15 of the transfer
/// window's width per voxel (of the smallest spacing). Weaker gradients shade in proportion.
/// Chosen so that an edge (skin against air, bone against soft tissue: 0.3 or more) is shaded
/// fully and the noise of a homogeneous region of an MRI (0.02–0.05) barely. Keep in sync with
/// the shader's use of `shading_scale.w` (raycaster.rs).
pub const GRADIENT_FOR_FULL_SHADING: f32 = 0.15;

impl Shading {
    /// The parameters of [`Default`] (3D Slicer's volume-rendering defaults: ambient 0.1,
    /// diffuse 0.9, specular 0.2, power 10), switched off.
    pub const OFF: Self = Self {
        enabled: false,
        ambient: 0.1,
        diffuse: 0.9,
        specular: 0.2,
        shininess: 10.0,
    };

    /// Whether a frame with `settings` is drawn shaded: shading on, DVR, not the heat map.
    pub fn applies(settings: &RenderSettings) -> bool {
        settings.shading.enabled && settings.mode == RenderMode::Dvr && !settings.heatmap
    }
}

impl Default for Shading {
    /// On, with 3D Slicer's parameters (ambient 0.1, diffuse 0.9, specular 0.2, shininess 10):
    /// what users of volume-rendering tools expect to see.
    fn default() -> Self {
        Self {
            enabled: true,
            ..Self::OFF
        }
    }
}

impl RenderSettings {
    /// Full detail, opacity correction on, pixel LOD off, unshaded, unclipped.
    pub fn full_detail(depth: u32) -> Self {
        Self {
            mode: RenderMode::Dvr,
            max_level: depth,
            pixel_lod: false,
            opacity_correction: true,
            density: 1.0,
            heatmap: false,
            trilinear: true,
            shading: Shading::OFF,
            clip: Clip::NONE,
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
