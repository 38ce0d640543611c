//! The transfer function: value window, opacity mode, and the lookup table that turns a
//! voxel's 16-bit value level into a color. The table is what both the CPU and the GPU recolor
//! read, so they agree to the bit.

use serde::{Deserialize, Serialize};

use super::pack_rgba;
use voxscope_volume::{LEVELS, Quantization, ValueWindow};

/// How a voxel's opacity follows from its value.
// The curve is held inline (not boxed) so that a transfer function stays `Copy`: it is
// compared every frame to decide what to redraw.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum OpacityMode {
    /// Alpha equals the gray value: `alpha = t`, `t` the value's place in the window (0…1;
    /// the paper's default).
    Gray,
    /// Transparent below the threshold on `t`, opaque at or above it.
    Binary,
    /// A piecewise-linear curve of control points in the data's units (and, where its points
    /// carry colors, the colors too).
    Points(OpacityCurve),
}

impl OpacityMode {
    /// `gray`, `binary`, `points`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Gray => "gray",
            Self::Binary => "binary",
            Self::Points(_) => "points",
        }
    }

    /// The curve of [`Self::Points`].
    pub fn curve(&self) -> Option<&OpacityCurve> {
        match self {
            Self::Points(curve) => Some(curve),
            _ => None,
        }
    }
}

/// Most control points an [`OpacityCurve`] holds (fixed, so a transfer function stays `Copy`
/// and can be compared and sent to the GPU's recolor without allocating).
pub const MAX_CURVE_POINTS: usize = 16;

/// One control point of an [`OpacityCurve`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ControlPoint {
    /// Where it is, in the data's units (Hounsfield units for CT).
    pub value: f64,
    /// Opacity there, 0…1.
    pub opacity: f32,
    /// Its own color, where the curve colors the data instead of the colormap.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<[u8; 3]>,
}

impl ControlPoint {
    /// A point without a color of its own.
    pub fn new(value: f64, opacity: f32) -> Self {
        Self {
            value,
            opacity,
            color: None,
        }
    }
}

/// Why points (or the command line's `V:A,…`) make no opacity curve: displays as the one line
/// the command line, the Python module and a view file's reader show.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurveError {
    /// No point at all.
    #[error("an opacity curve needs at least one point")]
    NoPoints,
    /// More than [`MAX_CURVE_POINTS`] points.
    #[error("an opacity curve has at most {MAX_CURVE_POINTS} points, not {0}")]
    TooManyPoints(usize),
    /// Point `number` (from 1) has an infinite or NaN value.
    #[error("point {number} has no finite value")]
    NotFinite { number: usize },
    /// Point `number` (from 1) has an opacity outside 0…1.
    #[error("point {number} at {value}: opacity {opacity} is outside 0…1")]
    OpacityOutside {
        number: usize,
        value: f64,
        opacity: f32,
    },
    /// A point's value is not above the one before it.
    #[error("points must be sorted by value: {value} follows {previous}")]
    Unsorted { value: f64, previous: f64 },
    /// Text without the `:` of `VALUE:OPACITY`.
    #[error("'{0}' is not VALUE:OPACITY")]
    NotPair(String),
    /// Text that is not a number.
    #[error("'{0}' is not a number")]
    NotNumber(String),
}

/// A piecewise-linear opacity curve: control points sorted by value, linear in between, flat
/// outside (the first point's opacity below it, the last's above). When any point has a
/// color, colors are interpolated the same way between the points that have one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(into = "Vec<ControlPoint>", try_from = "Vec<ControlPoint>")]
pub struct OpacityCurve {
    points: [ControlPoint; MAX_CURVE_POINTS],
    len: usize,
}

impl OpacityCurve {
    /// A curve through `points`, which must be 1…[`MAX_CURVE_POINTS`] points with finite
    /// values in increasing order and opacities in 0…1.
    pub fn new(points: &[ControlPoint]) -> Result<Self, CurveError> {
        if points.is_empty() {
            return Err(CurveError::NoPoints);
        }
        if points.len() > MAX_CURVE_POINTS {
            return Err(CurveError::TooManyPoints(points.len()));
        }
        for (i, point) in points.iter().enumerate() {
            if !point.value.is_finite() {
                return Err(CurveError::NotFinite { number: i + 1 });
            }
            if !(0.0..=1.0).contains(&point.opacity) {
                return Err(CurveError::OpacityOutside {
                    number: i + 1,
                    value: point.value,
                    opacity: point.opacity,
                });
            }
            if i > 0 && point.value <= points[i - 1].value {
                return Err(CurveError::Unsorted {
                    value: point.value,
                    previous: points[i - 1].value,
                });
            }
        }
        let mut curve = Self {
            points: [ControlPoint::new(0.0, 0.0); MAX_CURVE_POINTS],
            len: points.len(),
        };
        curve.points[..points.len()].copy_from_slice(points);
        Ok(curve)
    }

