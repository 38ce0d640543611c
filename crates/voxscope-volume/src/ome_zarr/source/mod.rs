//! Where `convert` reads its input from, z slab by z slab: raw files, raw-encoded NRRD (whose
//! axes load as stored), folders of slices and what the Zarr reader opens (OME-Zarr, N5,
//! precomputed, Imaris: the finest level, by region) are read a slab at a time (so the output
//! can be larger than memory); every other format is loaded whole and handed out in slabs.

mod bands;
mod region;
mod values;

pub use values::scaled_type;

use std::fs::File;
use std::path::{Path, PathBuf};

use super::super::error::Problem;
use super::super::io::io_reason;
use super::super::{
    Endian, LoadError, LoadOptions, MAX_AXIS, RawLayout, ValueScale, Volume, VoxelData, VoxelType,
    format_dims,
};

/// An input volume read in z slabs.
#[derive(Debug)]
pub struct SlabSource {
    /// The path or spec it came from.
    pub name: String,
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// The voxel size along x, y, z.
    pub spacing: [f64; 3],
    /// The type of the values [`Self::read`] returns: the stored type, or where the input
    /// maps its stored values to its units ([`Self::value_scale`]), the type of those.
    pub voxel_type: VoxelType,
    /// The type the input stores.
    pub stored_type: VoxelType,
    /// The input's map from stored values to its units (NIfTI `scl_slope`/`scl_inter`,
    /// DICOM rescale), which [`Self::read`] applies: an OME-Zarr image has no such map, so
    /// its values are written in the data's units.
    pub value_scale: ValueScale,
    /// The spacing's unit, when the input says.
    pub unit: Option<String>,
    input: Input,
}

enum Input {
    Memory(VoxelData),
    /// The finest level of a store, file or URL the Zarr reader opens, read by region
    /// (`spacing`: `--spacing`, if given).
    Pyramid {
        pyramid: Box<super::Pyramid>,
        spacing: Option<[f64; 3]>,
    },
    Raw {
        file: File,
        /// Byte offset of the first voxel.
        offset: u64,
        endian: Endian,
    },
    Slices(Vec<PathBuf>),
    /// A loaded volume repeated along every axis (`tile`: the volume's own dimensions).
    Tiled {
        data: VoxelData,
        tile: [usize; 3],
    },
    /// A loaded volume of dimensions `from` interpolated (trilinear) onto a grid `factor` times
    /// finer along each axis, each voxel plus a uniform value in ±`noise` fixed by its place.
    Upsampled {
        data: VoxelData,
        from: [usize; 3],
        factor: [usize; 3],
        noise: f64,
    },
}

impl std::fmt::Debug for Input {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Memory(_) => "Memory",
            Self::Pyramid { .. } => "Pyramid",
            Self::Raw { .. } => "Raw",
            Self::Slices(_) => "Slices",
            Self::Tiled { .. } => "Tiled",
            Self::Upsampled { .. } => "Upsampled",
        })
    }
}

impl SlabSource {
    /// Opens `spec` as the loaders would (`options` as for [`super::super::load`]); raw files
    /// and folders of slices are not read yet.
    pub fn open(spec: &str, options: &LoadOptions) -> Result<Self, LoadError> {
        let path = Path::new(spec);
        if options.raw.is_none() && super::is_zarr_spec(spec) {
            let pyramid = super::Pyramid::open_spec(spec, options.select, options.remote)?;
            return Ok(Self::pyramid(pyramid, options.spacing));
        }
        // The fast paths below read one-frame sources; another frame goes through the loaders,
        // which read it from a 4-D file or say it does not exist.
        if options.select != super::super::Selection::default() {
            return super::super::load(spec, options).map(Self::from_volume);
        }
        if let Some(layout) = &options.raw {
            return Self::raw(path, layout, options.spacing).map_err(|p| LoadError::new(spec, p));
        }
        let is_nrrd = super::super::format::by_extension(&path.to_string_lossy())
            .is_some_and(|format| format.name == "NRRD");
        if is_nrrd && path.is_file() {
            let extent =
                super::super::nrrd::raw_extent(path).map_err(|p| LoadError::new(spec, p))?;
            if let Some(extent) = extent {
                return Self::nrrd(path, extent, options.spacing)
                    .map_err(|p| LoadError::new(spec, p));
            }
        }
        if path.is_dir()
            && !super::is_zarr_folder(path)
            && super::super::dicom::dicom_files(path).is_empty()
        {
            if let Some(level) = super::unfinished_store(path) {
                return Err(LoadError::new(spec, super::unfinished_problem(&level)));
            }
            return Self::slices(path, options.spacing).map_err(|p| LoadError::new(spec, p));
        }
        let volume = super::super::load(spec, options)?;
        Ok(Self::from_volume(volume))
    }

