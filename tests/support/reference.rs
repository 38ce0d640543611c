//! The CPU reference renderers, f64 throughout, that the GPU's images must match:
//!
//! - the octree's: exact ray–box intersections and a different traversal from the shader's
//!   (recursion, children sorted by entry distance), with the same compositing, skipping,
//!   level-of-detail, face-shading and clipping rules;
//! - a trilinear ray marcher for `dense` and `bricks`: the same sample positions
//!   (`t_enter + (k + jitter)·step`, one voxel apart, from the clipped entry, the pixel's
//!   jitter [`pixel_jitter`], the middle of the step for labels), the same filter (texel centers at voxel centers, clamped to the
//!   edge) over the levels as the GPU texture holds them, and the same gradient rule for
//!   shading; for a label volume ([`MarchVolume::into_labels`]) the nearest voxel's label, and
//!   MIP the first visible label.
//!
//! Each also reports the probe (`GpuProbe`): the point where the ray's opacity reaches
//! `PROBE_ALPHA` (DVR) or of its maximum (MIP).

use glam::DVec3;
use image::RgbaImage;
use voxscope_octree::{Octree, TransferFunction, unpack_rgba};
use voxscope_render::{
    Camera, EARLY_TERMINATION_ALPHA, GRADIENT_FOR_FULL_SHADING, PROBE_ALPHA, RenderMode,
    RenderSettings, Shading, ViewFrame,
};
use voxscope_volume::{Quantization, QuantizedVolume};

/// Where in its sample steps pixel (`x`, `y`) samples, in [0, 1): `pixel_jitter` of
/// ray_common.wgsl, the same integer hash.
pub fn pixel_jitter(x: u32, y: u32) -> f64 {
    let mut h = x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841);
    h = (h ^ (h >> 16)).wrapping_mul(0x7feb_352d);
    h = (h ^ (h >> 15)).wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    (h >> 8) as f64 / 16_777_216.0
}

/// The probe of one pixel as a CPU reference renderer finds it.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceProbe {
    /// The probed point in voxel space, if the ray got there.
    pub point: Option<DVec3>,
    /// How far the answer is from another one, so a test can tell a pixel where f32 arithmetic
    /// may pick a neighbouring sample from a wrong answer: DVR, the distance of the opacity
    /// before and after the crossing from `PROBE_ALPHA` (or of the final opacity, where the ray
    /// never gets there); the marcher's MIP, how close (in value
    /// levels) any filtered sample comes to rounding to the maximum's level or past it.
    /// Infinite where no such choice exists (the octree's MIP compares integer levels).
    pub margin: f64,
}

/// One pixel's ray in voxel space, and what the renderers share about a view.
struct View {
    frame: ViewFrame,
    extent: DVec3,
    spacing: DVec3,
    dims: DVec3,
    width: u32,
    height: u32,
}

impl View {
    fn new(dims: [usize; 3], spacing: [f64; 3], camera: &Camera, width: u32, height: u32) -> Self {
        let spacing = DVec3::from(spacing);
        let dims = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
        let extent = dims * spacing;
        Self {
            frame: camera.frame(extent.to_array(), width as f64 / height as f64),
            extent,
            spacing,
            dims,
            width,
            height,
        }
    }

    /// Origin, voxel-space direction and the direction's world length of pixel (`x`, `y`).
    fn ray(&self, x: u32, y: u32) -> (DVec3, DVec3, f64) {
        let (ndc_x, ndc_y) = ViewFrame::pixel_ndc(x, y, self.width, self.height);
        let world_dir = self.frame.ray_direction(ndc_x, ndc_y);
        let origin = (self.frame.eye + self.extent * 0.5) / self.spacing;
        (origin, world_dir / self.spacing, world_dir.length())
    }

