//! A damaged-store generator for the fault tests and the network fuzz: Zarr stores written by
//! voxscope's own writer (the codecs that carry checks: gzip's CRC-32, zstd frames with a
//! content checksum, sharding's crc32c index; and uncompressed chunks), and copies of them
//! with one seeded kind of damage: a chunk cut short, lengthened, emptied, a byte flipped,
//! replaced by garbage or by a decompression bomb; metadata that is not JSON, declares a
//! huge shape, or is tens of megabytes. A reader must refuse each (one line) or, where the
//! damage changes no value (a byte of a header no value depends on, junk after a gzip
//! member), read the same values: never other values. An N5 container (n5-viewer levels of
//! uncompressed blocks, the edge blocks cut as Java's N5 writes them) is written here, by
//! hand, to the N5 specification, and a neuroglancer precomputed volume (raw chunks, the edge
//! ones cut) to neuroglancer's.

use std::path::{Path, PathBuf};

use super::fault_server::Rng;
use voxscope_volume::ome_zarr::{
    Compression, Downsampling, PyramidWriter, WriteOptions, ZarrVersion,
};
use voxscope_volume::{VoxelData, VoxelType};

/// A store the generator writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreKind {
    /// OME-Zarr 0.4 (Zarr v2), gzip chunks of 8³.
    Gzip,
    /// OME-Zarr 0.5 (Zarr v3), zstd chunks of 8³ with content checksums, one a shard.
    Zstd,
    /// OME-Zarr 0.5, shards of 2³ zstd chunks of 8³ (crc32c index).
    Sharded,
    /// OME-Zarr 0.4, uncompressed chunks of 8³.
    Raw,
    /// N5 (n5-viewer `scales`), uncompressed blocks of 8³, edge blocks cut to the dataset.
    N5,
    /// neuroglancer precomputed, unsharded raw chunks of 8³, edge chunks cut to the volume.
    Precomputed,
}

impl StoreKind {
    pub const ALL: [Self; 6] = [
        Self::Gzip,
        Self::Zstd,
        Self::Sharded,
        Self::Raw,
        Self::N5,
        Self::Precomputed,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Gzip => "gzip.ome.zarr",
            Self::Zstd => "zstd.ome.zarr",
            Self::Sharded => "sharded.ome.zarr",
            Self::Raw => "raw.ome.zarr",
            Self::N5 => "raw.n5",
            Self::Precomputed => "raw.precomputed",
        }
    }
}

/// Voxels of the generated stores: three levels (20×18×14, 10×9×7, 5×5×4), chunks that do not
/// divide them.
pub const DIMS: [usize; 3] = [20, 18, 14];

/// The generated volume's values (16-bit, every voxel distinct in its neighbourhood).
pub fn values() -> Vec<u16> {
    (0..DIMS.iter().product::<usize>())
        .map(|i| ((i * 7919) % 4001) as u16)
        .collect()
}

/// Writes the store `kind` under `folder`; its path.
pub fn write_store(folder: &Path, kind: StoreKind) -> PathBuf {
    let path = folder.join(kind.name());
    let (version, compression, shard_chunks) = match kind {
        StoreKind::N5 => {
            write_n5(&path);
            return path;
        }
        StoreKind::Precomputed => {
            write_precomputed(&path);
            return path;
        }
        StoreKind::Gzip => (ZarrVersion::V04, Compression::Gzip, 1),
        StoreKind::Zstd => (ZarrVersion::V05, Compression::Zstd, 1),
        StoreKind::Sharded => (ZarrVersion::V05, Compression::Zstd, 2),
        StoreKind::Raw => (ZarrVersion::V04, Compression::None, 1),
    };
    let options = WriteOptions {
        version,
        chunk: 8,
        shard_chunks,
        compression,
        downsampling: Downsampling::Mean,
        name: kind.name().to_owned(),
        unit: None,
    };
    let mut writer = PyramidWriter::create(&path, DIMS, VoxelType::U16, [1.0; 3], &options)
        .unwrap_or_else(|e| panic!("{}: {e}", kind.name()));
    writer
        .push(&VoxelData::U16(values()))
        .unwrap_or_else(|e| panic!("{}: {e}", kind.name()));
    writer
        .finish()
        .unwrap_or_else(|e| panic!("{}: {e}", kind.name()));
    path
}

