//! The command line: `voxscope [FILE]` opens the app; `voxscope info`, `render`, `movie`,
//! `bench`, `ceilings`, `probe`, `slice` and `convert` work without a window.

/// `print!` to standard output where a reader that has gone (`voxscope info X | head`) ends
/// the process quietly, as Unix tools do, rather than in a panic.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::write_out(format_args!($($arg)*))
    };
}

/// `println!` as [`out!`] writes.
macro_rules! outln {
    () => {
        $crate::cli::write_out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::write_out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

mod args;
mod bench;
mod ceilings;
mod composite;
mod convert;
mod info;
mod labels;
mod movie;
mod prepare;
mod probe;
mod render;
mod render_options;
mod slice;
mod stream;
mod view;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

pub use args::{ChannelChoice, ClipArgs, RendererArg, TransferArgs, VolumeArgs, scene_error_text};
pub use composite::ChannelArgs;
pub use convert::{ConvertArgs, ConvertCommand};
pub use labels::LabelArgs;
pub use prepare::Prepared;
pub use render_options::RenderOptions;
pub use stream::StreamArgs;

/// voxscope: look inside volume data. A flat-list sparse octree, ray-cast on the GPU.
#[derive(Debug, Parser)]
#[command(name = "voxscope", version, about, long_about = None, args_conflicts_with_subcommands = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Volume to open in the app (any format `info` reads, a folder, or synthetic:KIND:SIZE).
    /// Without a command and a file, the app opens the built-in sample head MRI.
    pub file: Option<String>,
    /// A view file (RON, as File ▸ Save view… and `render --save-view` write it) to open the
    /// app on: its data, camera, transfer functions, settings, rulers and layout.
    #[arg(long, value_name = "V.ron", conflicts_with = "file")]
    pub view: Option<std::path::PathBuf>,
    /// The app's starting crop box and clip plane.
    #[command(flatten)]
    pub clip: ClipArgs,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print the volume (dimensions, type, spacing, values) and its octree, level by level.
    Info(Box<info::InfoArgs>),
    /// Render the volume to a PNG without a window.
    Render(Box<render::RenderArgs>),
    /// Write a movie: a turntable or a path through saved views, as GIF, WebP, APNG, MP4 or PNGs.
    Movie(Box<movie::MovieArgs>),
    /// Measure GPU time per frame (near, medium, far; gray, binary, MIP), build and recolor.
    Bench(bench::BenchArgs),
    /// Measure the GPU's own ceilings: memory bandwidth, filtered samples, fetch latencies, FMA.
    Ceilings(ceilings::CeilingsArgs),
    /// Print one voxel's value, position and unit (indices as the app and `slice` show them).
    Probe(probe::ProbeArgs),
    /// Write one slice of the volume to a PNG at one pixel per voxel, oriented as the app shows it.
    Slice(slice::SliceArgs),
    /// Write any readable volume as a multiscale OME-Zarr image (0.4, or 0.5 sharded).
    Convert(convert::ConvertCommand),
}

/// The exit code of `render` and `movie` when they wrote their output but some bricks a view
/// needed could not be read (drawn from a coarser level, listed on stderr) or were still coarse
/// when `--max-wait` ran out: not 0, so that scripts notice, and not 1 (an error: no output).
pub const EXIT_INCOMPLETE: u8 = 3;

/// The exit code of a render or movie that wrote its output: 0, or [`EXIT_INCOMPLETE`].
fn exit_code(rendered: render::Rendered) -> u8 {
    match rendered {
        render::Rendered::Complete => 0,
        render::Rendered::Incomplete => EXIT_INCOMPLETE,
    }
}

/// Runs the command line; returns the process exit code: 0, 1 for an error (printed as one
/// line), 2 for a usage error (clap's), [`EXIT_INCOMPLETE`] for an incomplete image.
pub fn run() -> std::process::ExitCode {
    match run_from(std::env::args_os()) {
        Ok(status) => std::process::ExitCode::from(status),
        Err(message) => {
            eprintln!("error: {message}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Runs the command line on `args` (the program's name first) and returns its exit status (0,
/// or [`EXIT_INCOMPLETE`]) or its one-line error: what `voxscope` does, for the Python
/// module's `python -m voxscope` and `view()`. Usage errors, `--help` and `--version` print
/// and exit the process, as clap does.
pub fn run_from<I, T>(args: I) -> Result<u8, String>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let matches = Cli::command().get_matches_from(args);
    let mut cli = Cli::from_arg_matches(&matches).unwrap_or_else(|error| error.exit());
    // The options given on the command line (beside a --view, they win over it).
    let given = |name: &str| view::Given::of(matches.subcommand_matches(name));
    let volume = match &mut cli.command {
        Some(Command::Info(args)) => Some(&mut args.volume),
        Some(Command::Render(args)) => Some(&mut args.volume),
        Some(Command::Movie(args)) => Some(&mut args.volume),
        Some(Command::Bench(args)) => Some(&mut args.volume),
        Some(Command::Probe(args)) => Some(&mut args.volume),
        Some(Command::Slice(args)) => Some(&mut args.volume),
        Some(Command::Ceilings(_) | Command::Convert(_)) | None => None,
    };
    if let Some(volume) = volume {
        volume.apply_field()?;
        volume.apply_series()?;
    }
    if let Some(Command::Convert(command)) = &mut cli.command {
        let args = match &mut command.step {
            None => Some(&mut command.args),
            Some(convert::ConvertStep::Plan(plan)) => Some(&mut plan.args),
            Some(_) => None,
        };
        if let Some(args) = args
            && let Some(series) = args.series.take()
            && let Some(input) = &mut args.input
        {
            *input = args::series_file(input, series);
        }
    }
    let ran = match cli.command {
        Some(Command::Info(args)) => info::run(&args),
        Some(Command::Movie(args)) => {
            return movie::run(&args, &given("movie")).map(exit_code);
        }
        Some(Command::Render(args)) => {
            return render::run(&args, &given("render")).map(exit_code);
        }
        Some(Command::Bench(args)) => bench::run(&args),
        Some(Command::Ceilings(args)) => ceilings::run(&args),
        Some(Command::Probe(args)) => probe::run(&args),
        Some(Command::Slice(args)) => slice::run(&args),
        Some(Command::Convert(args)) => convert::run(&args),
        None => crate::app::run(
            match cli.view {
                Some(view) => crate::app::Start::View(view),
                None => crate::app::Start::Open(cli.file.map(voxscope_scene::VolumeSource::Spec)),
            },
            cli.clip.clip(),
        ),
    };
    ran.map(|()| 0)
}

/// Writes `text` to standard output. A closed pipe ends the process with status 0 (its
/// reader has what it wanted); any other failure to write is reported once on stderr.
pub(crate) fn write_out(text: std::fmt::Arguments) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    if let Err(error) = stdout.write_fmt(text).and_then(|()| stdout.flush()) {
        if error.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to standard output: {error}");
        std::process::exit(1);
    }
}
