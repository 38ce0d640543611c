//! The HDF5 file under an Imaris dataset, read with `hdf5-reader` (pure Rust, read-only; see
//! docs/formats.md for why this reader): the file read by positioned reads rather than a
//! memory map (a file cut short while open is an error, not a SIGBUS), every read and chunk
//! bounded, attributes as the text Imaris writes them (arrays of one-character strings), and
//! a box of a dataset read as the little-endian bytes of a Zarr chunk.

use std::fs::File;
use std::path::Path;

use hdf5_reader::messages::HdfMessage;
use hdf5_reader::storage::{DynStorage, Storage, StorageBuffer};
use hdf5_reader::{ByteOrder, Dataset, Datatype, Hdf5File, OpenOptions, SliceInfo, SliceInfoElem};

use crate::error::printable;

/// The most bytes one read of the file may ask for, and one decoded chunk may have.
pub(super) const MAX_CHUNK_BYTES: usize = 512 << 20;

/// The HDF5 filters voxscope decodes (`hdf5-reader`'s built-in ones): their names by id.
const FILTERS: [(u16, &str); 7] = [
    (1, "deflate"),
    (2, "shuffle"),
    (3, "fletcher32"),
    (4, "szip"),
    (5, "nbit"),
    (6, "scaleoffset"),
    (32004, "lz4"),
];

/// Filters seen in the wild that voxscope does not decode, named in its error.
const FOREIGN_FILTERS: [(u16, &str); 5] = [
    (307, "bzip2"),
    (32001, "blosc"),
    (32008, "bitshuffle"),
    (32015, "zstd"),
    (32026, "blosc2"),
];

/// A file read by positioned reads: each range read is checked against the file's length
/// when it was opened and against [`MAX_CHUNK_BYTES`] before anything is allocated.
struct FileStorage {
    file: File,
    len: u64,
}

impl Storage for FileStorage {
    fn len(&self) -> u64 {
        self.len
    }

    fn read_range(&self, offset: u64, len: usize) -> hdf5_reader::error::Result<StorageBuffer> {
        let end = offset.checked_add(len as u64);
        if len > MAX_CHUNK_BYTES || end.is_none_or(|end| end > self.len) {
            return Err(hdf5_reader::error::Error::UnexpectedEof {
                offset,
                needed: len as u64,
                available: self.len.saturating_sub(offset),
            });
        }
        let mut bytes = vec![0; len];
        read_exact_at(&self.file, &mut bytes, offset)?;
        Ok(StorageBuffer::from_vec(bytes))
    }
}

#[cfg(unix)]
fn read_exact_at(file: &File, buffer: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buffer, offset)
}

#[cfg(windows)]
fn read_exact_at(file: &File, mut buffer: &mut [u8], mut offset: u64) -> std::io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !buffer.is_empty() {
        match file.seek_read(buffer, offset)? {
            0 => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            n => {
                buffer = &mut buffer[n..];
                offset += n as u64;
            }
        }
    }
    Ok(())
}

/// Opens the HDF5 file at `path`: no chunk cache of its own (the pyramid's caches hold what
/// is decoded), reads and chunks bounded.
pub(super) fn open(path: &Path) -> Result<Hdf5File, String> {
    let file =
        File::open(path).map_err(|e| format!("cannot open: {}", crate::io::io_reason(&e)))?;
    let len = file
        .metadata()
        .map_err(|e| format!("cannot open: {}", crate::io::io_reason(&e)))?
        .len();
    let storage: DynStorage = std::sync::Arc::new(FileStorage { file, len });
    let options = OpenOptions::default()
        .with_chunk_cache_bytes(0)
        .with_max_chunk_bytes(MAX_CHUNK_BYTES)
        .with_max_read_bytes(MAX_CHUNK_BYTES);
    Hdf5File::from_storage_with_options(storage, options)
        .map_err(|e| format!("is not a readable HDF5 file: {}", printable(&e.to_string())))
}

/// The text of attribute `name` of the group at `path`, as Imaris writes it (an array of
/// one-character strings, or one string; numbers as their decimal text), if present.
pub(super) fn attribute_text(file: &Hdf5File, path: &str, name: &str) -> Option<String> {
    let attribute = file.group(path).ok()?.attribute(name).ok()?;
    let text = match &attribute.datatype {
        Datatype::String { .. } => {
            let bytes: Vec<u8> = attribute
                .raw_data
                .iter()
                .copied()
                .take(4096)
                .filter(|&b| b != 0)
                .collect();
            String::from_utf8_lossy(&bytes).into_owned()
        }
        Datatype::VarLen { .. } => attribute.read_string().ok()?,
        _ => attribute.read_as_f64().ok()?.to_string(),
    };
    Some(printable(text.trim()))
}

/// The Zarr `data_type` of an HDF5 element type, if voxscope reads it.
pub(super) fn zarr_type(datatype: &Datatype) -> Option<&'static str> {
    Some(match *datatype {
        Datatype::FixedPoint { size, signed, .. } => match (size, signed) {
            (1, false) => "uint8",
            (1, true) => "int8",
            (2, false) => "uint16",
            (2, true) => "int16",
            (4, false) => "uint32",
            (4, true) => "int32",
            (8, false) => "uint64",
            (8, true) => "int64",
            _ => return None,
        },
        Datatype::FloatingPoint { size: 4, .. } => "float32",
        Datatype::FloatingPoint { size: 8, .. } => "float64",
        _ => return None,
    })
}

