//! Turning what the user typed (a path, a `synthetic:` spec, a raw layout) into a [`Volume`],
//! and the size checks every loader shares.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use super::error::Problem;
use super::{LoadError, RawLayout, Volume, VoxelType, checked_voxel_count, format_dims};

/// What the command line adds to a path.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Read the file as headerless voxels with this layout.
    pub raw: Option<RawLayout>,
    /// Override the spacing the file gives (or lacks).
    pub spacing: Option<[f64; 3]>,
}

/// Loads the volume named by `spec`: a file path, or `synthetic:KIND:SIZE`.
///
/// Files are recognized by extension, then by magic bytes. Nothing is ever written to `spec`.
pub fn load(spec: &str, options: &LoadOptions) -> Result<Volume, LoadError> {
    let mut volume = if let Some(rest) = spec.strip_prefix("synthetic:") {
        super::synthetic::generate(rest).map_err(|p| LoadError::new(spec, p))?
    } else {
        load_file(Path::new(spec), options).map_err(|p| LoadError::new(spec, p))?
    };
    if let Some(spacing) = options.spacing {
        if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(LoadError::new(spec, "--spacing values must be positive"));
        }
        volume.spacing = spacing;
    }
    Ok(volume)
}

fn load_file(path: &Path, options: &LoadOptions) -> Result<Volume, Problem> {
    let metadata =
        std::fs::metadata(path).map_err(|e| format!("cannot open: {}", io_reason(&e)))?;
    if metadata.is_dir() {
        if !super::dicom::dicom_files(path).is_empty() {
            return super::dicom::load(path);
        }
        return super::slices::load(path);
    }
    if metadata.len() == 0 {
        return Err("file is empty".into());
    }
    if let Some(layout) = &options.raw {
        return super::raw::load(path, layout, metadata.len());
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if name.ends_with(".nii") || name.ends_with(".nii.gz") || name.ends_with(".hdr") {
        return super::nifti::load(path);
    }
    if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        return super::nrrd::load(path);
    }
    if name.ends_with(".vti") {
        return super::vti::load(path);
    }
    if name.ends_with(".dcm") || super::dicom::is_dicom(path) {
        return super::dicom::load(path);
    }
    if name.ends_with(".tif") || name.ends_with(".tiff") {
        return super::tiff::load(path);
    }
    if [".mrc", ".map", ".rec", ".ccp4", ".mrcs", ".st", ".ali"]
        .iter()
        .any(|ext| name.ends_with(ext))
    {
        return super::mrc::load(path);
    }
    // No known extension: look at the first bytes.
    let mut head = Vec::with_capacity(212);
    File::open(path)
        .and_then(|f| f.take(212).read_to_end(&mut head))
        .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    let read = head.len();
    let magic: [u8; 4] = std::array::from_fn(|i| head.get(i).copied().unwrap_or(0));
    if read >= 212 && &head[208..212] == b"MAP " {
        return super::mrc::load(path);
    }
    if read >= 4 && &magic == b"NRRD" {
        return super::nrrd::load(path);
    }
    if read >= 4
        && (&magic == b"II*\0" || &magic == b"MM\0*" || &magic == b"II+\0" || &magic == b"MM\0+")
    {
        return super::tiff::load(path);
    }
    if super::nifti::looks_like_nifti(path) {
        return super::nifti::load(path);
    }
    Err("unrecognized format: expected NIfTI-1 (.nii, .nii.gz), NRRD (.nrrd, .nhdr), TIFF (.tif, .tiff), MRC (.mrc, .map, .rec), VTK ImageData (.vti), DICOM (.dcm, or a folder), or raw voxels with --raw WxHxD:TYPE".into())
}

/// Opens `path` for reading, buffered; the problem names the OS reason.
pub(crate) fn open(path: &Path) -> Result<BufReader<File>, Problem> {
    File::open(path)
        .map(BufReader::new)
        .map_err(|e| format!("cannot open {}: {}", path.display(), io_reason(&e)))
}

/// The OS reason without Rust's "(os error N)" suffix.
pub(crate) fn io_reason(error: &std::io::Error) -> String {
    let text = error.to_string();
    match text.find(" (os error") {
        Some(cut) => text[..cut].to_owned(),
        None => text,
    }
}

/// Deflate cannot compress better than about 1032:1; a claim beyond that is false.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// How the voxel bytes are stored, for the size check before allocating.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Storage {
    Plain,
    Gzip,
}

/// Validates `dims`×`voxel_type` against the limits and against the `available` bytes of
/// the file, and returns the byte count of the voxel data. Nothing of that size exists yet.
pub(crate) fn checked_payload_bytes(
    dims: [usize; 3],
    voxel_type: VoxelType,
    available: u64,
    storage: Storage,
) -> Result<usize, Problem> {
    let count = checked_voxel_count(dims)?;
    let bytes = count * voxel_type.size();
    let fits = match storage {
        Storage::Plain => bytes as u64 <= available,
        Storage::Gzip => bytes as u64 <= available.saturating_mul(MAX_DEFLATE_RATIO),
    };
    if !fits {
        let holds = match storage {
            Storage::Plain => format!("the file holds only {available} bytes"),
            Storage::Gzip => format!("a {available}-byte gzip stream cannot hold that much"),
        };
        return Err(format!(
            "truncated or inconsistent: dimensions {} of {} need {bytes} bytes of voxel data but {holds}",
            format_dims(dims),
            voxel_type.name(),
        ));
    }
    Ok(bytes)
}

/// Reads exactly `bytes` bytes of voxel data from `reader` (sizes already validated).
pub(crate) fn read_payload(reader: impl Read, bytes: usize) -> Result<Vec<u8>, Problem> {
    let mut payload = Vec::with_capacity(bytes);
    reader
        .take(bytes as u64)
        .read_to_end(&mut payload)
        .map_err(|e| format!("cannot read voxel data: {}", io_reason(&e)))?;
    if payload.len() < bytes {
        return Err(format!(
            "truncated: expected {bytes} bytes of voxel data, found {}",
            payload.len()
        ));
    }
    Ok(payload)
}

/// Skips `count` bytes of `reader`, failing if it ends first.
pub(crate) fn skip_bytes(reader: &mut impl Read, count: u64) -> Result<(), Problem> {
    let skipped = std::io::copy(&mut reader.take(count), &mut std::io::sink())
        .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    if skipped < count {
        return Err(format!(
            "truncated: the file ends before its voxel data starts (offset {count})"
        ));
    }
    Ok(())
}
