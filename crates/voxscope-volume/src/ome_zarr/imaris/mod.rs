//! Imaris `.ims` files (what light-sheet and confocal facilities hand their users) read by the
//! OME-Zarr reader: [`ImarisStore`] shows the file's HDF5 groups to zarrs as a Zarr v3 store
//! whose root is an OME-Zarr 0.5 image ([`layout`]) and whose chunks are boxes of the `Data`
//! datasets, decoded from the file as they are asked for ([`hdf5`]). Everything after the
//! metadata is the Zarr path's: resolution levels as the pyramid, channels with their colors
//! and ranges, time points, region reads, the streaming renderer's bricks under its budgets,
//! `convert` from Imaris to OME-Zarr.

mod chunks;
mod hdf5;
mod layout;

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use hdf5_reader::{Dataset, Hdf5File};
use zarrs::storage::byte_range::ByteRangeIterator;
use zarrs::storage::{
    Bytes, MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
};

use super::adapted::{slice_ranges, zarr_document};
use super::{Pyramid, PyramidOptions, ReadableStorage};
use crate::error::Problem;
use chunks::ChunkMap;
use layout::Layout;

/// The format's name in `info` and errors.
pub const FORMAT: &str = "Imaris";

/// HDF5's signature, at the start of the file (files with a user block before their
/// superblock are opened by `.ims` name, not recognized by these bytes).
const HDF5_SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";

/// Whether `head` (a file's first bytes) starts with HDF5's signature.
pub fn sniff(head: &[u8]) -> bool {
    head.starts_with(HDF5_SIGNATURE)
}

/// Whether the file at `path` starts with HDF5's signature.
pub(super) fn is_hdf5_file(path: &Path) -> bool {
    let mut head = [0; HDF5_SIGNATURE.len()];
    std::fs::File::open(path)
        .and_then(|mut file| std::io::Read::read_exact(&mut file, &mut head))
        .is_ok()
        && sniff(&head)
}

/// Whether `path` is a file [`open`] reads: an `.ims` file (any case).
pub fn is_imaris_file(path: &Path) -> bool {
    path.extension()
        .and_then(|ext| ext.to_str())
        .is_some_and(|ext| ext.eq_ignore_ascii_case("ims"))
        && path.is_file()
}

/// Opens the Imaris file at `path` as a [`Pyramid`] of format [`FORMAT`], its version the
/// file's `ImarisVersion`.
pub(super) fn open(path: &Path, source: &str, options: PyramidOptions) -> Result<Pyramid, Problem> {
    let file = hdf5::open(path)?;
    let layout = Layout::read(&file)?;
    let codecs: Vec<String> = layout
        .levels
        .iter()
        .map(|level| match level.filters.is_empty() {
            true => "hdf5 raw".to_owned(),
            false => format!("hdf5 {}", level.filters.join(" ")),
        })
        .collect();
    let version = layout.version.clone();
    let store: ReadableStorage = Arc::new(ImarisStore {
        file,
        layout,
        datasets: Mutex::new(HashMap::new()),
    });
    let mut pyramid = super::open::open_root(store, source, options, &|_| {}, None)?;
    for (level, codec) in pyramid.levels.iter_mut().zip(codecs) {
        level.codec = codec;
    }
    pyramid.format = FORMAT;
    pyramid.ome_version = version;
    // A chunk's key names no file: nothing is fetched ahead by key.
    pyramid.chunks_are_objects = false;
    Ok(pyramid)
}

/// The most `Data` datasets kept open (each with its chunk map): past them, all are closed.
const MAX_OPEN_DATASETS: usize = 256;

/// How one `Data` dataset is read.
enum Data {
    /// By its chunk map, one chunk per Zarr chunk.
    Chunks(ChunkMap),
    /// By region (other chunk indexes, unchunked data, chunks unlike the level's).
    Regions(Box<Dataset>),
}

/// An Imaris file as a Zarr v3 store (see the module's documentation).
struct ImarisStore {
    file: Hdf5File,
    layout: Layout,
    /// The `Data` datasets opened so far, by level, time point and channel.
    datasets: Mutex<HashMap<(usize, u64, u64), Arc<Data>>>,
}

