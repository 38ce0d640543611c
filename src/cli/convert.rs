//! `voxscope convert IN OUT.ome.zarr`: any readable volume to a multiscale OME-Zarr image, its
//! values in the data's units (a stored value scale applied: [`SlabSource::value_scale`]).

use std::path::Path;
use std::time::Instant;

use clap::{Args, ValueEnum};

use voxscope_scene::option_text::{parse_max_requests, parse_spacing};
use voxscope_volume::ome_zarr::{
    Compression, Downsampling, PyramidOptions, PyramidWriter, SlabSource, WriteOptions, ZarrVersion,
};
use voxscope_volume::remote::RemoteOptions;
use voxscope_volume::{LoadOptions, RawLayout, ValueScale, format_dims};

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// The volume to convert: any file or folder voxscope opens (raw with --raw), or a Zarr
    /// store's URL (http://, https://, s3://BUCKET/PATH).
    pub input: String,
    /// The folder to write (`NAME.ome.zarr`); it must not exist.
    pub output: String,
    /// Read INPUT as headerless voxels: XxYxZ:TYPE[:le|:be] (read in slabs, never whole).
    #[arg(long, value_name = "LAYOUT", value_parser = RawLayout::parse)]
    pub raw: Option<RawLayout>,
    /// Voxel size SX,SY,SZ (overrides the input's).
    #[arg(long, value_name = "SX,SY,SZ", value_parser = parse_spacing)]
    pub spacing: Option<[f64; 3]>,
    /// The channel of a multi-channel OME-Zarr input.
    #[arg(long, default_value_t = 0)]
    pub channel: usize,
    /// The time point of a time-lapse OME-Zarr input.
    #[arg(long, default_value_t = 0)]
    pub time: usize,
    /// The series of a bioformats2raw input to convert (0, 1, …); default: the first.
    #[arg(long, value_name = "N")]
    pub series: Option<u32>,
    /// A URL input: requests in flight at once, at most (1 to 1024).
    #[arg(long, value_name = "N", default_value_t = voxscope_volume::remote::DEFAULT_MAX_REQUESTS, value_parser = parse_max_requests)]
    pub max_requests: usize,
    /// OME-Zarr 0.4 (Zarr v2, a file per chunk) or 0.5 (Zarr v3, sharded).
    #[arg(long, value_enum, default_value_t = FormatArg::V04)]
    pub format: FormatArg,
    /// Chunk side in voxels: a power of two from 8 to 512.
    #[arg(long, default_value_t = 64)]
    pub chunk: usize,
    /// Chunks per shard side for --format 0.5 (a shard holds N³ chunks).
    #[arg(long, default_value_t = 2)]
    pub shard: usize,
    /// blosc-lz4, blosc-zstd, zstd, gzip or none.
    #[arg(long, default_value = "blosc-lz4", value_parser = Compression::parse)]
    pub compression: Compression,
    /// Label data: coarser levels take the maximum of each 2×2×2 block, not the mean.
    #[arg(long)]
    pub labels: bool,
    /// The spacing's unit in the metadata (millimeter, micrometer, …); default: the input's,
    /// if it says.
    #[arg(long)]
    pub unit: Option<String>,
    /// Repeat the input N times along each axis, or X, Y and Z times (large test volumes from
    /// real data; the input is held in memory, the output written slab by slab).
    #[arg(long, value_name = "N|X,Y,Z", value_parser = parse_copies)]
    pub tile: Option<[usize; 3]>,
    /// Interpolate the input (trilinear) onto a grid N times finer along each axis, or X, Y
    /// and Z times (large test volumes from real data that, unlike tiles, repeat nothing; the
    /// input is held in memory, the output written slab by slab). The spacing becomes as much
    /// finer. Not for labels (interpolation would invent ids).
    #[arg(long, value_name = "N|X,Y,Z", value_parser = parse_copies, conflicts_with_all = ["tile", "labels"])]
    pub upsample: Option<[usize; 3]>,
    /// With --upsample: add to each voxel a uniform value in ±NOISE (the data's units), fixed
    /// by the voxel's place, so that the finer grid is not smooth.
    #[arg(
        long,
        value_name = "NOISE",
        requires = "upsample",
        default_value_t = 0.0
    )]
    pub noise: f64,
}

/// `--format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    #[value(name = "0.4")]
    V04,
    #[value(name = "0.5")]
    V05,
}

pub fn run(args: &ConvertArgs) -> Result<(), String> {
    let spec = args.input.as_str();
    if Path::new(spec) == Path::new(&args.output) {
        return Err(format!("{}: the output is the input", args.output));
    }
    let started = Instant::now();
    let load_options = LoadOptions {
        raw: args.raw,
        spacing: args.spacing,
        select: PyramidOptions {
            channel: args.channel,
            time: args.time,
        },
        remote: RemoteOptions {
            max_requests: args.max_requests,
            ..Default::default()
        },
    };
    let source = SlabSource::open(spec, &load_options).map_err(|e| e.to_string())?;
    let levels = write(source, args, |message| eprint!("{message}"))?;
    let shown: Vec<String> = levels.iter().map(|d| format_dims(*d)).collect();
    println!(
        "wrote {} ({} levels: {}) in {:.2} s",
        args.output,
        levels.len(),
        shown.join(", "),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Writes `source` (a file opened for reading in slabs, or a volume in memory: the Python
/// module's arrays) as the OME-Zarr image `args` describe (`args.input` names it), saying
/// what it does and how far it is through `report`; returns the levels' dimensions.
pub fn write(
    mut source: SlabSource,
    args: &ConvertArgs,
    mut report: impl FnMut(&str),
) -> Result<Vec<[usize; 3]>, String> {
    let spec = args.input.as_str();
    let output = Path::new(&args.output);
    if let Some(copies) = args.tile {
        source = source.tiled(copies).map_err(|e| e.to_string())?;
    }
    if let Some(factor) = args.upsample {
        source = source
            .upsampled(factor, args.noise)
            .map_err(|e| e.to_string())?;
    }
    let options = WriteOptions {
        version: match args.format {
            FormatArg::V04 => ZarrVersion::V04,
            FormatArg::V05 => ZarrVersion::V05,
        },
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
    let mut writer = PyramidWriter::create(
        output,
        source.dims,
        source.voxel_type,
        source.spacing,
        &options,
    )
    .map_err(|p| format!("{}: {p}", args.output))?;
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
        match args.format {
            FormatArg::V04 => "0.4",
            FormatArg::V05 => "0.5",
        },
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
    let depth = source.dims[2];
    let slab = writer.slab_depth();
    let mut z = 0;
    while z < depth {
        let count = slab.min(depth - z);
        let data = source.read(z, count).map_err(|e| e.to_string())?;
        writer
            .push(&data)
            .map_err(|p| format!("{}: {p}", args.output))?;
        z += count;
        report(&format!(
            "\rconverting: {:3.0} %",
            100.0 * z as f64 / depth as f64
        ));
    }
    let levels = writer
        .finish()
        .map_err(|p| format!("{}: {p}", args.output))?;
    report("\rconverting: done \n");
    Ok(levels)
}

/// `--tile N` or `--tile X,Y,Z`.
fn parse_copies(text: &str) -> Result<[usize; 3], String> {
    let numbers: Vec<usize> = text
        .split(',')
        .map(|n| n.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{text}' is not N or X,Y,Z"))?;
    match numbers[..] {
        [n] => Ok([n; 3]),
        [x, y, z] => Ok([x, y, z]),
        _ => Err(format!("'{text}' is not N or X,Y,Z")),
    }
}
