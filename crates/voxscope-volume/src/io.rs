//! Reading files for the loaders: opening, the size checks every loader makes before it
//! allocates, and exact reads and skips that say what ended too early. Every loader uses
//! these; they use nothing of the loaders or the registry.

use std::fs::File;
use std::io::{BufRead, BufReader, ErrorKind, Read};
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

/// Reads exactly `bytes` bytes of voxel data from `reader` (sizes already validated). Plain
/// data was checked against the file, so all of it is reserved at once; a gzip stream may
/// claim up to [`MAX_DEFLATE_RATIO`] times its size, so its buffer grows with what really
/// arrives (never beyond `bytes`), and a false claim costs no more than the true content.
pub(crate) fn read_payload(
    reader: impl Read,
    bytes: usize,
    storage: Storage,
) -> Result<Vec<u8>, Problem> {
    const FIRST_GZIP_RESERVE: usize = 1 << 20;
    let mut payload = Vec::with_capacity(match storage {
        Storage::Plain => bytes,
        Storage::Gzip => bytes.min(FIRST_GZIP_RESERVE),
    });
    let mut reader = reader.take(bytes as u64);
    let mut chunk = vec![0u8; 1 << 16];
    loop {
        let read = match reader.read(&mut chunk) {
            Ok(0) => break,
            Ok(read) => read,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(format!("cannot read voxel data: {}", io_reason(&e))),
        };
        if payload.capacity() - payload.len() < read {
            // Double, but never past what the header declared.
            let grow = payload.capacity().max(read).min(bytes - payload.len());
            payload.reserve_exact(grow.max(read));
        }
        payload.extend_from_slice(&chunk[..read]);
    }
    if payload.len() < bytes {
        return Err(format!(
            "truncated: expected {bytes} bytes of voxel data, found {}",
            payload.len()
        ));
    }
    Ok(payload)
}

/// Skips `count` lines of `reader` (NRRD's `line skip`), failing if it ends first. Reads in
/// the reader's buffer, so a line without an end costs no memory, and stops at the end of
/// the file, so a huge count costs no more time than the file's size.
pub(crate) fn skip_lines(reader: &mut impl BufRead, count: u64) -> Result<(), Problem> {
    let mut skipped = 0u64;
    while skipped < count {
        let buffer = match reader.fill_buf() {
            Ok(buffer) => buffer,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(format!("cannot read: {}", io_reason(&e))),
        };
        if buffer.is_empty() {
            return Err(format!(
                "line skip {count}: the data ends after {skipped} lines"
            ));
        }
        let (used, ended_line) = match buffer.iter().position(|&b| b == b'\n') {
            Some(at) => (at + 1, true),
            None => (buffer.len(), false),
        };
        reader.consume(used);
        skipped += ended_line as u64;
    }
    Ok(())
}

/// Why `metadata` is not a regular file (`is a folder`, `is a device`…), if it is not.
pub(crate) fn not_a_file(metadata: &std::fs::Metadata) -> Option<&'static str> {
    let kind = metadata.file_type();
    if kind.is_file() {
        return None;
    }
    if kind.is_dir() {
        return Some("is a folder, not a file");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_char_device() || kind.is_block_device() {
            return Some("is a device, not a file");
        }
        if kind.is_fifo() {
            return Some("is a named pipe, not a file");
        }
        if kind.is_socket() {
            return Some("is a socket, not a file");
        }
    }
    Some("is not a regular file")
}

/// The size of `path`, a file another file points at (a data file, an `.img`). The problem
/// completes a sentence that names the file: `does not exist`, `is a folder, not a file`.
pub(crate) fn regular_file_size(path: &Path) -> Result<u64, Problem> {
    let metadata = std::fs::metadata(path).map_err(|e| {
        if e.kind() == ErrorKind::NotFound {
            "does not exist".to_owned()
        } else {
            format!("cannot be opened: {}", io_reason(&e))
        }
    })?;
    match not_a_file(&metadata) {
        Some(what) => Err(what.to_owned()),
        None => Ok(metadata.len()),
    }
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
