//! Procedural volumes for tests, demos and benchmarks: `synthetic:KIND:SIZE`, where SIZE is
//! `N` (a cube) or `XxYxZ`. Deterministic: the same spec always gives the same voxels.

use rayon::prelude::*;

use super::error::Problem;
use super::raw::parse_dims;
use super::{Scalar, Volume, checked_voxel_count};

/// The procedural volumes voxscope can make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SyntheticKind {
    /// A ball (u8): 0 outside, rising from 80 at the rim to 255 at the center.
    Sphere,
    /// Concentric shells (u16): alternating bands of 1000 and 0, for binary thresholds.
    Shells,
    /// Smooth value noise in about −1…1 (f32), a dense semi-transparent cloud.
    Noise,
    /// A linear ramp (u8) from 0 at the origin corner to 255 at the far corner.
    Gradient,
    /// A CT phantom of a chest (i16, Hounsfield units): a scanner's circular field of view
    /// (air, −1000) padded with −3024 outside it, a body of fat (−90) around soft tissue (45),
    /// two lungs (−900…−550), a spine (900), ribs (700) and a contrast-filled aorta (300), with a
    /// little noise. What a real CT looks like to the transfer function, without a CT file.
    Ct,
    /// A segmentation (u8 labels 0…12): a body (label 1) in a skin two voxels thick (7), a
    /// membrane across it about a voxel thick (10), and nine organs of different sizes
    /// (numbered out of order, so that neighbours' labels are far apart); 0 outside. What a tissue atlas looks
    /// like to the renderers: values that name, not measure.
    Labels,
}

impl SyntheticKind {
    pub const ALL: [SyntheticKind; 6] = [
        Self::Sphere,
        Self::Shells,
        Self::Noise,
        Self::Gradient,
        Self::Ct,
        Self::Labels,
    ];

    /// The name used in specs.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sphere => "sphere",
            Self::Shells => "shells",
            Self::Noise => "noise",
            Self::Gradient => "gradient",
            Self::Ct => "ct",
            Self::Labels => "labels",
        }
    }

    /// Makes a volume of this kind with the given dimensions.
    pub fn generate(self, dims: [usize; 3]) -> Result<Volume, Problem> {
        let count = checked_voxel_count(dims)?;
        let center = dims.map(|d| (d as f64 - 1.0) / 2.0);
        let radius = dims.iter().copied().min().unwrap_or(1) as f64 * 0.4;
        let position = |i: usize| {
            [
                (i % dims[0]) as f64,
                ((i / dims[0]) % dims[1]) as f64,
                (i / (dims[0] * dims[1])) as f64,
            ]
        };
        let distance = |p: [f64; 3]| {
            ((p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2) + (p[2] - center[2]).powi(2))
                .sqrt()
        };
        let data = match self {
            Self::Sphere => fill::<u8>(count, |i| {
                let r = distance(position(i)) / radius.max(0.5);
                if r <= 1.0 { 255.0 - 175.0 * r } else { 0.0 }
            }),
            Self::Shells => fill::<u16>(count, |i| {
                let r = distance(position(i)) / radius.max(0.5);
                let band = (r * 4.0).floor() as i64;
                if r <= 1.0 && band % 2 == 0 {
                    1000.0
                } else {
                    0.0
                }
            }),
            Self::Noise => fill::<f32>(count, |i| value_noise(position(i))),
            Self::Gradient => {
                let span = (dims[0] + dims[1] + dims[2]).saturating_sub(3).max(1) as f64;
                fill::<u8>(count, |i| {
                    let p = position(i);
                    255.0 * (p[0] + p[1] + p[2]) / span
                })
            }
            Self::Ct => fill::<i16>(count, |i| chest_phantom(position(i), dims)),
            Self::Labels => fill::<u8>(count, |i| tissue_labels(position(i), dims)),
        };
        Volume::new(
            format!(
                "synthetic:{}:{}x{}x{}",
                self.name(),
                dims[0],
                dims[1],
                dims[2]
            ),
            "synthetic",
            dims,
            [1.0; 3],
            data,
        )
        .map_err(|e| e.problem)
    }
}

/// Parses `KIND:SIZE` (the part after `synthetic:`) and generates the volume.
pub(crate) fn generate(spec: &str) -> Result<Volume, Problem> {
    let names = SyntheticKind::ALL.map(|k| k.name()).join(", ");
    let (kind_name, size) = spec
        .split_once(':')
        .ok_or_else(|| format!("synthetic spec needs KIND:SIZE (kinds: {names})"))?;
    let kind = SyntheticKind::ALL
        .into_iter()
        .find(|k| k.name() == kind_name)
        .ok_or_else(|| format!("unknown synthetic kind '{kind_name}' (kinds: {names})"))?;
    let dims =
        parse_dims(size).ok_or_else(|| format!("synthetic size '{size}' is not N or XxYxZ"))?;
    kind.generate(dims)
}

fn fill<T: Scalar>(count: usize, value: impl Fn(usize) -> f64 + Sync) -> super::VoxelData {
    T::wrap(
        (0..count)
            .into_par_iter()
            .map(|i| T::from_f64(value(i).round_if_integer::<T>()))
            .collect(),
    )
}

/// Rounds for integer targets so generated values are not truncated toward zero.
trait RoundForType {
    fn round_if_integer<T: Scalar>(self) -> f64;
}

impl RoundForType for f64 {
    fn round_if_integer<T: Scalar>(self) -> f64 {
        if T::TYPE.is_integer() {
            self.round()
        } else {
            self
        }
    }
}

