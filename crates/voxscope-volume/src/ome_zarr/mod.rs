//! OME-Zarr (0.1–0.5: Zarr v2 and v3, sharding) and plain Zarr arrays: a [`Pyramid`] of levels
//! read region by region, never a whole level at once, and a [`Volume`] of the finest level
//! that fits [`VOLUME_VOXEL_BUDGET`] for the in-memory renderers.
//!
//! Chunks are read and decoded by zarrs (blosc, zstd, gzip, zlib, bz2, uncompressed, and
//! numcodecs' lz4 and lzma through [`numcodecs`]'s plugins; `.` or `/` chunk
//! keys; sharding) from any zarrs `ReadableStorageTraits` store: a folder, or a URL
//! (`http://`, `https://`, `s3://`: [`super::remote`]). What a file declares is checked before anything of that size exists:
//! the region a caller asks for bounds the output, a chunk holds at most [`MAX_CHUNK_BYTES`]
//! decoded, a shard at most [`MAX_SHARD_CHUNKS`] chunks, a metadata document at most 16 MiB,
//! and a compressed chunk never decodes into more than its chunk's bytes ([`guard`]).
//!
//! **Missing chunks read as the array's fill value** (Zarr's rule: writers skip chunks that
//! hold only the fill value). A chunk that is present but cannot be decoded, or decodes to
//! the wrong size, is an error that names the chunk's key.

mod adapted;
mod detect;
mod guard;
mod imaris;
mod levels;
mod metadata;
mod n5;
mod numcodecs;
mod open;
mod precomputed;
mod read;
mod read_ahead;
mod shard_index;
mod source;
mod units;
mod write;

use std::path::Path;
use std::sync::Arc;

use zarrs::array::data_type::{
    Float32DataType, Float64DataType, Int8DataType, Int16DataType, Int32DataType, Int64DataType,
    UInt8DataType, UInt16DataType, UInt32DataType, UInt64DataType,
};
use zarrs::array::{Array, DataType};
use zarrs::storage::{ReadableStorageTraits, StoreKey};

use super::error::Problem;
use super::remote::{RemoteOptions, RemoteStats, RemoteStore};
use super::{LoadError, MAX_VOXELS, Selection, Volume, VoxelType, format_dims};

pub use detect::{
    StoreKind, is_zarr_folder, is_zarr_spec, store_kind, stores_inside, unfinished_store,
};
pub(crate) use detect::{folder_of_stores_problem, series_path, unfinished_problem};
pub use imaris::{is_imaris_file, sniff as sniff_hdf5};
pub use metadata::{
    Axis, AxisKind, Bioformats2raw, LabelColor, LabelImage, OmeroChannel, Plate, SeriesEntry,
};
pub use n5::is_n5_folder;
use open::open_root;
pub use precomputed::is_precomputed_folder;
pub use read::MAX_PREFETCH_CHUNKS;
pub use source::SlabSource;
pub use write::{
    Columns, Compression, DisplayWindow, Downsampling, ImageLayout, PyramidWriter, Window,
    WindowReport, WindowWriter, WriteOptions, Written, ZarrVersion, create_arrays, display_window,
    level_dims, read_level, write_group,
};
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

