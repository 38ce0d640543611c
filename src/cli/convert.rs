//! `voxscope convert IN OUT.ome.zarr`: any readable volume to a multiscale OME-Zarr image, its
//! values in the data's units (a stored value scale applied: [`SlabSource::value_scale`]).

use std::path::Path;
use std::time::Instant;

use clap::{Args, Subcommand, ValueEnum};

use voxscope_scene::ConvertOptions;
use voxscope_scene::option_text::{parse_bytes, parse_copies, parse_max_requests, parse_spacing};
use voxscope_volume::ome_zarr::{Compression, SlabSource, ZarrVersion};
use voxscope_volume::{RawLayout, format_dims};

/// `voxscope convert`: in one process, or as a plan, parts and a finalize step that a
/// scheduler runs (docs/cluster.md).
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct ConvertCommand {
    #[command(subcommand)]
    pub step: Option<ConvertStep>,
    #[command(flatten)]
    pub args: ConvertArgs,
}

/// The steps of a conversion that parts share.
#[derive(Debug, Subcommand)]
pub enum ConvertStep {
    /// Read the input's metadata, write the output's arrays and a plan of N parts
    /// (OUT/.voxscope/plan.json), and print N.
    Plan(Box<PlanArgs>),
    /// Write one part's shards at every level it builds (idempotent: a finished part returns
    /// at once). Its number comes from --part, else SLURM_ARRAY_TASK_ID or
    /// JOB_COMPLETION_INDEX.
    Run(RunArgs),
    /// Check every part, build the coarsest levels and write the image's metadata, last.
    Finalize(FinalizeArgs),
}

#[derive(Debug, Args)]
pub struct PlanArgs {
    #[command(flatten)]
    pub args: ConvertArgs,
    /// How many parts (separate processes, on any machines that share OUT) write the image.
    #[arg(long, value_name = "N")]
    pub parts: usize,
    /// The most a part's column slab holds (`256MiB`, `2GiB`); a part's peak memory is about
    /// twice this, and `finalize` keeps within it too.
    #[arg(long, value_name = "SIZE", default_value = "512MiB", value_parser = parse_bytes)]
    pub part_memory: u64,
}

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The output folder `convert plan` wrote.
    pub output: String,
    /// This part's number and the plan's part count, I/N (0 ≤ I < N).
    #[arg(long, value_name = "I/N", value_parser = parse_part)]
    pub part: Option<(usize, usize)>,
}

#[derive(Debug, Args)]
pub struct FinalizeArgs {
    /// The output folder whose parts have all run.
    pub output: String,
}

fn parse_part(text: &str) -> Result<(usize, usize), String> {
    let (i, n) = text
        .split_once('/')
        .ok_or_else(|| format!("{text}: write the part as I/N, e.g. 0/4"))?;
    let number = |t: &str| {
        t.trim()
            .parse::<usize>()
            .map_err(|_| format!("{text}: write the part as I/N, e.g. 0/4"))
    };
    let (i, n) = (number(i)?, number(n)?);
    if i >= n {
        return Err(format!(
            "{text}: the part's number is 0 to {}",
            n.saturating_sub(1)
        ));
    }
    Ok((i, n))
}

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// The volume to convert: any file or folder voxscope opens (raw with --raw), or a Zarr
    /// store's URL (http://, https://, s3://BUCKET/PATH).
    #[arg(required = true)]
    pub input: Option<String>,
    /// The folder to write (`NAME.ome.zarr`); it must not exist.
    #[arg(required = true)]
    pub output: Option<String>,
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

/// The part a scheduler gives this process: Slurm's array task id (`--array=0-N-1`, or any
/// of those resubmitted alone: the id is the part), or a Kubernetes Indexed Job's completion
/// index.
fn scheduled_part() -> Option<usize> {
    let number = |name: &str| std::env::var(name).ok()?.trim().parse::<usize>().ok();
    number("SLURM_ARRAY_TASK_ID").or_else(|| number("JOB_COMPLETION_INDEX"))
}