    /// The entry (clamped to the eye) and exit of a ray through the volume's box, the crop
    /// box and the clip plane of `settings` (`volume_interval` in ray_common.wgsl).
    fn interval(&self, origin: DVec3, dir: DVec3, settings: &RenderSettings) -> (f64, f64) {
        let fractions = settings.clip.box_fractions();
        let low = DVec3::from_array(std::array::from_fn(|a| fractions[a][0] as f64)) * self.dims;
        let high = DVec3::from_array(std::array::from_fn(|a| fractions[a][1] as f64)) * self.dims;
        let (enter, leave) = box_interval(origin, dir, low, high);
        let (mut enter, mut leave) = (enter.max(0.0), leave);
        if let Some(plane) = settings.clip.plane {
            // n · p_normalized ≥ d with p_normalized = p / dims.
            let normal = DVec3::from_array(plane.normal.map(f64::from)) / self.dims;
            let facing = normal.dot(dir);
            let height = normal.dot(origin) - plane.distance as f64;
            if facing > 0.0 {
                enter = enter.max(-height / facing);
            } else if facing < 0.0 {
                leave = leave.min(-height / facing);
            } else if height < 0.0 {
                leave = -1.0;
            }
        }
        (enter, leave)
    }

    /// Smallest spacing ÷ each axis's spacing: voxel-space gradients to world ones.
    fn to_world(&self) -> DVec3 {
        DVec3::splat(self.spacing.min_element()) / self.spacing
    }

    /// Runs `trace` for every pixel (its ray and jitter) and writes its color.
    fn image(&self, trace: impl Fn(DVec3, DVec3, f64, f64) -> DVec3) -> RgbaImage {
        let mut image = RgbaImage::new(self.width, self.height);
        for y in 0..self.height {
            for x in 0..self.width {
                let (origin, dir, world_length) = self.ray(x, y);
                let rgb = trace(origin, dir, world_length, pixel_jitter(x, y));
                let to_byte = |c: f64| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
                image.put_pixel(
                    x,
                    y,
                    image::Rgba([to_byte(rgb.x), to_byte(rgb.y), to_byte(rgb.z), 255]),
                );
            }
        }
        image
    }
}

/// The shading rule of `ray_common.wgsl` (`shade_with`).
fn shade_with(shading: &Shading, rgb: DVec3, cosine: f64, weight: f64) -> DVec3 {
    let lit = rgb * (shading.ambient as f64 + shading.diffuse as f64 * cosine)
        + DVec3::splat(shading.specular as f64 * cosine.max(1e-6).powf(shading.shininess as f64));
    rgb + (lit - rgb) * weight
}

/// The weight scale of shading: 1 ÷ (the window's width in levels × the full-shading gradient).
fn shading_weight_scale(transfer: &TransferFunction, quantization: Quantization) -> f64 {
    let width = ((transfer.window.high - transfer.window.low) / quantization.step)
        .abs()
        .max(1.0);
    1.0 / (width * GRADIENT_FOR_FULL_SHADING as f64)
}

/// Renders `octree` (already recolored with `transfer`) on the CPU.
pub fn reference_render(
    octree: &Octree,
    spacing: [f64; 3],
    transfer: &TransferFunction,
    camera: &Camera,
    settings: &RenderSettings,
    width: u32,
    height: u32,
) -> RgbaImage {
    let view = View::new(octree.dims, spacing, camera, width, height);
    let lookup_table = transfer.lookup_table(octree.quantization);
    let scene = Scene::new(octree, &view, transfer, &lookup_table, settings);
    view.image(|origin, dir, world_length, _| scene.trace(&view, origin, dir, world_length).0)
}

/// The probe of pixel `pixel` of the octree's reference render.
pub fn reference_probe(
    octree: &Octree,
    spacing: [f64; 3],
    transfer: &TransferFunction,
    camera: &Camera,
    settings: &RenderSettings,
    size: (u32, u32),
    pixel: (u32, u32),
) -> ReferenceProbe {
    let view = View::new(octree.dims, spacing, camera, size.0, size.1);
    let lookup_table = transfer.lookup_table(octree.quantization);
    let scene = Scene::new(octree, &view, transfer, &lookup_table, settings);
    let (origin, dir, world_length) = view.ray(pixel.0, pixel.1);
    scene.trace(&view, origin, dir, world_length).1
}

struct Scene<'a> {
    octree: &'a Octree,
    /// MIP of a label volume: the first visible node's color (`first_label`).
    first_label: bool,
    lookup_table: &'a [u32],
    saturation: u16,
    settings: &'a RenderSettings,
    lod_factor: f64,
    shaded: bool,
    to_world: DVec3,
    weight_scale: f64,
}

struct Ray {
    origin: DVec3,
    dir: DVec3,
    /// World length of `dir`, for the pixel footprint.
    world_length: f64,
    t: f64,
    t_leave: f64,
    color: DVec3,
    alpha: f64,
    running_max: u16,
    /// The value level of the node the ray was in before (shading).
    previous_level: Option<f64>,
    probe_t: Option<f64>,
    margin: f64,
}