/// An N5 container of three levels (every other voxel of the one before), blocks of 8³.
fn write_n5(path: &Path) {
    const BLOCK: usize = 8;
    let write_json = |folder: &Path, json: serde_json::Value| {
        std::fs::create_dir_all(folder).expect("a folder");
        std::fs::write(folder.join("attributes.json"), json.to_string()).expect("a document");
    };
    write_json(
        path,
        serde_json::json!({"n5": "2.5.1", "scales": [[1, 1, 1], [2, 2, 2], [4, 4, 4]]}),
    );
    for (s, (dims, level)) in subsampled_levels().into_iter().enumerate() {
        let dataset = path.join(format!("s{s}"));
        write_json(
            &dataset,
            serde_json::json!({"dimensions": dims, "blockSize": [BLOCK, BLOCK, BLOCK], "dataType": "uint16",
                "compression": {"type": "raw"}}),
        );
        let grid: [usize; 3] = std::array::from_fn(|a| dims[a].div_ceil(BLOCK));
        for b in 0..grid.iter().product::<usize>() {
            let at = [b % grid[0], b / grid[0] % grid[1], b / grid[0] / grid[1]];
            let start: [usize; 3] = std::array::from_fn(|a| at[a] * BLOCK);
            let extent: [usize; 3] = std::array::from_fn(|a| BLOCK.min(dims[a] - start[a]));
            let mut block = vec![0u8, 0, 0, 3];
            for e in extent {
                block.extend_from_slice(&(e as u32).to_be_bytes());
            }
            block_values(&level, dims, start, extent, &mut |v| {
                block.extend_from_slice(&v.to_be_bytes())
            });
            let file = dataset.join(format!("{}/{}/{}", at[0], at[1], at[2]));
            std::fs::create_dir_all(file.parent().expect("a parent")).expect("a folder");
            std::fs::write(file, block).expect("a block");
        }
    }
}

/// The levels the hand-written stores hold: the volume, then every other voxel of the level
/// before, twice; each with its dimensions.
fn subsampled_levels() -> Vec<([usize; 3], Vec<u16>)> {
    let mut levels = vec![(DIMS, values())];
    for _ in 0..2 {
        let (dims, level) = &levels[levels.len() - 1];
        let coarser: [usize; 3] = std::array::from_fn(|a| dims[a].div_ceil(2));
        let values = (0..coarser.iter().product::<usize>())
            .map(|i| {
                let (x, y, z) = (
                    i % coarser[0],
                    i / coarser[0] % coarser[1],
                    i / coarser[0] / coarser[1],
                );
                level[2 * x + dims[0] * (2 * y + dims[1] * 2 * z)]
            })
            .collect();
        levels.push((coarser, values));
    }
    levels
}

/// The values of the block of `dims` starting at `start` of `extent` voxels, x fastest, each
/// written by `put`.
fn block_values(
    level: &[u16],
    dims: [usize; 3],
    start: [usize; 3],
    extent: [usize; 3],
    put: &mut dyn FnMut(u16),
) {
    for z in 0..extent[2] {
        for y in 0..extent[1] {
            for x in 0..extent[0] {
                let (x, y, z) = (start[0] + x, start[1] + y, start[2] + z);
                put(level[x + dims[0] * (y + dims[1] * z)]);
            }
        }
    }
}

