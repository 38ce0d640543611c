//! Writing a window of an image's levels: the voxels of one column of level `from` (all of z)
//! fed slab by slab, and the same column of each coarser level up to `to`, each by 2×2×2 mean
//! (or max) of the one before. A part of a conversion writes its columns of level 0 and the
//! levels it can build from them; `finalize` feeds the last of those, whole, for the rest.
//!
//! Only one slab (a chunk's or shard's depth of z slices) per level is held in memory. A
//! column's sides are whole shards and whole chunk-range tiles at every level written (but at
//! the image's edge), so no two windows write one object.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use rayon::prelude::*;
use zarrs::array::codec::array_to_bytes::sharding::{ShardingCodecOptions, SubchunkWriteOrder};
use zarrs::array::{Array, ArraySubset, CodecSpecificOptions, Element};
use zarrs::filesystem::FilesystemStore;

use super::super::super::error::{Problem, printable};
use super::super::super::{Scalar, VoxelData, VoxelType};
use super::recorded::{Recorded, Written};
use super::{Downsampling, ImageLayout, Window};
use crate::with_voxel_slice;

/// What a window's writing left: every object written (key, size, CRC-32C) and the smallest
/// and largest finite value of level `from`, where it was written and held a number.
#[derive(Debug, Clone, Default)]
pub struct WindowReport {
    pub written: BTreeMap<String, Written>,
    pub range: Option<[f64; 2]>,
}

/// Writes one window of levels `from..=to`; feed it level `from`'s slices of the window in z
/// order with [`Self::push`], then [`Self::finish`].
pub struct WindowWriter {
    inner: Box<dyn SlabSink>,
    store: Arc<Recorded>,
}

impl std::fmt::Debug for WindowWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WindowWriter").finish_non_exhaustive()
    }
}

impl WindowWriter {
    /// Opens the level arrays under `root` (written by [`super::create_arrays`] for `layout`)
    /// to write `window` (level-0 voxels) of levels `from..=to`; level `from` itself only
    /// where `write_from` (else it is read to build the coarser ones).
    pub fn open(
        root: &Path,
        layout: &ImageLayout,
        window: Window,
        from: usize,
        to: usize,
        write_from: bool,
    ) -> Result<Self, Problem> {
        let count = layout.levels().len();
        if from > to || to >= count {
            return Err(format!(
                "levels {from} to {to} of an image of {count} levels"
            ));
        }
        let store = Arc::new(Recorded::new(Arc::new(
            FilesystemStore::new(root)
                .map_err(|e| format!("cannot open {}: {e}", root.display()))?,
        )));
        macro_rules! typed {
            ($t:ty) => {
                Box::new(TypedWriter::<$t>::open(
                    &store, layout, window, from, to, write_from,
                )?) as Box<dyn SlabSink>
            };
        }
        let inner = match layout.voxel_type {
            VoxelType::U8 => typed!(u8),
            VoxelType::I8 => typed!(i8),
            VoxelType::U16 => typed!(u16),
            VoxelType::I16 => typed!(i16),
            VoxelType::U32 => typed!(u32),
            VoxelType::I32 => typed!(i32),
            VoxelType::F32 => typed!(f32),
            VoxelType::F64 => typed!(f64),
        };
        Ok(Self { inner, store })
    }

    /// How many z slices the writer takes at a time without copying more than it needs (a
    /// slab of level `from`): feeding it this many at a time keeps memory at one slab.
    pub fn slab_depth(&self) -> usize {
        self.inner.slab_depth()
    }

    /// Appends whole z slices of the window: `data` holds `width * height * n` voxels of the
    /// image's type, x fastest.
    pub fn push(&mut self, data: &VoxelData) -> Result<(), Problem> {
        self.inner.push(data).map(|_| ())
    }

    /// Writes what remains; says what was written.
    pub fn finish(mut self) -> Result<WindowReport, Problem> {
        let range = self.inner.finish()?;
        let written = self.store.written().map_err(|e| {
            format!(
                "cannot read back what was written: {}",
                printable(&e.to_string())
            )
        })?;
        Ok(WindowReport { written, range })
    }
}