impl Ray {
    fn finished(&self, scene: &Scene) -> bool {
        match scene.settings.mode {
            _ if scene.first_label => self.alpha >= 1.0,
            RenderMode::Dvr => self.alpha >= EARLY_TERMINATION_ALPHA as f64,
            RenderMode::Mip => self.running_max >= scene.saturation,
        }
    }
}

/// Exact entry and exit distances of the ray through the box `[low, high]`.
fn box_interval(origin: DVec3, dir: DVec3, low: DVec3, high: DVec3) -> (f64, f64) {
    let mut t0 = f64::NEG_INFINITY;
    let mut t1 = f64::INFINITY;
    for axis in 0..3 {
        let (o, d) = (origin[axis], dir[axis]);
        if d == 0.0 {
            if o < low[axis] || o >= high[axis] {
                return (1.0, 0.0);
            }
            continue;
        }
        let a = (low[axis] - o) / d;
        let b = (high[axis] - o) / d;
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0, t1)
}

/// A node's value level for the shading step: the middle of its bounds, `otherwise` if empty.
fn node_level(bounds: voxscope_octree::ValueBounds, otherwise: Option<f64>) -> Option<f64> {
    if bounds.is_empty() {
        otherwise
    } else {
        Some(0.5 * (bounds.min() as f64 + bounds.max() as f64))
    }
}

impl<'a> Scene<'a> {
    fn new(
        octree: &'a Octree,
        view: &View,
        transfer: &TransferFunction,
        lookup_table: &'a [u32],
        settings: &'a RenderSettings,
    ) -> Self {
        Self {
            octree,
            first_label: octree.labels && settings.mode == RenderMode::Mip,
            lookup_table,
            saturation: transfer.saturation_level(octree.quantization),
            settings,
            lod_factor: (2.0 * view.frame.tan_half_fov_y / view.height as f64)
                / view.spacing.min_element(),
            shaded: Shading::applies(settings),
            to_world: view.to_world(),
            weight_scale: shading_weight_scale(transfer, octree.quantization),
        }
    }

    fn trace(
        &self,
        view: &View,
        origin: DVec3,
        dir: DVec3,
        world_length: f64,
    ) -> (DVec3, ReferenceProbe) {
        let (enter, leave) = view.interval(origin, dir, self.settings);
        let none = ReferenceProbe {
            point: None,
            margin: f64::INFINITY,
        };
        if enter >= leave {
            return (DVec3::ZERO, none);
        }
        let mut ray = Ray {
            origin,
            dir,
            world_length,
            t: enter,
            t_leave: leave,
            color: DVec3::ZERO,
            alpha: 0.0,
            running_max: 0,
            previous_level: None,
            probe_t: None,
            margin: f64::INFINITY,
        };
        self.visit(&mut ray, 0, 0, DVec3::ZERO, self.octree.side() as f64);
        let margin = match (self.settings.mode, ray.probe_t) {
            // The ray stayed below the probed opacity: by how much.
            (RenderMode::Dvr, None) => PROBE_ALPHA as f64 - ray.alpha,
            _ => ray.margin,
        };
        let probe = ReferenceProbe {
            point: ray.probe_t.map(|t| origin + t * dir),
            margin,
        };
        let color = match self.settings.mode {
            _ if self.first_label => ray.color,
            RenderMode::Dvr => ray.color,
            RenderMode::Mip => {
                let [r, g, b, _] = unpack_rgba(self.lookup_table[ray.running_max as usize]);
                DVec3::new(r as f64, g as f64, b as f64) / 255.0
            }
        };
        (color, probe)
    }

