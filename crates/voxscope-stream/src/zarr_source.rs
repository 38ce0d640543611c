//! An OME-Zarr (or plain Zarr) image as a brick source: bricks are read region by region from
//! the file's own levels, never the whole volume. Each pyramid level is drawn from the
//! coarsest stored level that is at least as fine along every axis; where the file's levels
//! are coarser by other steps than the pyramid's (no levels at all, or xy-only downscaling as
//! many microscopy files have), the stored voxels a brick covers are reduced here (mean, or
//! max for label images), so one brick never reads more than [`MAX_BRICK_READ`] voxels.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use super::preview::preview_level;
use super::pyramid::{Downsampling, PyramidShape};
use super::streamer::pinned_levels;
use crate::{
    BRICK_SIZE, BrickData, BrickError, BrickId, BrickSource, PADDED_BRICK, PADDED_BRICK_VOXELS,
    SourceError, ValueRange,
};
use voxscope_volume::ome_zarr::Pyramid;
use voxscope_volume::remote::RemoteStats;
use voxscope_volume::{Quantization, Scalar, VoxelData, VoxelType, with_voxel_slice};

/// The most stored voxels one brick may read (64 Mi: 128 MiB of 16-bit data); a file whose
/// coarsest level is larger cannot give the pyramid's coarse levels without reading that much,
/// and is refused at open with the advice to convert it.
pub const MAX_BRICK_READ: u64 = 1 << 26;

/// The most chunks one brick may read from a URL's store (each a request, all in flight
/// together): a store of tiny chunks (1-voxel chunks: 42 875 a brick) is refused at open, with
/// the way around, rather than read for hours.
pub const MAX_REMOTE_BRICK_CHUNKS: u64 = 4096;

/// Where one pyramid level's bricks come from: a stored level, and how many of its voxels one
/// pyramid voxel covers along x, y, z.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct LevelSource {
    stored: usize,
    ratio: [usize; 3],
}

/// A Zarr image read brick by brick.
pub struct ZarrSource {
    name: String,
    pyramid: Arc<Pyramid>,
    shape: PyramidShape,
    sources: Vec<LevelSource>,
    quantization: Quantization,
    max_value_level: u16,
    how: Downsampling,
    /// The values are labels ([`Self::of_labels`]).
    labels: bool,
    /// Decoded chunks as value levels: neighbouring bricks share a chunk (and every brick's
    /// apron reaches into its neighbours'), so each chunk is decoded once while it is used.
    chunks: Mutex<ChunkCache>,
    /// The six one-voxel faces of decoded chunks, kept longer than the chunks for a tenth of
    /// their bytes (64³ chunks): a brick's apron reaches one voxel into the chunks beside its
    /// own, and is taken from there rather than by decoding those chunks again
    /// ([`chunk_faces`]). Not of thin chunks, whose faces are the chunk ([`keeps_faces`]).
    faces: Mutex<ChunkCache>,
    /// Chunks being read and decoded now, each with a lock its reader holds meanwhile: a
    /// loader that needs one waits for that reader rather than decoding it again (the loaders
    /// take neighbouring bricks at once, and eight bricks and their aprons share a chunk). A
    /// thread of a rayon pool never waits: it decodes on its own.
    decoding: Mutex<HashMap<ChunkKey, Arc<Mutex<()>>>>,
    /// Per stored level, every chunk's smallest and largest value where the store has them
    /// (`voxscope convert` writes them), x fastest: what [`BrickSource::known_range`] answers
    /// from.
    chunk_ranges: Vec<Option<Vec<[f64; 2]>>>,
    /// Chunks of unsharded levels handed to the store to fetch ahead (a network's requests, a
    /// folder's files read ahead; [`BrickSource::fetch_ahead`]): not asked for again (at most [`MAX_FETCHED_AHEAD`],
    /// then forgotten all at once).
    fetched_ahead: Mutex<FetchedAhead>,
    /// Chunks read and decoded so far ([`BrickSource::chunks_decoded`]).
    decoded: std::sync::atomic::AtomicU64,
    /// Chunks [`BrickSource::fetch_ahead`] has looked up so far ([`Self::chunks_looked_at_ahead`]).
    looked_at_ahead: std::sync::atomic::AtomicU64,
}

