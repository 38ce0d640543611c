//! Writing a multiscale OME-Zarr image (`voxscope convert`): level 0 as given, each coarser
//! level by 2×2×2 mean (or max, for labels) of the one before, until the coarsest fits one
//! chunk. In three steps any process may run: [`create_arrays`] writes the arrays' metadata;
//! [`WindowWriter`]s fill columns of levels slab by slab (a conversion's parts: a column's
//! sides are whole shards at every level it writes, so no two write one object); and
//! [`write_group`] writes the group's metadata last, so that no reader sees an image before
//! it is complete. [`PyramidWriter`] is the three in one, over the whole plane.
//!
//! Metadata is written as the OME-Zarr 0.4 (Zarr v2) or 0.5 (Zarr v3, sharded) specification
//! spells it; zarrs encodes and stores the chunks, a slab's in parallel. Beside each level, a
//! small float64 array `ranges/N` holds every chunk's minimum and maximum (grid z, y, x, then
//! `[min, max]`; NaN where a chunk holds no number), named in the group's
//! `voxscope.chunk_ranges` attribute, so a reader knows which chunks a transfer function makes
//! empty before it reads them. Its chunks cover [`ImageLayout::tile`] voxels along x and y, the
//! same whichever columns wrote them: the bytes written do not depend on how many parts did.

use std::fs;
use std::path::Path;
use std::sync::Arc;

use serde_json::json;
use zarrs::array::{Array, ArraySubset};
use zarrs::filesystem::FilesystemStore;

use super::super::error::{Problem, printable};
use super::super::io::io_reason;
use super::super::{VoxelData, VoxelType, format_dims};
use documents::{
    ArraySpec, array_document, metadata_name, with_min_max_axis, write_json, zarr_types,
};
pub use group::{DisplayWindow, write_group};
pub use options::{Compression, Downsampling, WriteOptions, ZarrVersion};
pub use recorded::Written;
pub use window::{WindowReport, WindowWriter};

mod documents;
mod group;
mod options;
mod recorded;
mod window;

/// The levels an image of `dims` in `chunk`-sided chunks has: halving (rounding up) until
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

/// The image a conversion writes: level 0's voxels, their type and size, and how it is
/// stored; from these, every level and the columns parts of a conversion may own.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageLayout {
    /// Level 0's voxels along x, y, z.
    pub dims: [usize; 3],
    pub voxel_type: VoxelType,
    /// The voxel size along x, y, z.
    pub spacing: [f64; 3],
    pub options: WriteOptions,
}

/// A box of the x-y plane, all of z: level-0 voxels `origin .. origin + size` along x and y.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub origin: [usize; 2],
    pub size: [usize; 2],
}

impl Window {
    /// This window at `level` (whose voxels are `dims`): its first voxel and its size.
    fn at_level(self, level: usize, dims: [usize; 3]) -> ([usize; 2], [usize; 2]) {
        let origin = self.origin.map(|o| o >> level);
        let end: [usize; 2] = std::array::from_fn(|a| {
            (self.origin[a] + self.size[a])
                .div_ceil(1 << level)
                .min(dims[a])
        });
        (origin, [end[0] - origin[0], end[1] - origin[1]])
    }
}

/// How the x-y plane is cut into columns that parts write: `grid` columns of `side` level-0
/// voxels (the last ones cut by the image's edge), each written at levels `0..levels`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Columns {
    pub side: [usize; 2],
    pub grid: [usize; 2],
    pub levels: usize,
}

impl Columns {
    /// How many columns there are.
    pub fn count(&self) -> usize {
        self.grid[0] * self.grid[1]
    }

    /// Column `index` (row by row, x fastest) of a plane of `dims` voxels.
    pub fn window(&self, index: usize, dims: [usize; 3]) -> Window {
        let (cx, cy) = (index % self.grid[0], index / self.grid[0]);
        let origin = [cx * self.side[0], cy * self.side[1]];
        Window {
            origin,
            size: std::array::from_fn(|a| self.side[a].min(dims[a] - origin[a])),
        }
    }
}

impl ImageLayout {
    /// Checks the options against the image.
    pub fn new(
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
        Ok(Self {
            dims,
            voxel_type,
            spacing,
            options: options.clone(),
        })
    }

    /// Every level's voxels along x, y, z.
    pub fn levels(&self) -> Vec<[usize; 3]> {
        level_dims(self.dims, self.options.chunk)
    }

    /// The side of what one write stores whole: a shard (0.5) or a chunk (0.4); also the
    /// depth of a slab.
    pub fn unit(&self) -> usize {
        match self.options.version {
            ZarrVersion::V04 => self.options.chunk,
            ZarrVersion::V05 => self.options.chunk * self.options.shard_chunks,
        }
    }

    /// The side, in voxels of any level, of a chunk of the chunk-ranges arrays along x and y:
    /// whole write units, at least 8 chunks.
    pub fn tile(&self) -> usize {
        let per_unit = self.unit() / self.options.chunk;
        per_unit * 8usize.div_ceil(per_unit) * self.options.chunk
    }