    fn visit(&self, ray: &mut Ray, index: usize, level: u32, corner: DVec3, size: f64) {
        if ray.finished(self) {
            return;
        }
        let (t0, t1) = box_interval(ray.origin, ray.dir, corner, corner + DVec3::splat(size));
        let start = t0.max(ray.t);
        let end = t1.min(ray.t_leave);
        if end <= start {
            return;
        }
        let node = self.octree.nodes[index];
        let bounds = self.octree.bounds[index];
        let mip = self.settings.mode == RenderMode::Mip && !self.first_label;
        let skip = if mip {
            bounds.is_empty() || bounds.max() <= ray.running_max
        } else {
            node.alpha() == 0
        };
        if skip {
            ray.previous_level = node_level(bounds, ray.previous_level);
            ray.t = end;
            return;
        }
        let cut = node.is_leaf()
            || level >= self.settings.max_level
            || (self.settings.pixel_lod && size <= start * ray.world_length * self.lod_factor);
        if cut {
            if mip {
                if bounds.max() > ray.running_max {
                    ray.probe_t = Some(0.5 * (start + end));
                }
                ray.running_max = ray.running_max.max(bounds.max());
            } else if self.first_label {
                let [r, g, b, _] = unpack_rgba(node.color).map(|c| c as f64 / 255.0);
                ray.color = DVec3::new(r, g, b);
                ray.alpha = 1.0;
                ray.probe_t = Some(start);
            } else {
                let [r, g, b, a] = unpack_rgba(node.color).map(|c| c as f64 / 255.0);
                let node_alpha = (a * self.settings.density as f64).min(1.0);
                let mut a = node_alpha;
                let voxels_per_t = ray.dir.length();
                if self.settings.opacity_correction && a < 1.0 {
                    a = 1.0 - (1.0 - a).powf((end - start) * voxels_per_t);
                }
                let mut rgb = DVec3::new(r, g, b);
                if self.shaded {
                    let here = node_level(bounds, ray.previous_level);
                    let step = match (here, ray.previous_level) {
                        (Some(here), Some(before)) => (here - before).abs(),
                        _ => 0.0,
                    };
                    rgb = self.shade_face(ray, corner, size, rgb, step);
                    ray.previous_level = here;
                }
                let alpha_before = ray.alpha;
                ray.color += (1.0 - ray.alpha) * a * rgb;
                ray.alpha += (1.0 - ray.alpha) * a;
                let probe_alpha = PROBE_ALPHA as f64;
                if ray.probe_t.is_none() && ray.alpha >= probe_alpha {
                    // Where in the node alpha reached it (continuous with opacity
                    // correction, else at the face), a thousandth of a voxel inside at least.
                    let mut t_cross = start;
                    if self.settings.opacity_correction && node_alpha < 1.0 {
                        let voxels = ((1.0 - probe_alpha) / (1.0 - alpha_before)).ln()
                            / (1.0 - node_alpha).ln();
                        t_cross = start + voxels.max(0.0) / voxels_per_t;
                    }
                    ray.probe_t = Some(t_cross.max(start + 1e-3 / voxels_per_t).min(end));
                    ray.margin = (probe_alpha - alpha_before).min(ray.alpha - probe_alpha);
                }
            }
            ray.t = end;
            return;
        }
        let half = size / 2.0;
        let mut children: Vec<(f64, usize, DVec3)> = (0..8)
            .filter_map(|child| {
                let offset = DVec3::new(
                    (child & 1) as f64,
                    ((child >> 1) & 1) as f64,
                    (child >> 2) as f64,
                );
                let child_corner = corner + offset * half;
                let (c0, c1) = box_interval(
                    ray.origin,
                    ray.dir,
                    child_corner,
                    child_corner + DVec3::splat(half),
                );
                (c1 > c0.max(start)).then_some((c0, child, child_corner))
            })
            .collect();
        children.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (_, child, child_corner) in children {
            self.visit(
                ray,
                node.first_child as usize + child,
                level + 1,
                child_corner,
                half,
            );
            if ray.finished(self) {
                return;
            }
        }
    }

    /// The octree's face shading (`shade_face` in raycast.wgsl): the normal of the face the ray
    /// enters the node by, weighted by the step of value levels across it.
    fn shade_face(&self, ray: &Ray, corner: DVec3, size: f64, rgb: DVec3, step: f64) -> DVec3 {
        let near = DVec3::from_array(std::array::from_fn(|axis| {
            let plane = corner[axis] + if ray.dir[axis] >= 0.0 { 0.0 } else { size };
            if ray.dir[axis] == 0.0 {
                f64::NEG_INFINITY
            } else {
                (plane - ray.origin[axis]) / ray.dir[axis]
            }
        }));
        let latest = near.max_element();
        let axis = if near.x >= latest {
            0
        } else if near.y >= latest {
            1
        } else {
            2
        };
        // |n · l| of the axis' face: the world direction's component along it.
        let world_dir = ray.dir / self.to_world;
        let cosine = (world_dir[axis].abs() / world_dir.length()).min(1.0);
        let weight = (step * self.to_world[axis] * self.weight_scale).min(1.0);
        shade_with(&self.settings.shading, rgb, cosine, weight)
    }
}

