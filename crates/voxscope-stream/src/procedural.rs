//! Procedural pyramids generated lazily, brick by brick: `synthetic:noise:16384` is 8 TB of
//! 16-bit voxels that no disk holds, so a benchmark on it measures the renderer and not I/O.
//!
//! The field is fractal value noise: octave `k` is smooth (smoothstep-interpolated) noise on a
//! lattice `2^k` level-0 voxels apart, with an amplitude growing as √(2^k). Level `l` sums the
//! octaves of period `2^(l+1)` and more: the finer octaves average out over its voxels (each
//! covers `2^l` level-0 voxels), so each level looks like the 2× mean of the one below, as a
//! real pyramid's would, and every level has detail at its own resolution.

use super::pyramid::PyramidShape;
use crate::{BRICK_SIZE, BrickData, BrickError, BrickId, BrickSource, PADDED_BRICK, SourceError};
use voxscope_volume::Quantization;

/// Fractal value noise, 16-bit, of any size.
pub struct NoiseSource {
    name: String,
    shape: PyramidShape,
    /// Octaves 1…`octaves` (periods 2…2^octaves level-0 voxels).
    octaves: u32,
    /// 1 / (the octaves' combined amplitude): values spread over most of 0…1.
    normalization: f32,
}

impl NoiseSource {
    /// Noise of `dims` voxels (`name` is the spec, for messages).
    pub fn new(name: &str, dims: [usize; 3]) -> Result<Self, SourceError> {
        let shape = PyramidShape::new(dims).map_err(SourceError::shape(name))?;
        let octaves = shape.depth().max(1);
        let energy: f32 = (1..=octaves).map(amplitude).map(|a| a * a).sum();
        Ok(Self {
            name: name.to_owned(),
            shape,
            octaves,
            normalization: 1.0 / energy.sqrt(),
        })
    }
}

/// Octave `k`'s amplitude: √(2^k).
fn amplitude(k: u32) -> f32 {
    (2.0f32).powf(k as f32 * 0.5)
}

impl BrickSource for NoiseSource {
    fn name(&self) -> &str {
        &self.name
    }

    fn shape(&self) -> &PyramidShape {
        &self.shape
    }

    fn spacing(&self) -> [f64; 3] {
        [1.0; 3]
    }

    fn quantization(&self) -> Quantization {
        Quantization {
            offset: 0.0,
            step: 1.0 / 65535.0,
        }
    }

    fn max_value_level(&self) -> u16 {
        u16::MAX
    }

    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        let Some(level) = self.shape.levels.get(id.level as usize) else {
            return Err(BrickError::invalid(format!("{}: no {id}", self.name)));
        };
        if self.shape.key(id).is_none() {
            return Err(BrickError::invalid(format!("{}: no {id}", self.name)));
        }
        // Each padded voxel's center in level-0 voxels, per axis (clamped to the level).
        let centers: [Vec<f32>; 3] = std::array::from_fn(|axis| {
            let first = id.brick[axis] as usize * BRICK_SIZE;
            (0..PADDED_BRICK)
                .map(|i| {
                    let voxel = (first + i).saturating_sub(1).min(level.dims[axis] - 1);
                    (voxel as f32 + 0.5) * level.scale as f32
                })
                .collect()
        });
        let mut field = vec![0f32; PADDED_BRICK * PADDED_BRICK * PADDED_BRICK];
        for k in (id.level + 1).max(1)..=self.octaves {
            add_octave(&mut field, &centers, k, amplitude(k));
        }
        let levels = field
            .iter()
            .map(|&f| {
                let unit = (0.5 + 0.9 * f * self.normalization).clamp(0.0, 1.0);
                (unit * 65535.0).round() as u16
            })
            .collect();
        let inside = std::array::from_fn(|a| {
            level.dims[a].saturating_sub(id.brick[a] as usize * BRICK_SIZE)
        });
        Ok(BrickData::new(levels, inside))
    }
}

/// Per padded voxel along one axis: the lattice cell it is in (relative to the first one) and
/// its smoothstep weight towards the next lattice point.
struct AxisWeights {
    cell: Vec<usize>,
    weight: Vec<f32>,
    /// Lattice points spanned, from `first`.
    points: usize,
    first: i64,
}

fn axis_weights(centers: &[f32], period: f32) -> AxisWeights {
    let first = (centers[0] / period).floor() as i64;
    let (mut cell, mut weight) = (Vec::new(), Vec::new());
    for &c in centers {
        let u = c / period;
        let base = u.floor();
        let t = u - base;
        cell.push((base as i64 - first) as usize);
        weight.push(t * t * (3.0 - 2.0 * t));
    }
    let points = cell.iter().copied().max().unwrap_or(0) + 2;
    AxisWeights {
        cell,
        weight,
        points,
        first,
    }
}

