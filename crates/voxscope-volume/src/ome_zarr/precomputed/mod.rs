//! neuroglancer precomputed volumes (the connectomics archives: MICrONS, H01, FAFB, and what
//! cloud-volume and igneous write) read by the OME-Zarr reader: [`PrecomputedStore`] shows a
//! volume to zarrs as a Zarr v3 store whose root is an OME-Zarr image of the `info`'s scales
//! ([`info`]) and whose chunks are the volume's chunk files ([`chunk`]; a chunk's key is its
//! file name, so fetches ahead ask a server for the right objects). Everything after the
//! metadata is the Zarr path's: levels, region reads, streaming, budgets, the remote client,
//! `convert` to OME-Zarr. A segmentation is a label image.
//!
//! Unsharded scales are read: `raw`, `jpeg`, `png` and `compressed_segmentation` chunks,
//! gzip-compressed or not (cloud-volume's `.gz` files too).

mod chunk;
mod info;
mod segmentation;

use std::path::Path;
use std::sync::Arc;

use serde_json::{Map, Value};
use zarrs::storage::byte_range::ByteRangeIterator;
use zarrs::storage::{
    Bytes, MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
};

use super::adapted::{slice_ranges, zarr_document};
use super::open::Warm;
use super::{MAX_METADATA_BYTES, Pyramid, PyramidOptions, ReadableStorage};
use crate::error::Problem;

/// The document at a precomputed volume's root.
pub(super) const INFO: &str = "info";

/// Whether the folder `path` is a precomputed volume: an `info` file that is a JSON object
/// with `scales`, and no Zarr or N5 document.
pub fn is_precomputed_folder(path: &Path) -> bool {
    let info = path.join(INFO);
    path.is_dir()
        && info.is_file()
        && !["zarr.json", ".zgroup", ".zarray", super::n5::ATTRIBUTES]
            .iter()
            .any(|name| path.join(name).is_file())
        && std::fs::metadata(&info).is_ok_and(|m| m.len() <= MAX_METADATA_BYTES)
        && std::fs::read(&info)
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Value>(&bytes).ok())
            .is_some_and(|v| v.get("scales").is_some())
}

/// The `info` of the root of `store`, if it has one: `Ok(None)` where there is none or it is
/// no precomputed `info` (no `scales`); `Err` where it is one that cannot be read.
fn read_info(store: &ReadableStorage) -> Result<Option<info::Info>, Problem> {
    let key = StoreKey::new(INFO).map_err(|e| e.to_string())?;
    match store.size_key(&key) {
        Ok(Some(size)) if size > MAX_METADATA_BYTES => {
            return Err(format!(
                "info is {size} bytes; metadata of more than {MAX_METADATA_BYTES} bytes is not read"
            ));
        }
        Ok(Some(_)) => {}
        Ok(None) | Err(_) => return Ok(None),
    }
    let Ok(Some(bytes)) = store.get(&key) else {
        return Ok(None);
    };
    let document: Map<String, Value> = match serde_json::from_slice(&bytes) {
        Ok(Value::Object(map)) if map.contains_key("scales") => map,
        _ => return Ok(None),
    };
    info::parse(&document).map(Some)
}

/// Whether the root of `store` (whose Zarr and N5 documents are missing) holds a
/// precomputed `info`.
pub(super) fn is_precomputed_root(store: &ReadableStorage) -> bool {
    !matches!(read_info(store), Ok(None))
}

/// Opens the precomputed volume at the root of `store` as a [`Pyramid`] of format
/// `precomputed`, named `name` (its folder's or URL's last part).
pub(super) fn open(
    store: ReadableStorage,
    source: &str,
    options: PyramidOptions,
    warm: Warm,
) -> Result<Pyramid, Problem> {
    let info = read_info(&store)?.ok_or("is not a precomputed volume: no info with scales")?;
    if let Some(scale) = info.scales.iter().find(|s| s.sharding.is_some()) {
        return Err(format!(
            "scale '{}' is sharded; voxscope reads unsharded precomputed scales so far",
            crate::error::escape(&scale.key)
        ));
    }
    let name = source
        .trim_end_matches('/')
        .rsplit('/')
        .next()
        .filter(|n| !n.is_empty())
        .map(str::to_owned);
    let adapted: ReadableStorage = Arc::new(PrecomputedStore {
        inner: store,
        info,
        name,
    });
    let mut pyramid = super::open::open_root(adapted, source, options, warm, None)?;
    pyramid.format = "precomputed";
    pyramid.ome_version = None;
    Ok(pyramid)
}

/// A precomputed volume as a Zarr v3 store (see the module's documentation).
struct PrecomputedStore {
    inner: ReadableStorage,
    info: info::Info,
    name: Option<String>,
}

/// What a key of the adapted store names.
enum Named<'a> {
    /// A Zarr document (`zarr.json`, …) of the node `node`.
    Document { node: &'a str, name: &'a str },
    /// A chunk file of this extent (x, y, z).
    Chunk([u32; 3]),
    /// Anything else (passed through).
    Other,
}

impl PrecomputedStore {
    fn named<'a>(&self, key: &'a str) -> Named<'a> {
        if let Some((node, name)) = zarr_document(key) {
            return Named::Document { node, name };
        }
        let (scale, file) = key.rsplit_once('/').unwrap_or(("", key));
        match chunk::extent_of(file) {
            Some(extent) if self.info.scale(scale).is_some() => Named::Chunk(extent),
            _ => Named::Other,
        }
    }

    /// `zarr.json` of the root or of a scale; nothing else.
    fn document(&self, node: &str, name: &str) -> MaybeBytes {
        if name != "zarr.json" {
            return None;
        }
        let document = match node.strip_suffix('/') {
            None => self.info.root_json(self.name.as_deref()),
            Some(key) => self.info.array_json(self.info.scale(key)?),
        };
        Some(Bytes::from(document.to_string()))
    }

    /// A chunk file's bytes, or its gzip-compressed `.gz` sibling's (cloud-volume's files).
    fn chunk_file(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        if let Some(bytes) = self.inner.get(key)? {
            return Ok(Some(bytes));
        }
        let gz = StoreKey::new(format!("{}.gz", key.as_str()))
            .map_err(|e| StorageError::Other(e.to_string()))?;
        self.inner.get(&gz)
    }

    fn chunk(&self, key: &StoreKey, extent: [u32; 3]) -> Result<MaybeBytes, StorageError> {
        Ok(self
            .chunk_file(key)?
            .map(|bytes| Bytes::from(chunk::with_extent(extent, &bytes))))
    }
}

impl ReadableStorageTraits for PrecomputedStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        match self.named(key.as_str()) {
            Named::Document { node, name } => Ok(self.document(node, name)),
            Named::Chunk(extent) => self.chunk(key, extent),
            Named::Other => self.inner.get(key),
        }
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let whole = match self.named(key.as_str()) {
            Named::Document { node, name } => self.document(node, name),
            Named::Chunk(extent) => self.chunk(key, extent)?,
            Named::Other => return self.inner.get_partial_many(key, byte_ranges),
        };
        Ok(whole.map(|bytes| slice_ranges(bytes, byte_ranges)))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        match self.named(key.as_str()) {
            Named::Document { node, name } => Ok(self.document(node, name).map(|d| d.len() as u64)),
            Named::Chunk(extent) => Ok(self.chunk(key, extent)?.map(|c| c.len() as u64)),
            Named::Other => self.inner.size_key(key),
        }
    }

    fn supports_get_partial(&self) -> bool {
        self.inner.supports_get_partial()
    }
}
