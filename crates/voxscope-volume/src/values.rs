//! Value statistics: the data's range, a 16-bit quantization of every voxel (what the octree
//! keeps per node), the histogram, and the value window that maps data units to 0…1.

use rayon::prelude::*;

use super::error::OptionError;
use super::{Scalar, ValueScale, Volume};
use crate::with_voxel_slice;

/// Number of quantization levels (and histogram bins): the octree stores 16-bit levels.
pub const LEVELS: usize = 1 << 16;

/// Maps a 16-bit level to a value in the data's own units: `value = offset + level * step`.
///
/// Integer data whose range spans at most 65 536 values gets `step = |slope|`, so every
/// stored value has its own level and nothing is lost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantization {
    pub offset: f64,
    pub step: f64,
}

impl Quantization {
    /// The value of `level` in data units.
    #[inline]
    pub fn value(self, level: u16) -> f64 {
        self.offset + level as f64 * self.step
    }

    /// The nearest level of `value` (clamped to the 16-bit range).
    #[inline]
    pub fn level(self, value: f64) -> u16 {
        ((value - self.offset) / self.step)
            .round()
            .clamp(0.0, (LEVELS - 1) as f64) as u16
    }
}

/// Voxel counts per quantization level.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    /// `LEVELS` bins, one per quantization level.
    pub counts: Vec<u64>,
    /// What each bin's level means in data units.
    pub quantization: Quantization,
    /// Sum of `counts`.
    pub total: u64,
}

impl Histogram {
    /// The value below which `percent` percent of the voxels lie (nearest level).
    pub fn percentile(&self, percent: f64) -> f64 {
        let wanted = (percent / 100.0 * self.total as f64).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (level, &count) in self.counts.iter().enumerate() {
            seen += count;
            if seen >= wanted {
                return self.quantization.value(level as u16);
            }
        }
        self.quantization.value((LEVELS - 1) as u16)
    }
}

/// A low/high pair in data units; values map linearly to 0…1 between them, clamped.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ValueWindow {
    pub low: f64,
    pub high: f64,
}

impl ValueWindow {
    /// Parses `LOW:HIGH` (for example `-1000:400`).
    pub fn parse(text: &str) -> Result<Self, OptionError> {
        let (low, high) = text
            .split_once(':')
            .ok_or_else(|| OptionError::WindowNotLowHigh(text.to_owned()))?;
        let parse = |s: &str| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| OptionError::WindowBound(s.to_owned()))
        };
        let window = Self {
            low: parse(low)?,
            high: parse(high)?,
        };
        if window.high <= window.low {
            return Err(OptionError::WindowReversed(text.to_owned()));
        }
        Ok(window)
    }

    /// Where `value` falls in the window, 0…1.
    #[inline]
    pub fn normalize(self, value: f64) -> f64 {
        ((value - self.low) / (self.high - self.low)).clamp(0.0, 1.0)
    }
}

/// A volume reduced to what the octree needs: one 16-bit level per voxel, how levels map to
/// values, the histogram and the range.
#[derive(Debug, Clone)]
pub struct QuantizedVolume {
    pub dims: [usize; 3],
    pub levels: Vec<u16>,
    pub quantization: Quantization,
    pub histogram: Histogram,
    /// Smallest and largest finite value, in data units.
    pub value_range: [f64; 2],
}

impl QuantizedVolume {
    /// Quantizes every voxel of `volume` (non-finite values count as the minimum).
    pub fn new(volume: &Volume) -> Self {
        with_voxel_slice!(&volume.data, values => Self::of_values(volume.dims, values, volume.value_scale))
    }

    /// Quantizes `values` (x fastest, then y, then z, in a grid of `dims`), stored values
    /// that `scale` maps to the data's units: [`Self::new`] without a [`Volume`] owning them
    /// (the Python module reads a numpy array's memory in place).
    pub fn of_values<T: Scalar>(dims: [usize; 3], values: &[T], scale: ValueScale) -> Self {
        let [min, max] = finite_range(values, |v| scale.apply(v));
        let span = max - min;
        let integer_step = scale.slope.abs();
        let step = if span <= 0.0 {
            1.0
        } else if T::TYPE.is_integer() && span / integer_step <= (LEVELS - 1) as f64 {
            integer_step
        } else {
            span / (LEVELS - 1) as f64
        };
        let quantization = Quantization { offset: min, step };
        let levels: Vec<u16> = values
            .par_iter()
            .map(|&v| {
                let value = scale.apply(v.to_f64());
                if value.is_finite() {
                    quantization.level(value)
                } else {
                    0
                }
            })
            .collect();
        let counts = levels
            .par_chunks(1 << 16)
            .fold(
                || vec![0u64; LEVELS],
                |mut counts, chunk| {
                    for &level in chunk {
                        counts[level as usize] += 1;
                    }
                    counts
                },
            )
            .reduce(
                || vec![0u64; LEVELS],
                |mut a, b| {
                    a.iter_mut().zip(&b).for_each(|(a, b)| *a += b);
                    a
                },
            );
        let histogram = Histogram {
            total: levels.len() as u64,
            counts,
            quantization,
        };
        Self {
            dims,
            levels,
            quantization,
            histogram,
            value_range: [min, max],
        }
    }

    /// The default window: the 0.5 and 99.5 percentiles, widened to the full range when the
    /// data is nearly constant.
    pub fn robust_window(&self) -> ValueWindow {
        let low = self.histogram.percentile(0.5);
        let high = self.histogram.percentile(99.5);
        if high > low {
            return ValueWindow { low, high };
        }
        let [min, max] = self.value_range;
        if max > min {
            ValueWindow {
                low: min,
                high: max,
            }
        } else {
            ValueWindow {
                low: min - 0.5,
                high: min + 0.5,
            }
        }
    }
}

/// Smallest and largest finite mapped value; `[0, 0]` when there is none.
fn finite_range<T: Scalar>(values: &[T], map: impl Fn(f64) -> f64 + Sync) -> [f64; 2] {
    let (min, max) = values
        .par_iter()
        .map(|v| map(v.to_f64()))
        .filter(|v| v.is_finite())
        .fold(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |(lo, hi), v| (lo.min(v), hi.max(v)),
        )
        .reduce(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |(a, b), (c, d)| (a.min(c), b.max(d)),
        );
    if min <= max { [min, max] } else { [0.0, 0.0] }
}

/// A data value as people write it: integers plain, others with 4 significant digits.
pub fn format_value(value: f64) -> String {
    if value.fract() == 0.0 && value.abs() < 1e9 {
        format!("{value:.0}")
    } else if value != 0.0 && (value.abs() >= 1e5 || value.abs() < 1e-3) {
        format!("{value:.3e}")
    } else {
        let decimals = (3 - value.abs().log10().floor() as i32).clamp(0, 6) as usize;
        format!("{value:.decimals$}")
    }
}
