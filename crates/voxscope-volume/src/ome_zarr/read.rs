//! Reading regions of a [`Pyramid`]'s levels: bounds checked, the selected channel and time
//! point, a remote store's chunks fetched together, and the failing chunk named.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use zarrs::array::data_type::Float64DataType;

use zarrs::array::{Array, ArrayError, ArrayShardedExt, ArraySubset, CodecError};
use zarrs::storage::byte_range::ByteRange;
use zarrs::storage::{ReadableStorageTraits, StoreKey};

use super::super::error::{Problem, escape, printable, quoted};
use super::super::remote::HeldFetches;
use super::super::series::{ChannelInfo, Container, Series, parse_hex_color};
use super::super::{
    LoadError, LoadErrorKind, MAX_VOXELS, ValueWindow, VoxelData, VoxelType, format_dims,
};
use super::shard_index::ShardIndexLayout;
use super::{Pyramid, Stored};

/// The most chunks [`Pyramid::prefetch_regions`] asks for at once.
pub const MAX_PREFETCH_CHUNKS: usize = 4096;

/// The most chunks one region read over a network may need (each a request): a store of tiny
/// chunks (a 64³ array in 1-voxel chunks is 262 144 objects) is refused up front in one line,
/// with the way around, rather than read for minutes.
pub const MAX_REMOTE_READ_CHUNKS: u64 = 16384;

/// Why a read failed: the problem (naming the level and chunk), its kind, and its shared
/// cause ([`LoadError::cause`]).
struct ReadFailure {
    problem: Problem,
    kind: LoadErrorKind,
    cause: Option<String>,
}

impl ReadFailure {
    fn invalid(problem: Problem) -> Self {
        Self {
            problem,
            kind: LoadErrorKind::Invalid,
            cause: None,
        }
    }
}

