//! The transfer function: value window, opacity mode, and the lookup table that turns a
//! voxel's 16-bit value level into a color. The table is what both the CPU and the GPU recolor
//! read, so they agree to the bit.

use serde::{Deserialize, Serialize};

use super::pack_rgba;
use crate::volume::{Quantization, ValueWindow, values::LEVELS};

/// How a voxel's opacity follows from its normalized value `t` (0…1 inside the window).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum OpacityMode {
    /// Alpha equals the gray value: `alpha = t` (the paper's default).
    Gray,
    /// Transparent below the threshold, opaque at or above it.
    Binary,
}

/// Maps values to colors. Color is the colormap at `t`; alpha follows [`OpacityMode`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TransferFunction {
    pub opacity: OpacityMode,
    /// Values at or below `low` map to 0, at or above `high` to 1 (data units).
    pub window: ValueWindow,
    /// Binary mode's threshold on `t`, 0…1.
    pub threshold: f32,
    /// The color of `t` (gray unless chosen otherwise).
    #[serde(default)]
    pub colormap: Colormap,
}

/// The colors a normalized value `t` can take: grays, or one of the perceptually uniform maps
/// of matplotlib (Smith & van der Walt), which keep equal value steps equally visible.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Colormap {
    #[default]
    Grays,
    Viridis,
    Inferno,
    Magma,
    Plasma,
    Cividis,
    /// Categorical colors by integer value (label volumes, segmentations): value `v` gets the
    /// `v mod 20`-th color of a 20-color qualitative palette; 0 is black.
    Labels,
}

impl Colormap {
    pub const ALL: [Colormap; 7] = [
        Self::Grays,
        Self::Viridis,
        Self::Inferno,
        Self::Magma,
        Self::Plasma,
        Self::Cividis,
        Self::Labels,
    ];

    /// `grays`, `viridis`, …
    pub fn name(self) -> &'static str {
        match self {
            Self::Grays => "grays",
            Self::Viridis => "viridis",
            Self::Inferno => "inferno",
            Self::Magma => "magma",
            Self::Plasma => "plasma",
            Self::Cividis => "cividis",
            Self::Labels => "labels",
        }
    }

    /// The colormap called `name` (as [`Self::name`] spells it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }

    /// RGB of a voxel whose value is `value` and normalized value `t` (0…1): continuous maps
    /// follow `t`, [`Self::Labels`] the integer value.
    pub fn rgb_of(self, value: f64, t: f64) -> [u8; 3] {
        match self {
            Self::Labels => {
                let label = value.round();
                if label == 0.0 || !label.is_finite() {
                    return [0; 3];
                }
                let index = (label.abs() as u64 % 20) as usize;
                if index < 10 {
                    colorous::TABLEAU10[index].as_array()
                } else {
                    colorous::SET3[index - 10].as_array()
                }
            }
            _ => self.rgb(t),
        }
    }

    /// RGB of `t` (0…1); [`Self::Labels`] shows its palette along `t`.
    pub fn rgb(self, t: f64) -> [u8; 3] {
        let t = t.clamp(0.0, 1.0);
        let gradient = match self {
            Self::Labels => return Self::Labels.rgb_of(1.0 + (t * 19.0).round(), t),
            Self::Grays => {
                let gray = (t * 255.0).round() as u8;
                return [gray; 3];
            }
            Self::Viridis => colorous::VIRIDIS,
            Self::Inferno => colorous::INFERNO,
            Self::Magma => colorous::MAGMA,
            Self::Plasma => colorous::PLASMA,
            Self::Cividis => colorous::CIVIDIS,
        };
        gradient.eval_continuous(t).as_array()
    }
}

impl TransferFunction {
    /// Alpha = gray over `window`.
    pub fn gray(window: ValueWindow) -> Self {
        Self {
            opacity: OpacityMode::Gray,
            window,
            threshold: 0.5,
            colormap: Colormap::Grays,
        }
    }

    /// RGBA of a voxel whose normalized value is `t` (0…1).
    pub fn color_of_normalized(&self, t: f64) -> [u8; 4] {
        let t = t.clamp(0.0, 1.0);
        let value = self.window.low + t * (self.window.high - self.window.low);
        self.color_of(value, t)
    }

    /// RGBA of a voxel of `value` (data units), `t` being its place in the window.
    fn color_of(&self, value: f64, t: f64) -> [u8; 4] {
        let t = t.clamp(0.0, 1.0);
        let [r, g, b] = self.colormap.rgb_of(value, t);
        let alpha = match self.opacity {
            OpacityMode::Gray => (t * 255.0).round() as u8,
            OpacityMode::Binary => {
                if t >= self.threshold as f64 {
                    255
                } else {
                    0
                }
            }
        };
        [r, g, b, alpha]
    }

    /// Packed colors for all 65 536 value levels of `quantization`.
    pub fn lookup_table(&self, quantization: Quantization) -> Vec<u32> {
        (0..LEVELS)
            .map(|level| {
                let value = quantization.value(level as u16);
                pack_rgba(self.color_of(value, self.window.normalize(value)))
            })
            .collect()
    }

    /// The first value level at which `t` reaches 1 (top of the window): a MIP ray that has
    /// seen it can stop.
    pub fn saturation_level(&self, quantization: Quantization) -> u16 {
        let level = (self.window.high - quantization.offset) / quantization.step;
        level.ceil().clamp(0.0, (LEVELS - 1) as f64) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn label_colors_follow_the_integer_value_and_zero_is_black() {
        let transfer = TransferFunction {
            opacity: OpacityMode::Binary,
            window: ValueWindow {
                low: 0.0,
                high: 40.0,
            },
            threshold: 0.5 / 40.0,
            colormap: Colormap::Labels,
        };
        let quantization = Quantization {
            offset: 0.0,
            step: 1.0,
        };
        let table = transfer.lookup_table(quantization);
        assert_eq!(table[0], 0, "label 0: black and transparent");
        let colors: Vec<[u8; 4]> = (1..=20)
            .map(|v| super::super::unpack_rgba(table[v]))
            .collect();
        for (i, a) in colors.iter().enumerate() {
            assert_eq!(a[3], 255, "labels are opaque");
            for b in &colors[i + 1..] {
                assert_ne!(a, b, "20 labels, 20 colors");
            }
        }
        assert_eq!(table[21], table[1], "the palette repeats every 20 labels");
    }
}