impl ImarisStore {
    /// The document `name` of the node `node`: the root's and the levels' `zarr.json`.
    fn document(&self, node: &str, name: &str) -> MaybeBytes {
        if name != "zarr.json" {
            return None;
        }
        let document = match node.strip_suffix('/') {
            None if node.is_empty() => self.layout.root_json(),
            Some(level) => {
                let level = self.layout.levels.get(level.parse::<usize>().ok()?)?;
                self.layout.array_json(level)
            }
            None => return None,
        };
        Some(Bytes::from(document.to_string()))
    }

    /// The `Data` of `level`, time point `t`, channel `c`, opened once.
    fn dataset(&self, level: usize, t: u64, c: u64) -> Result<Arc<Data>, StorageError> {
        let key = (level, t, c);
        if let Some(dataset) = self
            .datasets
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&key)
        {
            return Ok(dataset.clone());
        }
        let path = self.layout.data_path(level, t, c);
        let dataset = self
            .file
            .dataset(&path)
            .map_err(|_| StorageError::Other(format!("has no dataset {path}")))?;
        let stored = hdf5::zarr_type(dataset.dtype());
        if stored != Some(self.layout.zarr_type) {
            return Err(StorageError::Other(format!(
                "{path} holds {} where level 0 holds {}",
                hdf5::type_text(dataset.dtype()),
                self.layout.zarr_type
            )));
        }
        hdf5::filters(&self.file, &dataset)
            .map_err(|e| StorageError::Other(format!("{path} {e}")))?;
        let map = ChunkMap::of(&self.file, &dataset)
            .map_err(|e| StorageError::Other(format!("{path}: {e}")))?;
        let data = Arc::new(match map {
            Some(map) if map.shape() == self.layout.levels[level].chunk => Data::Chunks(map),
            _ => Data::Regions(Box::new(dataset)),
        });
        let mut open = self.datasets.lock().unwrap_or_else(|e| e.into_inner());
        if open.len() >= MAX_OPEN_DATASETS {
            open.clear();
        }
        open.insert(key, data.clone());
        Ok(data)
    }

    /// The level, time point, channel and z, y, x chunk the chunk key `key` (`L/c/…`) names.
    fn locate(&self, key: &str) -> Option<(usize, u64, u64, [u64; 3])> {
        let (level, coords) = key.split_once("/c/")?;
        let level = level.parse::<usize>().ok()?;
        let coords: Vec<u64> = coords
            .split('/')
            .map(|c| c.parse().ok())
            .collect::<Option<_>>()?;
        let (t, c, zyx) = self.layout.chunk_of(level, &coords)?;
        Some((level, t, c, zyx))
    }

    /// The chunk `key`: its box of the level's dataset, decoded; `None` for a key that names
    /// no chunk.
    fn chunk(&self, key: &str) -> Result<MaybeBytes, StorageError> {
        let Some((level, t, c, zyx)) = self.locate(key) else {
            return Ok(None);
        };
        let chunk = self.layout.levels[level].chunk;
        let bytes = match &*self.dataset(level, t, c)? {
            Data::Chunks(map) => map.read(&self.file, zyx),
            Data::Regions(dataset) => {
                let start: [u64; 3] = std::array::from_fn(|a| zyx[a] * chunk[a]);
                hdf5::read_box(dataset, self.layout.zarr_type, start, chunk)
            }
        }
        .map_err(|e| StorageError::Other(format!("{}: {e}", self.layout.data_path(level, t, c))))?;
        Ok(Some(Bytes::from(bytes)))
    }
}

impl ReadableStorageTraits for ImarisStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        match zarr_document(key.as_str()) {
            Some((node, name)) => Ok(self.document(node, name)),
            None => self.chunk(key.as_str()),
        }
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let Some(bytes) = self.get(key)? else {
            return Ok(None);
        };
        Ok(Some(slice_ranges(bytes, byte_ranges)))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        if let Some((node, name)) = zarr_document(key.as_str()) {
            return Ok(self.document(node, name).map(|bytes| bytes.len() as u64));
        }
        // A chunk's decoded size, known without reading it.
        Ok(self.locate(key.as_str()).map(|(level, ..)| {
            let voxels: u64 = self.layout.levels[level].chunk.iter().product();
            voxels * hdf5::element_bytes(self.layout.zarr_type) as u64
        }))
    }

    fn supports_get_partial(&self) -> bool {
        false
    }
}