/// Bytes of chunks' faces a [`ZarrSource`] keeps at most, and less where the streamer's RAM
/// budget is smaller ([`BrickSource::reserve_caches`]): 2 700 chunks' of 64³.
pub const FACE_CACHE_BYTES: usize = 128 << 20;

/// The most stored voxels [`ZarrSource::warm_first_image`] reads as one region (16 Mi: 32 MiB
/// as value levels, 128 MiB while a 64-bit type is converted).
pub const WARM_VOXELS: u64 = 1 << 24;

/// Bytes of decoded chunks a [`ZarrSource`] keeps at most (value levels, 2 bytes a voxel),
/// and less where the streamer's RAM budget is smaller ([`BrickSource::reserve_caches`]).
pub const CHUNK_CACHE_BYTES: usize = 512 << 20;

/// Row parts of a chunk at most this long are copied a value at a time, not by a call.
const SHORT_RUN: usize = 8;

/// A decoded chunk: stored level and chunk index.
type ChunkKey = (usize, [usize; 3]);

/// How many level-0 voxels one voxel of the stored level `level` covers along each axis, if
/// that is a power of two per axis (from the `scale` transforms; from the dimensions where
/// those are missing).
fn stored_factor(pyramid: &Pyramid, level: usize) -> Option<[usize; 3]> {
    let finest = &pyramid.levels[0];
    let info = &pyramid.levels[level];
    let mut factor = [1usize; 3];
    for (a, factor) in factor.iter_mut().enumerate() {
        let by_spacing = info.spacing[a] / finest.spacing[a];
        let ratio = if by_spacing.is_finite() && by_spacing > 0.0 {
            by_spacing
        } else {
            finest.dims[a] as f64 / info.dims[a] as f64
        };
        let power = ratio.log2().round();
        if !(0.0..=14.0).contains(&power) || (ratio / power.exp2() - 1.0).abs() > 0.1 {
            return None;
        }
        *factor = power.exp2() as usize;
    }
    Some(factor)
}

impl ZarrSource {
    /// The pyramid of `pyramid`'s selected channel and time point. Reads nothing but, for
    /// floating-point and 32-bit data without stored chunk ranges or an `omero` range, the
    /// coarsest level (to fix the quantization).
    pub fn new(pyramid: Arc<Pyramid>) -> Result<Self, SourceError> {
        let name = pyramid.source.clone();
        let dims = pyramid.levels[0].dims;
        let shape = PyramidShape::new(dims).map_err(SourceError::shape(&name))?;
        let factors: Vec<Option<[usize; 3]>> = (0..pyramid.levels.len())
            .map(|level| stored_factor(&pyramid, level))
            .collect();
        let mut sources = Vec::with_capacity(shape.levels.len());
        for (level, info) in shape.levels.iter().enumerate() {
            let step = 1usize << level;
            // The coarsest stored level whose voxels are no larger than this level's.
            let stored = factors
                .iter()
                .enumerate()
                .filter_map(|(i, f)| f.map(|f| (i, f)))
                .filter(|(_, f)| f.iter().all(|&f| f <= step))
                .max_by_key(|(_, f)| f.iter().product::<usize>())
                .map_or(0, |(i, _)| i);
            let factor = factors[stored].unwrap_or([1; 3]);
            let ratio = factor.map(|f| step / f);
            let read: u64 = (0..3)
                .map(|a| ((PADDED_BRICK * ratio[a]).min(pyramid.levels[stored].dims[a])) as u64)
                .product();
            if read > MAX_BRICK_READ {
                let coarsest = pyramid.levels.last().map_or(dims, |l| l.dims);
                return Err(SourceError::CoarsestTooLarge {
                    name,
                    coarsest,
                    level_dims: info.dims,
                    read,
                });
            }
            let info = &pyramid.levels[stored];
            let chunks: u64 = (0..3)
                .map(|a| {
                    let span = (PADDED_BRICK * ratio[a]).min(info.dims[a]);
                    (span.div_ceil(info.chunk[a]) + 1).min(info.chunk_grid()[a]) as u64
                })
                .product();
            if pyramid.remote_stats().is_some() && chunks > MAX_REMOTE_BRICK_CHUNKS {
                return Err(SourceError::ChunksTooSmall {
                    name,
                    level: stored,
                    chunk: info.chunk,
                    requests: chunks,
                });
            }
            sources.push(LevelSource { stored, ratio });
        }
        let (quantization, max_value_level) = quantization_of(&pyramid)?;
        // The stored levels' chunk ranges, for the levels bricks are read from (a store
        // without them, or with damaged ones, is read brick by brick as any other). Not for a
        // URL's store: reading them before the first image costs round trips (8.2 s to open a
        // 2048³ store at 50 ms a request, against 0.02 s from its folder: run 52).
        let mut chunk_ranges = vec![None; pyramid.levels.len()];
        let local = pyramid.remote_stats().is_none();
        for source in sources.iter().filter(|_| local) {
            if chunk_ranges[source.stored].is_none() {
                chunk_ranges[source.stored] = pyramid.chunk_ranges(source.stored).ok().flatten();
            }
        }
        let how = match pyramid.downscaling.as_deref() {
            // A label image (`image-label`) is categories whatever its levels were made with.
            _ if pyramid.label_image => Downsampling::Mode,
            Some(kind) if kind.contains("mode") => Downsampling::Mode,
            Some(kind) if kind.contains("max") || kind.contains("nearest") => Downsampling::Max,
            _ => Downsampling::Mean,
        };
        Ok(Self {
            name,
            pyramid,
            shape,
            sources,
            quantization,
            max_value_level,
            how,
            labels: how == Downsampling::Mode,
            chunks: Mutex::default(),
            faces: Mutex::new(ChunkCache::with_capacity(FACE_CACHE_BYTES)),
            decoding: Mutex::default(),
            chunk_ranges,
            fetched_ahead: Mutex::default(),
            decoded: std::sync::atomic::AtomicU64::new(0),
            looked_at_ahead: std::sync::atomic::AtomicU64::new(0),
        })
    }

