//! N5 containers (Janelia's archives, BigStitcher's and BigDataViewer's output, OpenOrganelle)
//! read by the OME-Zarr reader: [`N5Store`] shows a container to zarrs as a Zarr v3 store,
//! each node's `attributes.json` as its `zarr.json` ([`attributes`]) and every block as the
//! chunk of the same key ([`block`]). Everything after the metadata is the Zarr path's: the
//! pyramid's levels, region reads, the streaming renderer's bricks, the remote client (a
//! block's key is its N5 path, so fetches ahead ask the server for the right objects),
//! `convert` from N5 to OME-Zarr.

mod attributes;
mod block;

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
use crate::error::{Problem, printable};

/// The document every N5 node has.
pub(super) const ATTRIBUTES: &str = "attributes.json";

/// Whether the folder `path` is an N5 container, group or dataset: an `attributes.json` and
/// no Zarr documents.
pub fn is_n5_folder(path: &Path) -> bool {
    path.is_dir()
        && path.join(ATTRIBUTES).is_file()
        && !["zarr.json", ".zgroup", ".zarray"]
            .iter()
            .any(|name| path.join(name).is_file())
}

/// Whether the root of `store` (whose Zarr documents are missing) is an N5 node.
pub(super) fn is_n5_root(store: &ReadableStorage) -> bool {
    matches!(read_attributes(store, ""), Ok(Some(_)))
}

/// The `attributes.json` of the node `prefix` (`""`, `s0/`), if present: a JSON object of at
/// most [`MAX_METADATA_BYTES`].
fn read_attributes(
    store: &ReadableStorage,
    prefix: &str,
) -> Result<Option<Map<String, Value>>, StorageError> {
    let name = format!("{prefix}{ATTRIBUTES}");
    let key = StoreKey::new(&name).map_err(|e| StorageError::Other(e.to_string()))?;
    match store.size_key(&key)? {
        None => return Ok(None),
        Some(size) if size > MAX_METADATA_BYTES => {
            return Err(StorageError::Other(format!(
                "{name} is {size} bytes; metadata of more than {MAX_METADATA_BYTES} bytes is not read"
            )));
        }
        Some(_) => {}
    }
    let Some(bytes) = store.get(&key)? else {
        return Ok(None);
    };
    match serde_json::from_slice(&bytes) {
        Ok(Value::Object(map)) => Ok(Some(map)),
        Ok(_) => Err(StorageError::Other(format!("{name} is not a JSON object"))),
        Err(e) => Err(StorageError::Other(format!(
            "{name} is not valid JSON: {e}"
        ))),
    }
}

/// Opens the N5 node at the root of `store` (a container or group with multiscale metadata,
/// or a dataset) as a [`Pyramid`] of format `N5`, its version the root's `n5` attribute.
pub(super) fn open(
    store: ReadableStorage,
    source: &str,
    options: PyramidOptions,
    warm: Warm,
) -> Result<Pyramid, Problem> {
    let version = read_attributes(&store, "")
        .ok()
        .flatten()
        .and_then(|root| root.get("n5").and_then(Value::as_str).map(printable));
    let n5: ReadableStorage = Arc::new(N5Store::new(store));
    let mut pyramid = super::open::open_root(n5, source, options, warm, None).map_err(|problem| {
        if problem.starts_with("is a Zarr group without") {
            "is an N5 group without multiscale metadata (n5-viewer 'scales', cosem 'multiscales' or BigDataViewer 'downsamplingFactors'); open a dataset inside it, such as s0".to_owned()
        } else {
            problem
        }
    })?;
    pyramid.format = "N5";
    pyramid.ome_version = version;
    Ok(pyramid)
}

/// The names a [`super::open::Warm`] fetches ahead for an N5 store: every node's
/// `attributes.json` in place of its Zarr documents.
pub(super) fn n5_documents(names: &[String]) -> Vec<String> {
    let mut documents: Vec<String> = names
        .iter()
        .map(|name| match zarr_document(name) {
            Some((node, _)) => format!("{node}{ATTRIBUTES}"),
            None => name.clone(),
        })
        .collect();
    documents.dedup();
    documents
}

/// An N5 container as a Zarr v3 store (see the module's documentation).
pub(super) struct N5Store {
    inner: ReadableStorage,
}

impl N5Store {
    pub(super) fn new(inner: ReadableStorage) -> Self {
        Self { inner }
    }

    /// What the Zarr document `name` at `node` holds: `zarr.json` translated from the node's
    /// `attributes.json`; Zarr v2's documents are never there.
    fn document(&self, node: &str, name: &str) -> Result<MaybeBytes, StorageError> {
        if name != "zarr.json" {
            return Ok(None);
        }
        let Some(found) = read_attributes(&self.inner, node)? else {
            return Ok(None);
        };
        let read_child = |child: &str| {
            read_attributes(&self.inner, &format!("{node}{child}/"))
                .ok()
                .flatten()
        };
        let document = attributes::zarr_json(&found, &read_child)
            .map_err(|problem| StorageError::Other(format!("{node}{ATTRIBUTES}: {problem}")))?;
        Ok(Some(Bytes::from(document.to_string())))
    }
}

impl ReadableStorageTraits for N5Store {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        match zarr_document(key.as_str()) {
            Some((node, name)) => self.document(node, name),
            None => self.inner.get(key),
        }
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let Some((node, name)) = zarr_document(key.as_str()) else {
            return self.inner.get_partial_many(key, byte_ranges);
        };
        let Some(document) = self.document(node, name)? else {
            return Ok(None);
        };
        Ok(Some(slice_ranges(document, byte_ranges)))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        match zarr_document(key.as_str()) {
            Some((node, name)) => Ok(self.document(node, name)?.map(|d| d.len() as u64)),
            None => self.inner.size_key(key),
        }
    }

    fn supports_get_partial(&self) -> bool {
        self.inner.supports_get_partial()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn documents_fetched_ahead_are_n5_ones() {
        assert_eq!(
            n5_documents(&["zarr.json".into(), ".zgroup".into(), "s0/zarr.json".into()]),
            ["attributes.json", "s0/attributes.json"]
        );
    }
}
