//! OME-Zarr (0.1–0.5: Zarr v2 and v3, sharding) and plain Zarr arrays: a [`Pyramid`] of levels
//! read region by region, never a whole level at once, and a [`Volume`] of the finest level
//! that fits [`VOLUME_VOXEL_BUDGET`] for the in-memory renderers.
//!
//! Chunks are read and decoded by zarrs (blosc, zstd, gzip, uncompressed; `.` or `/` chunk
//! keys; sharding) from any zarrs `ReadableStorageTraits` store: a folder, or a URL
//! (`http://`, `https://`, `s3://`: [`super::remote`]). What a file declares is checked before anything of that size exists:
//! the region a caller asks for bounds the output, a chunk holds at most [`MAX_CHUNK_BYTES`]
//! decoded, a shard at most [`MAX_SHARD_CHUNKS`] chunks, a metadata document at most 16 MiB,
//! and a compressed chunk never decodes into more than its chunk's bytes ([`guard`]).
//!
//! **Missing chunks read as the array's fill value** (Zarr's rule: writers skip chunks that
//! hold only the fill value). A chunk that is present but cannot be decoded, or decodes to
//! the wrong size, is an error that names the chunk's key.

mod guard;
mod metadata;
mod source;
mod write;

use std::path::Path;
use std::sync::Arc;

use serde_json::{Map, Value};
use zarrs::array::data_type::{
    Float32DataType, Float64DataType, Int8DataType, Int16DataType, Int32DataType, Int64DataType,
    UInt8DataType, UInt16DataType, UInt32DataType, UInt64DataType,
};
use zarrs::array::{Array, ArrayMetadata, ArrayShardedExt, ArraySubset, DataType};
use zarrs::storage::{ReadableStorageTraits, StoreKey};

use super::error::{Problem, printable, quoted};
use super::remote::{RemoteOptions, RemoteStats, RemoteStore};
use super::series::{ChannelInfo, Series, parse_hex_color};
use super::{
    LoadError, MAX_VOXELS, Selection, ValueWindow, Volume, VoxelData, VoxelType, format_dims,
};

pub use metadata::{Axis, AxisKind, OmeroChannel};
pub use source::SlabSource;
pub use write::{Compression, Downsampling, PyramidWriter, WriteOptions, ZarrVersion, level_dims};
/// A store the pyramid reads from: a folder ([`zarrs::filesystem::FilesystemStore`]) or any
/// other zarrs storage (HTTP, object stores).
pub use zarrs::storage::ReadableStorage;

/// The largest decoded chunk (or inner chunk of a shard) read: any read of a chunk holds all
/// of it in memory at once. Larger chunks are refused; rechunk such data (`voxscope convert`).
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// The most chunks one shard may hold: its index (16 bytes a chunk) is read whole.
pub const MAX_SHARD_CHUNKS: u64 = 1 << 20;

/// The largest metadata document (`zarr.json`, `.zarray`, `.zattrs`, `.zgroup`) read.
const MAX_METADATA_BYTES: u64 = 16 << 20;

/// The largest level [`load`] (the app's and CLI's in-memory path) reads: 512³ voxels. The
/// finest level within it is opened; finer levels wait for the streaming renderer.
pub const VOLUME_VOXEL_BUDGET: usize = 512 * 512 * 512;

/// Which 3D volume of a multi-channel, time-lapse image is read: the loaders' [`Selection`].
pub type PyramidOptions = Selection;

/// One resolution level: its grid, its place in space and how it is stored.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelInfo {
    /// The array's path inside the group (`0`, `s1`); empty for a plain array at the root.
    pub path: String,
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Voxel size along x, y, z in the axes' units (the level's `scale`).
    pub spacing: [f64; 3],
    /// The first voxel's center along x, y, z (the level's `translation`).
    pub origin: [f64; 3],
    /// The chunk a read decodes as a unit, along x, y, z (the inner chunk of a shard).
    pub chunk: [usize; 3],
    /// The shard (one stored object holding many chunks) along x, y, z, if sharded.
    pub shard: Option<[usize; 3]>,
    /// The codecs, as `blosc lz4`, `zstd`, `sharding(blosc zstd)`, `none`.
    pub codec: String,
    /// The value missing chunks read as, in the stored type.
    pub fill_value: f64,
}

impl LevelInfo {
    /// Voxels of the level (one channel, one time point).
    pub fn voxel_count(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product()
    }

    /// Chunks along x, y, z.
    pub fn chunk_grid(&self) -> [usize; 3] {
        std::array::from_fn(|a| self.dims[a].div_ceil(self.chunk[a]))
    }
}

/// The stored scalar type, which may be wider than voxscope's [`VoxelType`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stored {
    Native(VoxelType),
    /// 64-bit integers, read as f64 (exact below 2⁵³).
    U64,
    I64,
}

impl Stored {
    fn of(data_type: &DataType) -> Option<Self> {
        Some(if data_type.is::<UInt8DataType>() {
            Self::Native(VoxelType::U8)
        } else if data_type.is::<Int8DataType>() {
            Self::Native(VoxelType::I8)
        } else if data_type.is::<UInt16DataType>() {
            Self::Native(VoxelType::U16)
        } else if data_type.is::<Int16DataType>() {
            Self::Native(VoxelType::I16)
        } else if data_type.is::<UInt32DataType>() {
            Self::Native(VoxelType::U32)
        } else if data_type.is::<Int32DataType>() {
            Self::Native(VoxelType::I32)
        } else if data_type.is::<Float32DataType>() {
            Self::Native(VoxelType::F32)
        } else if data_type.is::<Float64DataType>() {
            Self::Native(VoxelType::F64)
        } else if data_type.is::<UInt64DataType>() {
            Self::U64
        } else if data_type.is::<Int64DataType>() {
            Self::I64
        } else {
            return None;
        })
    }

    fn voxel_type(self) -> VoxelType {
        match self {
            Self::Native(voxel_type) => voxel_type,
            Self::U64 | Self::I64 => VoxelType::F64,
        }
    }
}

