//! Any readable volume to a multiscale OME-Zarr image ([`convert`]), its values in the data's
//! units (a stored value scale applied: [`SlabSource::value_scale`]), as [`ConvertOptions`]
//! say: the command line's `convert` and the Python module's `convert()` both map into them.

use std::path::Path;

use voxscope_volume::ome_zarr::{
    Compression, Downsampling, ImageLayout, SlabSource, WriteOptions, ZarrVersion, create_arrays,
};
use voxscope_volume::remote::RemoteOptions;
use voxscope_volume::{LoadOptions, RawLayout, Selection, ValueScale, format_dims};

use crate::SceneError;

mod finalize;
mod part;
mod plan;

pub use finalize::finalize;
pub use part::{PartMarker, PartOutcome, run_part};
pub use plan::{PART_SLAB_BYTES, PLAN_FOLDER, Plan, PlanOptions};

/// The most parts a conversion is cut into.
pub const MAX_PARTS: usize = 100_000;

/// A problem of the conversion into `output`, as its one line says it.
pub(super) fn failed(output: &Path, problem: impl std::fmt::Display) -> SceneError {
    SceneError::Failed(format!("{}: {problem}", output.display()))
}

/// `range` widened to hold `other`.
pub(super) fn widened(range: &mut Option<[f64; 2]>, [low, high]: [f64; 2]) {
    let merged = range.get_or_insert([low, high]);
    merged[0] = merged[0].min(low);
    merged[1] = merged[1].max(high);
}

/// Feeds `writer` the `depth` slices of its window that `read(z, n)` returns, a slab at a
/// time (`progress(z)` after each), and finishes it.
pub(super) fn write_column(
    output: &Path,
    mut writer: voxscope_volume::ome_zarr::WindowWriter,
    depth: usize,
    mut read: impl FnMut(usize, usize) -> Result<voxscope_volume::VoxelData, SceneError>,
    mut progress: impl FnMut(usize),
) -> Result<voxscope_volume::ome_zarr::WindowReport, SceneError> {
    let slab = writer.slab_depth();
    let mut z = 0;
    while z < depth {
        let n = slab.min(depth - z);
        let data = read(z, n)?;
        writer.push(&data).map_err(|p| failed(output, p))?;
        z += n;
        progress(z);
    }
    writer.finish().map_err(|p| failed(output, p))
}

/// How to read the input and write the OME-Zarr image.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertOptions {
    /// Read the input as headerless voxels of this layout (in slabs, never whole).
    pub raw: Option<RawLayout>,
    /// The voxel size, instead of the input's.
    pub spacing: Option<[f64; 3]>,
    /// The channel and time point of a multi-channel or time-lapse input.
    pub channel: usize,
    pub time: usize,
    /// A URL input: requests in flight at once, at most.
    pub max_requests: usize,
    /// OME-Zarr 0.4 (Zarr v2, a file per chunk) or 0.5 (Zarr v3, sharded).
    pub version: ZarrVersion,
    /// Chunk side in voxels, and chunks per shard side (0.5).
    pub chunk: usize,
    pub shard: usize,
    pub compression: Compression,
    /// Label data: coarser levels take the maximum of each 2×2×2 block, not the mean.
    pub labels: bool,
    /// The spacing's unit in the metadata (default: the input's, if it says).
    pub unit: Option<String>,
    /// Repeat the input this many times along x, y and z.
    pub tile: Option<[usize; 3]>,
    /// Interpolate the input onto a grid this many times finer along x, y and z, each voxel
    /// shifted by a uniform value in ±`noise`.
    pub upsample: Option<[usize; 3]>,
    pub noise: f64,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        Self {
            raw: None,
            spacing: None,
            channel: 0,
            time: 0,
            max_requests: voxscope_volume::remote::DEFAULT_MAX_REQUESTS,
            version: ZarrVersion::V04,
            chunk: 64,
            shard: 2,
            compression: Compression::BloscLz4,
            labels: false,
            unit: None,
            tile: None,
            upsample: None,
            noise: 0.0,
        }
    }
}

impl ConvertOptions {
    /// How the input is read.
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            raw: self.raw,
            spacing: self.spacing,
            select: Selection {
                channel: self.channel,
                time: self.time,
            },
            remote: RemoteOptions {
                max_requests: self.max_requests,
                ..Default::default()
            },
        }
    }
}

