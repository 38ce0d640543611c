//! Volumes: a 3D grid of scalars with its spacing, the loaders that make one from a file or a
//! spec, and the value statistics that the transfer function needs. Pure CPU; knows nothing of
//! octrees or GPUs.

mod channels;
mod dicom;
mod error;
pub mod format;
mod io;
mod mrc;
mod nifti;
mod nrrd;
pub mod ome_zarr;
mod orientation;
pub mod progress;
mod raw;
mod registry;
pub mod remote;
mod sample;
mod series;
mod slices;
mod synthetic;
mod tiff;
mod values;
mod voxel_type;
mod vti;

pub use channels::{
    DEFAULT_CHANNEL_COLORS, MAX_CHANNELS, channel_color, channel_color_by_name, load_all_channels,
    load_as_channels, load_channels, load_opened_channels,
};
use error::DimsError;
pub use error::{LoadError, LoadErrorKind, OptionError};
pub use format::{Format, dialog_extensions, dialog_filter_name};
pub use nrrd::NrrdEncoding;
pub use orientation::Orientation;
pub use raw::RawLayout;
pub use raw::parse_dims;
pub use registry::{LoadOptions, load, load_opened};
pub use sample::{SAMPLE_NAME, sample};
pub use series::{ChannelInfo, Container, Selection, Series};
pub use synthetic::SyntheticKind;
pub use values::{Histogram, LEVELS, Quantization, QuantizedVolume, ValueWindow, format_value};
pub use voxel_type::{Endian, Scalar, VoxelData, VoxelType};

/// Largest accepted extent along one axis. Larger headers are corrupt or not volumes.
pub const MAX_AXIS: usize = 1 << 16;

/// Largest accepted voxel count (4 Gi voxels), checked before anything of that size is allocated.
pub const MAX_VOXELS: usize = 1 << 32;

/// A regular 3D grid of scalar voxels.
///
/// Voxels are stored x fastest, then y, then z. Loaders that know the patient orientation
/// (NIfTI, NRRD with `space directions`) reorder the axes so that +x points to the patient's
/// right, +y to anterior and +z to superior (RAS), so a head is drawn upright.
#[derive(Debug, Clone)]
pub struct Volume {
    /// Where it came from: the file path or the synthetic spec.
    pub name: String,
    /// The file format (`NIfTI-1`, `NRRD`, `raw`, `synthetic`).
    pub format: &'static str,
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Size of a voxel along x, y, z, in the file's unit (usually mm).
    pub spacing: [f64; 3],
    /// The voxels in their stored type.
    pub data: VoxelData,
    /// Maps stored values to the data's own units: `value = stored * slope + intercept`.
    pub value_scale: ValueScale,
    /// How the axes were reordered on load, if at all.
    pub orientation: Orientation,
    /// Format-specific facts worth showing (`unit`, `modality`, `series`…), in order.
    pub metadata: Vec<(String, String)>,
    /// The window the file advises for display (OME-Zarr's `omero` window), if any; the
    /// default window where no other is chosen.
    pub default_window: Option<ValueWindow>,
    /// The file's channels and time points and which frame this volume is (one of each for
    /// plain 3-D files).
    pub series: Series,
}

/// A linear map from stored values to the data's own units (NIfTI `scl_slope`/`scl_inter`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueScale {
    pub slope: f64,
    pub intercept: f64,
}

impl ValueScale {
    /// The identity map.
    pub const IDENTITY: Self = Self {
        slope: 1.0,
        intercept: 0.0,
    };

    /// Applies the map.
    #[inline]
    pub fn apply(self, stored: f64) -> f64 {
        stored * self.slope + self.intercept
    }
}