    /// A ramp from transparent at `low` to `opacity` at `high` (`low < high`).
    pub fn ramp(low: f64, high: f64, opacity: f32) -> Self {
        let high = if high > low { high } else { low + 1.0 };
        Self::new(&[
            ControlPoint::new(low, 0.0),
            ControlPoint::new(high, opacity),
        ])
        .expect("two sorted points in range")
    }

    /// Parses the command line's `V:A,V:A,…` (value in data units, opacity 0…1).
    pub fn parse(text: &str) -> Result<Self, CurveError> {
        let points = text
            .split(',')
            .map(|pair| {
                let (value, opacity) = pair
                    .split_once(':')
                    .ok_or_else(|| CurveError::NotPair(pair.to_owned()))?;
                let value: f64 = value
                    .trim()
                    .parse()
                    .map_err(|_| CurveError::NotNumber(value.to_owned()))?;
                let opacity: f32 = opacity
                    .trim()
                    .parse()
                    .map_err(|_| CurveError::NotNumber(opacity.to_owned()))?;
                Ok(ControlPoint::new(value, opacity))
            })
            .collect::<Result<Vec<_>, CurveError>>()?;
        Self::new(&points)
    }

    /// The control points, sorted by value.
    pub fn points(&self) -> &[ControlPoint] {
        &self.points[..self.len]
    }

    /// True when the points carry colors (the curve colors the data, not the colormap).
    pub fn has_colors(&self) -> bool {
        self.points().iter().any(|p| p.color.is_some())
    }

    /// The opacity at `value`.
    pub fn opacity_at(&self, value: f64) -> f32 {
        interpolate(self.points(), value, |p| Some([p.opacity])).map_or(0.0, |[a]| a)
    }

    /// The color at `value`, interpolated between the points that have one.
    pub fn color_at(&self, value: f64) -> Option<[u8; 3]> {
        interpolate(self.points(), value, |p| {
            p.color.map(|c| c.map(|channel| channel as f32))
        })
        .map(|rgb| rgb.map(|channel| channel.round().clamp(0.0, 255.0) as u8))
    }

    /// Adds a point, keeping the order; returns its index, or `None` when the curve is full
    /// or a point already has that value.
    pub fn insert(&mut self, point: ControlPoint) -> Option<usize> {
        if self.len == MAX_CURVE_POINTS || self.points().iter().any(|p| p.value == point.value) {
            return None;
        }
        let index = self.points().partition_point(|p| p.value < point.value);
        self.points.copy_within(index..self.len, index + 1);
        self.points[index] = point;
        self.len += 1;
        Some(index)
    }

    /// Removes point `index`; the last point is never removed.
    pub fn remove(&mut self, index: usize) -> bool {
        if self.len <= 1 || index >= self.len {
            return false;
        }
        self.points.copy_within(index + 1..self.len, index);
        self.len -= 1;
        true
    }

    /// Moves point `index` to `value` and `opacity`, kept strictly between its neighbours
    /// (so dragging never reorders the points) and opacity clamped to 0…1.
    pub fn move_point(&mut self, index: usize, value: f64, opacity: f32) {
        if index >= self.len || !value.is_finite() {
            return;
        }
        let gap = |a: f64, b: f64| ((b - a).abs() * 1e-6).max(f64::EPSILON * a.abs().max(1.0));
        let mut value = value;
        if index > 0 {
            let left = self.points[index - 1].value;
            value = value.max(left + gap(left, self.points[index].value));
        }
        if index + 1 < self.len {
            let right = self.points[index + 1].value;
            value = value.min(right - gap(self.points[index].value, right));
        }
        self.points[index].value = value;
        self.points[index].opacity = opacity.clamp(0.0, 1.0);
    }

    /// Sets or clears point `index`'s own color.
    pub fn set_color(&mut self, index: usize, color: Option<[u8; 3]>) {
        if let Some(point) = self.points[..self.len].get_mut(index) {
            point.color = color;
        }
    }

    /// The value range where the curve changes: its first and last points.
    pub fn span(&self) -> [f64; 2] {
        [self.points[0].value, self.points[self.len - 1].value]
    }
}

impl From<OpacityCurve> for Vec<ControlPoint> {
    fn from(curve: OpacityCurve) -> Self {
        curve.points().to_vec()
    }
}

impl TryFrom<Vec<ControlPoint>> for OpacityCurve {
    type Error = CurveError;

    fn try_from(points: Vec<ControlPoint>) -> Result<Self, CurveError> {
        Self::new(&points)
    }
}