/// `source` with `--tile` and `--upsample` applied, as `args` ask.
pub(super) fn prepared(
    mut source: SlabSource,
    args: &ConvertOptions,
) -> Result<SlabSource, SceneError> {
    if let Some(copies) = args.tile {
        source = source.tiled(copies)?;
    }
    if let Some(factor) = args.upsample {
        source = source.upsampled(factor, args.noise)?;
    }
    Ok(source)
}

/// Plans the conversion of `source` (opened from `spec`; see [`convert`]) into `output` in
/// `parts` parts: writes the arrays' metadata and the plan (`.voxscope/plan.json`), and
/// returns the plan and the source, `--tile` and `--upsample` applied. `slab_bytes` bounds
/// a part's slab ([`PART_SLAB_BYTES`]); `None` writes one column of the whole plane.
pub fn plan_conversion(
    source: SlabSource,
    spec: &str,
    output: &Path,
    args: &ConvertOptions,
    parts: usize,
    slab_bytes: Option<u64>,
) -> Result<(Plan, SlabSource), SceneError> {
    let written = |p| SceneError::Failed(format!("{}: {p}", output.display()));
    if !(1..=MAX_PARTS).contains(&parts) {
        return Err(written(format!("--parts {parts}: from 1 to {MAX_PARTS}")));
    }
    let source = prepared(source, args)?;
    if parts > 1 && !source.reads_by_region() {
        return Err(SceneError::Failed(format!(
            "{}: this file is read whole, not by region, so each of {parts} parts would read all of it; convert it in one process (`voxscope convert IN OUT`), or to raw voxels first",
            source.name
        )));
    }
    let options = WriteOptions {
        version: args.version,
        chunk: args.chunk,
        shard_chunks: args.shard,
        compression: args.compression,
        downsampling: if args.labels {
            Downsampling::Max
        } else {
            Downsampling::Mean
        },
        name: Path::new(spec)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| spec.to_owned()),
        unit: args.unit.clone().or_else(|| source.unit.clone()),
    };
    let layout = ImageLayout::new(source.dims, source.voxel_type, source.spacing, &options)
        .map_err(written)?;
    let plan = Plan::new(spec, &source, args, &layout, parts, slab_bytes);
    create_arrays(output, &layout).map_err(written)?;
    plan.write(output)?;
    Ok((plan, source))
}

/// Writes `source` (a file opened for reading in slabs, or a volume in memory: the Python
/// module's arrays), which `spec` names, as the OME-Zarr image `options` describe at
/// `output`, saying what it does and how far it is through `report`; returns the levels'
/// dimensions. The three steps of a conversion in one process: [`plan_conversion`] of one
/// part over the whole plane, [`run_part`], [`finalize`].
pub fn convert(
    source: SlabSource,
    spec: &str,
    output: &Path,
    args: &ConvertOptions,
    mut report: impl FnMut(&str),
) -> Result<Vec<[usize; 3]>, SceneError> {
    let (_, source) = plan_conversion(source, spec, output, args, 1, None)?;
    report(&format!(
        "converting {} ({} {}, {}) to OME-Zarr {} in {}³ chunks\n",
        source.name,
        format_dims(source.dims),
        source.voxel_type.name(),
        if source.streams() {
            "read in slabs"
        } else {
            "loaded whole"
        },
        plan::version_name(args.version),
        args.chunk
    ));
    // Values stored with a scale (NIfTI scl_slope/scl_inter, DICOM rescale) are written in
    // the data's units: an OME-Zarr image has no such scale, and every reader would take the
    // stored integers for the values.
    if source.value_scale != ValueScale::IDENTITY {
        report(&format!(
            "values in the data's units: stored {} × {} + {} written as {}\n",
            source.stored_type.name(),
            source.value_scale.slope,
            source.value_scale.intercept,
            source.voxel_type.name()
        ));
    }
    run_part(output, 0, Some(1), Some(source), |progress| {
        report(&progress.replace("part 0/1", "converting"))
    })?;
    let levels = finalize(output, &mut report)?;
    report("\rconverting: done \n");
    Ok(levels)
}