/// Which array dimension holds what.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    ndim: usize,
    time: Option<usize>,
    channel: Option<usize>,
    /// x, y, z; z is absent for a 2D image (then one slice deep).
    space: [Option<usize>; 3],
}

/// A multiscale image (or a plain Zarr array as one level), opened for reading regions.
pub struct Pyramid {
    /// The path (or store description) it was opened from.
    pub source: String,
    /// `OME-Zarr` or `Zarr` (a plain array).
    pub format: &'static str,
    /// The OME-Zarr version (`0.4`, `0.5`), if the group says.
    pub ome_version: Option<String>,
    /// 2 or 3.
    pub zarr_format: u8,
    /// The image's name in the metadata, if any.
    pub name: Option<String>,
    /// Finest first.
    pub levels: Vec<LevelInfo>,
    /// The stored array's axes, outermost first.
    pub axes: Vec<Axis>,
    /// Units of x, y, z (from the axes), if given.
    pub units: [Option<String>; 3],
    /// Extent of the channel axis (1 without one).
    pub channels: usize,
    /// Extent of the time axis (1 without one).
    pub time_points: usize,
    /// The channel and time point that [`Self::read_region`] reads.
    pub selected: PyramidOptions,
    /// `omero` channel names, colors and windows (empty without `omero`).
    pub omero: Vec<OmeroChannel>,
    /// The type [`Self::read_region`] returns.
    pub voxel_type: VoxelType,
    /// The stored data type's Zarr name (`uint16`, `int64`, …).
    pub stored_type: String,
    /// How the levels were computed (`type` of the multiscale), if said.
    pub downscaling: Option<String>,
    stored: Stored,
    layout: Layout,
    arrays: Vec<Array<dyn ReadableStorageTraits>>,
    store: ReadableStorage,
    /// Where the levels' chunk ranges are (`voxscope.chunk_ranges.paths`), full store paths.
    range_paths: Vec<String>,
    /// The store again, where it is remote: a region's chunks are fetched together.
    remote: Option<Arc<RemoteStore>>,
    /// Where a remote store's reads run: zarrs reads a region's chunks (a sharded array's
    /// shards) on rayon threads, each blocked on the network while it waits, so they get a
    /// pool of their own as large as the request limit, not the cores' global pool.
    reader_pool: Option<Arc<rayon::ThreadPool>>,
}

impl std::fmt::Debug for Pyramid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pyramid")
            .field("source", &self.source)
            .field("levels", &self.levels)
            .field("voxel_type", &self.voxel_type)
            .finish_non_exhaustive()
    }
}

/// Whether `spec` names something [`Pyramid::open_spec`] opens: a URL
/// ([`super::remote::is_url`]) or a Zarr folder.
pub fn is_zarr_spec(spec: &str) -> bool {
    super::remote::is_url(spec) || is_zarr_folder(Path::new(spec))
}

/// Whether `path` is a Zarr folder: `.zgroup`, `.zarray` or `zarr.json` in it.
pub fn is_zarr_folder(path: &Path) -> bool {
    path.is_dir()
        && [".zgroup", ".zarray", "zarr.json"]
            .iter()
            .any(|name| path.join(name).is_file())
}

impl Pyramid {
    /// Opens the Zarr folder at `path` (an OME-Zarr group, a bioformats2raw container, or a
    /// plain array), selecting the channel and time point of `options`.
    pub fn open(path: &Path, options: PyramidOptions) -> Result<Self, LoadError> {
        let source = path.display().to_string();
        if !path.is_dir() {
            return Err(LoadError::new(
                &source,
                "is not a folder (a Zarr store is one)",
            ));
        }
        let store = zarrs::filesystem::FilesystemStore::new(path)
            .map_err(|e| LoadError::new(&source, format!("cannot open: {e}")))?;
        Self::open_store(Arc::new(store), &source, options)
    }