/// A neuroglancer precomputed volume of three scales (every other voxel of the one before),
/// raw chunks of 8³ named by their voxel ranges, the edge ones cut.
fn write_precomputed(path: &Path) {
    const CHUNK: usize = 8;
    let levels = subsampled_levels();
    let scales: Vec<serde_json::Value> = levels
        .iter()
        .enumerate()
        .map(|(s, (dims, _))| {
            let f = 1 << s;
            serde_json::json!({"key": format!("{f}_{f}_{f}"), "size": dims,
                "resolution": [f, f, f], "voxel_offset": [0, 0, 0],
                "chunk_sizes": [[CHUNK, CHUNK, CHUNK]], "encoding": "raw"})
        })
        .collect();
    std::fs::create_dir_all(path).expect("a folder");
    let info = serde_json::json!({"@type": "neuroglancer_multiscale_volume", "type": "image",
        "data_type": "uint16", "num_channels": 1, "scales": scales});
    std::fs::write(path.join("info"), info.to_string()).expect("the info");
    for (s, (dims, level)) in levels.iter().enumerate() {
        let f = 1 << s;
        let folder = path.join(format!("{f}_{f}_{f}"));
        std::fs::create_dir_all(&folder).expect("a folder");
        let grid: [usize; 3] = std::array::from_fn(|a| dims[a].div_ceil(CHUNK));
        for b in 0..grid.iter().product::<usize>() {
            let at = [b % grid[0], b / grid[0] % grid[1], b / grid[0] / grid[1]];
            let start: [usize; 3] = std::array::from_fn(|a| at[a] * CHUNK);
            let end: [usize; 3] = std::array::from_fn(|a| (start[a] + CHUNK).min(dims[a]));
            let extent: [usize; 3] = std::array::from_fn(|a| end[a] - start[a]);
            let mut bytes = Vec::new();
            block_values(level, *dims, start, extent, &mut |v| {
                bytes.extend_from_slice(&v.to_le_bytes())
            });
            let name = format!(
                "{}-{}_{}-{}_{}-{}",
                start[0], end[0], start[1], end[1], start[2], end[2]
            );
            std::fs::write(folder.join(name), bytes).expect("a chunk");
        }
    }
}

/// Every file under `root`, relative, sorted (the order a seed picks from).
pub fn files(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if let Ok(relative) = path.strip_prefix(root) {
                out.push(relative.to_path_buf());
            }
        }
    }
    out.sort();
    out
}

/// Whether `relative` is a metadata document (not a chunk or shard).
pub fn is_metadata(relative: &Path) -> bool {
    let name = relative
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    matches!(
        name,
        "zarr.json" | ".zarray" | ".zattrs" | ".zgroup" | "attributes.json" | "info"
    )
}

/// One kind of damage.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Damage {
    /// A chunk cut to this many bytes (fewer than it has).
    Truncate(PathBuf, usize),
    /// Junk bytes appended to a chunk.
    Extend(PathBuf, usize),
    /// A chunk of no bytes.
    Empty(PathBuf),
    /// One byte of a chunk changed (at this offset).
    Flip(PathBuf, usize),
    /// A chunk's bytes replaced by as many random ones.
    Garbage(PathBuf),
    /// A chunk replaced by a zstd frame declaring 2⁵⁰ decoded bytes.
    Bomb(PathBuf),
    /// A metadata document that is not JSON.
    BadJson(PathBuf),
    /// A metadata document of 20 MB.
    HugeDocument(PathBuf),
    /// An array's shape declared 10¹² voxels per axis.
    HugeShape(PathBuf),
}

impl Damage {
    /// A seeded damage of the store at `root` (written by [`write_store`] as `kind`).
    pub fn pick(root: &Path, kind: StoreKind, rng: &mut Rng) -> Self {
        let all = files(root);
        let chunks: Vec<&PathBuf> = all.iter().filter(|p| !is_metadata(p)).collect();
        let documents: Vec<&PathBuf> = all
            .iter()
            .filter(|p| {
                is_metadata(p)
                    && !p.ends_with(".zgroup")
                    && !(kind == StoreKind::Gzip
                        && p.ends_with(".zattrs")
                        && p.components().count() > 1)
            })
            .collect();
        let chunk = chunks[rng.below(chunks.len() as u64) as usize].clone();
        let size = std::fs::metadata(root.join(&chunk)).map_or(0, |m| m.len() as usize);
        // The raw stores carry no check: only damage that changes a chunk's length is
        // detectable there.
        let chunk_damages = if matches!(
            kind,
            StoreKind::Raw | StoreKind::N5 | StoreKind::Precomputed
        ) {
            4
        } else {
            7
        };
        let choice = rng.below(chunk_damages + 3);
        if choice >= chunk_damages {
            let document = documents[rng.below(documents.len() as u64) as usize].clone();
            return match choice - chunk_damages {
                0 => Self::BadJson(document),
                1 => Self::HugeDocument(document),
                _ => Self::HugeShape(document),
            };
        }
        match choice {
            0 => Self::Truncate(chunk, rng.below(size.max(1) as u64) as usize),
            1 => Self::Extend(chunk, 1 + rng.below(64) as usize),
            2 => Self::Empty(chunk),
            3 => Self::Bomb(chunk),
            4 => Self::Flip(chunk, rng.below(size.max(1) as u64) as usize),
            _ => Self::Garbage(chunk),
        }
    }