    /// The columns for `parts` parts: each column's slab of level 0 (a unit deep) within
    /// `slab_bytes` where the tiles allow, as wide as that lets it, and at least `parts`
    /// columns where the plane has as many tiles; one column of the whole plane, holding
    /// every level, where `slab_bytes` is `None` or that column fits it.
    pub fn columns(&self, parts: usize, slab_bytes: Option<u64>) -> Columns {
        self.columns_at(0, parts, slab_bytes, 1)
    }

    /// [`Self::columns`] of level `level`'s plane (sides in its voxels; `levels` counts
    /// `level` itself), each holding at least `least_levels` levels where the image has them.
    pub fn columns_at(
        &self,
        level: usize,
        parts: usize,
        slab_bytes: Option<u64>,
        least_levels: usize,
    ) -> Columns {
        let all = self.levels();
        let count = all.len() - level.min(all.len() - 1);
        let [nx, ny, nz] = all[level.min(all.len() - 1)];
        let whole = Columns {
            side: [nx, ny],
            grid: [1, 1],
            levels: count,
        };
        let slab = |side: [usize; 2]| {
            (side[0] as u64 * side[1] as u64)
                .saturating_mul((self.unit().min(nz) * self.voxel_type.size()) as u64)
        };
        let Some(budget) = slab_bytes else {
            return whole;
        };
        if parts <= 1 && slab([nx, ny]) <= budget {
            return whole;
        }
        let tile = self.tile();
        let grid = |side: usize| [nx.div_ceil(side), ny.div_ceil(side)];
        let least = least_levels.clamp(1, count) - 1;
        let mut k = least;
        while k + 1 < count && slab([tile << (k + 1); 2]) <= budget {
            k += 1;
        }
        while k > least && grid(tile << k).iter().product::<usize>() < parts {
            k -= 1;
        }
        let side = tile << k;
        if grid(side) == [1, 1] {
            return whole;
        }
        Columns {
            side: [side; 2],
            grid: grid(side),
            levels: k + 1,
        }
    }
}

/// Creates the folder `root` (which must not exist) and the arrays of every level and their
/// chunk ranges, empty: what the parts of a conversion fill.
pub fn create_arrays(root: &Path, layout: &ImageLayout) -> Result<(), Problem> {
    let options = &layout.options;
    if root.exists() {
        return Err(format!(
            "{} exists; convert writes a new folder",
            root.display()
        ));
    }
    fs::create_dir_all(root)
        .map_err(|e| format!("cannot create {}: {}", root.display(), io_reason(&e)))?;
    let chunk = options.chunk;
    let unit = layout.unit();
    let sharded = options.version == ZarrVersion::V05;
    let tile_chunks = layout.tile() / chunk;
    for (index, dims) in layout.levels().iter().enumerate() {
        let zyx = [dims[2], dims[1], dims[0]];
        // A shard never exceeds the level (its chunks are the grid's anyway).
        let shard = sharded.then(|| zyx.map(|n| unit.min(n.next_multiple_of(chunk))));
        let document = array_document(
            options.version,
            ArraySpec {
                shape: zyx,
                chunk: [chunk; 3],
                shard,
                type_names: zarr_types(layout.voxel_type),
                type_size: layout.voxel_type.size(),
                compression: options.compression,
                fill_value: json!(0),
            },
        );
        write_json(
            &root
                .join(index.to_string())
                .join(metadata_name(options.version)),
            &document,
        )?;
        let grid = zyx.map(|n| n.div_ceil(chunk));
        let ranges_document = array_document(
            options.version,
            ArraySpec {
                shape: grid,
                chunk: [
                    (unit / chunk).min(grid[0]),
                    tile_chunks.min(grid[1]),
                    tile_chunks.min(grid[2]),
                ],
                shard: None,
                type_names: ("<f8", "float64"),
                type_size: 8,
                compression: Compression::Zstd,
                fill_value: json!("NaN"),
            },
        );
        // v3 arrays are 4D here: z, y, x chunk index, then [min, max].
        write_json(
            &root
                .join("ranges")
                .join(index.to_string())
                .join(metadata_name(options.version)),
            &with_min_max_axis(ranges_document),
        )?;
    }
    match options.version {
        ZarrVersion::V04 => write_json(&root.join("ranges/.zgroup"), &json!({"zarr_format": 2})),
        ZarrVersion::V05 => write_json(
            &root.join("ranges/zarr.json"),
            &json!({"zarr_format": 3, "node_type": "group", "attributes": {}}),
        ),
    }
}

