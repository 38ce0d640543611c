//! The registry: turns what the user typed (a path, a `synthetic:` spec, a raw layout) into a
//! [`Volume`] by picking the loader from the format table ([`super::format`]).

use std::fs::File;
use std::io::Read;
use std::path::Path;

use super::error::Problem;
use super::format;
use super::io::{io_reason, not_a_file};
use super::{LoadError, LoadErrorKind, RawLayout, Selection, Volume};

/// What the command line adds to a path.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Read the file as headerless voxels with this layout.
    pub raw: Option<RawLayout>,
    /// Override the spacing the file gives (or lacks).
    pub spacing: Option<[f64; 3]>,
    /// The channel and time point of a multi-channel or time-lapse image (every format).
    pub select: Selection,
    /// How a URL's store is read (requests in flight).
    pub remote: super::remote::RemoteOptions,
}

/// Loads the volume named by `spec`: a file path, a URL of a Zarr store (`http://`,
/// `https://`, `s3://`: [`super::remote`]), or `synthetic:KIND:SIZE`.
///
/// Files are recognized by extension, then by magic bytes ([`format::FORMATS`]); a folder is a
/// Zarr store (OME-Zarr or a plain array) when it holds `zarr.json`, `.zgroup` or
/// `.zarray`, a DICOM series when it holds DICOM files, else a folder of slices. Nothing is ever written to
/// `spec`.
pub fn load(spec: &str, options: &LoadOptions) -> Result<Volume, LoadError> {
    let volume = if let Some(rest) = spec.strip_prefix("synthetic:") {
        super::synthetic::generate(rest).map_err(|p| LoadError::new(spec, p))?
    } else if super::remote::is_url(spec) {
        if options.raw.is_some() {
            return Err(LoadError::new(
                super::remote::redact_url(spec),
                "--raw reads files; a URL must be a Zarr store",
            ));
        }
        super::ome_zarr::load_url(spec, options.select, options.remote)
            .map_err(|p| LoadError::new(super::remote::redact_url(spec), p))?
    } else {
        load_file(Path::new(spec), options).map_err(|error| match error {
            FileError::Problem(problem) => LoadError::new(spec, problem),
            FileError::Unrecognized => LoadError::new(spec, format::unrecognized_problem())
                .with_kind(LoadErrorKind::Unrecognized),
        })?
    };
    finish(volume, spec, options)
}

/// [`load`] of a Zarr store already opened as `pyramid` (what `info` lists, then reads): the
/// same volume, without opening the store again.
pub fn load_opened(
    pyramid: &super::ome_zarr::Pyramid,
    spec: &str,
    options: &LoadOptions,
) -> Result<Volume, LoadError> {
    finish(pyramid.memory_volume()?, spec, options)
}

/// What every loaded volume passes: the frame asked for, and `--spacing`.
fn finish(mut volume: Volume, spec: &str, options: &LoadOptions) -> Result<Volume, LoadError> {
    // Loaders of 4-D formats refuse a frame they lack before reading and record the one they
    // read; the others read the only one there is, which must be the one asked for.
    let series = &volume.series;
    if series.selected != options.select {
        options
            .select
            .check(series.channel_count(), series.time_points)
            .map_err(|p| LoadError::new(super::remote::redact_url(spec), p))?;
    }
    if let Some(spacing) = options.spacing {
        if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(LoadError::new(
                super::remote::redact_url(spec),
                "--spacing values must be positive",
            ));
        }
        volume.spacing = spacing;
    }
    Ok(volume)
}

/// Why a file did not load: a problem, or no format recognized it.
enum FileError {
    Problem(Problem),
    Unrecognized,
}

impl From<Problem> for FileError {
    fn from(problem: Problem) -> Self {
        Self::Problem(problem)
    }
}

fn load_file(path: &Path, options: &LoadOptions) -> Result<Volume, FileError> {
    // A bioformats2raw container's series `ROOT/N` (`--series N`), whether or not it exists.
    if super::ome_zarr::series_path(path).is_some() {
        return super::ome_zarr::load(path, options.select).map_err(FileError::Problem);
    }
    let metadata =
        std::fs::metadata(path).map_err(|e| format!("cannot open: {}", io_reason(&e)))?;
    if metadata.is_dir() {
        if super::ome_zarr::is_zarr_folder(path) {
            return super::ome_zarr::load(path, options.select).map_err(FileError::Problem);
        }
        if !super::dicom::dicom_files(path).is_empty() {
            return super::dicom::load(path).map_err(FileError::Problem);
        }
        if let Some(level) = super::ome_zarr::unfinished_store(path) {
            return Err(FileError::Problem(super::ome_zarr::unfinished_problem(
                &level,
            )));
        }
        let stores = super::ome_zarr::stores_inside(path);
        if !stores.is_empty() {
            return Err(FileError::Problem(
                super::ome_zarr::folder_of_stores_problem(&stores),
            ));
        }
        return super::slices::load(path).map_err(FileError::Problem);
    }
    // Devices and pipes are refused: /dev/zero would be read forever, a pipe would block.
    if let Some(what) = not_a_file(&metadata) {
        return Err(FileError::Problem(what.into()));
    }
    if metadata.len() == 0 {
        return Err(FileError::Problem("file is empty".into()));
    }
    if let Some(layout) = &options.raw {
        return super::raw::load(path, layout, metadata.len()).map_err(FileError::Problem);
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if let Some(format) = format::by_extension(&name) {
        return format
            .load(path, options.select)
            .map_err(FileError::Problem);
    }
    // No known extension: look at the first bytes.
    let mut head = Vec::with_capacity(format::SNIFF_BYTES);
    File::open(path)
        .and_then(|f| f.take(format::SNIFF_BYTES as u64).read_to_end(&mut head))
        .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    match format::by_magic(&head) {
        Some(format) => format
            .load(path, options.select)
            .map_err(FileError::Problem),
        None => Err(FileError::Unrecognized),
    }
}