    /// A loaded volume, handed out in slabs, its values in its units ([`scaled_type`]).
    pub fn from_volume(volume: Volume) -> Self {
        let unit = volume
            .metadata_value("unit")
            .and_then(super::units::ome_unit)
            .map(str::to_owned);
        let stored_type = volume.data.voxel_type();
        let value_scale = volume.value_scale;
        Self {
            name: volume.name,
            dims: volume.dims,
            spacing: volume.spacing,
            voxel_type: scaled_type(&volume.data, value_scale),
            stored_type,
            value_scale,
            unit,
            input: Input::Memory(volume.data),
        }
    }

    /// The finest level of `pyramid` (its channel and time point chosen at open), read by
    /// region: its values as stored (an OME-Zarr image has no value scale; 64-bit integers
    /// read as f64).
    fn pyramid(pyramid: super::Pyramid, spacing: Option<[f64; 3]>) -> Self {
        let finest = &pyramid.levels[0];
        Self {
            name: pyramid.source.clone(),
            dims: finest.dims,
            spacing: spacing.unwrap_or(finest.spacing),
            voxel_type: pyramid.voxel_type,
            stored_type: pyramid.voxel_type,
            value_scale: ValueScale::IDENTITY,
            unit: pyramid
                .units
                .iter()
                .flatten()
                .find_map(|unit| super::units::ome_unit(unit))
                .map(str::to_owned),
            input: Input::Pyramid {
                pyramid: Box::new(pyramid),
                spacing,
            },
        }
    }

    /// Whether slabs are read from the file as they are asked for (not loaded whole first).
    pub fn streams(&self) -> bool {
        matches!(
            self.input,
            Input::Raw { .. } | Input::Slices(_) | Input::Pyramid { .. }
        )
    }

    /// Whether any box is read without reading the whole input: what parts of a conversion
    /// need, each reading only its columns (a file loaded whole, such as `.nii.gz`, is not).
    pub fn reads_by_region(&self) -> bool {
        !matches!(self.input, Input::Memory(_))
    }

    /// The dimensions `counts` times the input's along x, y and z, for `option` (`--tile`,
    /// `--upsample`, whose counts are `noun`): only of an input held in memory, and within
    /// [`MAX_AXIS`] voxels per axis.
    fn multiplied_dims(
        &self,
        option: &str,
        counts: [usize; 3],
        noun: &str,
    ) -> Result<[usize; 3], LoadError> {
        if !matches!(self.input, Input::Memory(_)) {
            return Err(LoadError::new(
                &self.name,
                format!(
                    "{option} needs an input that is loaded whole (not raw, raw NRRD, slices or tiles)"
                ),
            ));
        }
        let dims: [usize; 3] = std::array::from_fn(|a| self.dims[a].saturating_mul(counts[a]));
        if counts.contains(&0) || dims.iter().any(|&d| d > MAX_AXIS) {
            return Err(LoadError::new(
                &self.name,
                format!(
                    "{option} {}: {noun} from 1 up to {MAX_AXIS} voxels per axis",
                    format_dims(counts)
                ),
            ));
        }
        Ok(dims)
    }

    /// This input held in memory: a pyramid's finest level within the in-memory budget
    /// loaded whole (what `--tile` and `--upsample` repeat), anything else as it is.
    fn held(self) -> Result<Self, LoadError> {
        if !matches!(self.input, Input::Pyramid { .. }) {
            return Ok(self);
        }
        let Input::Pyramid { pyramid, spacing } = self.input else {
            unreachable!("matched above");
        };
        let mut volume = pyramid.memory_volume()?;
        if let Some(spacing) = spacing {
            volume.spacing = spacing;
        }
        Ok(Self::from_volume(volume))
    }

    /// The input repeated `copies` times along x, y and z (`convert --tile`): large test
    /// volumes with the structure of real data, written slab by slab (only the input is held
    /// in memory). Refused for inputs read slab by slab from the file.
    pub fn tiled(self, copies: [usize; 3]) -> Result<Self, LoadError> {
        let this = self.held()?;
        let dims = this.multiplied_dims("--tile", copies, "copies")?;
        let Input::Memory(data) = this.input else {
            unreachable!("multiplied_dims refuses inputs not held in memory");
        };
        Ok(Self {
            dims,
            input: Input::Tiled {
                data,
                tile: this.dims,
            },
            ..this
        })
    }