/// The type-erased writer behind [`WindowWriter`].
trait SlabSink {
    fn slab_depth(&self) -> usize;
    fn push(&mut self, data: &VoxelData) -> Result<usize, Problem>;
    fn finish(&mut self) -> Result<Option<[f64; 2]>, Problem>;
}

/// One level's arrays (`None`: not written, only reduced) and the slab being filled.
struct Level<T> {
    /// The whole level's voxels along x, y, z.
    dims: [usize; 3],
    /// The window at this level: its first voxel and its size along x and y.
    origin: [usize; 2],
    size: [usize; 2],
    arrays: Option<(Array<Recorded>, Array<Recorded>)>,
    /// Slices buffered, `size[0] * size[1]` voxels each.
    buffer: Vec<T>,
    /// Slices already written.
    written: usize,
}

impl<T> Level<T> {
    fn plane(&self) -> usize {
        self.size[0] * self.size[1]
    }
}

struct TypedWriter<T> {
    chunk: usize,
    /// The chunk or shard side (what one `store_array_subset` writes), and the slab depth.
    unit: usize,
    downsampling: Downsampling,
    /// The levels `from..=to`.
    levels: Vec<Level<T>>,
    /// The first level's number in the image.
    from: usize,
    /// The smallest and largest finite value written at the first level.
    range: Option<[f64; 2]>,
    finished: bool,
}

/// Numbers the writer stores: voxscope's voxel types, as zarrs elements.
trait Voxel: Scalar + Element + PartialOrd + Default {}
impl<T: Scalar + Element + PartialOrd + Default> Voxel for T {}

/// A chunk's grid index (z, y, x) and its smallest and largest finite value.
type ChunkRange = ([usize; 3], f64, f64);

/// Opens an array to write, its shards' inner chunks in C order (zarrs' default is the order
/// they finish encoding in): the same voxels make the same bytes, run after run, whichever
/// part writes them.
fn open_array(store: &Arc<Recorded>, path: &str) -> Result<Array<Recorded>, Problem> {
    let in_order = CodecSpecificOptions::default().with_option(
        ShardingCodecOptions::default().with_subchunk_write_order(SubchunkWriteOrder::C),
    );
    Array::open(store.clone(), &format!("/{path}"))
        .map(|array| array.with_codec_specific_options(&in_order))
        .map_err(|e| {
            format!(
                "cannot open the array {path}: {}",
                printable(&e.to_string())
            )
        })
}

impl<T: Voxel> TypedWriter<T> {
    fn open(
        store: &Arc<Recorded>,
        layout: &ImageLayout,
        window: Window,
        from: usize,
        to: usize,
        write_from: bool,
    ) -> Result<Self, Problem> {
        let all = layout.levels();
        let mut levels = Vec::with_capacity(to + 1 - from);
        for (index, dims) in all.iter().enumerate().take(to + 1).skip(from) {
            let (origin, size) = window.at_level(index, *dims);
            let arrays = if index > from || write_from {
                Some((
                    open_array(store, &index.to_string())?,
                    open_array(store, &format!("ranges/{index}"))?,
                ))
            } else {
                None
            };
            levels.push(Level {
                dims: *dims,
                origin,
                size,
                arrays,
                buffer: Vec::new(),
                written: 0,
            });
        }
        Ok(Self {
            chunk: layout.options.chunk,
            unit: layout.unit(),
            downsampling: layout.options.downsampling,
            levels,
            from,
            range: None,
            finished: false,
        })
    }

    /// Appends `slices` to level `index` (of `levels`), writing every complete slab: whole
    /// slabs straight from `slices`, only a partial one copied into the level's buffer (a
    /// 4096² slab is 2 GiB of 16-bit voxels: copying it on one thread held 16 cores idle).
    fn push_level(&mut self, index: usize, slices: &[T]) -> Result<(), Problem> {
        let slab_len = self.levels[index].plane() * self.unit;
        let mut rest = slices;
        let buffered = self.levels[index].buffer.len();
        if buffered > 0 {
            let take = (slab_len - buffered).min(rest.len());
            self.levels[index].buffer.extend_from_slice(&rest[..take]);
            rest = &rest[take..];
            if self.levels[index].buffer.len() == slab_len {
                let slab = std::mem::take(&mut self.levels[index].buffer);
                self.write_slab(index, &slab)?;
            }
        }
        while rest.len() >= slab_len {
            let (slab, after) = rest.split_at(slab_len);
            self.write_slab(index, slab)?;
            rest = after;
        }
        self.levels[index].buffer.extend_from_slice(rest);
        Ok(())
    }