/// A volume as `dense` and `bricks` sample it: the value level of every voxel as the GPU's
/// texture holds it (exact when every level fits 8 bits, else rounded to half floats).
pub struct MarchVolume {
    pub dims: [usize; 3],
    levels: Vec<f64>,
    quantization: Quantization,
    /// Labels: sampled at the nearest voxel whatever the settings, MIP the first visible one.
    labels: bool,
}

impl MarchVolume {
    pub fn new(volume: &QuantizedVolume) -> Self {
        let eight_bit = volume.levels.iter().all(|&level| level <= 255);
        let levels = volume
            .levels
            .iter()
            .map(|&level| {
                if eight_bit {
                    level as f64
                } else {
                    half::f16::from_f32(level as f32).to_f64()
                }
            })
            .collect();
        Self {
            dims: volume.dims,
            levels,
            quantization: volume.quantization,
            labels: false,
        }
    }

    /// This volume's values as labels (categories), as the renderers draw a label volume.
    pub fn into_labels(self) -> Self {
        Self {
            labels: true,
            ..self
        }
    }

    fn voxel(&self, index: [i64; 3]) -> f64 {
        let clamped: [usize; 3] =
            std::array::from_fn(|a| index[a].clamp(0, self.dims[a] as i64 - 1) as usize);
        self.levels[clamped[0] + self.dims[0] * (clamped[1] + self.dims[1] * clamped[2])]
    }

    /// The filtered level at voxel-space point `p`: trilinear between voxel centers (or the
    /// nearest voxel), clamped to the edge, as a texture sampler does.
    fn sample(&self, p: DVec3, trilinear: bool) -> f64 {
        if !trilinear {
            return self.voxel(std::array::from_fn(|a| p[a].floor() as i64));
        }
        let u = p - DVec3::splat(0.5);
        let base = u.floor();
        let f = u - base;
        let mut value = 0.0;
        for corner in 0..8 {
            let offset = [corner & 1, (corner >> 1) & 1, corner >> 2];
            let weight: f64 = (0..3)
                .map(|a| if offset[a] == 1 { f[a] } else { 1.0 - f[a] })
                .product();
            if weight != 0.0 {
                value +=
                    weight * self.voxel(std::array::from_fn(|a| base[a] as i64 + offset[a] as i64));
            }
        }
        value
    }

    /// The gradient of the filtered levels at `p`: central differences half a voxel either side.
    fn gradient(&self, p: DVec3, trilinear: bool) -> DVec3 {
        DVec3::from_array(std::array::from_fn(|a| {
            let mut offset = DVec3::ZERO;
            offset[a] = 0.5;
            self.sample(p + offset, trilinear) - self.sample(p - offset, trilinear)
        }))
    }
}

/// Renders `volume` as `dense` does (and `bricks`, which takes the same samples), on the CPU.
pub fn reference_march(
    volume: &MarchVolume,
    spacing: [f64; 3],
    transfer: &TransferFunction,
    camera: &Camera,
    settings: &RenderSettings,
    width: u32,
    height: u32,
) -> RgbaImage {
    let view = View::new(volume.dims, spacing, camera, width, height);
    let marcher = Marcher::new(volume, &view, transfer, settings);
    view.image(|origin, dir, _, jitter| marcher.march(&view, origin, dir, jitter).0)
}

/// The probe of pixel `pixel` of the marcher's render.
pub fn reference_march_probe(
    volume: &MarchVolume,
    spacing: [f64; 3],
    transfer: &TransferFunction,
    camera: &Camera,
    settings: &RenderSettings,
    size: (u32, u32),
    pixel: (u32, u32),
) -> ReferenceProbe {
    let view = View::new(volume.dims, spacing, camera, size.0, size.1);
    let marcher = Marcher::new(volume, &view, transfer, settings);
    let (origin, dir, _) = view.ray(pixel.0, pixel.1);
    marcher
        .march(&view, origin, dir, pixel_jitter(pixel.0, pixel.1))
        .1
}

struct Marcher<'a> {
    volume: &'a MarchVolume,
    lookup_table: Vec<u32>,
    saturation: u16,
    settings: &'a RenderSettings,
    shaded: bool,
    to_world: DVec3,
    weight_scale: f64,
}

