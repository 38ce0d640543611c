//! Writing a multiscale OME-Zarr image slab by slab (`voxscope convert`): level 0 as given,
//! each coarser level by 2×2×2 mean (or max, for labels) of the one before, until the coarsest
//! fits one chunk. Only one slab (a chunk's or shard's depth of z slices) per level is held in
//! memory, so the output may be larger than RAM when the input can be read in slabs.
//!
//! Metadata is written as the OME-Zarr 0.4 (Zarr v2) or 0.5 (Zarr v3, sharded) specification
//! spells it; zarrs encodes and stores the chunks, a slab's chunks in parallel. Beside each
//! level, a small float64 array `ranges/N` holds every chunk's minimum and maximum (grid z,
//! y, x, then `[min, max]`; NaN where a chunk holds no number), named in the group's
//! `voxscope.chunk_ranges` attribute, so a reader knows which chunks a transfer function makes
//! empty before it reads them.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use rayon::prelude::*;
use serde_json::{Value, json};
use zarrs::array::{Array, ArraySubset, Element};
use zarrs::filesystem::FilesystemStore;

use super::super::error::{Problem, printable};
use super::super::io::io_reason;
use super::super::{Scalar, VoxelData, VoxelType, format_dims};
use crate::with_voxel_slice;
use documents::{
    ArraySpec, array_document, metadata_name, open_array, with_min_max_axis, write_json, zarr_types,
};
pub use options::{Compression, Downsampling, WriteOptions, ZarrVersion};

mod documents;
mod options;

/// Writes one image; feed it z slices in order with [`Self::push`], then [`Self::finish`].
pub struct PyramidWriter {
    inner: Box<dyn SlabSink>,
    root: PathBuf,
    received: usize,
    depth: usize,
}

impl std::fmt::Debug for PyramidWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PyramidWriter")
            .field("root", &self.root)
            .field("received", &self.received)
            .finish_non_exhaustive()
    }
}

/// The levels [`PyramidWriter`] writes for `dims` and `chunk`: halving (rounding up) until
/// every axis fits one chunk.
pub fn level_dims(dims: [usize; 3], chunk: usize) -> Vec<[usize; 3]> {
    let mut levels = vec![dims];
    while levels
        .last()
        .is_some_and(|d| d.iter().any(|&n| n > chunk.max(1)))
    {
        let last = levels[levels.len() - 1];
        levels.push(last.map(|n| n.div_ceil(2)));
    }
    levels
}

impl PyramidWriter {
    /// Creates the folder `root` (which must not exist) and the level arrays for a volume of
    /// `dims` voxels of `voxel_type`, spaced `spacing` (x, y, z).
    pub fn create(
        root: &Path,
        dims: [usize; 3],
        voxel_type: VoxelType,
        spacing: [f64; 3],
        options: &WriteOptions,
    ) -> Result<Self, Problem> {
        if !(options.chunk.is_power_of_two() && (8..=512).contains(&options.chunk)) {
            return Err(format!(
                "chunk size {} is not a power of two from 8 to 512",
                options.chunk
            ));
        }
        if !(1..=16).contains(&options.shard_chunks) {
            return Err(format!(
                "{} chunks per shard side is not 1 to 16",
                options.shard_chunks
            ));
        }
        if dims.contains(&0) {
            return Err(format!(
                "dimensions {} contain a zero extent",
                format_dims(dims)
            ));
        }
        if root.exists() {
            return Err(format!(
                "{} exists; convert writes a new folder",
                root.display()
            ));
        }
        fs::create_dir_all(root)
            .map_err(|e| format!("cannot create {}: {}", root.display(), io_reason(&e)))?;
        let store = Arc::new(
            FilesystemStore::new(root)
                .map_err(|e| format!("cannot open {}: {e}", root.display()))?,
        );
        let plan = Plan {
            root: root.to_path_buf(),
            dims,
            voxel_type,
            spacing,
            options: options.clone(),
        };
        macro_rules! typed {
            ($t:ty) => {
                Box::new(TypedWriter::<$t>::create(plan, store)?) as Box<dyn SlabSink>
            };
        }
        let inner = match voxel_type {
            VoxelType::U8 => typed!(u8),
            VoxelType::I8 => typed!(i8),
            VoxelType::U16 => typed!(u16),
            VoxelType::I16 => typed!(i16),
            VoxelType::U32 => typed!(u32),
            VoxelType::I32 => typed!(i32),
            VoxelType::F32 => typed!(f32),
            VoxelType::F64 => typed!(f64),
        };
        let depth = inner.slab_depth();
        Ok(Self {
            inner,
            root: root.to_path_buf(),
            received: 0,
            depth,
        })
    }