/// A multiscale image (or a plain Zarr array as one level), opened for reading regions. A clone
/// shares the store, its caches and connections ([`Self::of_channel`]).
#[derive(Clone)]
pub struct Pyramid {
    /// The path (or store description) it was opened from.
    pub source: String,
    /// `OME-Zarr`, `Zarr` (a plain array), `N5` or `precomputed` (neuroglancer's).
    pub format: &'static str,
    /// The OME-Zarr version (`0.4`, `0.5`), if the group says; an N5 container's `n5` version.
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
    /// The HCS plate the image is a field of, where the store's root is a plate (its first
    /// well's first field opens).
    pub plate: Option<Plate>,
    /// The image is a label image (its group has OME-Zarr `image-label` metadata): its values
    /// are categories (nearest samples, coarser levels by the mode).
    pub label_image: bool,
    /// The series of the bioformats2raw container the image is one of, where the store's root
    /// is such a container (its first series opens unless another is asked for).
    pub bioformats2raw: Option<Bioformats2raw>,
    stored: Stored,
    layout: Layout,
    arrays: Arc<Vec<Array<dyn ReadableStorageTraits>>>,
    store: ReadableStorage,
    /// Where the levels' chunk ranges are (`voxscope.chunk_ranges.paths`), full store paths.
    range_paths: Vec<String>,
    /// The image group's path in the store (`""`, or a plate's field or a series, `A/1/0/`).
    image_prefix: String,
    /// The store again, where it is remote: a region's chunks are fetched together.
    remote: Option<Arc<RemoteStore>>,
    /// Where the store is a folder: its chunk files are read ahead of a streamer's reads.
    read_ahead: Option<Arc<read_ahead::ReadAhead>>,
    /// Where a remote store's reads run: zarrs reads a region's chunks (a sharded array's
    /// shards) on rayon threads, each blocked on the network while it waits, so they get a
    /// pool of their own as large as the request limit, not the cores' global pool.
    reader_pool: Option<Arc<rayon::ThreadPool>>,
    /// Whether a batch of sharded regions is being fetched ahead
    /// ([`Pyramid::fetch_ahead_regions`]): one batch at a time, the next call asks for the
    /// newest regions once it ends.
    shard_batch_busy: Arc<std::sync::atomic::AtomicBool>,
    /// Whether a chunk's store key names an object a URL's store can fetch ahead by itself
    /// (false for a precomputed volume with sharded scales, whose chunks are ranges the
    /// store adapter finds: nothing is fetched ahead or bounded by key).
    chunks_are_objects: bool,
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

/// The store keys of `names` (paths in a store); a name that is no key is left out.
fn store_keys(names: &[String]) -> Vec<StoreKey> {
    names
        .iter()
        .filter_map(|name| StoreKey::new(name).ok())
        .collect()
}

/// Fetches the metadata documents `names` of the remote `store` together (one round trip).
fn prefetch_named(store: &RemoteStore, names: &[String]) {
    store.prefetch_documents(&store_keys(names), MAX_METADATA_BYTES);
}

impl Pyramid {
    /// Opens the Zarr folder at `path` (an OME-Zarr group, a bioformats2raw container, or a
    /// plain array), selecting the channel and time point of `options`.
    ///
    /// A path `ROOT/N` inside a bioformats2raw container `ROOT` opens the container's series
    /// `N` (`--series N`), listing the others; one the container lacks is named with its
    /// count. The container itself opens its first series and says so on stderr.
    pub fn open(path: &Path, options: PyramidOptions) -> Result<Self, LoadError> {
        let source = path.display().to_string();
        if let Some((root, series)) = series_path(path) {
            let store = zarrs::filesystem::FilesystemStore::new(&root)
                .map_err(|e| LoadError::new(&source, format!("cannot open: {e}")))?;
            guard::register();
            let mut pyramid = open_root(Arc::new(store), &source, options, &|_| {}, Some(&series))
                .map_err(|problem| LoadError::new(&source, problem))?;
            pyramid.read_ahead = read_ahead::ReadAhead::for_folder(root).map(Arc::new);
            return Ok(pyramid);
        }
        if path.is_file() && imaris::is_hdf5_file(path) {
            guard::register();
            return imaris::open(path, &source, options)
                .map_err(|problem| LoadError::new(&source, problem));
        }
        if !path.is_dir() {
            return Err(LoadError::new(
                &source,
                "is not a folder (a Zarr store is one) nor an Imaris file",
            ));
        }
        let store = zarrs::filesystem::FilesystemStore::new(path)
            .map_err(|e| LoadError::new(&source, format!("cannot open: {e}")))?;
        let mut pyramid = if is_n5_folder(path) {
            guard::register();
            n5::open(Arc::new(store), &source, options, &|_| {})
                .map_err(|problem| LoadError::new(&source, problem))?
        } else if is_precomputed_folder(path) {
            guard::register();
            precomputed::open(Arc::new(store), &source, options, &|_| {})
                .map_err(|problem| LoadError::new(&source, problem))?
        } else {
            if let Some(level) = unfinished_store(path) {
                return Err(LoadError::new(&source, unfinished_problem(&level)));
            }
            Self::open_store(Arc::new(store), &source, options)?
        };
        pyramid.read_ahead = read_ahead::ReadAhead::for_folder(path.to_path_buf()).map(Arc::new);
        Ok(pyramid)
    }