    /// Applies the damage to the store at `root` (a copy: the generator never changes the
    /// original).
    pub fn apply(&self, root: &Path, rng: &mut Rng) {
        let edit = |relative: &Path, change: &dyn Fn(Vec<u8>) -> Vec<u8>| {
            let path = root.join(relative);
            let bytes = std::fs::read(&path).unwrap_or_default();
            std::fs::write(&path, change(bytes)).expect("the copy is writable");
        };
        match self {
            Self::Truncate(p, keep) => edit(p, &|mut b| {
                b.truncate(*keep);
                b
            }),
            Self::Extend(p, extra) => {
                let junk: Vec<u8> = (0..*extra).map(|_| rng.next() as u8).collect();
                edit(p, &|mut b| {
                    b.extend_from_slice(&junk);
                    b
                })
            }
            Self::Empty(p) => edit(p, &|_| Vec::new()),
            Self::Flip(p, at) => {
                let bit = 1u8 << rng.below(8);
                edit(p, &|mut b| {
                    if let Some(byte) = b.get_mut(*at) {
                        *byte ^= bit;
                    }
                    b
                })
            }
            Self::Garbage(p) => {
                let seed = rng.next();
                edit(p, &|b| {
                    let mut r = Rng::new(seed);
                    (0..b.len().max(1)).map(|_| r.next() as u8).collect()
                })
            }
            Self::Bomb(p) => edit(p, &|_| {
                let mut frame = vec![0x28, 0xB5, 0x2F, 0xFD, 0xE0];
                frame.extend_from_slice(&(1u64 << 50).to_le_bytes());
                frame.extend_from_slice(&[0x01, 0x00, 0x00]);
                frame
            }),
            Self::BadJson(p) => edit(p, &|b| {
                let mut b = b;
                b.truncate(b.len() / 2);
                b
            }),
            Self::HugeDocument(p) => edit(p, &|_| {
                let mut b = b"{\"padding\": \"".to_vec();
                b.resize(20 << 20, b'x');
                b.extend_from_slice(b"\"}");
                b
            }),
            Self::HugeShape(p) => edit(p, &|b| {
                let text = String::from_utf8_lossy(&b).into_owned();
                let Ok(mut json) = serde_json::from_str::<serde_json::Value>(&text) else {
                    return b;
                };
                // A precomputed volume's every scale's `size` (an N5 group's `scales` are
                // lists, left as they are).
                if let Some(scales) = json.get_mut("scales").and_then(|s| s.as_array_mut()) {
                    let huge = serde_json::Value::from(vec![1_000_000_000_000u64; 3]);
                    let sized = scales.iter_mut().filter_map(|scale| scale.as_object_mut());
                    let mut any = false;
                    for scale in sized {
                        scale.insert("size".to_owned(), huge.clone());
                        any = true;
                    }
                    if any {
                        return json.to_string().into_bytes();
                    }
                }
                // Zarr's `shape`, N5's `dimensions`.
                let key = if json.get("shape").is_some() {
                    "shape"
                } else {
                    "dimensions"
                };
                if let Some(shape) = json.get_mut(key).and_then(|s| s.as_array_mut()) {
                    for extent in shape.iter_mut() {
                        *extent = serde_json::json!(1_000_000_000_000u64);
                    }
                }
                json.to_string().into_bytes()
            }),
        }
    }
}

/// A copy of the store at `from` in `to` (a fresh folder).
pub fn copy_store(from: &Path, to: &Path) {
    for relative in files(from) {
        let target = to.join(&relative);
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).expect("a folder");
        }
        std::fs::copy(from.join(&relative), target).expect("a copy");
    }
}
