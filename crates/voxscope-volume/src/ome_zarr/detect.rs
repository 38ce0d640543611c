//! Which folders and specs the Zarr reader opens: Zarr stores (and bioformats2raw series
//! paths), N5 containers, precomputed volumes, URLs; and a Zarr store still being written.

use std::path::Path;
use std::sync::Arc;

use super::n5::is_n5_folder;
use super::precomputed::is_precomputed_folder;
use super::{ReadableStorage, open};

/// Whether `spec` names something [`Pyramid::open_spec`] opens: a URL
/// ([`super::remote::is_url`]), a Zarr, N5 or precomputed folder, or an Imaris file.
pub fn is_zarr_spec(spec: &str) -> bool {
    crate::remote::is_url(spec)
        || is_zarr_folder(Path::new(spec))
        || super::imaris::is_imaris_file(Path::new(spec))
}

/// Whether `path` is a folder [`Pyramid::open`] reads: a Zarr folder (`.zgroup`, `.zarray` or
/// `zarr.json` in it; or a bioformats2raw container's series `ROOT/N`, which opens, or is
/// named missing, from `ROOT`), an N5 container, group or dataset ([`is_n5_folder`]), or a
/// neuroglancer precomputed volume ([`is_precomputed_folder`]).
pub fn is_zarr_folder(path: &Path) -> bool {
    (path.is_dir()
        && [".zgroup", ".zarray", "zarr.json"]
            .iter()
            .any(|name| path.join(name).is_file()))
        || series_path(path).is_some()
        || is_n5_folder(path)
        || is_precomputed_folder(path)
}

/// What kind of store a folder [`is_zarr_folder`] accepts is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreKind {
    Zarr,
    N5,
    Precomputed,
}

impl StoreKind {
    /// As the app's browser names it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Zarr => "Zarr store",
            Self::N5 => "N5 container",
            Self::Precomputed => "precomputed volume",
        }
    }
}

/// The kind of store the folder `path` is, if it is one ([`is_zarr_folder`]).
pub fn store_kind(path: &Path) -> Option<StoreKind> {
    if is_n5_folder(path) {
        Some(StoreKind::N5)
    } else if is_precomputed_folder(path) {
        Some(StoreKind::Precomputed)
    } else {
        is_zarr_folder(path).then_some(StoreKind::Zarr)
    }
}

/// If `path` is `ROOT/N` with `ROOT` a bioformats2raw container (a folder) and `N` a number
/// (whether or not the series exists): `ROOT` and `N`.
pub(crate) fn series_path(path: &Path) -> Option<(std::path::PathBuf, String)> {
    let name = path.file_name()?.to_str()?;
    if name.is_empty() || name.len() > 9 || !name.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let root = path.parent()?;
    let root = if root.as_os_str().is_empty() {
        Path::new(".")
    } else {
        root
    };
    if !root.is_dir() {
        return None;
    }
    let store = zarrs::filesystem::FilesystemStore::new(root).ok()?;
    let store: ReadableStorage = Arc::new(store);
    open::is_bioformats2raw_root(&store).then(|| (root.to_path_buf(), name.to_owned()))
}

/// If the folder `path` is a Zarr store whose root document is not written yet (`voxscope
/// convert` writes it last, once every level is complete): the subfolder that already holds a
/// Zarr array named as `convert` names levels (`0`, `1`, …; a subfolder that is a store of
/// its own is no sign of it).
pub fn unfinished_store(path: &Path) -> Option<String> {
    if is_zarr_folder(path) {
        return None;
    }
    subfolders(path)
        .into_iter()
        .filter(|sub| {
            sub.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                !n.is_empty() && n.len() <= 9 && n.bytes().all(|b| b.is_ascii_digit())
            })
        })
        .find(|sub| is_zarr_array_folder(sub))
        .and_then(|sub| sub.file_name().map(|n| n.to_string_lossy().into_owned()))
}

/// The first 64 subfolders of `path`, sorted.
fn subfolders(path: &Path) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir(path) else {
        return Vec::new();
    };
    let mut entries: Vec<_> = entries.flatten().map(|e| e.path()).collect();
    entries.sort();
    entries.truncate(64);
    entries
}

/// Whether the folder `path` holds a Zarr array's document: `.zarray`, or a `zarr.json` of
/// `node_type` array.
fn is_zarr_array_folder(path: &Path) -> bool {
    path.join(".zarray").is_file()
        || std::fs::metadata(path.join("zarr.json")).is_ok_and(|m| m.len() <= 1 << 20)
            && std::fs::read(path.join("zarr.json"))
                .ok()
                .and_then(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).ok())
                .is_some_and(|doc| doc.get("node_type").and_then(|t| t.as_str()) == Some("array"))
}

/// The stores (Zarr, N5, precomputed) among the first 64 subfolders of the folder `path`,
/// where `path` is none itself: a folder of stores, of which one is to be opened.
pub fn stores_inside(path: &Path) -> Vec<String> {
    if is_zarr_folder(path) {
        return Vec::new();
    }
    subfolders(path)
        .into_iter()
        .filter(|sub| store_kind(sub).is_some())
        .filter_map(|sub| sub.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect()
}

/// The words for a folder that holds the stores `names` ([`stores_inside`]).
pub(crate) fn folder_of_stores_problem(names: &[String]) -> String {
    let shown: Vec<String> = names
        .iter()
        .take(4)
        .map(|n| format!("'{}'", crate::error::escape(n)))
        .collect();
    let more = if names.len() > 4 {
        format!(" and {} more", names.len() - 4)
    } else {
        String::new()
    };
    format!(
        "is a folder of stores, not one: {}{more}; open one of them",
        shown.join(", ")
    )
}

/// The words for a store whose root document is missing while `level` holds an array.
pub(crate) fn unfinished_problem(level: &str) -> String {
    format!(
        "is a Zarr store still being written (or cut short): '{}' holds an array but the root has no zarr.json, .zgroup or .zarray yet; `voxscope convert` writes it last, when every level is complete",
        crate::error::escape(level)
    )
}