impl Volume {
    /// A volume from parts; checks that the voxel count matches the dimensions.
    pub fn new(
        name: impl Into<String>,
        format: &'static str,
        dims: [usize; 3],
        spacing: [f64; 3],
        data: VoxelData,
    ) -> Result<Self, LoadError> {
        let name = name.into();
        let count = checked_voxel_count(dims).map_err(|e| LoadError::new(&name, e.to_string()))?;
        if data.len() != count {
            return Err(LoadError::new(
                &name,
                format!(
                    "{} voxels given for dimensions {}",
                    data.len(),
                    format_dims(dims)
                ),
            ));
        }
        Ok(Self {
            name,
            format,
            dims,
            spacing: sanitize_spacing(spacing),
            data,
            value_scale: ValueScale::IDENTITY,
            orientation: Orientation::AsStored,
            metadata: Vec::new(),
            default_window: None,
            series: Series::default(),
        })
    }

    /// Number of voxels.
    pub fn voxel_count(&self) -> usize {
        self.dims.iter().product()
    }

    /// The stored voxel type.
    pub fn voxel_type(&self) -> VoxelType {
        self.data.voxel_type()
    }

    /// Linear index of voxel (x, y, z).
    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The value at (x, y, z) in the data's own units (slow path: tests and probes).
    pub fn value(&self, x: usize, y: usize, z: usize) -> Option<f64> {
        if x >= self.dims[0] || y >= self.dims[1] || z >= self.dims[2] {
            return None;
        }
        self.data
            .get(self.index(x, y, z))
            .map(|v| self.value_scale.apply(v))
    }

    /// Whether the volume was read from a label image (an OME-Zarr `image-label`, a
    /// precomputed segmentation): its values are categories, whatever their number.
    pub fn is_label_image(&self) -> bool {
        self.metadata_value(ome_zarr::LABEL_IMAGE_FACT).is_some()
    }

    /// The value of metadata `key` (`modality`, `unit`, …), where the file gave one.
    pub fn metadata_value(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, value)| value.trim())
    }

    /// The unit of positions and spacing: the file's where it names one, millimetres for the
    /// patient formats (NIfTI, NRRD, DICOM: their standards' unit), else none (an uncalibrated
    /// TIFF stack, raw voxels, a synthetic volume): positions are then in the spacing's own
    /// units, and nothing is to be said of them.
    pub fn spatial_unit(&self) -> Option<&str> {
        self.metadata_value("unit")
            .filter(|unit| !unit.is_empty())
            .or(matches!(self.format, "NIfTI-1" | "NRRD" | "DICOM").then_some("mm"))
    }

    /// A length or position of `text` with its unit where the volume has one (`12.5 mm`, or
    /// `12.5`).
    pub fn with_unit(&self, text: impl std::fmt::Display) -> String {
        match self.spatial_unit() {
            Some(unit) => format!("{text} {unit}"),
            None => text.to_string(),
        }
    }

    /// Physical size of the grid along x, y, z (dims × spacing).
    pub fn extent(&self) -> [f64; 3] {
        std::array::from_fn(|axis| self.dims[axis] as f64 * self.spacing[axis])
    }
}

/// `dims` multiplied out, with the limits checked; the error says which limit failed.
pub(crate) fn checked_voxel_count(dims: [usize; 3]) -> Result<usize, DimsError> {
    if dims.contains(&0) {
        return Err(DimsError::ZeroExtent(dims));
    }
    if dims.iter().any(|&d| d > MAX_AXIS) {
        return Err(DimsError::AxisTooLong(dims));
    }
    let count = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    match count {
        Some(count) if count <= MAX_VOXELS => Ok(count),
        _ => Err(DimsError::TooManyVoxels(dims)),
    }
}

/// `256x256x62`.
pub fn format_dims(dims: [usize; 3]) -> String {
    format!("{}x{}x{}", dims[0], dims[1], dims[2])
}

/// Zero, negative or non-finite spacings (common in hand-written headers) become 1, signs
/// are dropped (orientation is handled separately).
fn sanitize_spacing(spacing: [f64; 3]) -> [f64; 3] {
    spacing.map(|s| {
        let s = s.abs();
        if s.is_finite() && s > 0.0 { s } else { 1.0 }
    })
}
