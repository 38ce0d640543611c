//! Reading files for the loaders: opening, the size checks every loader makes before it
//! allocates, and exact reads and skips that say what ended too early. Every loader uses
//! these; they use nothing of the loaders or the registry.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use super::error::Problem;
use super::{VoxelType, checked_voxel_count, format_dims};

/// Deflate cannot compress better than about 1032:1 (a run of 258 bytes per 2-bit code), so a
/// gzip or zlib stream that claims more than this many bytes per stored byte is false.
pub(crate) const MAX_DEFLATE_RATIO: u64 = 1032;

/// Opens `path` for reading, buffered; the problem names the path and the OS reason.
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