impl<'a> Marcher<'a> {
    fn new(
        volume: &'a MarchVolume,
        view: &View,
        transfer: &TransferFunction,
        settings: &'a RenderSettings,
    ) -> Self {
        Self {
            volume,
            lookup_table: transfer.lookup_table(volume.quantization),
            saturation: transfer.saturation_level(volume.quantization),
            settings,
            shaded: Shading::applies(settings),
            to_world: view.to_world(),
            weight_scale: shading_weight_scale(transfer, volume.quantization),
        }
    }

    fn march(
        &self,
        view: &View,
        origin: DVec3,
        dir: DVec3,
        jitter: f64,
    ) -> (DVec3, ReferenceProbe) {
        let mut probe = ReferenceProbe {
            point: None,
            margin: f64::INFINITY,
        };
        let (enter, leave) = view.interval(origin, dir, self.settings);
        if enter >= leave {
            return (DVec3::ZERO, probe);
        }
        let step = 1.0 / dir.length();
        // `ray_jitter` of ray_common.wgsl: labels are never dithered.
        let jitter = if self.volume.labels { 0.5 } else { jitter };
        let trilinear = self.settings.trilinear && !self.volume.labels;
        let first_label = self.volume.labels && self.settings.mode == RenderMode::Mip;
        let (mut color, mut alpha) = (DVec3::ZERO, 0.0);
        let mut running_max = 0u16;
        // MIP: every sample's filtered value, for the probe's margin; and whether the ray
        // stopped at the saturation level.
        let mut values: Vec<f64> = Vec::new();
        let mut saturated = false;
        let mut k = 0.0;
        loop {
            let t = enter + (k + jitter) * step;
            if t >= leave {
                break;
            }
            let p = origin + t * dir;
            let raw = self.volume.sample(p, trilinear);
            let level = raw.round().clamp(0.0, 65535.0) as u16;
            if first_label {
                let [r, g, b, a] = unpack_rgba(self.lookup_table[level as usize]);
                if a > 0 {
                    color = DVec3::new(r as f64, g as f64, b as f64) / 255.0;
                    probe.point = Some(p);
                    break;
                }
                k += 1.0;
                continue;
            }
            match self.settings.mode {
                RenderMode::Mip => {
                    values.push(raw);
                    if level > running_max {
                        probe.point = Some(p);
                    }
                    running_max = running_max.max(level);
                    if running_max >= self.saturation {
                        saturated = true;
                        break;
                    }
                }
                RenderMode::Dvr => {
                    let [r, g, b, a] =
                        unpack_rgba(self.lookup_table[level as usize]).map(|c| c as f64 / 255.0);
                    let a = (a * self.settings.density as f64).min(1.0);
                    let mut rgb = DVec3::new(r, g, b);
                    if self.shaded && a > 0.0 {
                        rgb = self.shade_sample(rgb, self.volume.gradient(p, trilinear), dir);
                    }
                    let alpha_before = alpha;
                    color += (1.0 - alpha) * a * rgb;
                    alpha += (1.0 - alpha) * a;
                    let probe_alpha = PROBE_ALPHA as f64;
                    if probe.point.is_none() && alpha >= probe_alpha {
                        probe.point = Some(p);
                        probe.margin = (probe_alpha - alpha_before).min(alpha - probe_alpha);
                    }
                    if alpha >= EARLY_TERMINATION_ALPHA as f64 {
                        break;
                    }
                }
            }
            k += 1.0;
        }
        if self.settings.mode == RenderMode::Dvr && probe.point.is_none() {
            // The ray stayed below the probed opacity: by how much.
            probe.margin = PROBE_ALPHA as f64 - alpha;
        }
        if self.settings.mode == RenderMode::Mip && !first_label {
            let [r, g, b, _] = unpack_rgba(self.lookup_table[running_max as usize]);
            color = DVec3::new(r as f64, g as f64, b as f64) / 255.0;
            // The answer is the first sample that rounds to the final maximum M: another
            // rounding of a sample near M − ½ (or, short of saturation, M + ½) could move it.
            let top = running_max as f64;
            let mut edges = vec![top - 0.5];
            if !saturated {
                edges.push(top + 0.5);
            }
            probe.margin = if probe.point.is_none() {
                f64::INFINITY
            } else {
                values
                    .iter()
                    .flat_map(|value| edges.iter().map(move |edge| (value - edge).abs()))
                    .fold(f64::INFINITY, f64::min)
            };
        }
        (color, probe)
    }

