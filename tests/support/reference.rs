//! The CPU reference renderer: f64 throughout, exact ray–box intersections, and a different
//! traversal from the shader's (recursion, children sorted by entry distance), with the same
//! compositing, skipping and level-of-detail rules. GPU images must match it.

use glam::DVec3;
use image::RgbaImage;
use voxscope::octree::{Octree, TransferFunction, unpack_rgba};
use voxscope::render::{Camera, EARLY_TERMINATION_ALPHA, RenderMode, RenderSettings, ViewFrame};

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
    let spacing = DVec3::from(spacing);
    let dims = DVec3::new(
        octree.dims[0] as f64,
        octree.dims[1] as f64,
        octree.dims[2] as f64,
    );
    let extent = dims * spacing;
    let frame = camera.frame(extent.to_array(), width as f64 / height as f64);
    let lookup_table = transfer.lookup_table(octree.quantization);
    let scene = Scene {
        octree,
        dims,
        lookup_table: &lookup_table,
        saturation: transfer.saturation_level(octree.quantization),
        settings,
        lod_factor: (2.0 * frame.tan_half_fov_y / height as f64) / spacing.min_element(),
    };
    let mut image = RgbaImage::new(width, height);
    for y in 0..height {
        for x in 0..width {
            let (ndc_x, ndc_y) = ViewFrame::pixel_ndc(x, y, width, height);
            let world_dir = frame.ray_direction(ndc_x, ndc_y);
            let origin = (frame.eye + extent * 0.5) / spacing;
            let dir = world_dir / spacing;
            let rgb = scene.trace(origin, dir, world_dir.length());
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

struct Scene<'a> {
    octree: &'a Octree,
    dims: DVec3,
    lookup_table: &'a [u32],
    saturation: u16,
    settings: &'a RenderSettings,
    lod_factor: f64,
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
}

impl Ray {
    fn finished(&self, scene: &Scene) -> bool {
        match scene.settings.mode {
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

impl Scene<'_> {
    fn trace(&self, origin: DVec3, dir: DVec3, world_length: f64) -> DVec3 {
        let (enter, leave) = box_interval(origin, dir, DVec3::ZERO, self.dims);
        let enter = enter.max(0.0);
        if enter >= leave {
            return DVec3::ZERO;
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
        };
        self.visit(&mut ray, 0, 0, DVec3::ZERO, self.octree.side() as f64);
        match self.settings.mode {
            RenderMode::Dvr => ray.color,
            RenderMode::Mip => {
                let [r, g, b, _] = unpack_rgba(self.lookup_table[ray.running_max as usize]);
                DVec3::new(r as f64, g as f64, b as f64) / 255.0
            }
        }
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
        let mip = self.settings.mode == RenderMode::Mip;
        let skip = if mip {
            bounds.is_empty() || bounds.max() <= ray.running_max
        } else {
            node.alpha() == 0
        };
        if skip {
            ray.t = end;
            return;
        }
        let cut = node.is_leaf()
            || level >= self.settings.max_level
            || (self.settings.pixel_lod && size <= start * ray.world_length * self.lod_factor);
        if cut {
            if mip {
                ray.running_max = ray.running_max.max(bounds.max());
            } else {
                let [r, g, b, a] = unpack_rgba(node.color).map(|c| c as f64 / 255.0);
                let mut a = (a * self.settings.density as f64).min(1.0);
                if self.settings.opacity_correction && a < 1.0 {
                    a = 1.0 - (1.0 - a).powf((end - start) * ray.dir.length());
                }
                ray.color += (1.0 - ray.alpha) * a * DVec3::new(r, g, b);
                ray.alpha += (1.0 - ray.alpha) * a;
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