/// Piecewise-linear interpolation of `channels` over the points that have them, flat outside.
fn interpolate<const N: usize>(
    points: &[ControlPoint],
    value: f64,
    channels: impl Fn(&ControlPoint) -> Option<[f32; N]>,
) -> Option<[f32; N]> {
    let mut below: Option<(f64, [f32; N])> = None;
    for point in points {
        let Some(here) = channels(point) else {
            continue;
        };
        if point.value >= value {
            return Some(match below {
                Some((at, before)) if point.value > at => {
                    let f = ((value - at) / (point.value - at)) as f32;
                    std::array::from_fn(|c| before[c] + (here[c] - before[c]) * f)
                }
                _ => here,
            });
        }
        below = Some((point.value, here));
    }
    below.map(|(_, last)| last)
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
    pub fn color_of(&self, value: f64, t: f64) -> [u8; 4] {
        let t = t.clamp(0.0, 1.0);
        let point_color = self.opacity.curve().and_then(|curve| curve.color_at(value));
        let [r, g, b] = point_color.unwrap_or_else(|| self.colormap.rgb_of(value, t));
        let alpha = match &self.opacity {
            OpacityMode::Gray => (t * 255.0).round() as u8,
            OpacityMode::Binary => {
                if t >= self.threshold as f64 {
                    255
                } else {
                    0
                }
            }
            OpacityMode::Points(curve) => (curve.opacity_at(value) * 255.0).round() as u8,
        };
        [r, g, b, alpha]
    }

    /// The opacity curve as a function of the value, for any mode (what the editor draws).
    pub fn opacity_of(&self, value: f64) -> f32 {
        self.color_of(value, self.window.normalize(value))[3] as f32 / 255.0
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

    /// The first value level from which the color no longer changes (the top of the window,
    /// or of a colored curve): a MIP ray that has seen it can stop.
    pub fn saturation_level(&self, quantization: Quantization) -> u16 {
        let top = match self.opacity.curve() {
            Some(curve) if curve.has_colors() => self.window.high.max(curve.span()[1]),
            _ => self.window.high,
        };
        let level = (top - quantization.offset) / quantization.step;
        level.ceil().clamp(0.0, (LEVELS - 1) as f64) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(points: &[(f64, f32)]) -> OpacityCurve {
        let points: Vec<ControlPoint> = points
            .iter()
            .map(|&(v, a)| ControlPoint::new(v, a))
            .collect();
        OpacityCurve::new(&points).expect("a valid curve")
    }

    #[test]
    fn a_curve_is_linear_between_points_and_flat_outside() {
        let c = curve(&[(-100.0, 0.0), (100.0, 0.5), (300.0, 1.0)]);
        assert_eq!(c.opacity_at(-1000.0), 0.0);
        assert_eq!(c.opacity_at(0.0), 0.25);
        assert_eq!(c.opacity_at(100.0), 0.5);
        assert_eq!(c.opacity_at(200.0), 0.75);
        assert_eq!(c.opacity_at(5000.0), 1.0);
        assert_eq!(c.color_at(0.0), None, "no point has a color");
    }

    #[test]
    fn point_colors_are_interpolated_between_colored_points() {
        let mut c = curve(&[(0.0, 0.0), (50.0, 0.5), (100.0, 1.0)]);
        c.set_color(0, Some([0, 0, 0]));
        c.set_color(2, Some([200, 100, 50]));
        assert_eq!(
            c.color_at(50.0),
            Some([100, 50, 25]),
            "the uncolored middle is skipped"
        );
        assert_eq!(c.color_at(-10.0), Some([0, 0, 0]));
        assert_eq!(c.color_at(1e9), Some([200, 100, 50]));
    }

    #[test]
    fn parse_insert_move_and_remove_keep_the_curve_sorted() {
        let mut c = OpacityCurve::parse("0:0, 100:1").expect("parses");
        assert_eq!(c.points().len(), 2);
        assert_eq!(c.insert(ControlPoint::new(50.0, 0.2)), Some(1));
        assert_eq!(
            c.insert(ControlPoint::new(50.0, 0.9)),
            None,
            "same value twice"
        );
        c.move_point(1, 500.0, 2.0);
        let moved = c.points()[1];
        assert!(moved.value < 100.0 && moved.value > 99.0, "{moved:?}");
        assert_eq!(moved.opacity, 1.0);
        assert!(c.remove(0) && c.remove(0));
        assert!(!c.remove(0), "the last point stays");
        for bad in ["", "1", "a:1", "1:b", "5:0,1:1", "0:1.5", "0:0,0:1"] {
            assert!(OpacityCurve::parse(bad).is_err(), "{bad:?} is refused");
        }
        let many = (0..=MAX_CURVE_POINTS)
            .map(|i| format!("{i}:0"))
            .collect::<Vec<_>>()
            .join(",");
        assert!(OpacityCurve::parse(&many).is_err());
    }

    #[test]
    fn a_curve_survives_ron() {
        let mut c = curve(&[(-1000.0, 0.0), (200.0, 0.7)]);
        c.set_color(1, Some([255, 240, 220]));
        let mode = OpacityMode::Points(c);
        let text = ron::to_string(&mode).expect("encodes");
        let back: OpacityMode = ron::from_str(&text).expect("decodes");
        assert_eq!(back, mode);
        assert!(
            ron::from_str::<OpacityMode>(
                "Points([(value: 5.0, opacity: 0.0), (value: 1.0, opacity: 1.0)])"
            )
            .is_err()
        );
    }

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