    /// This source of a label volume (its values categories: the app knows from the level it
    /// reads whole): sampled at the nearest voxel, and the levels it computes from stored ones
    /// reduced by their mode, whatever the store says of its own downsampling.
    pub fn of_labels(mut self, labels: bool) -> Self {
        self.labels = labels;
        if labels {
            self.how = Downsampling::Mode;
        }
        self
    }

    /// The value levels of the stored level's voxels `[origin, origin + size)`, x fastest,
    /// assembled from whole decoded chunks (cached) and the faces kept of chunks the region
    /// only reaches one voxel into; `None` where another loader decodes a chunk it needs and
    /// `wait` is off (the chunks no other loader decodes are decoded and cached meanwhile).
    fn read_levels(
        &self,
        stored: usize,
        origin: [usize; 3],
        size: [usize; 3],
        wait: bool,
    ) -> Result<Option<Vec<u16>>, voxscope_volume::LoadError> {
        let mut parts = self.region_parts(stored, origin, size);
        // Over a network, the chunks still to decode are asked for together (a folder's store
        // does nothing here); a chunk whose kept faces or decoded voxels serve is not. A read
        // that does not wait leaves out the chunks another loader is decoding (their fetch
        // under way would be waited for).
        let missing: Vec<(usize, [usize; 3], [usize; 3])> = parts
            .iter()
            .filter(|part| matches!(part.from, PartFrom::Missing))
            .filter(|part| wait || !self.being_decoded((stored, part.index)))
            .map(|part| (stored, part.part.start, part.part.extent))
            .collect();
        // What they fetched is held for the reads below, whatever the fetch cache keeps.
        let _held = (!missing.is_empty()).then(|| self.pyramid.prefetch_regions(&missing));
        // The chunks no other loader is decoding first, then those that one is (waited for
        // last, by when it has usually finished): neighbouring bricks share chunks, and a
        // loader that waited for each in turn would idle while it could decode its own.
        for part in parts.iter_mut() {
            if matches!(part.from, PartFrom::Missing)
                && let Some(levels) = self.chunk_levels(
                    (stored, part.index),
                    part.part.start,
                    part.part.extent,
                    false,
                )?
            {
                part.from = PartFrom::Decoded(levels);
            }
        }
        if !wait
            && parts
                .iter()
                .any(|part| matches!(part.from, PartFrom::Missing))
        {
            return Ok(None);
        }
        let mut out = vec![0u16; size.iter().product()];
        for part in parts {
            let RegionPart { index, part, from } = part;
            let levels = match from {
                PartFrom::Faces(face, faces) => {
                    copy_from_face(&faces, face, &part, origin, size, &mut out);
                    continue;
                }
                PartFrom::Decoded(levels) => levels,
                PartFrom::Missing => self
                    .chunk_levels((stored, index), part.start, part.extent, true)?
                    .expect("a chunk waited for is read"),
            };
            let ChunkPart {
                start,
                extent,
                lo,
                hi,
            } = part;
            let run = hi[0] - lo[0];
            for z in lo[2]..hi[2] {
                for y in lo[1]..hi[1] {
                    let from = (lo[0] - start[0])
                        + extent[0] * ((y - start[1]) + extent[1] * (z - start[2]));
                    let to = (lo[0] - origin[0])
                        + size[0] * ((y - origin[1]) + size[1] * (z - origin[2]));
                    copy_run(&mut out[to..to + run], &levels[from..from + run]);
                }
            }
        }
        Ok(Some(out))
    }