    /// Writes one slab of level `index` (its write units in parallel), where that level is
    /// written, then hands its 2× reduction to the next level.
    fn write_slab(&mut self, index: usize, slab: &[T]) -> Result<(), Problem> {
        let level = &self.levels[index];
        let [w, h] = level.size;
        let depth = slab.len() / (w * h);
        if let Some((array, ranges_array)) = &level.arrays {
            let ranges = write_units(
                array,
                slab,
                level,
                [self.chunk, self.unit],
                self.from + index,
            )?;
            if index == 0 {
                for (_, low, high) in &ranges {
                    if low <= high {
                        let [a, b] = self.range.get_or_insert([*low, *high]);
                        *a = a.min(*low);
                        *b = b.max(*high);
                    }
                }
            }
            store_ranges(ranges_array, &ranges, level, depth, self.chunk).map_err(|e| {
                format!(
                    "cannot write the chunk ranges of level {}: {e}",
                    self.from + index
                )
            })?;
        }
        self.levels[index].written += depth;
        if index + 1 < self.levels.len() {
            let reduced = reduce(slab, [w, h, depth], self.downsampling);
            self.push_level(index + 1, &reduced)?;
        }
        Ok(())
    }
}

/// Stores `slab` (the window of `level`, `depth` slices from its `written`) in write units of
/// `unit` voxels (a chunk's or shard's side) in parallel; returns each chunk's range.
fn write_units<T: Voxel>(
    array: &Array<Recorded>,
    slab: &[T],
    level: &Level<T>,
    [chunk, unit]: [usize; 2],
    number: usize,
) -> Result<Vec<ChunkRange>, Problem> {
    let [w, h] = level.size;
    let [ox, oy] = level.origin;
    let depth = slab.len() / (w * h);
    let z0 = level.written;
    let tiles: Vec<(usize, usize)> = (0..h.div_ceil(unit))
        .flat_map(|ty| (0..w.div_ceil(unit)).map(move |tx| (ty, tx)))
        .collect();
    let results: Vec<Result<Vec<ChunkRange>, Problem>> = tiles
        .par_iter()
        .map(|&(ty, tx)| {
            let (x0, y0) = (tx * unit, ty * unit);
            let (x1, y1) = ((x0 + unit).min(w), (y0 + unit).min(h));
            let (bw, bh) = (x1 - x0, y1 - y0);
            let mut block = Vec::with_capacity(bw * bh * depth);
            for z in 0..depth {
                for y in y0..y1 {
                    let row = (z * h + y) * w;
                    block.extend_from_slice(&slab[row + x0..row + x1]);
                }
            }
            let subset = ArraySubset::new_with_ranges(&[
                z0 as u64..(z0 + depth) as u64,
                (oy + y0) as u64..(oy + y1) as u64,
                (ox + x0) as u64..(ox + x1) as u64,
            ]);
            let mut ranges = Vec::new();
            for cz in 0..depth.div_ceil(chunk) {
                for cy in 0..bh.div_ceil(chunk) {
                    for cx in 0..bw.div_ceil(chunk) {
                        let (low, high) = block_range(&block, [bw, bh, depth], [cx, cy, cz], chunk);
                        ranges.push((
                            [
                                z0 / chunk + cz,
                                (oy + y0) / chunk + cy,
                                (ox + x0) / chunk + cx,
                            ],
                            low,
                            high,
                        ));
                    }
                }
            }
            store_whole_chunks(array, &subset, &block, T::default())
                .map_err(|e| format!("cannot write level {number} at z {z0}: {e}"))?;
            Ok(ranges)
        })
        .collect();
    let mut all = Vec::new();
    for result in results {
        all.extend(result?);
    }
    Ok(all)
}