/// How `datatype` reads as text in messages (`uint16`, `big-endian float32`, `compound`).
pub(super) fn type_text(datatype: &Datatype) -> String {
    let order = match datatype {
        Datatype::FixedPoint { byte_order, .. } | Datatype::FloatingPoint { byte_order, .. } => {
            byte_order
        }
        _ => return "a non-numeric HDF5 type".to_owned(),
    };
    let endian = if matches!(order, ByteOrder::BigEndian) {
        "big-endian "
    } else {
        ""
    };
    match zarr_type(datatype) {
        Some(name) => format!("{endian}{name}"),
        None => "an HDF5 number type voxscope does not read".to_owned(),
    }
}

/// The filters of `dataset`'s pipeline by name, in order (`shuffle deflate`); a filter
/// voxscope cannot decode is named in the error.
pub(super) fn filters(file: &Hdf5File, dataset: &Dataset) -> Result<Vec<&'static str>, String> {
    let header = file
        .get_or_parse_header(dataset.address())
        .map_err(|e| printable(&e.to_string()))?;
    let mut names = Vec::new();
    for message in &header.messages {
        let HdfMessage::FilterPipeline(pipeline) = message else {
            continue;
        };
        for filter in &pipeline.filters {
            if let Some((_, name)) = FILTERS.iter().find(|(id, _)| *id == filter.id) {
                names.push(*name);
                continue;
            }
            let name = FOREIGN_FILTERS
                .iter()
                .find(|(id, _)| *id == filter.id)
                .map(|(_, name)| format!(" ({name})"))
                .unwrap_or_default();
            return Err(format!(
                "is compressed with HDF5 filter {}{name}, which voxscope does not decode (deflate, shuffle, lz4, szip, nbit and scaleoffset are read); rewrite it with deflate or LZ4, as Imaris and ImarisConvert write",
                filter.id
            ));
        }
    }
    Ok(names)
}

/// The voxels of `dataset` in the box `start + chunk` (z, y, x; the box may reach past the
/// dataset, whose missing part reads as zeros), as the little-endian bytes of a Zarr chunk of
/// `chunk` voxels, z slowest. `zarr_type` is the dataset's type ([`zarr_type`]).
pub(super) fn read_box(
    dataset: &Dataset,
    zarr_type: &str,
    start: [u64; 3],
    chunk: [u64; 3],
) -> Result<Vec<u8>, String> {
    let shape = dataset.shape();
    if shape.len() != 3 {
        return Err(format!("holds {} dimensions, not 3", shape.len()));
    }
    let end: [u64; 3] = std::array::from_fn(|a| (start[a] + chunk[a]).min(shape[a]));
    let read: [u64; 3] = std::array::from_fn(|a| end[a].saturating_sub(start[a]));
    let element = element_bytes(zarr_type);
    let chunk_bytes = chunk.iter().product::<u64>() as usize * element;
    if read.contains(&0) {
        return Ok(vec![0; chunk_bytes]);
    }
    let selection = SliceInfo {
        selections: (0..3)
            .map(|a| SliceInfoElem::Slice {
                start: start[a],
                end: end[a],
                step: 1,
            })
            .collect(),
    };
    let bytes = match zarr_type {
        "uint8" => le_bytes::<u8>(dataset, &selection),
        "int8" => le_bytes::<i8>(dataset, &selection),
        "uint16" => le_bytes::<u16>(dataset, &selection),
        "int16" => le_bytes::<i16>(dataset, &selection),
        "uint32" => le_bytes::<u32>(dataset, &selection),
        "int32" => le_bytes::<i32>(dataset, &selection),
        "uint64" => le_bytes::<u64>(dataset, &selection),
        "int64" => le_bytes::<i64>(dataset, &selection),
        "float32" => le_bytes::<f32>(dataset, &selection),
        _ => le_bytes::<f64>(dataset, &selection),
    }?;
    if read == chunk {
        return Ok(bytes);
    }
    // An edge box: the rows read placed in a chunk of zeros.
    let mut out = vec![0; chunk_bytes];
    let row = read[2] as usize * element;
    for z in 0..read[0] as usize {
        for y in 0..read[1] as usize {
            let from = (z * read[1] as usize + y) * row;
            let to = ((z * chunk[1] as usize + y) * chunk[2] as usize) * element;
            out[to..to + row].copy_from_slice(&bytes[from..from + row]);
        }
    }
    Ok(out)
}

/// The bytes of one value of `zarr_type`.
pub(super) fn element_bytes(zarr_type: &str) -> usize {
    match zarr_type {
        "uint8" | "int8" => 1,
        "uint16" | "int16" => 2,
        "uint32" | "int32" | "float32" => 4,
        _ => 8,
    }
}

/// The selection's values as little-endian bytes.
fn le_bytes<T: hdf5_reader::H5Type + bytemuck::Pod>(
    dataset: &Dataset,
    selection: &SliceInfo,
) -> Result<Vec<u8>, String> {
    let values = dataset
        .read_slice::<T>(selection)
        .map_err(|e| printable(&e.to_string()))?;
    let values = values.as_standard_layout();
    let values = values
        .as_slice()
        .ok_or("a box read out of order (hdf5-reader)")?;
    let mut bytes: Vec<u8> = bytemuck::cast_slice(values).to_vec();
    if cfg!(target_endian = "big") {
        for value in bytes.chunks_exact_mut(size_of::<T>()) {
            value.reverse();
        }
    }
    Ok(bytes)
}
