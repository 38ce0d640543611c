//! `voxscope convert IN OUT.ome.zarr`: any readable volume to a multiscale OME-Zarr image, its
//! values in the data's units (a stored value scale applied: [`SlabSource::value_scale`]).

use std::path::Path;
use std::time::Instant;

use clap::{Args, ValueEnum};

use voxscope_scene::ConvertOptions;
use voxscope_scene::option_text::{parse_copies, parse_max_requests, parse_spacing};
use voxscope_volume::ome_zarr::{Compression, SlabSource, ZarrVersion};
use voxscope_volume::{RawLayout, format_dims};

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

impl ConvertArgs {
    /// These options as the scene layer converts with them.
    pub fn options(&self) -> ConvertOptions {
        ConvertOptions {
            raw: self.raw,
            spacing: self.spacing,
            channel: self.channel,
            time: self.time,
            max_requests: self.max_requests,
            version: match self.format {
                FormatArg::V04 => ZarrVersion::V04,
                FormatArg::V05 => ZarrVersion::V05,
            },
            chunk: self.chunk,
            shard: self.shard,
            compression: self.compression,
            labels: self.labels,
            unit: self.unit.clone(),
            tile: self.tile,
            upsample: self.upsample,
            noise: self.noise,
        }
    }
}

pub fn run(args: &ConvertArgs) -> Result<(), String> {
    let spec = args.input.as_str();
    if Path::new(spec) == Path::new(&args.output) {
        return Err(format!("{}: the output is the input", args.output));
    }
    let started = Instant::now();
    let options = args.options();
    let source = SlabSource::open(spec, &options.load_options()).map_err(|e| e.to_string())?;
    let levels =
        voxscope_scene::convert(source, spec, Path::new(&args.output), &options, |message| {
            eprint!("{message}")
        })
        .map_err(|e| e.to_string())?;
    let shown: Vec<String> = levels.iter().map(|d| format_dims(*d)).collect();
    outln!(
        "wrote {} ({} levels: {}) in {:.2} s",
        args.output,
        levels.len(),
        shown.join(", "),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