pub fn run(command: &ConvertCommand) -> Result<(), String> {
    match &command.step {
        None => run_whole(&command.args),
        Some(ConvertStep::Plan(plan)) => run_plan(&plan.args, plan.parts, plan.part_memory),
        Some(ConvertStep::Run(run)) => run_part(run),
        Some(ConvertStep::Finalize(finalize)) => {
            let started = Instant::now();
            let output = Path::new(&finalize.output);
            let levels = voxscope_scene::finalize(output, |message| eprint!("{message}"))
                .map_err(|e| e.to_string())?;
            outln!(
                "finalized {} ({}) in {:.2} s",
                finalize.output,
                shown_levels(&levels),
                started.elapsed().as_secs_f64()
            );
            Ok(())
        }
    }
}

fn shown_levels(levels: &[[usize; 3]]) -> String {
    let shown: Vec<String> = levels.iter().map(|d| format_dims(*d)).collect();
    format!("{} levels: {}", levels.len(), shown.join(", "))
}

/// The input and output of a whole conversion or a plan (clap requires both there).
fn paths(args: &ConvertArgs) -> Result<(&str, &str), String> {
    let (Some(input), Some(output)) = (args.input.as_deref(), args.output.as_deref()) else {
        return Err("convert needs an input and an output".to_owned());
    };
    if Path::new(input) == Path::new(output) {
        return Err(format!("{output}: the output is the input"));
    }
    Ok((input, output))
}

fn run_whole(args: &ConvertArgs) -> Result<(), String> {
    let (spec, output) = paths(args)?;
    let started = Instant::now();
    let options = args.options();
    let source = SlabSource::open(spec, &options.load_options()).map_err(|e| e.to_string())?;
    let levels = voxscope_scene::convert(source, spec, Path::new(output), &options, |message| {
        eprint!("{message}")
    })
    .map_err(|e| e.to_string())?;
    outln!(
        "wrote {output} ({}) in {:.2} s",
        shown_levels(&levels),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn run_plan(args: &ConvertArgs, parts: usize, part_memory: u64) -> Result<(), String> {
    let (spec, output) = paths(args)?;
    let options = args.options();
    let source = SlabSource::open(spec, &options.load_options()).map_err(|e| e.to_string())?;
    let (plan, _) = voxscope_scene::plan_conversion(
        source,
        spec,
        Path::new(output),
        &options,
        parts,
        Some(part_memory),
    )
    .map_err(|e| e.to_string())?;
    let columns = plan.columns();
    eprintln!(
        "planned {output}: {} parts over {} columns of {}x{} voxels, levels 0 to {} in the parts",
        plan.parts.len(),
        columns.count(),
        columns.side[0],
        columns.side[1],
        columns.levels - 1
    );
    outln!("{}", plan.parts.len());
    Ok(())
}

fn run_part(args: &RunArgs) -> Result<(), String> {
    let output = Path::new(&args.output);
    let (part, parts) = match args.part {
        Some((part, parts)) => (part, Some(parts)),
        None => (
            scheduled_part().ok_or_else(|| {
                format!(
                    "{}: which part? Give --part I/N, or run under a Slurm array (SLURM_ARRAY_TASK_ID) or a Kubernetes Indexed Job (JOB_COMPLETION_INDEX)",
                    args.output
                )
            })?,
            None,
        ),
    };
    let started = Instant::now();
    let outcome =
        voxscope_scene::run_part(output, part, parts, None, |message| eprint!("{message}"))
            .map_err(|e| e.to_string())?;
    match outcome {
        voxscope_scene::PartOutcome::AlreadyDone(marker) => outln!(
            "part {part}/{} of {} had finished: nothing to do",
            marker.parts,
            args.output
        ),
        voxscope_scene::PartOutcome::Written(marker) => {
            eprintln!();
            outln!(
                "part {part}/{} of {}: {} objects, {:.1} MB in, {:.1} MB out in {:.2} s{}",
                marker.parts,
                args.output,
                marker.objects.len(),
                marker.bytes_in as f64 / 1e6,
                marker.bytes_out as f64 / 1e6,
                started.elapsed().as_secs_f64(),
                marker
                    .peak_memory_bytes
                    .map(|b| format!(", peak memory {:.0} MB", b as f64 / 1e6))
                    .unwrap_or_default()
            )
        }
    }
    Ok(())
}