    /// The volume interpolated (trilinear) onto a grid `factor` times finer along x, y and z
    /// (`convert --upsample`), its spacing as much finer, each voxel plus a uniform value in
    /// ±`noise` (in the data's units) fixed by its place: large test volumes from real data
    /// that, unlike tiles, repeat nothing. For inputs loaded whole.
    pub fn upsampled(self, factor: [usize; 3], noise: f64) -> Result<Self, LoadError> {
        let this = self.held()?;
        let dims = this.multiplied_dims("--upsample", factor, "factors")?;
        if !(noise.is_finite() && noise >= 0.0) {
            return Err(LoadError::new(
                &this.name,
                format!("--noise {noise}: a value from 0 up"),
            ));
        }
        let Input::Memory(data) = this.input else {
            unreachable!("multiplied_dims refuses inputs not held in memory");
        };
        Ok(Self {
            dims,
            spacing: std::array::from_fn(|a| this.spacing[a] / factor[a] as f64),
            input: Input::Upsampled {
                data,
                from: this.dims,
                factor,
                noise,
            },
            ..this
        })
    }

    fn raw(path: &Path, layout: &RawLayout, spacing: Option<[f64; 3]>) -> Result<Self, Problem> {
        let dims = layout.dims;
        if dims.contains(&0) || dims.iter().any(|&d| d > MAX_AXIS) {
            return Err(format!(
                "raw layout {} needs extents from 1 to {MAX_AXIS}",
                format_dims(dims)
            ));
        }
        let bytes = dims
            .iter()
            .try_fold(layout.voxel_type.size() as u64, |acc, &d| {
                acc.checked_mul(d as u64)
            })
            .ok_or("raw layout: too many voxels")?;
        let file = File::open(path).map_err(|e| format!("cannot open: {}", io_reason(&e)))?;
        let length = file
            .metadata()
            .map_err(|e| format!("cannot read: {}", io_reason(&e)))?
            .len();
        if length != bytes {
            return Err(format!(
                "raw layout {}:{} needs {bytes} bytes but the file holds {length}",
                format_dims(dims),
                layout.voxel_type.name()
            ));
        }
        Ok(Self {
            name: path.display().to_string(),
            dims,
            spacing: spacing.unwrap_or([1.0; 3]),
            voxel_type: layout.voxel_type,
            stored_type: layout.voxel_type,
            value_scale: ValueScale::IDENTITY,
            unit: None,
            input: Input::Raw {
                file,
                offset: 0,
                endian: layout.endian,
            },
        })
    }

    fn nrrd(
        path: &Path,
        extent: super::super::nrrd::RawExtent,
        spacing: Option<[f64; 3]>,
    ) -> Result<Self, Problem> {
        if extent.dims.iter().any(|&d| d > MAX_AXIS) {
            return Err(format!(
                "dimensions {} exceed {MAX_AXIS} voxels per axis",
                format_dims(extent.dims)
            ));
        }
        let file = File::open(&extent.data)
            .map_err(|e| format!("cannot open {}: {}", extent.data.display(), io_reason(&e)))?;
        Ok(Self {
            name: path.display().to_string(),
            dims: extent.dims,
            spacing: spacing.unwrap_or(extent.spacing),
            voxel_type: extent.voxel_type,
            stored_type: extent.voxel_type,
            value_scale: ValueScale::IDENTITY,
            unit: None,
            input: Input::Raw {
                file,
                offset: extent.offset,
                endian: extent.endian,
            },
        })
    }

    fn slices(dir: &Path, spacing: Option<[f64; 3]>) -> Result<Self, Problem> {
        let files = super::super::slices::slice_files(dir)?;
        let first_file = files
            .first()
            .ok_or_else(super::super::slices::no_volume_in_folder)?;
        let first = super::super::slices::read_slice(first_file)
            .map_err(|p| format!("slice {}: {p}", first_file.display()))?;
        if files.len() > MAX_AXIS {
            return Err(format!("{} slices exceed {MAX_AXIS}", files.len()));
        }
        Ok(Self {
            name: dir.display().to_string(),
            dims: [first.dims[0], first.dims[1], files.len()],
            spacing: spacing.unwrap_or(first.spacing),
            voxel_type: first.data.voxel_type(),
            stored_type: first.data.voxel_type(),
            value_scale: ValueScale::IDENTITY,
            unit: None,
            input: Input::Slices(files),
        })
    }
}