    /// The chunks of the stored level that the region `[origin, origin + size)` reaches,
    /// each with the part of it inside the region and where that part comes from now.
    fn region_parts(&self, stored: usize, origin: [usize; 3], size: [usize; 3]) -> Vec<RegionPart> {
        let info = &self.pyramid.levels[stored];
        // (Locked in this order everywhere: the decoded chunks, then the faces.)
        let mut decoded = self.chunks.lock().ok();
        let mut kept_faces = self.faces.lock().ok();
        chunks_reached(info.chunk, origin, size)
            .map(|index| {
                let part = ChunkPart::of(info.chunk, info.dims, index, origin, size);
                let key = (stored, index);
                // An apron one voxel into this chunk: from its faces where they are kept.
                let faces = part.face().and_then(|face| {
                    let faces = kept_faces.as_mut()?.get(key)?;
                    Some(PartFrom::Faces(face, faces))
                });
                let from = faces
                    .or_else(|| decoded.as_mut()?.get(key).map(PartFrom::Decoded))
                    .unwrap_or(PartFrom::Missing);
                RegionPart { index, part, from }
            })
            .collect()
    }

    /// Whether another loader is reading and decoding chunk `key` now (its reader's entry
    /// stays from before it takes the chunk's lock until it has put the chunk in the cache).
    fn being_decoded(&self, key: ChunkKey) -> bool {
        self.decoding
            .lock()
            .is_ok_and(|decoding| decoding.contains_key(&key))
    }

    /// The value levels of one chunk (`start` and `extent` in the stored level's voxels):
    /// from the decoded-chunk cache, else read and decoded here, or by the loader already
    /// decoding it: waited for where `wait`, else `None`.
    fn chunk_levels(
        &self,
        key: ChunkKey,
        start: [usize; 3],
        extent: [usize; 3],
        wait: bool,
    ) -> Result<Option<Arc<Vec<u16>>>, voxscope_volume::LoadError> {
        let cached = |chunks: &Mutex<ChunkCache>| chunks.lock().ok().and_then(|mut c| c.get(key));
        if let Some(levels) = cached(&self.chunks) {
            return Ok(Some(levels));
        }
        // A thread of a rayon pool (the preview, the pinned levels) decodes on its own: while
        // it waits inside a read it may run another brick of its pool, which would then wait
        // for the lock this thread holds.
        if rayon::current_thread_index().is_some() {
            return self.decode_chunk(key, start, extent).map(Some);
        }
        let Ok(mut decoding) = self.decoding.lock() else {
            return self.decode_chunk(key, start, extent).map(Some);
        };
        let reader = Arc::clone(decoding.entry(key).or_default());
        drop(decoding);
        // The first here reads it; the others wait for it (or come back later) and then find
        // it in the cache (a reader that failed, or a cache that has let it go, leaves them to
        // read it).
        let _reading = match reader.try_lock() {
            Ok(reading) => reading,
            Err(std::sync::TryLockError::Poisoned(poisoned)) => poisoned.into_inner(),
            Err(std::sync::TryLockError::WouldBlock) if !wait => return Ok(None),
            Err(std::sync::TryLockError::WouldBlock) => reader
                .lock()
                .unwrap_or_else(|poisoned| poisoned.into_inner()),
        };
        let levels = match cached(&self.chunks) {
            Some(levels) => Ok(Some(levels)),
            None => self.decode_chunk(key, start, extent).map(Some),
        };
        if let Ok(mut decoding) = self.decoding.lock()
            && decoding.get(&key).is_some_and(|r| Arc::ptr_eq(r, &reader))
        {
            decoding.remove(&key);
        }
        levels
    }