    /// How many z slices the writer takes at a time without copying more than it needs (a
    /// slab of level 0): feeding it this many at a time keeps memory at one slab.
    pub fn slab_depth(&self) -> usize {
        self.depth
    }

    /// Appends whole z slices: `data` holds `x * y * n` voxels of the volume's type.
    pub fn push(&mut self, data: &VoxelData) -> Result<(), Problem> {
        let slices = self.inner.push(data)?;
        self.received += slices;
        Ok(())
    }

    /// Slices received so far.
    pub fn slices_received(&self) -> usize {
        self.received
    }

    /// Writes what remains and the group's metadata (last, so an interrupted conversion
    /// leaves no image that claims to be complete). Returns the levels' dimensions.
    pub fn finish(mut self) -> Result<Vec<[usize; 3]>, Problem> {
        self.inner.finish()
    }
}

/// The type-erased writer behind [`PyramidWriter`].
trait SlabSink {
    fn slab_depth(&self) -> usize;
    fn push(&mut self, data: &VoxelData) -> Result<usize, Problem>;
    fn finish(&mut self) -> Result<Vec<[usize; 3]>, Problem>;
}

struct Plan {
    root: PathBuf,
    dims: [usize; 3],
    voxel_type: VoxelType,
    spacing: [f64; 3],
    options: WriteOptions,
}

/// One level: its array, its ranges array and the slab being filled.
struct Level<T> {
    dims: [usize; 3],
    array: Array<FilesystemStore>,
    ranges: Array<FilesystemStore>,
    /// Slices buffered, `dims[0] * dims[1]` voxels each.
    buffer: Vec<T>,
    /// Slices already written.
    written: usize,
}

struct TypedWriter<T> {
    plan: Plan,
    /// Slices per write (a chunk's depth, or a shard's).
    depth: usize,
    /// The chunk or shard side (what one `store_array_subset` writes).
    unit: usize,
    levels: Vec<Level<T>>,
    finished: bool,
}

/// Numbers the writer stores: voxscope's voxel types, as zarrs elements.
trait Voxel: Scalar + Element + PartialOrd + Default {}
impl<T: Scalar + Element + PartialOrd + Default> Voxel for T {}

impl<T: Voxel> TypedWriter<T> {
    fn create(plan: Plan, store: Arc<FilesystemStore>) -> Result<Self, Problem> {
        let options = &plan.options;
        let chunk = options.chunk;
        let sharded = options.version == ZarrVersion::V05;
        let unit = if sharded {
            chunk * options.shard_chunks
        } else {
            chunk
        };
        let names = zarr_types(plan.voxel_type);
        let size = plan.voxel_type.size();
        let all = level_dims(plan.dims, chunk);
        let mut levels = Vec::with_capacity(all.len());
        for (index, dims) in all.iter().enumerate() {
            let zyx = [dims[2], dims[1], dims[0]];
            // A shard never exceeds the level (its chunks are the grid's anyway).
            let shard = sharded.then(|| zyx.map(|n| unit.min(n.next_multiple_of(chunk))));
            let document = array_document(
                options.version,
                ArraySpec {
                    shape: zyx,
                    chunk: [chunk; 3],
                    shard,
                    type_names: names,
                    type_size: size,
                    compression: options.compression,
                    fill_value: json!(0),
                },
            );
            write_json(
                &plan
                    .root
                    .join(index.to_string())
                    .join(metadata_name(options.version)),
                &document,
            )?;
            let grid = zyx.map(|n| n.div_ceil(chunk));
            let slab_chunks = (unit / chunk).min(grid[0]);
            let ranges_document = array_document(
                options.version,
                ArraySpec {
                    shape: grid,
                    chunk: [slab_chunks, grid[1], grid[2]],
                    shard: None,
                    type_names: ("<f8", "float64"),
                    type_size: 8,
                    compression: Compression::Zstd,
                    fill_value: json!("NaN"),
                },
            );
            // v3 arrays are 4D here: z, y, x chunk index, then [min, max].
            let ranges_document = with_min_max_axis(ranges_document);
            write_json(
                &plan
                    .root
                    .join("ranges")
                    .join(index.to_string())
                    .join(metadata_name(options.version)),
                &ranges_document,
            )?;
            levels.push(Level {
                dims: *dims,
                array: open_array(&store, &index.to_string())?,
                ranges: open_array(&store, &format!("ranges/{index}"))?,
                buffer: Vec::new(),
                written: 0,
            });
        }
        match options.version {
            ZarrVersion::V04 => write_json(
                &plan.root.join("ranges/.zgroup"),
                &json!({"zarr_format": 2}),
            )?,
            ZarrVersion::V05 => write_json(
                &plan.root.join("ranges/zarr.json"),
                &json!({"zarr_format": 3, "node_type": "group", "attributes": {}}),
            )?,
        }
        Ok(Self {
            plan,
            depth: unit,
            unit,
            levels,
            finished: false,
        })
    }