    /// Opens the Zarr store at `url` (`http://`, `https://`, `s3://BUCKET/PATH`; see
    /// [`super::remote`]) as [`Self::open`] opens a folder. The source it names in messages is
    /// the URL without user name, password or query.
    pub fn open_url(
        url: &str,
        options: PyramidOptions,
        remote: RemoteOptions,
    ) -> Result<Self, LoadError> {
        let source = super::remote::display_url(url);
        let store =
            RemoteStore::open(url, remote).map_err(|problem| LoadError::new(&source, problem))?;
        let mut pyramid = Self::open_store(store.clone(), &source, options)?;
        store.mark_opened();
        pyramid.remote = Some(store);
        let threads = remote.max_requests.clamp(4, 64);
        pyramid.reader_pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("voxscope-remote-{i}"))
            .build()
            .ok()
            .map(Arc::new);
        Ok(pyramid)
    }

    /// Opens a URL ([`Self::open_url`]) or a folder ([`Self::open`]).
    pub fn open_spec(
        spec: &str,
        options: PyramidOptions,
        remote: RemoteOptions,
    ) -> Result<Self, LoadError> {
        if super::remote::is_url(spec) {
            Self::open_url(spec, options, remote)
        } else {
            Self::open(Path::new(spec), options)
        }
    }

    /// Requests, bytes and errors of a remote store so far (`None` for a folder).
    pub fn remote_stats(&self) -> Option<RemoteStats> {
        self.remote.as_ref().map(|store| store.stats())
    }

    /// Opens the Zarr hierarchy at the root of `store`; `source` names it in messages.
    pub fn open_store(
        store: ReadableStorage,
        source: &str,
        options: PyramidOptions,
    ) -> Result<Self, LoadError> {
        guard::register();
        open_root(store, source, options).map_err(|problem| LoadError::new(source, problem))
    }

    /// The voxels `[origin, origin + size)` of `level` (x, y, z; within the level's
    /// dimensions, else an error), of the channel and time point chosen at open, x fastest,
    /// in [`Self::voxel_type`]. Memory: the region, plus one decoded chunk per reading thread.
    pub fn read_region(
        &self,
        level: usize,
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Result<VoxelData, LoadError> {
        self.read_region_problem(level, origin, size)
            .map_err(|problem| LoadError::new(&self.source, problem))
    }

    /// A whole level (or what [`load`] reads).
    pub fn read_level(&self, level: usize) -> Result<VoxelData, LoadError> {
        let dims = self
            .levels
            .get(level)
            .map(|l| l.dims)
            .ok_or_else(|| LoadError::new(&self.source, format!("no level {level}")))?;
        self.read_region(level, [0; 3], dims)
    }

    /// The finest level with at most `budget` voxels (the coarsest when none is).
    pub fn finest_within(&self, budget: u64) -> usize {
        self.levels
            .iter()
            .position(|l| l.voxel_count() <= budget)
            .unwrap_or(self.levels.len() - 1)
    }

    /// Every chunk's smallest and largest value at `level`, if the image has them (`voxscope
    /// convert` writes them): grid z, y, x order (x fastest, [`LevelInfo::chunk_grid`]); NaN
    /// for a chunk without a finite value. Lets a reader skip chunks a transfer function makes
    /// empty before it reads them. Costs 16 bytes per chunk; refused beyond 2²⁴ chunks.
    pub fn chunk_ranges(&self, level: usize) -> Result<Option<Vec<[f64; 2]>>, LoadError> {
        const MAX_CHUNKS: u64 = 1 << 24;
        let (Some(path), Some(info)) = (self.range_paths.get(level), self.levels.get(level)) else {
            return Ok(None);
        };
        let fail = |problem: String| LoadError::new(&self.source, problem);
        let array = Array::open(self.store.clone(), &format!("/{path}")).map_err(|e| {
            fail(format!(
                "chunk ranges {}: {}",
                quoted(path),
                printable(&e.to_string())
            ))
        })?;
        let [gx, gy, gz] = info.chunk_grid().map(|n| n as u64);
        if array.shape() != [gz, gy, gx, 2] || !array.data_type().is::<Float64DataType>() {
            return Err(fail(format!(
                "chunk ranges {} are not float64 [{gz}, {gy}, {gx}, 2] (level {level}'s chunk grid)",
                quoted(path)
            )));
        }
        if gz * gy * gx > MAX_CHUNKS {
            return Err(fail(format!(
                "chunk ranges {}: {} chunks exceed {MAX_CHUNKS}",
                quoted(path),
                gz * gy * gx
            )));
        }
        let values: Vec<f64> = array
            .retrieve_array_subset(&array.subset_all())
            .map_err(|e| {
                fail(format!(
                    "chunk ranges {}: {}",
                    quoted(path),
                    printable(&e.to_string())
                ))
            })?;
        Ok(Some(values.chunks_exact(2).map(|p| [p[0], p[1]]).collect()))
    }

    /// The channels (named, colored and windowed by `omero` where it says) and time points.
    pub fn series(&self) -> Series {
        let channels = (0..self.channels)
            .map(|index| {
                let omero = self.omero.get(index);
                ChannelInfo {
                    name: omero.and_then(|c| c.label.clone()),
                    color: omero
                        .and_then(|c| c.color.as_deref())
                        .and_then(parse_hex_color),
                    window: omero.and_then(|c| c.window),
                }
            })
            .collect();
        Series {
            channels,
            time_points: self.time_points,
            selected: self.selected,
        }
    }

    /// The `omero` window of the selected channel, if the file gives one.
    pub fn omero_window(&self) -> Option<ValueWindow> {
        self.omero
            .get(self.selected.channel)
            .and_then(|channel| channel.window)
    }

    /// The store key of the chunk of `level` holding voxel `(x, y, z)` (for messages and tests).
    pub fn chunk_key(&self, level: usize, voxel: [usize; 3]) -> Option<String> {
        let array = self.arrays.get(level)?;
        let info = &self.levels[level];
        let chunk = info.shard.unwrap_or(info.chunk);
        let mut indices = vec![0u64; self.layout.ndim];
        if let Some(t) = self.layout.time {
            indices[t] = self.selected.time as u64 / array_chunk(array, t);
        }
        if let Some(c) = self.layout.channel {
            indices[c] = self.selected.channel as u64 / array_chunk(array, c);
        }
        for (axis, dim) in self.layout.space.iter().enumerate() {
            if let Some(dim) = dim {
                indices[*dim] = (voxel[axis] / chunk[axis]) as u64;
            }
        }
        Some(array.chunk_key(&indices).to_string())
    }

    fn read_region_problem(
        &self,
        level: usize,
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Result<VoxelData, Problem> {
        let info = self
            .levels
            .get(level)
            .ok_or_else(|| format!("no level {level} (the pyramid has {})", self.levels.len()))?;
        for axis in 0..3 {
            let end = origin[axis].checked_add(size[axis]);
            if size[axis] == 0 || end.is_none_or(|end| end > info.dims[axis]) {
                return Err(format!(
                    "region {} at {} lies outside level {level} ({})",
                    format_dims(size),
                    format_dims(origin),
                    format_dims(info.dims)
                ));
            }
        }
        let count = size.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
        if count.is_none_or(|count| count > MAX_VOXELS) {
            return Err(format!(
                "region {} exceeds the limit of {MAX_VOXELS} voxels",
                format_dims(size)
            ));
        }
        let subset = self.subset(origin, size);
        let array = &self.arrays[level];
        if let Some(remote) = &self.remote
            && info.shard.is_none()
        {
            // zarrs asks for one chunk per reading thread at a time: over a network all of
            // the region's chunks are asked for at once first.
            if let Ok(Some(chunks)) = array.chunks_in_array_subset(&subset) {
                let keys: Vec<StoreKey> = chunks
                    .indices()
                    .into_iter()
                    .map(|indices| array.chunk_key(&indices))
                    .collect();
                remote.prefetch(&keys);
            }
        }
        let read = || match self.stored {
            Stored::Native(VoxelType::U8) => {
                array.retrieve_array_subset(&subset).map(VoxelData::U8)
            }
            Stored::Native(VoxelType::I8) => {
                array.retrieve_array_subset(&subset).map(VoxelData::I8)
            }
            Stored::Native(VoxelType::U16) => {
                array.retrieve_array_subset(&subset).map(VoxelData::U16)
            }
            Stored::Native(VoxelType::I16) => {
                array.retrieve_array_subset(&subset).map(VoxelData::I16)
            }
            Stored::Native(VoxelType::U32) => {
                array.retrieve_array_subset(&subset).map(VoxelData::U32)
            }
            Stored::Native(VoxelType::I32) => {
                array.retrieve_array_subset(&subset).map(VoxelData::I32)
            }
            Stored::Native(VoxelType::F32) => {
                array.retrieve_array_subset(&subset).map(VoxelData::F32)
            }
            Stored::Native(VoxelType::F64) => {
                array.retrieve_array_subset(&subset).map(VoxelData::F64)
            }
            Stored::U64 => array
                .retrieve_array_subset::<Vec<u64>>(&subset)
                .map(|v| VoxelData::F64(v.into_iter().map(|x| x as f64).collect())),
            Stored::I64 => array
                .retrieve_array_subset::<Vec<i64>>(&subset)
                .map(|v| VoxelData::F64(v.into_iter().map(|x| x as f64).collect())),
        };
        let read = match &self.reader_pool {
            Some(pool) => pool.install(read),
            None => read(),
        };
        read.map_err(|error| self.failing_chunk(level, &subset, &error.to_string()))
    }

    /// The region `origin`/`size` (x, y, z) as a subset of the stored array.
    fn subset(&self, origin: [usize; 3], size: [usize; 3]) -> ArraySubset {
        let mut ranges = vec![0u64..1; self.layout.ndim];
        if let Some(t) = self.layout.time {
            let t0 = self.selected.time as u64;
            ranges[t] = t0..t0 + 1;
        }
        if let Some(c) = self.layout.channel {
            let c0 = self.selected.channel as u64;
            ranges[c] = c0..c0 + 1;
        }
        for (axis, dim) in self.layout.space.iter().enumerate() {
            if let Some(dim) = dim {
                ranges[*dim] = origin[axis] as u64..(origin[axis] + size[axis]) as u64;
            }
        }
        ArraySubset::new_with_ranges(&ranges)
    }

    /// Why reading `subset` failed, naming the first chunk (in storage order) that fails
    /// alone; zarrs's own message when none does (a store failing intermittently).
    fn failing_chunk(&self, level: usize, subset: &ArraySubset, error: &str) -> Problem {
        /// Chunks retried one by one; the first failure is usually among the first.
        const MAX_RETRIED: usize = 4096;
        let array = &self.arrays[level];
        let path = &self.levels[level].path;
        let at = if path.is_empty() {
            format!("level {level}")
        } else {
            format!("level {level} ({})", quoted(path))
        };
        if let Ok(Some(chunks)) = array.chunks_in_array_subset(subset) {
            for indices in chunks.indices().into_iter().take(MAX_RETRIED) {
                let indices: Vec<u64> = indices.to_vec();
                let Ok(chunk) = array.chunk_subset_bounded(&indices) else {
                    continue;
                };
                let Ok(overlap) = chunk.overlap(subset) else {
                    continue;
                };
                let Ok(relative) = overlap.relative_to(chunk.start()) else {
                    continue;
                };
                if let Err(e) = array
                    .retrieve_chunk_subset::<zarrs::array::ArrayBytes<'static>>(&indices, &relative)
                {
                    return format!(
                        "{at}, chunk {}: {}",
                        quoted(&array.chunk_key(&indices).to_string()),
                        printable(&e.to_string())
                    );
                }
            }
        }
        format!("{at}: {}", printable(error))
    }
}

fn array_chunk(array: &Array<dyn ReadableStorageTraits>, dim: usize) -> u64 {
    let zeros = vec![0u64; array.dimensionality()];
    array
        .chunk_shape(&zeros)
        .ok()
        .and_then(|shape| shape.get(dim).map(|n| n.get()))
        .unwrap_or(1)
}

/// Reads a metadata document (JSON object) at `key`, if present, after checking its size.
fn read_json(store: &ReadableStorage, key: &str) -> Result<Option<Map<String, Value>>, Problem> {
    let store_key = StoreKey::new(key).map_err(|e| format!("store key {}: {e}", quoted(key)))?;
    match store.size_key(&store_key) {
        Ok(Some(size)) if size > MAX_METADATA_BYTES => {
            return Err(format!(
                "{key} is {size} bytes; metadata of more than {MAX_METADATA_BYTES} bytes is not read"
            ));
        }
        Ok(Some(_)) => {}
        Ok(None) => return Ok(None),
        Err(e) => return Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    }
    let bytes = match store.get(&store_key) {
        Ok(Some(bytes)) => bytes,
        Ok(None) => return Ok(None),
        Err(e) => return Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    };
    let value: Value =
        serde_json::from_slice(&bytes).map_err(|e| format!("{key} is not valid JSON: {e}"))?;
    match value {
        Value::Object(map) => Ok(Some(map)),
        _ => Err(format!("{key} is not a JSON object")),
    }
}

/// What sits at a node: a group with its attributes, an array, or nothing.
enum Node {
    Group {
        attributes: Map<String, Value>,
        zarr_format: u8,
    },
    Array {
        zarr_format: u8,
    },
    Missing,
}

fn node(store: &ReadableStorage, prefix: &str) -> Result<Node, Problem> {
    if let Some(json) = read_json(store, &format!("{prefix}zarr.json"))? {
        return match json.get("node_type").and_then(Value::as_str) {
            Some("group") => Ok(Node::Group {
                attributes: match json.get("attributes") {
                    Some(Value::Object(map)) => map.clone(),
                    _ => Map::new(),
                },
                zarr_format: 3,
            }),
            Some("array") => Ok(Node::Array { zarr_format: 3 }),
            _ => Err(format!(
                "{prefix}zarr.json has no node_type 'group' or 'array'"
            )),
        };
    }
    if store
        .size_key(&key(&format!("{prefix}.zarray"))?)
        .map_err(|e| e.to_string())?
        .is_some()
    {
        return Ok(Node::Array { zarr_format: 2 });
    }
    if store
        .size_key(&key(&format!("{prefix}.zgroup"))?)
        .map_err(|e| e.to_string())?
        .is_some()
    {
        let attributes = read_json(store, &format!("{prefix}.zattrs"))?.unwrap_or_default();
        return Ok(Node::Group {
            attributes,
            zarr_format: 2,
        });
    }
    Ok(Node::Missing)
}

fn key(text: &str) -> Result<StoreKey, Problem> {
    StoreKey::new(text).map_err(|e| format!("store key {}: {e}", quoted(text)))
}

fn open_root(
    store: ReadableStorage,
    source: &str,
    options: PyramidOptions,
) -> Result<Pyramid, Problem> {
    let (attributes, zarr_format, prefix) = match node(&store, "")? {
        Node::Missing => {
            return Err(
                "is not a Zarr store: no zarr.json, .zgroup or .zarray at its root".to_owned(),
            );
        }
        Node::Array { zarr_format } => {
            return open_levels(store, source, options, None, Map::new(), zarr_format, "");
        }
        Node::Group {
            attributes,
            zarr_format,
        } => {
            if metadata::bioformats2raw_image(&attributes) {
                // bioformats2raw.layout 3: the images are groups 0, 1, …; the first is read.
                match node(&store, "0/")? {
                    Node::Group {
                        attributes,
                        zarr_format,
                    } => (attributes, zarr_format, "0/"),
                    _ => {
                        return Err(
                            "is a bioformats2raw container without an image group '0'".to_owned()
                        );
                    }
                }
            } else {
                (attributes, zarr_format, "")
            }
        }
    };
    let multiscale = metadata::multiscale(&attributes)?.ok_or(
        "is a Zarr group without OME-Zarr 'multiscales' metadata (open an array inside it, or an OME-Zarr image)",
    )?;
    open_levels(
        store,
        source,
        options,
        Some(multiscale),
        attributes,
        zarr_format,
        prefix,
    )
}

fn open_levels(
    store: ReadableStorage,
    source: &str,
    options: PyramidOptions,
    multiscale: Option<metadata::Multiscale>,
    attributes: Map<String, Value>,
    zarr_format: u8,
    prefix: &str,
) -> Result<Pyramid, Problem> {
    let paths: Vec<String> = match &multiscale {
        Some(m) => m.datasets.iter().map(|d| d.path.clone()).collect(),
        None => vec![String::new()],
    };
    let mut arrays = Vec::with_capacity(paths.len());
    for path in &paths {
        let full = format!("{prefix}{path}");
        let shown = if full.is_empty() {
            "the root array".to_owned()
        } else {
            format!("array {}", quoted(&full))
        };
        // The documents zarrs reads whole are bounded first.
        for name in ["zarr.json", ".zarray", ".zattrs"] {
            let key = if full.is_empty() {
                name.to_owned()
            } else {
                format!("{full}/{name}")
            };
            read_size_checked(&store, &key)?;
        }
        let array = Array::open(store.clone(), &format!("/{full}"))
            .map_err(|e| format!("{shown}: {}", printable(&e.to_string())))?;
        let array = through_codec_plugins(array, &store, &full);
        arrays.push((full, shown, array));
    }

    let first = &arrays[0].2;
    let ndim = first.dimensionality();
    let axes = match multiscale.as_ref().and_then(|m| m.axes.clone()) {
        Some(axes) => axes,
        None => match first.dimension_names() {
            Some(names) if names.iter().all(Option::is_some) && names.len() == ndim => names
                .iter()
                .flatten()
                .map(|name| Axis {
                    name: printable(name),
                    kind: metadata::kind_by_name(name),
                    unit: None,
                })
                .collect(),
            _ => {
                if !(2..=5).contains(&ndim) {
                    return Err(format!(
                        "{} has {ndim} dimensions; a volume has 2 to 5 (t, c, z, y, x)",
                        arrays[0].1
                    ));
                }
                metadata::default_axes(ndim)
            }
        },
    };
    if axes.len() != ndim {
        return Err(format!(
            "the metadata names {} axes but {} has {ndim} dimensions",
            axes.len(),
            arrays[0].1
        ));
    }
    let layout = layout_of(&axes)?;
    let stored = Stored::of(first.data_type()).ok_or_else(|| {
        format!(
            "{} holds {} values; voxscope reads uint8/16/32/64, int8/16/32/64, float32 and float64",
            arrays[0].1,
            printable(&type_name(first.data_type()))
        )
    })?;
    let stored_type = type_name(first.data_type());
    let leading = |array: &Array<dyn ReadableStorageTraits>, dim: Option<usize>| {
        dim.map_or(1, |d| array.shape()[d])
    };
    let time_points = leading(first, layout.time);
    let channels = leading(first, layout.channel);
    for (dim, axis) in axes.iter().enumerate() {
        if let AxisKind::Other(kind) = &axis.kind
            && first.shape()[dim] != 1
        {
            return Err(format!(
                "axis {} (type {}) has extent {}; voxscope reads space, time and channel axes",
                quoted(&axis.name),
                quoted(kind),
                first.shape()[dim]
            ));
        }
    }
    if options.time as u64 >= time_points {
        return Err(format!(
            "time point {} does not exist (the image has {time_points})",
            options.time
        ));
    }
    if options.channel as u64 >= channels {
        return Err(format!(
            "channel {} does not exist (the image has {channels})",
            options.channel
        ));
    }

    let mut levels = Vec::with_capacity(arrays.len());
    for (index, (path, shown, array)) in arrays.iter().enumerate() {
        if array.dimensionality() != ndim {
            return Err(format!(
                "{shown} has {} dimensions but level 0 has {ndim}",
                array.dimensionality()
            ));
        }
        if Stored::of(array.data_type()) != Some(stored) {
            return Err(format!(
                "{shown} holds {} but level 0 holds {stored_type}",
                printable(&type_name(array.data_type()))
            ));
        }
        if leading(array, layout.time) != time_points || leading(array, layout.channel) != channels
        {
            return Err(format!(
                "{shown} has other channel or time extents than level 0"
            ));
        }
        levels.push(level_info(
            path,
            shown,
            array,
            &layout,
            stored,
            multiscale.as_ref().map(|m| (m, index)),
        )?);
    }
    // Levels without a scale are spaced by their size relative to level 0.
    if multiscale
        .as_ref()
        .is_none_or(|m| m.datasets.iter().all(|d| d.scale.is_none()))
    {
        let finest = levels[0].dims;
        for level in &mut levels {
            level.spacing = std::array::from_fn(|a| finest[a] as f64 / level.dims[a] as f64);
        }
    }

    let levels_len = levels.len();
    let units = std::array::from_fn(|a| layout.space[a].and_then(|d| axes[d].unit.clone()));
    let version = multiscale.as_ref().and_then(|m| m.version.clone());
    Ok(Pyramid {
        source: source.to_owned(),
        format: if multiscale.is_some() {
            "OME-Zarr"
        } else {
            "Zarr"
        },
        ome_version: version,
        zarr_format,
        name: multiscale.as_ref().and_then(|m| m.name.clone()),
        levels,
        axes,
        units,
        channels: channels as usize,
        time_points: time_points as usize,
        selected: options,
        omero: metadata::omero_channels(&attributes),
        voxel_type: stored.voxel_type(),
        stored_type,
        downscaling: multiscale.as_ref().and_then(|m| m.downscaling.clone()),
        stored,
        layout,
        arrays: arrays.into_iter().map(|(_, _, array)| array).collect(),
        range_paths: range_paths(&attributes, prefix, levels_len),
        store,
        remote: None,
        reader_pool: None,
    })
}

/// A Zarr v2 array rebuilt from its Zarr v3 form, so that its codecs come from zarrs's plugin
/// registry (where [`guard`]'s bounded decoders are): zarrs builds a v2 `blosc` compressor
/// directly, bypassing the registry. The chunk keys stay v2's. An array whose metadata has no
/// v3 form is kept as opened.
fn through_codec_plugins(
    array: Array<dyn ReadableStorageTraits>,
    store: &ReadableStorage,
    path: &str,
) -> Array<dyn ReadableStorageTraits> {
    let ArrayMetadata::V2(v2) = array.metadata() else {
        return array;
    };
    match zarrs::convert::array_metadata_v2_to_v3(v2) {
        Ok(v3) => {
            Array::new_with_metadata(store.clone(), &format!("/{path}"), ArrayMetadata::V3(v3))
                .unwrap_or(array)
        }
        Err(_) => array,
    }
}

/// `voxscope.chunk_ranges.paths`, one per level, when present and valid paths.
fn range_paths(attributes: &Map<String, Value>, prefix: &str, levels: usize) -> Vec<String> {
    let paths: Vec<String> = attributes
        .get("voxscope")
        .and_then(|v| v.pointer("/chunk_ranges/paths"))
        .and_then(Value::as_array)
        .map(|list| {
            list.iter()
                .filter_map(Value::as_str)
                .filter(|p| metadata::check_path(p).is_ok())
                .map(|p| format!("{prefix}{p}"))
                .collect()
        })
        .unwrap_or_default();
    if paths.len() == levels {
        paths
    } else {
        Vec::new()
    }
}

fn read_size_checked(store: &ReadableStorage, key: &str) -> Result<(), Problem> {
    match store.size_key(&self::key(key)?) {
        Ok(Some(size)) if size > MAX_METADATA_BYTES => Err(format!(
            "{key} is {size} bytes; metadata of more than {MAX_METADATA_BYTES} bytes is not read"
        )),
        Ok(_) => Ok(()),
        Err(e) => Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    }
}

/// Which dimension is time, channel, x, y, z: the last space axis is x (fastest), then y,
/// then z, as OME-Zarr orders them.
fn layout_of(axes: &[Axis]) -> Result<Layout, Problem> {
    let mut layout = Layout {
        ndim: axes.len(),
        time: None,
        channel: None,
        space: [None; 3],
    };
    let space: Vec<usize> = axes
        .iter()
        .enumerate()
        .filter(|(_, a)| a.kind == AxisKind::Space)
        .map(|(i, _)| i)
        .collect();
    if !(2..=3).contains(&space.len()) {
        let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
        return Err(format!(
            "axes {} have {} space axes; a volume has 2 or 3",
            quoted(&names.join(", ")),
            space.len()
        ));
    }
    for (axis, dim) in space.iter().rev().enumerate() {
        layout.space[axis] = Some(*dim);
    }
    for (dim, axis) in axes.iter().enumerate() {
        let slot = match axis.kind {
            AxisKind::Time => &mut layout.time,
            AxisKind::Channel => &mut layout.channel,
            _ => continue,
        };
        if slot.replace(dim).is_some() {
            return Err(format!(
                "axis {} is a second {:?} axis",
                quoted(&axis.name),
                axis.kind
            )
            .to_lowercase());
        }
    }
    Ok(layout)
}

fn level_info(
    path: &str,
    shown: &str,
    array: &Array<dyn ReadableStorageTraits>,
    layout: &Layout,
    stored: Stored,
    multiscale: Option<(&metadata::Multiscale, usize)>,
) -> Result<LevelInfo, Problem> {
    let shape = array.shape();
    let pick = |values: &[u64], axis: usize| layout.space[axis].map_or(1, |d| values[d]);
    let mut dims = [0usize; 3];
    for (axis, dim) in dims.iter_mut().enumerate() {
        let extent = pick(shape, axis);
        *dim = usize::try_from(extent)
            .ok()
            .filter(|&e| e > 0 && (e as u64) < (1 << 40))
            .ok_or_else(|| {
                format!(
                    "{shown} has extent {extent} along {}",
                    ["x", "y", "z"][axis]
                )
            })?;
    }
    if dims
        .iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
        .is_none_or(|count| count > 1 << 60)
    {
        return Err(format!(
            "{shown} has {} voxels, too many to address",
            format_dims(dims)
        ));
    }
    let element = stored_size(stored);
    let zeros = vec![0u64; shape.len()];
    let outer: Vec<u64> = array
        .chunk_shape(&zeros)
        .map_err(|e| format!("{shown}: {}", printable(&e.to_string())))?
        .iter()
        .map(|n| n.get())
        .collect();
    let inner: Vec<u64> = match array.subchunk_shape() {
        Some(inner) if array.is_sharded() => inner.iter().map(|n| n.get()).collect(),
        _ => outer.clone(),
    };
    let chunk_bytes = inner
        .iter()
        .try_fold(element, |acc, &n| acc.checked_mul(n))
        .unwrap_or(u64::MAX);
    if chunk_bytes > MAX_CHUNK_BYTES {
        return Err(format!(
            "{shown} has chunks of {} ({chunk_bytes} bytes decoded); at most {MAX_CHUNK_BYTES} are read",
            short_shape(&inner)
        ));
    }
    let sharded = array.is_sharded();
    if sharded {
        let per_shard = outer
            .iter()
            .zip(&inner)
            .try_fold(1u64, |acc, (o, i)| acc.checked_mul(o.div_ceil(*i)))
            .unwrap_or(u64::MAX);
        if per_shard > MAX_SHARD_CHUNKS {
            return Err(format!(
                "{shown} has shards of {} chunks; at most {MAX_SHARD_CHUNKS} are read",
                per_shard
            ));
        }
    }
    let to_usize = |values: &[u64], axis: usize| pick(values, axis).min(usize::MAX as u64) as usize;
    let chunk = std::array::from_fn(|axis| to_usize(&inner, axis));
    let shard = sharded.then(|| std::array::from_fn(|axis| to_usize(&outer, axis)));

    let (mut spacing, mut origin) = ([1.0; 3], [0.0; 3]);
    if let Some((multiscale, index)) = multiscale {
        let dataset = &multiscale.datasets[index];
        let ndim = layout.ndim;
        let check = |values: &Option<Vec<f64>>, what: &str| -> Result<(), Problem> {
            match values {
                Some(v) if v.len() != ndim => Err(format!(
                    "multiscales[0].datasets[{index}]: {what} has {} values for {ndim} axes",
                    v.len()
                )),
                _ => Ok(()),
            }
        };
        check(&dataset.scale, "scale")?;
        check(&dataset.translation, "translation")?;
        check(&multiscale.global_scale, "the multiscale's scale")?;
        check(
            &multiscale.global_translation,
            "the multiscale's translation",
        )?;
        for axis in 0..3 {
            let Some(dim) = layout.space[axis] else {
                continue;
            };
            let global_scale = multiscale.global_scale.as_ref().map_or(1.0, |s| s[dim]);
            let global_shift = multiscale
                .global_translation
                .as_ref()
                .map_or(0.0, |t| t[dim]);
            let scale = dataset.scale.as_ref().map_or(1.0, |s| s[dim]);
            let shift = dataset.translation.as_ref().map_or(0.0, |t| t[dim]);
            spacing[axis] = scale * global_scale;
            origin[axis] = shift * global_scale + global_shift;
        }
    }
    Ok(LevelInfo {
        path: path.to_owned(),
        dims,
        spacing,
        origin,
        chunk,
        shard,
        codec: describe_codecs(array.metadata()),
        fill_value: fill_value(array, stored),
    })
}

/// A data type's Zarr v3 name (`uint16`), whatever version the array is.
fn type_name(data_type: &DataType) -> String {
    use zarrs::plugin::ExtensionName;
    data_type
        .name_v3()
        .map(|name| name.into_owned())
        .unwrap_or_else(|| data_type.to_string())
}

fn stored_size(stored: Stored) -> u64 {
    match stored {
        Stored::Native(voxel_type) => voxel_type.size() as u64,
        Stored::U64 | Stored::I64 => 8,
    }
}

fn short_shape(shape: &[u64]) -> String {
    shape
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join("x")
}

/// The fill value as a number (0 when it cannot be read as one).
fn fill_value(array: &Array<dyn ReadableStorageTraits>, stored: Stored) -> f64 {
    let bytes = array.fill_value().as_ne_bytes();
    let take = |n: usize| -> Option<[u8; 8]> {
        let mut out = [0u8; 8];
        out[..n].copy_from_slice(bytes.get(..n)?);
        Some(out)
    };
    let value = match stored {
        Stored::Native(VoxelType::U8) => bytes.first().map(|&b| b as f64),
        Stored::Native(VoxelType::I8) => bytes.first().map(|&b| b as i8 as f64),
        Stored::Native(VoxelType::U16) => take(2).map(|b| u16::from_ne_bytes([b[0], b[1]]) as f64),
        Stored::Native(VoxelType::I16) => take(2).map(|b| i16::from_ne_bytes([b[0], b[1]]) as f64),
        Stored::Native(VoxelType::U32) => {
            take(4).map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64)
        }
        Stored::Native(VoxelType::I32) => {
            take(4).map(|b| i32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64)
        }
        Stored::Native(VoxelType::F32) => {
            take(4).map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64)
        }
        Stored::Native(VoxelType::F64) => take(8).map(f64::from_ne_bytes),
        Stored::U64 => take(8).map(|b| u64::from_ne_bytes(b) as f64),
        Stored::I64 => take(8).map(|b| i64::from_ne_bytes(b) as f64),
    };
    value.unwrap_or(0.0)
}