    /// Opens the Zarr store at `url` (`http://`, `https://`, `s3://BUCKET/PATH`; see
    /// [`super::remote`]) as [`Self::open`] opens a folder. The source it names in messages is
    /// the URL without user name, password or query.
    pub fn open_url(
        url: &str,
        options: PyramidOptions,
        remote: RemoteOptions,
    ) -> Result<Self, LoadError> {
        let source = super::remote::redact_url(url);
        let store =
            RemoteStore::open(url, remote).map_err(|e| LoadError::new(&source, e.to_string()))?;
        // Each step of the walk (the root's documents, then every level's) in one round trip.
        let warm = |names: &[String]| prefetch_named(&store, names);
        guard::register();
        // The root's documents, and in the same round trip those of the levels most stores
        // name `0`, `1`, … (what `open_root` then asks for is fetched already, or known
        // missing; a guess that failed is asked for again).
        let (root, guesses) = open::first_documents(remote.max_requests);
        store.prefetch_guessing(
            &store_keys(&root),
            &store_keys(&guesses),
            MAX_METADATA_BYTES,
        );
        let store_root: ReadableStorage = store.clone();
        // N5 and precomputed roots are looked for only where the server answered that the
        // Zarr documents are missing (a server that answers nothing is asked nothing more).
        let no_zarr_root = open::zarr_root_is_missing(&store_root);
        let opened = if no_zarr_root && n5::is_n5_root(&store_root) {
            let warm = |names: &[String]| prefetch_named(&store, &n5::n5_documents(names));
            n5::open(store_root, &source, options, &warm)
        } else if no_zarr_root && precomputed::is_precomputed_root(&store_root) {
            // The info is all the metadata there is: nothing to fetch ahead.
            precomputed::open(store_root, &source, options, &|_| {})
        } else {
            open_root(store_root, &source, options, &warm, None)
        };
        let mut pyramid = opened.map_err(|problem| LoadError::new(&source, problem))?;
        pyramid.note_series();
        store.mark_opened();
        pyramid.bound_objects(&store);
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

    /// Tells a URL's `store` the most bytes each level's objects (a chunk, or a shard with
    /// its index) may have: the decoded size with room for a codec's overhead. A body that
    /// grows past it is refused, whether or not the server said its length.
    fn bound_objects(&self, store: &RemoteStore) {
        for (level, (info, array)) in self.levels.iter().zip(self.arrays.iter()).enumerate() {
            let Some(bound) = self.object_bound(level) else {
                continue;
            };
            let prefix = if info.path.is_empty() {
                String::new()
            } else {
                format!("{}/", array.path().as_str().trim_start_matches('/'))
            };
            store.bound_objects(&prefix, bound);
        }
    }

    /// The most bytes one object (a chunk, or a shard with its index) of `level` may have:
    /// its decoded size with room for a codec's overhead.
    fn object_bound(&self, level: usize) -> Option<u64> {
        if !self.chunks_are_objects {
            return None;
        }
        let (info, array) = (self.levels.get(level)?, self.arrays.get(level)?);
        let zeros = vec![0u64; array.dimensionality()];
        let shape = array.chunk_shape(&zeros).ok()?;
        let elements = shape.iter().map(|n| n.get()).product::<u64>();
        let value_bytes = array.data_type().fixed_size().unwrap_or(8) as u64;
        let decoded = elements.saturating_mul(value_bytes);
        let inner_chunks = match info.shard {
            Some(shard) => (0..3)
                .map(|a| shard[a].div_ceil(info.chunk[a].max(1)) as u64)
                .product::<u64>(),
            None => 0,
        };
        // Compressors add at most a few bytes per block (blosc 16, zstd and deflate a
        // fraction of a percent); a shard adds its index (16 bytes a chunk and a crc32c).
        // A precomputed compressed_segmentation chunk of few labels per block can be larger
        // than its labels.
        let slack = if self.format == "precomputed" { 2 } else { 8 };
        Some(
            decoded
                .saturating_add(decoded / slack)
                .saturating_add(inner_chunks.saturating_mul(16))
                .saturating_add(64 << 10),
        )
    }

    /// Opens a URL ([`Self::open_url`]) or a folder ([`Self::open`]).
    pub fn open_spec(
        spec: &str,
        options: PyramidOptions,
        remote: RemoteOptions,
    ) -> Result<Self, LoadError> {
        if super::remote::is_url(spec) {
            let path = spec.split(['?', '#']).next().unwrap_or(spec);
            if path.to_ascii_lowercase().ends_with(".ims") {
                return Err(LoadError::new(
                    super::remote::redact_url(spec),
                    "is an Imaris file: voxscope reads .ims from a disk, not a URL (download it, or convert it to OME-Zarr where it is and stream that)",
                ));
            }
            Self::open_url(spec, options, remote)
        } else {
            Self::open(Path::new(spec), options)
        }
    }

    /// Requests, bytes and errors of a remote store so far (`None` for a folder).
    pub fn remote_stats(&self) -> Option<RemoteStats> {
        self.remote.as_ref().map(|store| store.stats())
    }

    /// Keeps at most `bytes` of fetched bytes in RAM, where the store is remote
    /// ([`RemoteStore::set_cache_bytes`]); a folder's store keeps none.
    pub fn set_fetch_cache_bytes(&self, bytes: u64) {
        if let Some(store) = &self.remote {
            store.set_cache_bytes(bytes);
        }
    }

    /// Which network store this pyramid reads, where remote: equal for pyramids that share
    /// one (clones of one opened store, such as its channels), whose fetch cache is one.
    pub fn remote_store_id(&self) -> Option<usize> {
        self.remote
            .as_ref()
            .map(|store| Arc::as_ptr(store) as *const () as usize)
    }

    /// Bytes of fetched objects kept in RAM (none for a folder's store).
    pub fn fetch_cached_bytes(&self) -> u64 {
        self.remote.as_ref().map_or(0, |store| store.cached_bytes())
    }

    /// Opens the Zarr hierarchy at the root of `store`; `source` names it in messages.
    pub fn open_store(
        store: ReadableStorage,
        source: &str,
        options: PyramidOptions,
    ) -> Result<Self, LoadError> {
        guard::register();
        let pyramid = open_root(store, source, options, &|_| {}, None)
            .map_err(|problem| LoadError::new(source, problem))?;
        pyramid.note_series();
        Ok(pyramid)
    }

    /// The format as `info` names it: `OME-Zarr 0.5 (Zarr v3)`, `Zarr (Zarr v2)`, `N5 2.5.1`
    /// (an N5 container is read as Zarr v3, which it is not).
    pub fn format_description(&self) -> String {
        let version = self
            .ome_version
            .as_ref()
            .map(|v| format!(" {v}"))
            .unwrap_or_default();
        if matches!(self.format, "N5" | "precomputed" | imaris::FORMAT) {
            format!("{}{version}", self.format)
        } else {
            format!("{}{version} (Zarr v{})", self.format, self.zarr_format)
        }
    }

    /// The label images of the image (its `labels/` group's list, each with its `image-label`
    /// colors), read from the store now: empty for a plain array or an image without labels.
    pub fn label_images(&self) -> Vec<LabelImage> {
        if self.format != "OME-Zarr" {
            return Vec::new();
        }
        // A URL's: the group's documents in one round trip, then every label's in one more
        // (where a server denies what it lacks, a Zarr v2 group's `zarr.json` is then known
        // missing rather than denied).
        let warm = |names: &[String]| {
            if let Some(remote) = &self.remote {
                prefetch_named(remote, names);
            }
        };
        open::label_images(&self.store, &self.image_prefix, &warm)
    }

    /// The spec that opens label image `label` of this image: the store's root (the folder or
    /// URL this pyramid was opened from, a series' container) followed by the label's path.
    pub fn label_spec(&self, root: &str, label: &LabelImage) -> String {
        let root = match &self.bioformats2raw {
            // `ROOT/N` names the series; the label's path starts with the series' group.
            Some(_) => match root.trim_end_matches('/').rsplit_once('/') {
                Some((container, last)) if last.bytes().all(|b| b.is_ascii_digit()) => {
                    container.to_owned()
                }
                _ => root.trim_end_matches('/').to_owned(),
            },
            None => root.trim_end_matches('/').to_owned(),
        };
        format!("{root}/{}", label.path)
    }

    /// Says on stderr that a bioformats2raw container of several series opened its first
    /// (once per container: a command may open it more than once).
    fn note_series(&self) {
        static NOTED: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
        if let Some(found) = &self.bioformats2raw
            && !found.chosen
            && found.series.len() > 1
        {
            let mut noted = NOTED.lock().unwrap_or_else(|e| e.into_inner());
            if noted.contains(&self.source) {
                return;
            }
            noted.push(self.source.clone());
            eprintln!(
                "note: {}: a bioformats2raw container of {} series; opened series 0 (--series N opens another; info lists them)",
                self.source,
                found.series.len()
            );
        }
    }
}

/// Reads the finest level within [`VOLUME_VOXEL_BUDGET`] of the Zarr folder at `path` as a
/// volume (the in-memory renderers' path; the streaming renderer reads the [`Pyramid`]).
/// Says on stderr when a finer level exists.
pub(crate) fn load(path: &Path, options: PyramidOptions) -> Result<Volume, Problem> {
    let pyramid = Pyramid::open(path, options).map_err(|e| e.problem)?;
    pyramid.memory_volume().map_err(|e| e.problem)
}

/// [`load`] for a URL ([`Pyramid::open_url`]).
pub(crate) fn load_url(
    url: &str,
    options: PyramidOptions,
    remote: RemoteOptions,
) -> Result<Volume, Problem> {
    let pyramid = Pyramid::open_url(url, options, remote).map_err(|e| e.problem)?;
    pyramid.memory_volume().map_err(|e| e.problem)
}

impl Pyramid {
    /// The same image reading channel `channel` of the time point this one reads, over the
    /// same store (nothing is opened or fetched again).
    pub fn of_channel(&self, channel: usize) -> Result<Self, LoadError> {
        if channel >= self.channels {
            return Err(LoadError::new(
                &self.source,
                format!("has no channel {channel} ({} channels)", self.channels),
            ));
        }
        let mut pyramid = self.clone();
        pyramid.selected.channel = channel;
        Ok(pyramid)
    }