impl Pyramid {
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
            .map_err(|failure| {
                LoadError::new(&self.source, failure.problem)
                    .with_kind(failure.kind)
                    .with_cause(failure.cause)
            })
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
                    inactive: omero.is_some_and(|c| !c.active),
                }
            })
            .collect();
        let container = match (&self.plate, &self.bioformats2raw) {
            (Some(plate), _) => Some(Container::Plate(plate.clone())),
            (None, Some(found)) if found.series.len() > 1 => Some(Container::Series(found.clone())),
            (None, _) => None,
        };
        Series {
            channels,
            time_points: self.time_points,
            selected: self.selected,
            container: container.map(Arc::new),
        }
    }

    /// The channels an image of several opens with, at most `most`: its `omero` list's
    /// `active` ones in order, else (none active, or no `omero`) the first ones.
    pub fn opening_channels(&self, most: usize) -> Vec<usize> {
        self.series().opening_channels(most)
    }

    /// The `omero` window of the selected channel, if the file gives one.
    pub fn omero_window(&self) -> Option<ValueWindow> {
        self.omero
            .get(self.selected.channel)
            .and_then(|channel| channel.window)
    }

    /// Fetches the chunks of every region (`level`, `origin`, `size`, as [`Self::read_region`]
    /// takes them) of a URL's store together, ahead of their reads: one round trip for all of
    /// them, not one a reading thread at a time. A sharded level's regions are fetched shard
    /// by shard: the shards' indexes together, then each shard's inner chunks of the regions
    /// as one batch of byte ranges, adjacent ones coalesced into one request
    /// ([`RemoteStore::prefetch_ranges`]). Regions outside their level, and anything beyond
    /// [`MAX_PREFETCH_CHUNKS`] chunks, are skipped; a folder's store does nothing. What was
    /// fetched (and the shards' indexes) stays readable while the answer lives, whatever the
    /// fetch cache keeps: the regions' reads, made while it lives, fetch none of it again.
    pub fn prefetch_regions(&self, regions: &[(usize, [usize; 3], [usize; 3])]) -> HeldFetches {
        let Some(remote) = self.remote.as_ref().filter(|_| self.chunks_are_objects) else {
            return HeldFetches::default();
        };
        let mut held = remote.prefetch(&self.unsharded_chunk_keys(regions));
        let ranges = self.shard_ranges(regions, &mut held);
        if !ranges.is_empty() {
            held.join(remote.prefetch_ranges(&ranges));
        }
        held
    }

    /// Starts fetching the chunks of `regions` of a URL's store in this order, the first
    /// soonest, and returns without waiting: what a streamer will read next. Unsharded
    /// levels' chunks go to [`RemoteStore::fetch_ahead`] (whole objects, up to twice the
    /// request limit under way, within half the fetch cache). Sharded levels' regions are
    /// fetched as [`Self::prefetch_regions`] does, on a thread of their own, one batch at a
    /// time (the shards' indexes, then each shard's inner chunks coalesced): a call while a
    /// batch is under way leaves its sharded regions to the next call. Returns how many unsharded
    /// fetches it started; a folder's store does nothing.
    pub fn fetch_ahead_regions(
        self: &Arc<Self>,
        regions: &[(usize, [usize; 3], [usize; 3])],
    ) -> usize {
        let Some(remote) = self.remote.as_ref().filter(|_| self.chunks_are_objects) else {
            return 0;
        };
        let sharded: Vec<(usize, [usize; 3], [usize; 3])> = regions
            .iter()
            .filter(|(level, _, _)| self.levels.get(*level).is_some_and(|l| l.shard.is_some()))
            .copied()
            .collect();
        if !sharded.is_empty()
            && self
                .shard_batch_busy
                .compare_exchange(false, true, Ordering::AcqRel, Ordering::Relaxed)
                .is_ok()
        {
            let pyramid = Arc::clone(self);
            let spawned = std::thread::Builder::new()
                .name("voxscope-shard-batch".into())
                .spawn(move || {
                    // Fetched ahead into the fetch cache, for reads to come: nothing is held.
                    let ranges = pyramid.shard_ranges(&sharded, &mut HeldFetches::default());
                    if let Some(remote) = &pyramid.remote
                        && !ranges.is_empty()
                    {
                        drop(remote.prefetch_ranges(&ranges));
                    }
                    pyramid.shard_batch_busy.store(false, Ordering::Release);
                });
            if spawned.is_err() {
                self.shard_batch_busy.store(false, Ordering::Release);
            }
        }
        if !remote.can_fetch_ahead() {
            return 0;
        }
        remote.fetch_ahead(&self.unsharded_chunk_keys(regions))
    }

    /// Starts fetching the unsharded chunks `chunks` (stored level and chunk indices x, y,
    /// z) in this order without waiting: a URL's store's ([`RemoteStore::fetch_ahead`]), or
    /// a folder's chunk files read ahead into the page cache ([`read_ahead`]). Returns how
    /// many of them, from the first, are fetched, being fetched or settled: those need not
    /// be asked for again. Chunks of sharded levels, or outside their level, end the run.
    ///
    /// [`read_ahead`]: super::read_ahead
    pub fn fetch_ahead_chunks(&self, chunks: &[(usize, [usize; 3])]) -> usize {
        if !self.chunks_are_objects {
            return 0;
        }
        match (&self.remote, &self.read_ahead) {
            (Some(remote), _) => remote.fetch_ahead(&self.unsharded_keys_of(chunks)),
            (None, Some(ahead)) => {
                let keys = self.unsharded_keys_of(chunks);
                ahead.advise(keys.iter().map(StoreKey::as_str))
            }
            (None, None) => 0,
        }
    }

    /// The store keys of `chunks` (as [`Self::fetch_ahead_chunks`] takes them) up to the first
    /// of a sharded level or outside its level.
    fn unsharded_keys_of(&self, chunks: &[(usize, [usize; 3])]) -> Vec<StoreKey> {
        chunks
            .iter()
            .map_while(|&(level, chunk)| {
                let info = self.levels.get(level)?;
                if info.shard.is_some() || (0..3).any(|a| chunk[a] >= info.chunk_grid()[a]) {
                    return None;
                }
                self.chunk_store_key(level, chunk.map(|c| c as u64))
            })
            .collect()
    }

    /// Chunk files of a folder's store read ahead so far ([`Self::fetch_ahead_chunks`]; 0 for
    /// a URL's store, and where the system cannot read ahead).
    pub fn files_read_ahead(&self) -> u64 {
        self.read_ahead.as_ref().map_or(0, |ahead| ahead.advised())
    }

    /// Whether [`Self::fetch_ahead_regions`] or [`Self::fetch_ahead_chunks`] may start
    /// anything now: a URL's store with room for more fetches ahead, or sharded levels and no
    /// batch under way; a folder with unsharded levels and room to read more ahead. Cheap: a
    /// streamer asks before it works out its bricks' regions.
    pub fn can_fetch_ahead(&self) -> bool {
        if !self.chunks_are_objects {
            return false;
        }
        if let Some(ahead) = &self.read_ahead {
            return ahead.has_room() && self.levels.iter().any(|l| l.shard.is_none());
        }
        self.remote.as_ref().is_some_and(|remote| {
            remote.can_fetch_ahead()
                || (self.levels.iter().any(|l| l.shard.is_some())
                    && !self.shard_batch_busy.load(Ordering::Relaxed))
        })
    }

    /// The keys of the chunks of `regions` that lie in unsharded levels, region by region, at
    /// most [`MAX_PREFETCH_CHUNKS`].
    fn unsharded_chunk_keys(&self, regions: &[(usize, [usize; 3], [usize; 3])]) -> Vec<StoreKey> {
        let mut keys = Vec::new();
        for &(level, origin, size) in regions {
            let Some(array) = self.region_array(level, origin, size) else {
                continue;
            };
            if self.levels[level].shard.is_some() {
                continue;
            }
            let subset = self.subset(origin, size);
            if let Ok(Some(chunks)) = array.chunks_in_array_subset(&subset) {
                if chunks.num_elements() > MAX_PREFETCH_CHUNKS as u64 {
                    continue;
                }
                keys.extend(
                    chunks
                        .indices()
                        .into_iter()
                        .map(|indices| array.chunk_key(&indices)),
                );
            }
            if keys.len() >= MAX_PREFETCH_CHUNKS {
                break;
            }
        }
        keys.truncate(MAX_PREFETCH_CHUNKS);
        keys
    }

    /// `level`'s array, if the region lies inside the level.
    fn region_array(
        &self,
        level: usize,
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Option<&Array<dyn ReadableStorageTraits>> {
        let (info, array) = (self.levels.get(level)?, self.arrays.get(level)?);
        let inside = (0..3).all(|a| {
            size[a] > 0
                && origin[a]
                    .checked_add(size[a])
                    .is_some_and(|end| end <= info.dims[a])
        });
        inside.then_some(array)
    }

    /// Per shard, the byte ranges of the inner chunks that the regions of sharded levels read
    /// (every shard's index fetched first, all at once, and held by `held`): what
    /// [`RemoteStore::prefetch_ranges`] fetches in one batch per shard. Only levels whose
    /// index voxscope reads itself ([`ShardIndexLayout`]); inner chunks never written have no
    /// range.
    fn shard_ranges(
        &self,
        regions: &[(usize, [usize; 3], [usize; 3])],
        held: &mut HeldFetches,
    ) -> Vec<(StoreKey, Vec<ByteRange>)> {
        let Some(remote) = &self.remote else {
            return Vec::new();
        };
        let mut layouts: BTreeMap<usize, Option<ShardIndexLayout>> = BTreeMap::new();
        // Per shard (level and shard indices): its key and the index entries wanted.
        let mut shards: BTreeMap<(usize, Vec<u64>), (StoreKey, Vec<u64>)> = BTreeMap::new();
        let mut inner_chunks = 0usize;
        for &(level, origin, size) in regions {
            let Some(array) = self.region_array(level, origin, size) else {
                continue;
            };
            if self.levels[level].shard.is_none() {
                continue;
            }
            let Some(layout) = layouts
                .entry(level)
                .or_insert_with(|| ShardIndexLayout::of(array))
                .as_ref()
            else {
                continue;
            };
            let grid = array.subchunk_grid();
            let Ok(Some(subchunks)) = grid.chunks_in_array_subset(&self.subset(origin, size))
            else {
                continue;
            };
            for indices in subchunks.indices() {
                let Some(entry) = layout.entry(&indices) else {
                    continue;
                };
                let shard: Vec<u64> = indices
                    .iter()
                    .zip(&layout.per_shard)
                    .map(|(&i, &n)| i / n)
                    .collect();
                let key = array.chunk_key(&shard);
                let wanted = &mut shards.entry((level, shard)).or_insert((key, Vec::new())).1;
                if !wanted.contains(&entry) {
                    wanted.push(entry);
                    inner_chunks += 1;
                }
            }
            if inner_chunks > MAX_PREFETCH_CHUNKS {
                return Vec::new();
            }
        }
        let index_ranges: Vec<(StoreKey, Vec<ByteRange>)> = shards
            .iter()
            .filter_map(|((level, _), (key, _))| {
                let layout = layouts.get(level)?.as_ref()?;
                Some((key.clone(), vec![layout.range()]))
            })
            .collect();
        if index_ranges.is_empty() {
            return Vec::new();
        }
        let indexes = remote.get_ranges(&index_ranges, held);
        shards
            .iter()
            .zip(indexes)
            .filter_map(|(((level, _), (key, entries)), index)| {
                let layout = layouts.get(level)?.as_ref()?;
                let index = index?.into_iter().next()?;
                let max_bytes = self.object_bound(*level)?;
                let ranges: Vec<ByteRange> = entries
                    .iter()
                    .filter_map(|&entry| layout.inner_range(&index, entry, max_bytes))
                    .collect();
                (!ranges.is_empty()).then(|| (key.clone(), ranges))
            })
            .collect()
    }

    /// The store key of the chunk (a shard, where the level is sharded) of `level` at the
    /// grid indices `chunk` (x, y, z), in the selected channel and time point.
    fn chunk_store_key(&self, level: usize, chunk: [u64; 3]) -> Option<StoreKey> {
        let array = self.arrays.get(level)?;
        let mut indices = vec![0u64; self.layout.ndim];
        if let Some(t) = self.layout.time {
            indices[t] = self.selected.time as u64 / array_chunk(array, t);
        }
        if let Some(c) = self.layout.channel {
            indices[c] = self.selected.channel as u64 / array_chunk(array, c);
        }
        for (axis, dim) in self.layout.space.iter().enumerate() {
            if let Some(dim) = dim {
                indices[*dim] = chunk[axis];
            }
        }
        Some(array.chunk_key(&indices))
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
    ) -> Result<VoxelData, ReadFailure> {
        let subset = self
            .region_subset(level, origin, size)
            .map_err(ReadFailure::invalid)?;
        if self.remote.is_some() {
            self.check_remote_chunks(level, origin, size)
                .map_err(ReadFailure::invalid)?;
        }
        self.read_subset(level, &subset)
    }

    /// A region read over a network must not need more than [`MAX_REMOTE_READ_CHUNKS`]
    /// chunks (each a request).
    fn check_remote_chunks(
        &self,
        level: usize,
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Result<(), Problem> {
        let chunk = self.levels[level].chunk;
        let chunks: u64 = (0..3)
            .map(|a| ((origin[a] + size[a] - 1) / chunk[a] - origin[a] / chunk[a] + 1) as u64)
            .product();
        if chunks <= MAX_REMOTE_READ_CHUNKS {
            return Ok(());
        }
        Err(format!(
            "reading {} voxels of level {level} takes {chunks} requests (its chunks hold {} voxels); at most {MAX_REMOTE_READ_CHUNKS} are made for one read over a network: copy the store and `voxscope convert` it to larger chunks",
            format_dims(size),
            format_dims(chunk)
        ))
    }

    /// The region `origin`/`size` of `level` as a subset of the stored array, once it is
    /// checked to lie inside the level and within [`MAX_VOXELS`].
    fn region_subset(
        &self,
        level: usize,
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Result<ArraySubset, Problem> {
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
        Ok(self.subset(origin, size))
    }

    /// Reads `subset` of `level`'s array: a remote store's chunks asked for together first.
    /// A failure says which chunk and whether it could not be fetched or does not decode.
    fn read_subset(&self, level: usize, subset: &ArraySubset) -> Result<VoxelData, ReadFailure> {
        let info = &self.levels[level];
        let array = &self.arrays[level];
        if let Some(remote) = &self.remote
            && info.shard.is_none()
            && self.chunks_are_objects
        {
            // zarrs asks for one chunk per reading thread at a time: over a network all of
            // the region's chunks are asked for at once first, into the fetch cache. They are
            // not held for the read: a whole volume loaded over the network would hold all of
            // its compressed chunks beside its voxels (a brick's read holds its own batch,
            // [`Self::prefetch_regions`]).
            if let Ok(Some(chunks)) = array.chunks_in_array_subset(subset) {
                let keys: Vec<StoreKey> = chunks
                    .indices()
                    .into_iter()
                    .map(|indices| array.chunk_key(&indices))
                    .collect();
                drop(remote.prefetch(&keys));
            }
        }
        let read = || match self.stored {
            Stored::Native(VoxelType::U8) => array.retrieve_array_subset(subset).map(VoxelData::U8),
            Stored::Native(VoxelType::I8) => array.retrieve_array_subset(subset).map(VoxelData::I8),
            Stored::Native(VoxelType::U16) => {
                array.retrieve_array_subset(subset).map(VoxelData::U16)
            }
            Stored::Native(VoxelType::I16) => {
                array.retrieve_array_subset(subset).map(VoxelData::I16)
            }
            Stored::Native(VoxelType::U32) => {
                array.retrieve_array_subset(subset).map(VoxelData::U32)
            }
            Stored::Native(VoxelType::I32) => {
                array.retrieve_array_subset(subset).map(VoxelData::I32)
            }
            Stored::Native(VoxelType::F32) => {
                array.retrieve_array_subset(subset).map(VoxelData::F32)
            }
            Stored::Native(VoxelType::F64) => {
                array.retrieve_array_subset(subset).map(VoxelData::F64)
            }
            Stored::U64 => array
                .retrieve_array_subset::<Vec<u64>>(subset)
                .map(|v| VoxelData::F64(v.into_iter().map(|x| x as f64).collect())),
            Stored::I64 => array
                .retrieve_array_subset::<Vec<i64>>(subset)
                .map(|v| VoxelData::F64(v.into_iter().map(|x| x as f64).collect())),
        };
        let read = match &self.reader_pool {
            Some(pool) => run_on(pool, &read),
            None => read(),
        };
        read.map_err(|error| self.failing_chunk(level, subset, &error))
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

    /// Why reading `subset` failed, naming the chunk: for a URL's store the first of the
    /// region's chunks the store remembers failing (its cause as the store put it); else the
    /// first chunk (in storage order) that fails alone; zarrs's own message when none does (a
    /// store failing intermittently).
    fn failing_chunk(&self, level: usize, subset: &ArraySubset, error: &ArrayError) -> ReadFailure {
        /// Chunks retried one by one; the first failure is usually among the first.
        const MAX_RETRIED: usize = 4096;
        let array = &self.arrays[level];
        let path = &self.levels[level].path;
        let at = if path.is_empty() {
            format!("level {level}")
        } else {
            format!("level {level} ({})", quoted(path))
        };
        let chunks = array
            .chunks_in_array_subset(subset)
            .ok()
            .flatten()
            .map(|chunks| {
                chunks
                    .indices()
                    .into_iter()
                    .take(MAX_RETRIED)
                    .map(|i| i.to_vec())
                    .collect::<Vec<_>>()
            })
            .unwrap_or_default();
        if let Some(remote) = &self.remote {
            for indices in &chunks {
                let key = array.chunk_key(indices);
                if let Some((cause, described)) = remote.failure_of(key.as_str()) {
                    return ReadFailure {
                        problem: format!("{at}, chunk {}: {described}", quoted(key.as_str())),
                        kind: failure_kind(error),
                        cause: Some(cause),
                    };
                }
            }
        }
        for indices in &chunks {
            let Ok(chunk) = array.chunk_subset_bounded(indices) else {
                continue;
            };
            let Ok(overlap) = chunk.overlap(subset) else {
                continue;
            };
            let Ok(relative) = overlap.relative_to(chunk.start()) else {
                continue;
            };
            if let Err(e) =
                array.retrieve_chunk_subset::<zarrs::array::ArrayBytes<'static>>(indices, &relative)
            {
                let key = array.chunk_key(indices);
                let (kind, cause) = self.chunk_failure(level, key.as_str(), &e);
                return ReadFailure {
                    problem: format!("{at}, chunk {}: {cause}", quoted(key.as_str())),
                    kind,
                    cause: Some(cause),
                };
            }
        }
        let (kind, cause) = (failure_kind(error), escape(&error.to_string()));
        ReadFailure {
            problem: format!("{at}: {cause}"),
            kind,
            cause: Some(cause),
        }
    }

    /// What went wrong with the chunk `key` of `level`, in words, and its kind. A chunk that
    /// ends before its data does (zarrs reads an uncompressed chunk's bytes by their offsets,
    /// and the read meets the file's end) is damaged, not a failed fetch: its size is said.
    fn chunk_failure(
        &self,
        level: usize,
        key: &str,
        error: &ArrayError,
    ) -> (LoadErrorKind, String) {
        let kind = failure_kind(error);
        if is_unexpected_end(error) {
            let size = StoreKey::new(key)
                .ok()
                .and_then(|k| self.store.size_key(&k).ok().flatten());
            let info = &self.levels[level];
            let expected = info.chunk.iter().product::<usize>() as u64 * self.stored_bytes();
            let size = size.map_or(String::new(), |s| format!(" ({s} bytes)"));
            return (
                LoadErrorKind::Decode,
                format!(
                    "the chunk is shorter than its data{size}: {} voxels of {} take {expected} bytes uncompressed",
                    format_dims(info.chunk),
                    self.stored_type
                ),
            );
        }
        (kind, escape(&error.to_string()))
    }

    /// Bytes of one stored value.
    fn stored_bytes(&self) -> u64 {
        match self.stored {
            Stored::Native(voxel_type) => voxel_type.size() as u64,
            Stored::U64 | Stored::I64 => 8,
        }
    }
}

/// `job`'s result, run on `pool` (a URL's reader pool) as [`rayon::ThreadPool::install`]
/// runs it, the calling thread waiting meanwhile. A thread of another rayon pool (the pinned
/// levels' bricks, the first image's regions, read in parallel on the global pool) hands it
/// over through a thread of its own: waiting in `install` itself, it would run its own
/// pool's other jobs meanwhile (rayon steals work while it waits on another pool), each
/// another brick whose read waits there in turn, nesting without bound until the stack
/// overflows (issue 57: a preview's 2 048 bricks). The read runs on `pool` either way, with
/// its threads sized for the network.
fn run_on<R: Send>(pool: &rayon::ThreadPool, job: &(impl Fn() -> R + Sync)) -> R {
    if rayon::current_thread_index().is_none() || pool.current_thread_index().is_some() {
        // A plain thread blocks in `install` without running anything else; a thread of
        // `pool` runs the job at once.
        return pool.install(job);
    }
    std::thread::scope(|scope| {
        let handed = std::thread::Builder::new()
            .name("voxscope-remote-read".into())
            .spawn_scoped(scope, || pool.install(job));
        match handed {
            Ok(reader) => reader
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            // No thread to be had: read here, on the calling thread's own pool.
            Err(_) => job(),
        }
    })
}

/// Whether zarrs's `error` is an I/O read that met the end of the data.
fn is_unexpected_end(error: &ArrayError) -> bool {
    let io = match error {
        ArrayError::StorageError(zarrs::storage::StorageError::IOError(io))
        | ArrayError::CodecError(CodecError::StorageError(
            zarrs::storage::StorageError::IOError(io),
        )) => Some(io.kind()),
        ArrayError::CodecError(CodecError::IOError(io)) => Some(io.kind()),
        _ => None,
    };
    io == Some(std::io::ErrorKind::UnexpectedEof)
}

/// What kind of failure zarrs' `error` is: the store could not deliver the bytes, or they do
/// not decode, or anything else. A store's own short read (an uncompressed chunk cut short)
/// is damage, not a failed fetch.
fn failure_kind(error: &ArrayError) -> LoadErrorKind {
    if is_unexpected_end(error) {
        return LoadErrorKind::Decode;
    }
    match error {
        ArrayError::StorageError(_)
        | ArrayError::CodecError(CodecError::StorageError(_) | CodecError::IOError(_)) => {
            LoadErrorKind::Fetch
        }
        ArrayError::CodecError(_)
        | ArrayError::UnexpectedChunkDecodedSize(..)
        | ArrayError::UnexpectedChunkDecodedShape(..)
        | ArrayError::InvalidBytesInputSize(..) => LoadErrorKind::Decode,
        _ => LoadErrorKind::Invalid,
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