/// The codecs as a short text: `blosc lz4`, `zstd`, `gzip`, `none`, `sharding(blosc zstd)`.
fn describe_codecs(metadata: &ArrayMetadata) -> String {
    fn codec_name(codec: &Value) -> Option<String> {
        let name = codec
            .get("name")
            .or_else(|| codec.get("id"))
            .and_then(Value::as_str)?;
        let config = codec.get("configuration").unwrap_or(codec);
        Some(match name {
            "bytes" | "crc32c" => return None,
            "blosc" => format!(
                "blosc {}",
                config.get("cname").and_then(Value::as_str).unwrap_or("?")
            ),
            "sharding_indexed" => {
                let inner = config
                    .get("codecs")
                    .and_then(Value::as_array)
                    .map(|codecs| list(codecs))
                    .unwrap_or_else(|| "none".to_owned());
                format!("sharding({inner})")
            }
            other => printable(other),
        })
    }
    fn list(codecs: &[Value]) -> String {
        let names: Vec<String> = codecs.iter().filter_map(codec_name).collect();
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        }
    }
    let json = serde_json::to_value(metadata).unwrap_or(Value::Null);
    match metadata {
        ArrayMetadata::V3(_) => json
            .get("codecs")
            .and_then(Value::as_array)
            .map(|codecs| list(codecs))
            .unwrap_or_else(|| "none".to_owned()),
        ArrayMetadata::V2(_) => {
            let mut codecs: Vec<Value> = json
                .get("filters")
                .and_then(Value::as_array)
                .cloned()
                .unwrap_or_default();
            if let Some(compressor) = json.get("compressor").filter(|c| !c.is_null()) {
                codecs.push(compressor.clone());
            }
            list(&codecs)
        }
    }
}