    /// An error where the channel axis is longer than a volume lists its channels
    /// (`Volume::series`: as many as an axis may have voxels).
    pub fn check_channel_axis(&self) -> Result<(), LoadError> {
        if self.channels > super::MAX_AXIS {
            return Err(LoadError::new(
                &self.source,
                format!(
                    "the channel axis has {} entries, more than {}",
                    self.channels,
                    super::MAX_AXIS
                ),
            ));
        }
        Ok(())
    }

    /// The finest level within [`VOLUME_VOXEL_BUDGET`] read whole, as [`load`] reads a store
    /// for the in-memory renderers; says on stderr when a finer level exists.
    pub fn memory_volume(&self) -> Result<Volume, LoadError> {
        self.check_channel_axis()?;
        let level = self.finest_within(VOLUME_VOXEL_BUDGET as u64);
        if level > 0 {
            eprintln!(
                "note: {}: opened level {level} ({}), the finest within {} voxels; level 0 is {}",
                self.source,
                format_dims(self.levels[level].dims),
                VOLUME_VOXEL_BUDGET,
                format_dims(self.levels[0].dims)
            );
        }
        self.level_volume(level)
    }

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

/// The fact (a line of `info`) that marks a volume read from a label image: an OME-Zarr
/// `image-label`, a precomputed segmentation.
pub(crate) const LABEL_IMAGE_FACT: &str = "labels";

/// The lines `info` shows for a volume read from `pyramid`'s `level`.
fn volume_facts(pyramid: &Pyramid, level: usize) -> Vec<(String, String)> {
    let mut facts = Vec::new();
    facts.push(("zarr".to_owned(), pyramid.format_description()));
    if pyramid.label_image {
        // What the transfer function it opens with reads ([`Volume::is_label_image`]).
        facts.push((
            LABEL_IMAGE_FACT.to_owned(),
            "a label image: its values are categories".to_owned(),
        ));
    }
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
    if let Some(plate) = &pyramid.plate {
        let wells: Vec<String> = plate
            .wells
            .iter()
            .map(|(well, fields)| format!("{well} (fields {})", fields.join(", ")))
            .collect();
        facts.push((
            "plate".to_owned(),
            format!(
                "{}rows {}; columns {}; {} wells: {}",
                plate
                    .name
                    .as_ref()
                    .map(|n| format!("{n}: "))
                    .unwrap_or_default(),
                plate.rows.join(", "),
                plate.columns.join(", "),
                plate.wells.len(),
                wells.join(", ")
            ),
        ));
        facts.push((
            "field".to_owned(),
            format!(
                "{} (the first well's first field; --field ROW/COLUMN/FIELD opens another)",
                plate.field
            ),
        ));
    }
    if let Some(found) = &pyramid.bioformats2raw {
        let listed: Vec<String> = found
            .series
            .iter()
            .enumerate()
            .map(|(index, entry)| {
                let mut text = index.to_string();
                if entry.path != index.to_string() {
                    text.push_str(&format!(" (group {})", entry.path));
                }
                if let Some(name) = &entry.name {
                    text.push_str(&format!(" \"{name}\""));
                }
                if let Some((shape, names)) = &entry.dims {
                    let shape: Vec<String> = shape.iter().map(u64::to_string).collect();
                    text.push_str(&format!(" {}", shape.join("x")));
                    if !names.is_empty() {
                        text.push_str(&format!(" ({})", names.join(" ")));
                    }
                }
                text
            })
            .collect();
        facts.push((
            "series".to_owned(),
            format!(
                "{} (bioformats2raw): {}",
                found.series.len(),
                listed.join("; ")
            ),
        ));
        facts.push((
            "open series".to_owned(),
            if found.chosen {
                found.opened.to_string()
            } else {
                format!("{} (the first; --series N opens another)", found.opened)
            },
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