    /// Reads and decodes one chunk into the decoded-chunk cache.
    fn decode_chunk(
        &self,
        (stored, index): ChunkKey,
        start: [usize; 3],
        extent: [usize; 3],
    ) -> Result<Arc<Vec<u16>>, voxscope_volume::LoadError> {
        let data = self.pyramid.read_region(stored, start, extent)?;
        self.decoded
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let levels = Arc::new(to_levels(data, self.quantization));
        if let Ok(mut cache) = self.chunks.lock() {
            cache.insert((stored, index), Arc::clone(&levels));
        }
        if keeps_faces(extent)
            && let Ok(mut faces) = self.faces.lock()
        {
            faces.insert((stored, index), Arc::new(chunk_faces(&levels, extent)));
        }
        Ok(levels)
    }

    /// Chunks [`BrickSource::fetch_ahead`] has looked up in the caches so far, each time it
    /// did: what fetching ahead costs the loaders, which call it before each brick they take
    /// and wait for the decoded chunks' lock while it looks.
    pub fn chunks_looked_at_ahead(&self) -> u64 {
        self.looked_at_ahead
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The stored level pyramid level `level` reads, and its reduction per axis.
    pub fn stored_level(&self, level: usize) -> Option<(usize, [usize; 3])> {
        self.sources.get(level).map(|s| (s.stored, s.ratio))
    }
}

impl BrickSource for ZarrSource {
    fn name(&self) -> &str {
        &self.name
    }

    fn shape(&self) -> &PyramidShape {
        &self.shape
    }

    fn spacing(&self) -> [f64; 3] {
        self.pyramid.levels[0].spacing
    }

    fn quantization(&self) -> Quantization {
        self.quantization
    }

    fn max_value_level(&self) -> u16 {
        self.max_value_level
    }

    fn remote_stats(&self) -> Option<RemoteStats> {
        self.pyramid.remote_stats()
    }

    /// Decoded chunks get a quarter of `ram` (at most [`CHUNK_CACHE_BYTES`]), or half (at most
    /// twice that) where a level bricks are read from has thin chunks ([`thin_chunk`]); their
    /// faces a sixteenth (at most [`FACE_CACHE_BYTES`]); a network store's fetched bytes an
    /// eighth (at most [`voxscope_volume::remote::FETCH_CACHE_BYTES`]).
    fn reserve_decoded_caches(&self, ram: u64) -> u64 {
        let thin = self
            .sources
            .iter()
            .any(|source| thin_chunk(self.pyramid.levels[source.stored].chunk));
        let chunks = if thin {
            (ram / 2).min(2 * CHUNK_CACHE_BYTES as u64)
        } else {
            (ram / 4).min(CHUNK_CACHE_BYTES as u64)
        };
        if let Ok(mut cache) = self.chunks.lock() {
            cache.set_capacity(chunks as usize);
        }
        let faces = (ram / 16).min(FACE_CACHE_BYTES as u64);
        if let Ok(mut cache) = self.faces.lock() {
            cache.set_capacity(faces as usize);
        }
        chunks + faces
    }

    fn reserve_fetch_cache(&self, ram: u64) -> u64 {
        if self.pyramid.remote_stats().is_none() {
            return 0;
        }
        let fetched = (ram / 8).min(voxscope_volume::remote::FETCH_CACHE_BYTES);
        self.pyramid.set_fetch_cache_bytes(fetched);
        fetched
    }

    fn fetch_store(&self) -> Option<usize> {
        self.pyramid.remote_store_id()
    }

    fn cached_bytes(&self) -> u64 {
        let chunks = self.chunks.lock().map_or(0, |cache| cache.bytes as u64);
        let faces = self.faces.lock().map_or(0, |cache| cache.bytes as u64);
        chunks + faces + self.pyramid.fetch_cached_bytes()
    }

    fn chunks_decoded(&self) -> u64 {
        self.decoded.load(std::sync::atomic::Ordering::Relaxed)
    }