/// Reads the finest level within [`VOLUME_VOXEL_BUDGET`] of the Zarr folder at `path` as a
/// volume (the in-memory renderers' path; the streaming renderer reads the [`Pyramid`]).
/// Says on stderr when a finer level exists.
pub(crate) fn load(path: &Path, options: PyramidOptions) -> Result<Volume, Problem> {
    let pyramid = Pyramid::open(path, options).map_err(|e| e.problem)?;
    load_pyramid(&pyramid)
}

/// [`load`] for a URL ([`Pyramid::open_url`]).
pub(crate) fn load_url(
    url: &str,
    options: PyramidOptions,
    remote: RemoteOptions,
) -> Result<Volume, Problem> {
    let pyramid = Pyramid::open_url(url, options, remote).map_err(|e| e.problem)?;
    load_pyramid(&pyramid)
}

fn load_pyramid(pyramid: &Pyramid) -> Result<Volume, Problem> {
    // Each channel is listed (`Volume::series`): as many as an axis may have voxels.
    if pyramid.channels > super::MAX_AXIS {
        return Err(format!(
            "the channel axis has {} entries, more than {}",
            pyramid.channels,
            super::MAX_AXIS
        ));
    }
    let level = pyramid.finest_within(VOLUME_VOXEL_BUDGET as u64);
    if level > 0 {
        eprintln!(
            "note: {}: opened level {level} ({}), the finest within {} voxels; level 0 is {}",
            pyramid.source,
            format_dims(pyramid.levels[level].dims),
            VOLUME_VOXEL_BUDGET,
            format_dims(pyramid.levels[0].dims)
        );
    }
    pyramid.level_volume(level).map_err(|e| e.problem)
}

