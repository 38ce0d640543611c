//! neuroglancer precomputed volumes (the connectomics archives: MICrONS, H01, FAFB, and what
//! cloud-volume and igneous write) read by the OME-Zarr reader: [`PrecomputedStore`] shows a
//! volume to zarrs as a Zarr v3 store whose root is an OME-Zarr image of the `info`'s scales
//! ([`info`]) and whose chunks are the volume's chunk files ([`chunk`]; a chunk's key is its
//! file name, so fetches ahead ask a server for the right objects). Everything after the
//! metadata is the Zarr path's: levels, region reads, streaming, budgets, the remote client,
//! `convert` to OME-Zarr. A segmentation is a label image.
//!
//! Scales unsharded (a file a chunk; cloud-volume's gzip-compressed `.gz` files too) and
//! sharded ([`sharded`]: a chunk is a range of a shard file) are read, their chunks `raw`,
//! `jpeg`, `png` or `compressed_segmentation`, gzip-compressed or not.

mod chunk;
mod info;
mod segmentation;
mod sharded;

use std::collections::HashMap;

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
    let sharded: HashMap<String, sharded::ShardedScale> = info
        .scales
        .iter()
        .filter_map(|scale| {
            let grid = std::array::from_fn(|a| scale.size[a].div_ceil(scale.chunk[a]));
            let sharding = scale.sharding.clone()?;
            let max_chunk_bytes = info.max_chunk_bytes(scale);
            Some((
                scale.key.clone(),
                sharded::ShardedScale::new(scale.key.clone(), sharding, grid, max_chunk_bytes),
            ))
        })
        .collect();
    let any_sharded = !sharded.is_empty();
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
        sharded,
    });
    let mut pyramid = super::open::open_root(adapted, source, options, warm, None)?;
    pyramid.format = "precomputed";
    pyramid.ome_version = None;
    // A sharded chunk's key names no object: nothing is fetched ahead by key.
    pyramid.chunks_are_objects = !any_sharded;
    Ok(pyramid)
}

/// A precomputed volume as a Zarr v3 store (see the module's documentation).
struct PrecomputedStore {
    inner: ReadableStorage,
    info: info::Info,
    name: Option<String>,
    /// The sharded scales, by key.
    sharded: HashMap<String, sharded::ShardedScale>,
}

/// What a key of the adapted store names.
enum Named<'a> {
    /// A Zarr document (`zarr.json`, …) of the node `node`.
    Document { node: &'a str, name: &'a str },
    /// A chunk of scale `scale`, its first voxel and extent (x, y, z).
    Chunk {
        scale: &'a str,
        begin: [i64; 3],
        extent: [u32; 3],
    },
    /// Anything else (passed through).
    Other,
}

impl PrecomputedStore {
    fn named<'a>(&self, key: &'a str) -> Named<'a> {
        if let Some((node, name)) = zarr_document(key) {
            return Named::Document { node, name };
        }
        let (scale, file) = key.rsplit_once('/').unwrap_or(("", key));
        match chunk::chunk_of_name(file) {
            Some((begin, extent)) if self.info.scale(scale).is_some() => Named::Chunk {
                scale,
                begin,
                extent,
            },
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

    /// The chunk `key` names, its extent before its bytes ([`chunk::with_extent`]): its file,
    /// or its range of a shard file.
    fn chunk(&self, key: &StoreKey, named: &Named) -> Result<MaybeBytes, StorageError> {
        let Named::Chunk {
            scale,
            begin,
            extent,
        } = *named
        else {
            return Ok(None);
        };
        let bytes = match (self.sharded.get(scale), self.info.scale(scale)) {
            (Some(sharded), Some(info)) => {
                let position: [u64; 3] = std::array::from_fn(|a| {
                    (begin[a] - info.voxel_offset[a]).max(0) as u64 / info.chunk[a]
                });
                sharded.chunk(self.inner.as_ref(), position)?
            }
            _ => self.chunk_file(key)?,
        };
        Ok(bytes.map(|bytes| Bytes::from(chunk::with_extent(extent, &bytes))))
    }
}

impl ReadableStorageTraits for PrecomputedStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        match self.named(key.as_str()) {
            Named::Document { node, name } => Ok(self.document(node, name)),
            named @ Named::Chunk { .. } => self.chunk(key, &named),
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
            named @ Named::Chunk { .. } => self.chunk(key, &named)?,
            Named::Other => return self.inner.get_partial_many(key, byte_ranges),
        };
        Ok(whole.map(|bytes| slice_ranges(bytes, byte_ranges)))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        match self.named(key.as_str()) {
            Named::Document { node, name } => Ok(self.document(node, name).map(|d| d.len() as u64)),
            named @ Named::Chunk { .. } => Ok(self.chunk(key, &named)?.map(|c| c.len() as u64)),
            Named::Other => self.inner.size_key(key),
        }
    }

    fn supports_get_partial(&self) -> bool {
        self.inner.supports_get_partial()
    }
}