    /// Appends `slices` to level `index`, writing every complete slab: whole slabs straight
    /// from `slices`, only a partial one copied into the level's buffer (a 4096² slab is
    /// 2 GiB of 16-bit voxels: copying it on one thread held 16 cores idle).
    fn push_level(&mut self, index: usize, slices: &[T]) -> Result<(), Problem> {
        let plane = self.levels[index].dims[0] * self.levels[index].dims[1];
        let slab_len = plane * self.depth;
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

    /// Writes one slab of level `index` (chunks in parallel), then hands its 2× reduction to
    /// the next level.
    fn write_slab(&mut self, index: usize, slab: &[T]) -> Result<(), Problem> {
        let level = &self.levels[index];
        let [nx, ny, _] = level.dims;
        let depth = slab.len() / (nx * ny);
        let z0 = level.written;
        let chunk = self.plan.options.chunk;
        let unit = self.unit;
        // The write units of this slab: (y, x) tiles of a chunk's or shard's side.
        let tiles: Vec<(usize, usize)> = (0..ny.div_ceil(unit))
            .flat_map(|ty| (0..nx.div_ceil(unit)).map(move |tx| (ty, tx)))
            .collect();
        let slab_ref = slab;
        let array = &level.array;
        // Per tile: the min/max of each chunk inside it, as (chunk index, min, max).
        let results: Vec<Result<Vec<ChunkRange>, Problem>> = tiles
            .par_iter()
            .map(|&(ty, tx)| {
                let (x0, y0) = (tx * unit, ty * unit);
                let (x1, y1) = ((x0 + unit).min(nx), (y0 + unit).min(ny));
                let (w, h) = (x1 - x0, y1 - y0);
                let mut block = Vec::with_capacity(w * h * depth);
                for z in 0..depth {
                    for y in y0..y1 {
                        let row = z * nx * ny + y * nx;
                        block.extend_from_slice(&slab_ref[row + x0..row + x1]);
                    }
                }
                let subset = ArraySubset::new_with_ranges(&[
                    z0 as u64..(z0 + depth) as u64,
                    y0 as u64..y1 as u64,
                    x0 as u64..x1 as u64,
                ]);
                let mut ranges = Vec::new();
                for cz in 0..depth.div_ceil(chunk) {
                    for cy in 0..h.div_ceil(chunk) {
                        for cx in 0..w.div_ceil(chunk) {
                            let mut low = f64::INFINITY;
                            let mut high = f64::NEG_INFINITY;
                            for z in cz * chunk..((cz + 1) * chunk).min(depth) {
                                for y in cy * chunk..((cy + 1) * chunk).min(h) {
                                    let row = (z * h + y) * w;
                                    for v in
                                        &block[row + cx * chunk..row + ((cx + 1) * chunk).min(w)]
                                    {
                                        let v = v.to_f64();
                                        if v.is_finite() {
                                            low = low.min(v);
                                            high = high.max(v);
                                        }
                                    }
                                }
                            }
                            let (low, high) = if low <= high {
                                (low, high)
                            } else {
                                (f64::NAN, f64::NAN)
                            };
                            ranges.push((
                                [(z0 / chunk) + cz, y0 / chunk + cy, x0 / chunk + cx],
                                low,
                                high,
                            ));
                        }
                    }
                }
                array.store_array_subset(&subset, block).map_err(|e| {
                    format!(
                        "cannot write level {index} at z {z0}: {}",
                        printable(&e.to_string())
                    )
                })?;
                Ok(ranges)
            })
            .collect();
        // The slab's row of the ranges grid.
        let grid = [nx.div_ceil(chunk), ny.div_ceil(chunk)];
        let rows = depth.div_ceil(chunk);
        let mut ranges = vec![f64::NAN; rows * grid[1] * grid[0] * 2];
        for result in results {
            for ([cz, cy, cx], low, high) in result? {
                let at = (((cz - z0 / chunk) * grid[1] + cy) * grid[0] + cx) * 2;
                ranges[at] = low;
                ranges[at + 1] = high;
            }
        }
        let subset = ArraySubset::new_with_ranges(&[
            (z0 / chunk) as u64..(z0 / chunk + rows) as u64,
            0..grid[1] as u64,
            0..grid[0] as u64,
            0..2,
        ]);
        level
            .ranges
            .store_array_subset(&subset, ranges)
            .map_err(|e| {
                format!(
                    "cannot write the chunk ranges of level {index}: {}",
                    printable(&e.to_string())
                )
            })?;
        self.levels[index].written += depth;
        if index + 1 < self.levels.len() {
            let reduced = reduce(slab, [nx, ny, depth], self.plan.options.downsampling);
            self.push_level(index + 1, &reduced)?;
        }
        Ok(())
    }

    fn write_group(&self) -> Result<(), Problem> {
        let options = &self.plan.options;
        let [sx, sy, sz] = self.plan.spacing;
        let axis = |name: &str| match &options.unit {
            Some(unit) => json!({"name": name, "type": "space", "unit": unit}),
            None => json!({"name": name, "type": "space"}),
        };
        let datasets: Vec<Value> = (0..self.levels.len())
            .map(|index| {
                let factor = (1u64 << index) as f64;
                let scale = [sz * factor, sy * factor, sx * factor];
                let shift = [sz, sy, sx].map(|s| s * (factor - 1.0) / 2.0);
                json!({
                    "path": index.to_string(),
                    "coordinateTransformations": [
                        {"type": "scale", "scale": scale},
                        {"type": "translation", "translation": shift}
                    ]
                })
            })
            .collect();
        let method = match options.downsampling {
            Downsampling::Mean => "mean",
            Downsampling::Max => "max",
        };
        let mut multiscale = json!({
            "name": options.name,
            "axes": [axis("z"), axis("y"), axis("x")],
            "datasets": datasets,
            "type": method,
            "metadata": {
                "description": format!("2x2x2 {method} of the level before; odd extents repeat their last voxel"),
                "method": "voxscope convert",
                "version": env!("CARGO_PKG_VERSION")
            }
        });
        let ranges = json!({
            "chunk_ranges": {
                "paths": (0..self.levels.len()).map(|i| format!("ranges/{i}")).collect::<Vec<_>>(),
                "layout": "float64 [chunk z, chunk y, chunk x, 2]: the chunk's smallest and largest finite value, NaN where it holds none",
                "chunk": options.chunk
            }
        });
        match options.version {
            ZarrVersion::V04 => {
                multiscale["version"] = json!("0.4");
                write_json(&self.plan.root.join(".zgroup"), &json!({"zarr_format": 2}))?;
                write_json(
                    &self.plan.root.join(".zattrs"),
                    &json!({"multiscales": [multiscale], "voxscope": ranges}),
                )
            }
            ZarrVersion::V05 => write_json(
                &self.plan.root.join("zarr.json"),
                &json!({
                    "zarr_format": 3,
                    "node_type": "group",
                    "attributes": {
                        "ome": {"version": "0.5", "multiscales": [multiscale]},
                        "voxscope": ranges
                    }
                }),
            ),
        }
    }
}

/// A chunk's grid index (z, y, x) and its smallest and largest finite value.
type ChunkRange = ([usize; 3], f64, f64);

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
        self.depth
    }

    fn push(&mut self, data: &VoxelData) -> Result<usize, Problem> {
        let plane = self.plan.dims[0] * self.plan.dims[1];
        let count = data.len();
        if !count.is_multiple_of(plane) {
            return Err(format!(
                "{count} voxels are not whole {}x{} slices",
                self.plan.dims[0], self.plan.dims[1]
            ));
        }
        let slices = count / plane;
        let pending = self.levels[0].written + self.levels[0].buffer.len() / plane;
        if pending + slices > self.plan.dims[2] {
            return Err(format!(
                "{} slices given for a depth of {}",
                pending + slices,
                self.plan.dims[2]
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

    fn finish(&mut self) -> Result<Vec<[usize; 3]>, Problem> {
        if self.finished {
            return Err("the image is already finished".into());
        }
        let plane = self.plan.dims[0] * self.plan.dims[1];
        let received = self.levels[0].written + self.levels[0].buffer.len() / plane;
        if received != self.plan.dims[2] {
            return Err(format!(
                "{received} slices received for a depth of {}",
                self.plan.dims[2]
            ));
        }
        // Flush level by level: each remainder feeds the next level's buffer.
        for index in 0..self.levels.len() {
            let rest = std::mem::take(&mut self.levels[index].buffer);
            if !rest.is_empty() {
                self.write_slab(index, &rest)?;
            }
        }
        self.write_group()?;
        self.finished = true;
        Ok(self.levels.iter().map(|l| l.dims).collect())
    }
}