impl Pyramid {
    /// Level `level` read whole as a volume, with the file's facts and window: what the
    /// in-memory renderers draw, and what the app's panels (histogram, statistics, slices) read
    /// while the streaming renderer draws the full resolution.
    pub fn level_volume(&self, level: usize) -> Result<Volume, LoadError> {
        let Some(info) = self.levels.get(level) else {
            return Err(LoadError::new(&self.source, format!("no level {level}")));
        };
        if info.voxel_count() > MAX_VOXELS as u64 {
            return Err(LoadError::new(
                &self.source,
                format!(
                    "even the coarsest level ({}) exceeds {MAX_VOXELS} voxels; `voxscope convert` writes one with more levels",
                    format_dims(info.dims)
                ),
            ));
        }
        let data = self.read_level(level)?;
        let mut volume = Volume::new(
            self.source.clone(),
            self.format,
            info.dims,
            info.spacing,
            data,
        )
        .map_err(|e| LoadError::new(&self.source, e.problem))?;
        volume.metadata = volume_facts(self, level);
        volume.default_window = self.omero_window();
        volume.series = self.series();
        Ok(volume)
    }
}

/// The lines `info` shows for a volume read from `pyramid`'s `level`.
fn volume_facts(pyramid: &Pyramid, level: usize) -> Vec<(String, String)> {
    let mut facts = Vec::new();
    let version = match &pyramid.ome_version {
        Some(version) => format!(
            "{} {version} (Zarr v{})",
            pyramid.format, pyramid.zarr_format
        ),
        None => format!("{} (Zarr v{})", pyramid.format, pyramid.zarr_format),
    };
    facts.push(("zarr".to_owned(), version));
    facts.push((
        "level".to_owned(),
        format!(
            "{level} of {} (finest {})",
            pyramid.levels.len(),
            format_dims(pyramid.levels[0].dims)
        ),
    ));
    if pyramid.channels > 1 || !pyramid.omero.is_empty() {
        let label = pyramid
            .omero
            .get(pyramid.selected.channel)
            .and_then(|c| c.label.clone())
            .map(|l| format!(" ({l})"))
            .unwrap_or_default();
        facts.push((
            "channel".to_owned(),
            format!(
                "{} of {}{label}",
                pyramid.selected.channel, pyramid.channels
            ),
        ));
    }
    if pyramid.time_points > 1 {
        facts.push((
            "time point".to_owned(),
            format!("{} of {}", pyramid.selected.time, pyramid.time_points),
        ));
    }
    if let Some(unit) = pyramid.units.iter().flatten().next() {
        facts.push(("unit".to_owned(), unit.clone()));
    }
    if pyramid.stored_type != pyramid.voxel_type.name()
        && matches!(pyramid.stored, Stored::U64 | Stored::I64)
    {
        facts.push((
            "stored as".to_owned(),
            format!("{} (read as f64)", pyramid.stored_type),
        ));
    }
    facts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pyramid_can_be_shared_by_loader_threads() {
        fn shareable<T: Send + Sync>() {}
        shareable::<Pyramid>();
    }

    #[test]
    fn levels_halve_until_one_chunk_holds_the_coarsest() {
        assert_eq!(
            level_dims([300, 200, 70], 64),
            vec![[300, 200, 70], [150, 100, 35], [75, 50, 18], [38, 25, 9]]
        );
        assert_eq!(level_dims([64, 64, 64], 64), vec![[64, 64, 64]]);
    }
}