    fn known_range(&self, id: BrickId) -> Option<ValueRange> {
        let level = self.shape.levels.get(id.level as usize)?;
        let source = self.sources.get(id.level as usize)?;
        let ranges = self.chunk_ranges.get(source.stored)?.as_ref()?;
        let info = &self.pyramid.levels[source.stored];
        let grid = info.chunk_grid();
        // The stored voxels the brick's own voxels cover, and the chunks holding them.
        let first: [usize; 3] = std::array::from_fn(|a| {
            let c0 = (id.brick[a] as usize * BRICK_SIZE).min(level.dims[a] - 1);
            covered(c0, c0, source.ratio[a], info.dims[a]).0 / info.chunk[a]
        });
        let last: [usize; 3] = std::array::from_fn(|a| {
            let c1 = ((id.brick[a] as usize + 1) * BRICK_SIZE - 1).min(level.dims[a] - 1);
            covered(c1, c1, source.ratio[a], info.dims[a]).1 / info.chunk[a]
        });
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in first[2]..=last[2] {
            for y in first[1]..=last[1] {
                for x in first[0]..=last[0] {
                    let [min, max] = *ranges.get(x + grid[0] * (y + grid[1] * z))?;
                    if !(min.is_finite() && max.is_finite()) {
                        return None;
                    }
                    low = low.min(min);
                    high = high.max(max);
                }
            }
        }
        // Widened to whole levels, so that rounding never hides a visible voxel.
        let q = self.quantization;
        let level_of = |value: f64, round: fn(f64) -> f64| {
            round((value - q.offset) / q.step).clamp(0.0, u16::MAX as f64) as u16
        };
        (low <= high).then(|| ValueRange {
            min: level_of(low, f64::floor),
            max: level_of(high, f64::ceil),
        })
    }

    /// Starts the fetches of the bricks' chunks that are neither decoded nor fetched ahead
    /// before, in the bricks' order: whole chunks ([`Pyramid::fetch_ahead_chunks`]), or a
    /// sharded level's inner chunks shard by shard, coalesced
    /// ([`Pyramid::fetch_ahead_regions`]). The chunks already handed to the store are
    /// remembered, and so are the bricks whose chunks all were (at a sharded level, whose
    /// inner chunks were all decoded), so that a call costs little once a view's chunks are
    /// on their way.
    fn fetch_ahead(&self, ids: &[BrickId]) {
        self.fetch_ahead_bricks(ids);
    }

    fn can_fetch_ahead(&self) -> bool {
        self.pyramid.can_fetch_ahead()
    }

    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        self.read_brick_waiting(id, true)
            .expect("a read that waits reads")
    }

    fn read_brick_unless_busy(&self, id: BrickId) -> Option<Result<BrickData, BrickError>> {
        self.read_brick_waiting(id, false)
    }

    fn labels(&self) -> bool {
        self.labels
    }
}

impl ZarrSource {
    /// A brick's read: `None` where another loader decodes a chunk it needs and `wait` is off.
    fn read_brick_waiting(&self, id: BrickId, wait: bool) -> Option<Result<BrickData, BrickError>> {
        let (Some(level), Some(source), Some(_)) = (
            self.shape.levels.get(id.level as usize),
            self.sources.get(id.level as usize),
            self.shape.key(id),
        ) else {
            return Some(Err(BrickError::invalid(format!("{}: no {id}", self.name))));
        };
        let stored_dims = self.pyramid.levels[source.stored].dims;
        let first = id.brick.map(|c| c as usize * BRICK_SIZE);
        let voxels = padded_voxels(first, level.dims);
        let (origin, size) = stored_region(&voxels, source.ratio, stored_dims);
        let stored = match self.read_levels(source.stored, origin, size, wait) {
            Ok(Some(stored)) => stored,
            Ok(None) => return None,
            Err(e) => return Some(Err(BrickError::of_load(id, &e))),
        };
        let inside = std::array::from_fn(|a| level.dims[a].saturating_sub(first[a]));
        let levels = if source.ratio == [1, 1, 1] {
            // One stored voxel a pyramid voxel (its mean, max and mode alike): rows copied.
            gather_padded(stored, origin, size, &voxels, stored_dims)
        } else {
            reduce_padded(
                &stored,
                origin,
                size,
                &voxels,
                source.ratio,
                stored_dims,
                self.how,
            )
        };
        Some(Ok(BrickData::new(levels, inside)))
    }
}

mod ahead;
mod chunk_cache;
mod faces;
mod levels;
mod warm;

use ahead::*;
use chunk_cache::*;
use faces::*;
use levels::*;

#[cfg(test)]
mod tests;
