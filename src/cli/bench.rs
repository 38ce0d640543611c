//! `voxscope bench` on the command line: its flags, mapped into the bench crate's
//! [`BenchOptions`], and its reports printed (one JSON object with `--json`). The benchmarks
//! themselves are the voxscope-bench crate's.

use clap::Args;

use super::args::{RendererArg, scene_error_text};
use super::prepare::reporting_progress;
use super::stream::StreamArgs;
use super::{ClipArgs, VolumeArgs};
use voxscope_bench::{BenchError, BenchOptions, BenchVolume};
use voxscope_render::DEFAULT_BRICK_SIZE;
use voxscope_volume::ValueWindow;

#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// Image size WxH.
    #[arg(long, default_value = "1024x768", value_parser = voxscope_scene::option_text::parse_size)]
    pub size: (u32, u32),
    /// Timed frames per case; the azimuth sweeps a full turn over them.
    #[arg(long, default_value_t = 200)]
    pub frames: u32,
    /// The cameras' azimuth, degrees (0: from the front): each case's turn of the azimuth
    /// starts there; the streaming benchmark's views look from there and its orbits start
    /// there.
    #[arg(long, default_value_t = 30.0, allow_hyphen_values = true)]
    pub azimuth: f64,
    /// Binary threshold on the windowed value, 0…1.
    #[arg(long, default_value_t = 0.3)]
    pub threshold: f32,
    /// Value window LOW:HIGH (default: 0.5–99.5 percentiles).
    #[arg(long, value_name = "LOW:HIGH", allow_hyphen_values = true, value_parser = ValueWindow::parse)]
    pub window: Option<ValueWindow>,
    /// Global opacity scale.
    #[arg(long, default_value_t = 1.0)]
    pub density: f32,
    /// Max level of every case (default: the voxels): what each renderer draws there, the
    /// octree's nodes or a pyramid level (docs/octree.md, "Which renderer draws what").
    #[arg(long)]
    pub level: Option<u32>,
    /// Only this renderer (default: all).
    #[arg(long, value_enum)]
    pub renderer: Option<RendererArg>,
    /// Voxels along a brick's side (bricks renderer): 4, 8, 16 or 32.
    #[arg(long, default_value_t = DEFAULT_BRICK_SIZE, value_parser = voxscope_scene::option_text::parse_brick_size)]
    pub brick_size: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Every case drawn clipped.
    #[command(flatten)]
    pub clip: ClipArgs,
    /// Measure the streaming renderer instead (`--renderer stream` too): first image, frame
    /// times while streaming during orbits, time to complete a stopped view, bytes read against
    /// the view's floor, and resident frame time against the bricks renderer.
    #[arg(long)]
    pub stream: bool,
    #[command(flatten)]
    pub stream_options: StreamArgs,
    /// With --stream: draw the orbits' frames at most F a second, as a display does (60: a
    /// full turn of 200 frames in 3.3 s); 0 draws each as soon as the last is done.
    #[arg(long, value_name = "F", default_value_t = 0.0, value_parser = parse_orbit_fps, requires = "stream")]
    pub orbit_fps: f64,
    /// Also time the composite of channels: the volume as N channels (each a copy, its own
    /// table and color) for each N listed (1 to 8), DVR and MIP, renderer `composite`.
    #[arg(long, value_name = "N,…", value_delimiter = ',', value_parser = parse_channel_count)]
    pub composite_channels: Option<Vec<usize>>,
}

/// Frames a second for --orbit-fps: 0 (unpaced), or from 1 up to 1000.
fn parse_orbit_fps(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(fps) if fps == 0.0 || (1.0..=1000.0).contains(&fps) => Ok(fps),
        _ => Err(format!(
            "frame rate '{text}' is not 0 or a number from 1 to 1000"
        )),
    }
}

/// A channel count for --composite-channels: 1 to [`voxscope_volume::MAX_CHANNELS`].
fn parse_channel_count(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=voxscope_volume::MAX_CHANNELS).contains(&n) => Ok(n),
        _ => Err(format!(
            "channel count '{text}' is not 1 to {}",
            voxscope_volume::MAX_CHANNELS
        )),
    }
}

impl BenchArgs {
    /// Whether these options ask for the streaming renderer's benchmark
    /// ([`voxscope_bench::stream`]) rather than the in-memory renderers'.
    pub fn streams(&self) -> bool {
        self.stream || self.renderer == Some(RendererArg::Stream)
    }

    /// What these flags ask the benchmarks to measure.
    pub fn options(&self) -> BenchOptions {
        BenchOptions {
            open: self.volume.open_options(),
            size: self.size,
            frames: self.frames,
            azimuth: self.azimuth,
            threshold: self.threshold,
            window: self.window,
            density: self.density,
            level: self.level,
            renderer: self.renderer.map(Into::into),
            brick_size: self.brick_size,
            clip: self.clip.clip(),
            stream: self.stream_options.options(),
            orbit_fps: self.orbit_fps,
            composite_channels: self.composite_channels.clone().unwrap_or_default(),
        }
    }
}

/// `voxscope bench`: the streaming renderer's benchmark (pretty-printed JSON without
/// `--json`), else the in-memory renderers' (a table without `--json`).
pub fn run(args: &BenchArgs) -> Result<(), String> {
    let options = args.options();
    if args.streams() {
        let report = voxscope_bench::stream::run(&options).map_err(|e| error_text(&e))?;
        if args.json {
            outln!("{report}");
        } else {
            outln!(
                "{}",
                serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?
            );
        }
        return Ok(());
    }
    let volume = reporting_progress(|progress| BenchVolume::open(&options, progress))
        .map_err(|e| error_text(&e))?;
    let report = voxscope_bench::renderers::run(&options, &volume).map_err(|e| error_text(&e))?;
    if args.json {
        outln!("{}", report.json);
    } else {
        out!("{}", report.table());
    }
    Ok(())
}

/// A benchmark's error as the command line says it: a volume that does not open as every
/// command says it ([`scene_error_text`]), the rest as they display.
fn error_text(error: &BenchError) -> String {
    match error {
        BenchError::Open(error) => scene_error_text(error),
        error => error.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;
    use voxscope_bench::BenchOptions;

    use super::BenchArgs;

    #[derive(Debug, Parser)]
    struct Bench {
        #[command(flatten)]
        args: BenchArgs,
    }

    fn options(args: &[&str]) -> BenchOptions {
        let argv = ["bench", "synthetic:sphere:32"].iter().chain(args);
        Bench::try_parse_from(argv).expect("parses").args.options()
    }

    /// The bench crate's defaults are the command line's.
    #[test]
    fn no_flags_measure_as_the_bench_crate_defaults() {
        let parsed = options(&[]);
        assert_eq!(
            parsed,
            BenchOptions {
                open: parsed.open.clone(),
                ..BenchOptions::default()
            }
        );
    }

    /// `--azimuth` turns every camera, a negative angle too.
    #[test]
    fn the_azimuth_turns_the_cameras() {
        let parsed = options(&["--azimuth", "-150.5"]);
        assert_eq!(parsed.azimuth, -150.5);
        let camera = parsed.camera(3.0);
        assert_eq!((camera.azimuth_deg, camera.distance), (-150.5, 3.0));
        assert_eq!(
            camera.elevation_deg,
            BenchOptions::default().camera(3.0).elevation_deg
        );
    }
}