/// The smallest and largest finite value of chunk `[cx, cy, cz]` of `block` (`dims` x, y, z);
/// NaN, NaN where it holds none.
fn block_range<T: Voxel>(
    block: &[T],
    dims: [usize; 3],
    [cx, cy, cz]: [usize; 3],
    chunk: usize,
) -> (f64, f64) {
    let [w, h, depth] = dims;
    let mut low = f64::INFINITY;
    let mut high = f64::NEG_INFINITY;
    for z in cz * chunk..((cz + 1) * chunk).min(depth) {
        for y in cy * chunk..((cy + 1) * chunk).min(h) {
            let row = (z * h + y) * w;
            for v in &block[row + cx * chunk..row + ((cx + 1) * chunk).min(w)] {
                let v = v.to_f64();
                if v.is_finite() {
                    low = low.min(v);
                    high = high.max(v);
                }
            }
        }
    }
    if low <= high {
        (low, high)
    } else {
        (f64::NAN, f64::NAN)
    }
}

/// Stores a slab's chunk ranges: the rows of the ranges grid it covers, over the window.
fn store_ranges<T>(
    array: &Array<Recorded>,
    ranges: &[ChunkRange],
    level: &Level<T>,
    depth: usize,
    chunk: usize,
) -> Result<(), String> {
    let [w, h] = level.size;
    let [ox, oy] = level.origin.map(|o| o / chunk);
    let grid = [w.div_ceil(chunk), h.div_ceil(chunk)];
    let z0 = level.written / chunk;
    let rows = depth.div_ceil(chunk);
    let mut values = vec![f64::NAN; rows * grid[1] * grid[0] * 2];
    for ([cz, cy, cx], low, high) in ranges {
        let at = (((cz - z0) * grid[1] + cy - oy) * grid[0] + cx - ox) * 2;
        values[at] = *low;
        values[at + 1] = *high;
    }
    let subset = ArraySubset::new_with_ranges(&[
        z0 as u64..(z0 + rows) as u64,
        oy as u64..(oy + grid[1]) as u64,
        ox as u64..(ox + grid[0]) as u64,
        0..2,
    ]);
    store_whole_chunks(array, &subset, &values, f64::NAN)
}

/// Stores `data` (C order over `subset`, which starts on chunk boundaries and ends on one or
/// at the array's edge) chunk by chunk, each whole, the part of a chunk beyond the array
/// `fill`. (zarrs reads a chunk the subset covers in part back and writes it over: what a
/// killed write left truncated would then fail to decode, and a part run again would fail.)
fn store_whole_chunks<T: Element + Copy>(
    array: &Array<Recorded>,
    subset: &ArraySubset,
    data: &[T],
    fill: T,
) -> Result<(), String> {
    let words = |e: &dyn std::fmt::Display| printable(&e.to_string());
    let origin = subset.start();
    let shape = subset.shape();
    let n = origin.len();
    let end: Vec<u64> = (0..n).map(|a| origin[a] + shape[a]).collect();
    let Some(chunks) = array
        .chunks_in_array_subset(subset)
        .map_err(|e| words(&e))?
    else {
        return Ok(());
    };
    for indices in &chunks.indices() {
        let chunk = array.chunk_subset(&indices).map_err(|e| words(&e))?;
        let (start, size) = (chunk.start(), chunk.shape());
        let lo: Vec<u64> = (0..n).map(|a| start[a].max(origin[a])).collect();
        let hi: Vec<u64> = (0..n).map(|a| (start[a] + size[a]).min(end[a])).collect();
        if (0..n).any(|a| lo[a] >= hi[a]) {
            continue;
        }
        let mut block = vec![fill; size.iter().product::<u64>() as usize];
        let row = (hi[n - 1] - lo[n - 1]) as usize;
        let offset = |at: &[u64], from: &[u64], dims: &[u64]| {
            (0..n).fold(0u64, |acc, a| acc * dims[a] + (at[a] - from[a])) as usize
        };
        let mut at = lo.clone();
        'rows: loop {
            let (src, dst) = (offset(&at, origin, shape), offset(&at, start, size));
            block[dst..dst + row].copy_from_slice(&data[src..src + row]);
            let mut axis = n - 1;
            loop {
                if axis == 0 {
                    break 'rows;
                }
                axis -= 1;
                at[axis] += 1;
                if at[axis] < hi[axis] {
                    break;
                }
                at[axis] = lo[axis];
            }
        }
        array.store_chunk(&indices, block).map_err(|e| words(&e))?;
    }
    Ok(())
}

