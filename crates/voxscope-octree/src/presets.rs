//! Volume-rendering presets (opacity and color curves in the data's units), and the rule that
//! picks the transfer function a volume opens with: a CT preset for CT, the labels colormap
//! for label volumes, the robust window for everything else.
//!
//! The CT curves are 3D Slicer's volume-rendering presets
//! (`Modules/Loadable/VolumeRendering/Resources/presets.xml`, BSD-style license): their
//! Hounsfield-unit control points and colors, rounded; where ours differs, the preset's doc
//! says how. Slicer's opacities are per millimetre of ray; voxscope's are per voxel step, the
//! same for the usual 0.5–1 mm CT voxels, and the opacity scale adjusts both.

use super::transfer::{Colormap, ControlPoint, OpacityCurve, OpacityMode, TransferFunction};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume};

/// A named transfer function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Preset {
    /// Bone alone: transparent below 152 HU (the lower edge of Slicer's CT-Bones), rising to
    /// 0.72 at 641 HU with CT-Bone's colors.
    CtBone,
    /// Soft tissue and bone, air and fat transparent: Slicer's CT-Muscle.
    CtSoftTissue,
    /// The lungs' parenchyma, −600…−400 HU: Slicer's CT-Lung.
    CtLung,
    /// Contrast-filled vessels (and bone), transparent below 144 HU: Slicer's CT-AAA.
    CtVessels,
    /// The body's surface, opaque from −160 HU: Slicer's CT-Soft-Tissue opacity, in a skin
    /// color instead of its grays.
    CtSkin,
    /// For MRI, microscopy and anything without fixed units: transparent at the 60th
    /// percentile, 0.8 at the 99.5th, with the colormap over that range.
    Ramp,
}

impl Preset {
    pub const ALL: [Self; 6] = [
        Self::CtSoftTissue,
        Self::CtBone,
        Self::CtVessels,
        Self::CtLung,
        Self::CtSkin,
        Self::Ramp,
    ];

    /// The command line's name: `ct-bone`, …, `ramp`.
    pub fn name(self) -> &'static str {
        match self {
            Self::CtBone => "ct-bone",
            Self::CtSoftTissue => "ct-soft-tissue",
            Self::CtLung => "ct-lung",
            Self::CtVessels => "ct-vessels",
            Self::CtSkin => "ct-skin",
            Self::Ramp => "ramp",
        }
    }

    /// The app's short label: `Bone`, `Soft tissue`, …
    pub fn label(self) -> &'static str {
        match self {
            Self::CtBone => "Bone",
            Self::CtSoftTissue => "Soft tissue",
            Self::CtLung => "Lung",
            Self::CtVessels => "Vessels",
            Self::CtSkin => "Skin",
            Self::Ramp => "Ramp",
        }
    }

    /// The preset called `name` (as [`Self::name`] spells it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// True for the presets in Hounsfield units.
    pub fn is_ct(self) -> bool {
        self != Self::Ramp
    }

    /// The transfer function of this preset for `volume`. CT presets keep their curves in HU
    /// and window the colormap (what slices show) over the tissue they show; the ramp takes
    /// its points from the volume's histogram.
    pub fn transfer(self, volume: &QuantizedVolume, colormap: Colormap) -> TransferFunction {
        let (points, window): (&[PresetPoint], ValueWindow) = match self {
            Self::CtBone => (
                &[
                    (152.0, 0.0, [198, 102, 93]),
                    (641.0, 0.72, [231, 208, 141]),
                    (3071.0, 0.71, [255, 255, 255]),
                ],
                level_width(400.0, 1800.0),
            ),
            Self::CtSoftTissue => (
                &[
                    (-155.0, 0.0, [140, 64, 38]),
                    (218.0, 0.68, [225, 154, 74]),
                    (420.0, 0.83, [255, 239, 243]),
                    (3071.0, 0.80, [211, 168, 255]),
                ],
                level_width(40.0, 400.0),
            ),
            Self::CtLung => (
                &[
                    (-600.0, 0.0, [0, 0, 255]),
                    (-599.0, 0.15, [0, 0, 255]),
                    (-530.0, 0.15, [34, 199, 18]),
                    (-460.0, 0.15, [237, 255, 28]),
                    (-400.0, 0.15, [227, 65, 6]),
                    (-399.0, 0.0, [227, 65, 6]),
                ],
                level_width(-600.0, 1500.0),
            ),
            Self::CtVessels => (
                &[
                    (144.0, 0.0, [157, 91, 47]),
                    (166.0, 0.69, [225, 154, 74]),
                    (214.0, 0.70, [255, 255, 255]),
                    (420.0, 0.83, [255, 239, 243]),
                    (3071.0, 0.80, [211, 168, 255]),
                ],
                level_width(300.0, 600.0),
            ),
            Self::CtSkin => (
                &[
                    (-167.0, 0.0, [225, 172, 150]),
                    (-160.0, 1.0, [225, 172, 150]),
                    (240.0, 1.0, [240, 220, 210]),
                ],
                level_width(40.0, 400.0),
            ),
            Self::Ramp => {
                let low = volume.histogram.percentile(60.0);
                let high = volume.histogram.percentile(99.5);
                let window = volume.robust_window();
                let (low, high) = if high > low {
                    (low, high)
                } else {
                    (window.low, window.high)
                };
                let curve = OpacityCurve::ramp(low, high, 0.8);
                return TransferFunction {
                    opacity: OpacityMode::Points(curve),
                    window: ValueWindow { low, high },
                    threshold: 0.5,
                    colormap,
                };
            }
        };
        let points: Vec<ControlPoint> = points
            .iter()
            .map(|&(value, opacity, color)| ControlPoint {
                value,
                opacity,
                color: Some(color),
            })
            .collect();
        TransferFunction {
            opacity: OpacityMode::Points(OpacityCurve::new(&points).expect("presets are valid")),
            window,
            threshold: 0.5,
            colormap,
        }
    }
}