    /// `shade_sample` of ray_common.wgsl: the gradient's direction under the headlight,
    /// weighted by its magnitude in window widths per voxel of the smallest spacing.
    fn shade_sample(&self, rgb: DVec3, gradient: DVec3, dir: DVec3) -> DVec3 {
        let world_gradient = gradient * self.to_world;
        let magnitude = world_gradient.length();
        let weight = (magnitude * self.weight_scale).min(1.0);
        let world_dir = dir / self.to_world;
        let cosine = if magnitude > 0.0 {
            (world_gradient.dot(world_dir).abs() / (magnitude * world_dir.length())).min(1.0)
        } else {
            0.0
        };
        shade_with(&self.settings.shading, rgb, cosine, weight)
    }
}

/// Peak signal-to-noise ratio of two RGB images, in dB (infinite when identical).
pub fn psnr(a: &RgbaImage, b: &RgbaImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let mut squared = 0.0;
    let mut count = 0.0;
    for (p, q) in a.pixels().zip(b.pixels()) {
        for c in 0..3 {
            let d = p[c] as f64 - q[c] as f64;
            squared += d * d;
            count += 1.0;
        }
    }
    let mse = squared / count;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0 * 255.0 / mse).log10()
    }
}

/// Fraction of pixels that are not black.
pub fn coverage(image: &RgbaImage) -> f64 {
    let lit = image
        .pixels()
        .filter(|p| p[0] > 2 || p[1] > 2 || p[2] > 2)
        .count();
    lit as f64 / (image.width() * image.height()) as f64
}

/// One channel of [`reference_composite`]: its levels and its (tinted) lookup table.
pub struct CompositeChannel<'a> {
    pub volume: &'a MarchVolume,
    pub table: Vec<u32>,
}

/// The composite of channels as `composite.wgsl` draws it, on the CPU: the dense march's
/// samples; DVR sums the channels' premultiplied colors at each sample, opacity
/// 1 − Π(1 − αc), front to back; MIP adds the colors of each channel's maximum; clamped.
pub fn reference_composite(
    channels: &[CompositeChannel<'_>],
    spacing: [f64; 3],
    camera: &Camera,
    settings: &RenderSettings,
    width: u32,
    height: u32,
) -> RgbaImage {
    let view = View::new(channels[0].volume.dims, spacing, camera, width, height);
    let trilinear = settings.trilinear;
    view.image(|origin, dir, _, jitter| {
        let (enter, leave) = view.interval(origin, dir, settings);
        let mut maxima = vec![0u16; channels.len()];
        let (mut color, mut alpha) = (DVec3::ZERO, 0.0);
        if enter < leave {
            let step = 1.0 / dir.length();
            let mut k = 0.0;
            loop {
                let t = enter + (k + jitter) * step;
                if t >= leave {
                    break;
                }
                let p = origin + t * dir;
                let mut premultiplied = DVec3::ZERO;
                let mut transparency = 1.0;
                for (c, channel) in channels.iter().enumerate() {
                    let level = channel
                        .volume
                        .sample(p, trilinear)
                        .round()
                        .clamp(0.0, 65535.0) as u16;
                    maxima[c] = maxima[c].max(level);
                    let [r, g, b, a] =
                        unpack_rgba(channel.table[level as usize]).map(|v| v as f64 / 255.0);
                    let a = (a * settings.density as f64).min(1.0);
                    premultiplied += a * DVec3::new(r, g, b);
                    transparency *= 1.0 - a;
                }
                if settings.mode == RenderMode::Dvr {
                    color += (1.0 - alpha) * premultiplied;
                    alpha += (1.0 - alpha) * (1.0 - transparency);
                    if alpha >= EARLY_TERMINATION_ALPHA as f64 {
                        break;
                    }
                }
                k += 1.0;
            }
        }
        if settings.mode == RenderMode::Mip {
            color = channels
                .iter()
                .zip(&maxima)
                .map(|(channel, &level)| {
                    let [r, g, b, _] = unpack_rgba(channel.table[level as usize]);
                    DVec3::new(r as f64, g as f64, b as f64) / 255.0
                })
                .sum();
        }
        color.min(DVec3::ONE)
    })
}