/// 2×2×2 reduction of `slab` (x fastest; `dims` = x, y, depth): `ceil(n / 2)` per axis, an
/// odd extent's last voxel paired with itself.
fn reduce<T: Voxel>(slab: &[T], dims: [usize; 3], downsampling: Downsampling) -> Vec<T> {
    let [nx, ny, nz] = dims;
    let out = [nx.div_ceil(2), ny.div_ceil(2), nz.div_ceil(2)];
    let plane = out[0] * out[1];
    let mut reduced = vec![T::default(); plane * out[2]];
    reduced
        .par_chunks_mut(plane)
        .enumerate()
        .for_each(|(z, plane_out)| {
            let zs = [2 * z, (2 * z + 1).min(nz - 1)];
            for y in 0..out[1] {
                let ys = [2 * y, (2 * y + 1).min(ny - 1)];
                for x in 0..out[0] {
                    let xs = [2 * x, (2 * x + 1).min(nx - 1)];
                    let at = |z: usize, y: usize, x: usize| slab[(z * ny + y) * nx + x];
                    plane_out[y * out[0] + x] = match downsampling {
                        Downsampling::Mean => {
                            let mut sum = 0.0;
                            for z in zs {
                                for y in ys {
                                    for x in xs {
                                        sum += at(z, y, x).to_f64();
                                    }
                                }
                            }
                            let mean = sum / 8.0;
                            T::from_f64(if T::TYPE.is_integer() {
                                (mean + 0.5).floor()
                            } else {
                                mean
                            })
                        }
                        Downsampling::Max => {
                            let mut best = at(zs[0], ys[0], xs[0]);
                            for z in zs {
                                for y in ys {
                                    for x in xs {
                                        let v = at(z, y, x);
                                        if v > best {
                                            best = v;
                                        }
                                    }
                                }
                            }
                            best
                        }
                    };
                }
            }
        });
    reduced
}

impl<T: Voxel> SlabSink for TypedWriter<T> {
    fn slab_depth(&self) -> usize {
        self.unit
    }

    fn push(&mut self, data: &VoxelData) -> Result<usize, Problem> {
        let first = &self.levels[0];
        let plane = first.plane();
        let count = data.len();
        if !count.is_multiple_of(plane) {
            return Err(format!(
                "{count} voxels are not whole {}x{} slices",
                first.size[0], first.size[1]
            ));
        }
        let slices = count / plane;
        let pending = first.written + first.buffer.len() / plane;
        if pending + slices > first.dims[2] {
            return Err(format!(
                "{} slices given for a depth of {}",
                pending + slices,
                first.dims[2]
            ));
        }
        // The Vec, not a slice: `Any` downcasts only sized types.
        #[allow(clippy::ptr_arg)]
        fn typed<T: 'static, U: 'static>(values: &Vec<U>) -> Option<&[T]> {
            let any: &dyn std::any::Any = values;
            any.downcast_ref::<Vec<T>>().map(Vec::as_slice)
        }
        let values: &[T] =
            with_voxel_slice!(data, values => typed::<T, _>(values)).ok_or_else(|| {
                format!(
                    "{} voxels given to a {} image",
                    data.voxel_type().name(),
                    T::TYPE.name()
                )
            })?;
        self.push_level(0, values)?;
        Ok(slices)
    }

    fn finish(&mut self) -> Result<Option<[f64; 2]>, Problem> {
        if self.finished {
            return Err("the window is already finished".into());
        }
        let first = &self.levels[0];
        let received = first.written + first.buffer.len() / first.plane();
        if received != first.dims[2] {
            return Err(format!(
                "{received} slices received for a depth of {}",
                first.dims[2]
            ));
        }
        // Flush level by level: each remainder feeds the next level's buffer.
        for index in 0..self.levels.len() {
            let rest = std::mem::take(&mut self.levels[index].buffer);
            if !rest.is_empty() {
                self.write_slab(index, &rest)?;
            }
        }
        self.finished = true;
        Ok(self.range)
    }
}