/// Adds octave `k` (lattice `2^k` level-0 voxels apart, values in −1…1 times `amplitude`) at
/// the padded voxels whose centers along each axis are `centers`: the lattice values of the
/// brick's region once, then separable interpolation along x, y and z.
fn add_octave(field: &mut [f32], centers: &[Vec<f32>; 3], k: u32, amplitude: f32) {
    let period = (1u64 << k) as f32;
    let [wx, wy, wz] = [0, 1, 2].map(|a| axis_weights(&centers[a], period));
    let (nx, ny, nz) = (wx.points, wy.points, wz.points);
    let lattice: Vec<f32> = (0..nz)
        .flat_map(|z| (0..ny).flat_map(move |y| (0..nx).map(move |x| (x, y, z))))
        .map(|(x, y, z)| {
            amplitude
                * lattice_value(
                    [
                        wx.first + x as i64,
                        wy.first + y as i64,
                        wz.first + z as i64,
                    ],
                    k,
                )
        })
        .collect();
    let n = PADDED_BRICK;
    // Along x: [z][y][voxel x].
    let mut along_x = vec![0f32; nz * ny * n];
    for zy in 0..nz * ny {
        let row = &lattice[zy * nx..(zy + 1) * nx];
        for x in 0..n {
            let c = wx.cell[x];
            along_x[zy * n + x] = row[c] + (row[c + 1] - row[c]) * wx.weight[x];
        }
    }
    // Along y: [z][voxel y][voxel x].
    let mut along_y = vec![0f32; nz * n * n];
    for z in 0..nz {
        for y in 0..n {
            let c = wy.cell[y];
            let (low, high) = (
                &along_x[(z * ny + c) * n..(z * ny + c + 1) * n],
                &along_x[(z * ny + c + 1) * n..(z * ny + c + 2) * n],
            );
            let out = &mut along_y[(z * n + y) * n..(z * n + y + 1) * n];
            let w = wy.weight[y];
            for x in 0..n {
                out[x] = low[x] + (high[x] - low[x]) * w;
            }
        }
    }
    // Along z, into the field.
    for z in 0..n {
        let c = wz.cell[z];
        let w = wz.weight[z];
        let (low, high) = (
            &along_y[c * n * n..(c + 1) * n * n],
            &along_y[(c + 1) * n * n..(c + 2) * n * n],
        );
        let out = &mut field[z * n * n..(z + 1) * n * n];
        for i in 0..n * n {
            out[i] += low[i] + (high[i] - low[i]) * w;
        }
    }
}

/// A deterministic value in −1…1 for lattice point `p` of octave `k`.
fn lattice_value(p: [i64; 3], k: u32) -> f32 {
    let mut h = (k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for c in p {
        h ^= (c as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = (h ^ (h >> 31)).wrapping_mul(0x94D0_49BB_1331_11EB);
    }
    h ^= h >> 29;
    (h >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PADDED_BRICK_VOXELS;

    fn brick(source: &NoiseSource, level: u32, brick: [u32; 3]) -> BrickData {
        source
            .read_brick(BrickId {
                level,
                brick,
                channel: 0,
            })
            .expect("a brick of the pyramid")
    }

    #[test]
    fn bricks_are_deterministic_and_agree_at_their_aprons() {
        let source = NoiseSource::new("noise", [256; 3]).expect("source");
        let a = brick(&source, 0, [1, 2, 3]);
        assert_eq!(a.levels.len(), PADDED_BRICK_VOXELS);
        assert_eq!(a, brick(&source, 0, [1, 2, 3]));
        assert!(a.range.min < a.range.max, "noise varies within a brick");
        // The apron past x = 31 of brick x = 1 is voxel 0 of brick x = 2.
        let b = brick(&source, 0, [2, 2, 3]);
        let at = |x: usize, y: usize, z: usize| x + PADDED_BRICK * (y + PADDED_BRICK * z);
        for (y, z) in [(1, 1), (5, 9), (32, 32)] {
            assert_eq!(a.levels[at(33, y, z)], b.levels[at(1, y, z)]);
            assert_eq!(a.levels[at(32, y, z)], b.levels[at(0, y, z)]);
        }
        assert!(
            source
                .read_brick(BrickId {
                    level: 0,
                    brick: [8, 0, 0],
                    channel: 0,
                })
                .is_err()
        );
    }

    #[test]
    fn a_coarser_level_is_close_to_the_mean_of_the_finer() {
        let source = NoiseSource::new("noise", [128; 3]).expect("source");
        let fine = brick(&source, 0, [0, 0, 0]);
        let coarse = brick(&source, 1, [0, 0, 0]);
        let at = |x: usize, y: usize, z: usize| x + PADDED_BRICK * (y + PADDED_BRICK * z);
        let mut error = 0f64;
        let mut count = 0;
        for z in 0..16 {
            for y in 0..16 {
                for x in 0..16 {
                    let mut sum = 0f64;
                    for (dx, dy, dz) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
                        sum +=
                            fine.levels[at(1 + 2 * x + dx, 1 + 2 * y + dy, 1 + 2 * z + dz)] as f64;
                    }
                    error += (sum / 8.0 - coarse.levels[at(1 + x, 1 + y, 1 + z)] as f64).abs();
                    count += 1;
                }
            }
        }
        let mean_error = error / count as f64 / 65535.0;
        assert!(
            mean_error < 0.03,
            "mean |coarse − mean(fine)| = {mean_error}"
        );
    }
}