/// The box `origin .. origin + size` (x, y, z) of level `level` of the image at `root`
/// (written by these writers for `layout`), x fastest: what `finalize` builds the coarsest
/// levels from.
pub fn read_level(
    root: &Path,
    layout: &ImageLayout,
    level: usize,
    origin: [usize; 3],
    size: [usize; 3],
) -> Result<VoxelData, Problem> {
    let levels = layout.levels();
    let read = |e: &dyn std::fmt::Display| {
        format!(
            "cannot read level {level} back: {}",
            printable(&e.to_string())
        )
    };
    let dims = *levels
        .get(level)
        .ok_or_else(|| format!("no level {level} of {}", levels.len()))?;
    if (0..3).any(|a| origin[a] + size[a] > dims[a]) {
        return Err(format!(
            "the box {} at {} lies outside level {level} ({})",
            format_dims(size),
            format_dims(origin),
            format_dims(dims)
        ));
    }
    let store = Arc::new(
        FilesystemStore::new(root).map_err(|e| format!("cannot open {}: {e}", root.display()))?,
    );
    let array = Array::open(store, &format!("/{level}")).map_err(|e| read(&e))?;
    let range = |a: usize| origin[a] as u64..(origin[a] + size[a]) as u64;
    let subset = ArraySubset::new_with_ranges(&[range(2), range(1), range(0)]);
    macro_rules! typed {
        ($variant:ident) => {
            array
                .retrieve_array_subset(&subset)
                .map(VoxelData::$variant)
                .map_err(|e| read(&e))
        };
    }
    match layout.voxel_type {
        VoxelType::U8 => typed!(U8),
        VoxelType::I8 => typed!(I8),
        VoxelType::U16 => typed!(U16),
        VoxelType::I16 => typed!(I16),
        VoxelType::U32 => typed!(U32),
        VoxelType::I32 => typed!(I32),
        VoxelType::F32 => typed!(F32),
        VoxelType::F64 => typed!(F64),
    }
}

/// The most voxels [`display_window`] reads for the window's percentiles.
const WINDOW_SAMPLE_VOXELS: usize = 1 << 22;

/// The display window of the image at `root` whose values span `range`: `range`, and the
/// 0.5 and 99.5 percentiles of the finest level of at most [`WINDOW_SAMPLE_VOXELS`] voxels
/// (what a viewer opens with), where they differ.
pub fn display_window(
    root: &Path,
    layout: &ImageLayout,
    range: Option<[f64; 2]>,
) -> Result<Option<DisplayWindow>, Problem> {
    let Some(range) = range else {
        return Ok(None);
    };
    let levels = layout.levels();
    let level = levels
        .iter()
        .position(|d| d.iter().product::<usize>() <= WINDOW_SAMPLE_VOXELS)
        .unwrap_or(levels.len() - 1);
    let values = read_level(root, layout, level, [0; 3], levels[level])?;
    let mut finite: Vec<f64> = (0..values.len())
        .filter_map(|i| values.get(i))
        .filter(|v| v.is_finite())
        .collect();
    let mut percentile = |p: f64| {
        if finite.is_empty() {
            return None;
        }
        let at = ((finite.len() - 1) as f64 * p / 100.0).round() as usize;
        let (_, v, _) = finite.select_nth_unstable_by(at, f64::total_cmp);
        Some(*v)
    };
    let window = match (percentile(0.5), percentile(99.5)) {
        (Some(low), Some(high)) if high > low => [low, high],
        _ => range,
    };
    Ok(Some(DisplayWindow { range, window }))
}

/// Writes one image in one process: [`create_arrays`], one [`WindowWriter`] over the whole
/// plane and every level, then [`write_group`]. Feed it z slices in order with
/// [`Self::push`], then [`Self::finish`].
#[derive(Debug)]
pub struct PyramidWriter {
    layout: ImageLayout,
    writer: WindowWriter,
    root: std::path::PathBuf,
    received: usize,
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
        let layout = ImageLayout::new(dims, voxel_type, spacing, options)?;
        create_arrays(root, &layout)?;
        let whole = Window {
            origin: [0, 0],
            size: [dims[0], dims[1]],
        };
        let last = layout.levels().len() - 1;
        let writer = WindowWriter::open(root, &layout, whole, 0, last, true)?;
        Ok(Self {
            layout,
            writer,
            root: root.to_path_buf(),
            received: 0,
        })
    }

    /// How many z slices the writer takes at a time without copying more than it needs (a
    /// slab of level 0): feeding it this many at a time keeps memory at one slab.
    pub fn slab_depth(&self) -> usize {
        self.writer.slab_depth()
    }

    /// Appends whole z slices: `data` holds `x * y * n` voxels of the volume's type.
    pub fn push(&mut self, data: &VoxelData) -> Result<(), Problem> {
        self.writer.push(data)?;
        self.received += data.len() / (self.layout.dims[0] * self.layout.dims[1]);
        Ok(())
    }

    /// Slices received so far.
    pub fn slices_received(&self) -> usize {
        self.received
    }

    /// Writes what remains and the group's metadata (last, so an interrupted conversion
    /// leaves no image that claims to be complete). Returns the levels' dimensions.
    pub fn finish(self) -> Result<Vec<[usize; 3]>, Problem> {
        let report = self.writer.finish()?;
        let display = display_window(&self.root, &self.layout, report.range)?;
        write_group(&self.root, &self.layout, display)?;
        Ok(self.layout.levels())
    }
}