/// A preset's control point: value (HU), opacity, color.
type PresetPoint = (f64, f32, [u8; 3]);

/// What kind of values a volume holds, for the transfer function it opens with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataKind {
    /// Hounsfield units: a DICOM of modality CT, or values from air (about −1000) to bone.
    Ct,
    /// A segmentation or atlas: integer voxels with at most [`MAX_LABELS`] distinct values,
    /// or a label image's (of distinct quantized values).
    Labels(usize),
    /// Anything else (MRI, microscopy, simulations).
    Other,
}

/// Most distinct values a label volume has.
pub const MAX_LABELS: usize = 64;

impl DataKind {
    /// Whether the values are labels (categories, not amounts).
    pub fn is_labels(self) -> bool {
        matches!(self, Self::Labels(_))
    }

    /// The kind of `volume`'s values, quantized as `quantized` (DICOM's modality from its
    /// metadata where it has one).
    pub fn of_volume(volume: &Volume, quantized: &QuantizedVolume) -> Self {
        if volume.is_label_image() {
            let distinct = quantized
                .histogram
                .counts
                .iter()
                .filter(|&&c| c > 0)
                .count();
            return Self::Labels(distinct);
        }
        Self::of(
            quantized,
            volume.metadata_value("modality"),
            volume.voxel_type().is_integer(),
        )
    }

    /// The kind of `volume`'s values; `modality` is DICOM's, where the file has one, and
    /// `integer` whether the voxels are stored as integers.
    pub fn of(volume: &QuantizedVolume, modality: Option<&str>, integer: bool) -> Self {
        let [low, high] = volume.value_range;
        let hounsfield = (-3100.0..=-900.0).contains(&low) && high >= 200.0;
        if modality.is_some_and(|m| m.trim().eq_ignore_ascii_case("CT")) || hounsfield {
            return Self::Ct;
        }
        if integer && volume.quantization.step == 1.0 {
            let distinct = volume.histogram.counts.iter().filter(|&&c| c > 0).count();
            if distinct <= MAX_LABELS {
                return Self::Labels(distinct);
            }
        }
        Self::Other
    }
}

/// The transfer function a volume of `kind` opens with when it needs its own: CT with
/// [`Preset::CtSoftTissue`] (air, the scanner's padding and fat transparent), labels with the
/// categorical colormap (label 0 transparent, every other label opaque). `None`: the user's
/// current choice over the robust window fits.
pub fn default_transfer(volume: &QuantizedVolume, kind: DataKind) -> Option<TransferFunction> {
    match kind {
        DataKind::Ct => Some(Preset::CtSoftTissue.transfer(volume, Colormap::Grays)),
        DataKind::Labels(_) => Some(labels_transfer(volume)),
        DataKind::Other => None,
    }
}

/// Categorical colors per integer value over the whole range, label 0 transparent.
pub fn labels_transfer(volume: &QuantizedVolume) -> TransferFunction {
    let [low, high] = volume.value_range;
    let window = if high > low {
        ValueWindow { low, high }
    } else {
        ValueWindow {
            low,
            high: low + 1.0,
        }
    };
    TransferFunction {
        opacity: OpacityMode::Binary,
        // Just above 0: every label but the background is opaque.
        threshold: (window.normalize(0.5) as f32).max(1e-4),
        window,
        colormap: Colormap::Labels,
    }
}

/// The window of a level and width, as radiologists give them.
fn level_width(level: f64, width: f64) -> ValueWindow {
    ValueWindow {
        low: level - width / 2.0,
        high: level + width / 2.0,
    }
}