/// The Hounsfield units of [`SyntheticKind::Ct`] at voxel `p` of a volume of `dims`.
fn chest_phantom(p: [f64; 3], dims: [usize; 3]) -> f64 {
    let [width, depth, height] = dims.map(|d| d.max(1) as f64);
    // Coordinates from the center, in units of the smaller of the two in-plane sides.
    let scale = width.min(depth);
    let x = (p[0] + 0.5 - width / 2.0) / scale;
    let y = (p[1] + 0.5 - depth / 2.0) / scale;
    let z = (p[2] + 0.5) / height;
    let ellipse =
        |cx: f64, cy: f64, rx: f64, ry: f64| ((x - cx) / rx).powi(2) + ((y - cy) / ry).powi(2);
    if x.hypot(y) > 0.48 {
        return -3024.0; // outside the scanner's field of view
    }
    let noise = 15.0 * hash_to_unit(p.map(|c| c as i64), 7);
    let body = ellipse(0.0, 0.0, 0.36, 0.26);
    if body >= 1.0 {
        return -1000.0 + noise;
    }
    let inner = ellipse(0.0, 0.0, 0.33, 0.23);
    let tissue = if inner >= 1.0 {
        -90.0 // subcutaneous fat
    } else if ellipse(0.0, 0.17, 0.05, 0.05) < 1.0 {
        900.0 // spine
    } else if ellipse(0.045, 0.10, 0.03, 0.03) < 1.0 {
        300.0 // aorta, with contrast
    } else if (inner.sqrt() - 0.93).abs() < 0.035 && (z * 6.0).fract() < 0.3 {
        700.0 // ribs: bands near the body wall
    } else if ellipse(-0.15, -0.01, 0.11, 0.15) < 1.0 || ellipse(0.15, -0.01, 0.11, 0.15) < 1.0 {
        // Lungs: parenchyma about −900…−550, textured like the airways and vessels in it.
        -720.0 + 240.0 * value_noise(p)
    } else {
        45.0 // soft tissue
    };
    tissue + noise
}

/// The label of [`SyntheticKind::Labels`] at voxel `p` of a volume of `dims`.
fn tissue_labels(p: [f64; 3], dims: [usize; 3]) -> f64 {
    // Coordinates from the center in units of each side, so the phantom fills any box.
    let q: [f64; 3] = std::array::from_fn(|a| (p[a] + 0.5) / dims[a].max(1) as f64 - 0.5);
    let inside = |center: [f64; 3], radii: [f64; 3]| {
        (0..3)
            .map(|a| ((q[a] - center[a]) / radii[a]).powi(2))
            .sum::<f64>()
            < 1.0
    };
    if !inside([0.0; 3], [0.45, 0.42, 0.46]) {
        return 0.0;
    }
    // Organs, the first that holds the point wins: labels deliberately not in order of place.
    let organs: [(f64, [f64; 3], [f64; 3]); 9] = [
        (12.0, [-0.2, -0.1, 0.15], [0.14, 0.12, 0.18]),
        (2.0, [0.2, -0.1, 0.15], [0.14, 0.12, 0.18]),
        (9.0, [0.0, 0.18, -0.05], [0.22, 0.1, 0.12]),
        (4.0, [-0.15, 0.05, -0.25], [0.1, 0.1, 0.1]),
        (11.0, [0.15, 0.05, -0.25], [0.1, 0.1, 0.1]),
        (6.0, [0.0, -0.25, -0.15], [0.06, 0.06, 0.2]),
        (3.0, [0.0, 0.0, 0.32], [0.08, 0.08, 0.06]),
        (8.0, [0.28, 0.2, 0.0], [0.05, 0.05, 0.3]),
        (5.0, [-0.28, 0.2, 0.0], [0.05, 0.05, 0.3]),
    ];
    if let Some((label, _, _)) = organs.iter().find(|(_, c, r)| inside(*c, *r)) {
        return *label;
    }
    // Two sheets a voxel or two thick: a membrane across the body and the skin, where any
    // blending of labels shows at once.
    let voxel = 1.0 / dims[2].max(1) as f64;
    if (q[2] - 0.05).abs() < 0.75 * voxel {
        return 10.0;
    }
    // The skin: two voxels thick along every axis.
    let skin: [f64; 3] = std::array::from_fn(|a| 2.0 / dims[a].max(1) as f64);
    if !inside([0.0; 3], [0.45 - skin[0], 0.42 - skin[1], 0.46 - skin[2]]) {
        return 7.0;
    }
    1.0
}

/// Two octaves of trilinear value noise on integer lattices (8 and 3 voxels apart).
fn value_noise(p: [f64; 3]) -> f64 {
    0.7 * lattice_noise(p, 8.0, 1) + 0.3 * lattice_noise(p, 3.0, 2)
}

fn lattice_noise(p: [f64; 3], cell: f64, seed: u64) -> f64 {
    let q = p.map(|c| c / cell);
    let base = q.map(|c| c.floor());
    let frac: [f64; 3] = std::array::from_fn(|a| {
        let t = q[a] - base[a];
        t * t * (3.0 - 2.0 * t) // smoothstep, so the noise has no visible lattice
    });
    let mut sum = 0.0;
    for corner in 0..8u32 {
        let offset = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let weight: f64 = (0..3)
            .map(|a| {
                if offset[a] == 1 {
                    frac[a]
                } else {
                    1.0 - frac[a]
                }
            })
            .product();
        let lattice = std::array::from_fn(|a| base[a] as i64 + offset[a] as i64);
        sum += weight * hash_to_unit(lattice, seed);
    }
    sum
}

/// A deterministic pseudo-random value in −1…1 for a lattice point.
fn hash_to_unit(point: [i64; 3], seed: u64) -> f64 {
    let mut h = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for c in point {
        h ^= (c as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = (h ^ (h >> 31)).wrapping_mul(0x94D0_49BB_1331_11EB);
    }
    h ^= h >> 29;
    (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}
