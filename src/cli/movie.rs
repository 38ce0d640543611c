//! `voxscope movie`: a turntable or a path through keyframe views, drawn frame by frame on the
//! GPU (each frame complete before it is written) into a GIF, WebP, APNG, MP4 or a folder of
//! numbered PNGs.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;

use super::view::{self, Given};
use super::{RenderOptions, VolumeArgs};
use crate::movie_writer::MovieFormat;
use voxscope_render::{RenderTarget, read_image};
use voxscope_scene::{
    ChannelRequest, ChannelState, DrawOptions, Drawable, OpenOptions, SavedView, Shot,
    keyframe_channels, keyframe_path, turntable,
};

/// Frames of a turntable without `--frames`.
const TURNTABLE_FRAMES: u32 = 120;
/// Frames per keyframe segment without `--frames`.
const SEGMENT_FRAMES: u32 = 60;

#[derive(Debug, Args)]
pub struct MovieArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    #[command(flatten)]
    pub options: RenderOptions,
    /// A view saved by `render --save-view` to start from (the options given beside it win).
    #[arg(long, value_name = "V.ron", conflicts_with = "keyframes")]
    pub view: Option<PathBuf>,
    /// A full turn about the vertical axis in --frames frames (default 120).
    #[arg(
        long,
        conflicts_with = "keyframes",
        required_unless_present = "keyframes"
    )]
    pub turntable: bool,
    /// Views saved by `render --save-view`, A.ron,B.ron,…: the camera moves on its orbit
    /// through them (azimuth, elevation, distance), window, transfer function, clip and level
    /// follow; --frames frames per segment (default 60).
    #[arg(long, value_name = "A.ron,B.ron,…", value_delimiter = ',', num_args = 1..)]
    pub keyframes: Option<Vec<PathBuf>>,
    /// Frames of the turn, or per segment between two keyframes.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub frames: Option<u32>,
    /// Frames per second of the movie.
    #[arg(long, default_value_t = 30.0, value_parser = parse_fps)]
    pub fps: f64,
    /// Output: .gif, .webp, .png (animated PNG), .mp4 (H.264, needs ffmpeg on the PATH), or
    /// a folder (numbered PNGs).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
}

fn parse_fps(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(fps) if fps.is_finite() && (0.1..=1000.0).contains(&fps) => Ok(fps),
        _ => Err(format!("'{text}' is not a frame rate from 0.1 to 1000")),
    }
}

/// Time spent per stage over the movie.
#[derive(Default)]
struct StageTimes {
    render: Duration,
    readback: Duration,
    encode: Duration,
}

pub fn run(args: &MovieArgs, given: &Given) -> Result<super::render::Rendered, String> {
    let started = Instant::now();
    let format = MovieFormat::of(&args.output)?;
    let keyframes = read_keyframes(args)?;
    let start_view = match (&args.view, keyframes.first()) {
        (Some(path), _) => Some((
            path.clone(),
            SavedView::read(path).map_err(|e| e.to_string())?,
        )),
        (None, Some(first)) => Some(first.clone()),
        (None, None) => None,
    };
    let (open, draw) = match &start_view {
        Some((path, saved)) => under_options(args, given, path, saved)?,
        None => (args.volume.open_options(), args.options.draw_options()),
    };
    args.options.check()?;
    let mut drawing = super::render::open_drawable(&open, &draw)?;
    // The composite's channels per frame, each channel's color and window following the
    // keyframes (empty for one volume).
    let channel_frames = match drawing.channels() {
        Some(channels) if keyframes.len() > 1 => {
            let keys: Vec<Vec<ChannelState>> = keyframes
                .iter()
                .map(|(path, saved)| {
                    under_options(args, given, path, saved)
                        .map(|(_, key)| key_channels(channels, &key.channels))
                })
                .collect::<Result<_, String>>()?;
            keyframe_channels(&keys, args.frames.unwrap_or(SEGMENT_FRAMES) as usize)
        }
        _ => Vec::new(),
    };
    let shots = if keyframes.is_empty() {
        let first = Shot {
            camera: draw.camera,
            settings: drawing.render_settings(&draw),
            transfer: drawing.transfer(),
        };
        turntable(&first, args.frames.unwrap_or(TURNTABLE_FRAMES) as usize)
    } else {
        let keys = keyframes
            .iter()
            .map(|(path, saved)| key_shot(args, given, &drawing, path, saved))
            .collect::<Result<Vec<Shot>, String>>()?;
        keyframe_path(&keys, args.frames.unwrap_or(SEGMENT_FRAMES) as usize)
    };
    let size = draw.size;
    let mut writer = format.create(&args.output, size, args.fps, shots.len())?;
    let target = RenderTarget::new(drawing.context(), size.0, size.1);
    let mut times = StageTimes::default();
    let mut coarse_frames = 0;
    let mut unreadable_frames = 0;
    let drawing_started = Instant::now();
    // An error ends the progress line before it is said.
    let ended = |error: String| {
        eprintln!();
        error
    };
    // A frame that fails leaves no half-written movie.
    let mut draw_frames = || -> Result<(), String> {
        for (index, shot) in shots.iter().enumerate() {
            let frame_started = Instant::now();
            drawing
                .set_transfer(&shot.transfer)
                .map_err(|e| ended(e.to_string()))?;
            if let Some(channels) = channel_frames.get(index) {
                drawing.set_channels(channels);
            }
            let drawn = drawing
                .draw_complete(&target, &shot.camera, &shot.settings, draw.max_wait)
                .map_err(|e| ended(e.to_string()))?;
            if drawn.is_none() {
                // The frame's render time is the GPU's, not its submission's.
                drawing
                    .context()
                    .wait_idle()
                    .map_err(|e| ended(e.to_string()))?;
            }
            if let Some(refinement) = drawn {
                coarse_frames += usize::from(!refinement.complete);
                unreadable_frames += usize::from(!refinement.unreadable.is_empty());
            }
            let rendered = Instant::now();
            let mut image =
                read_image(drawing.context(), &target).map_err(|e| ended(e.to_string()))?;
            drawing
                .draw_labels_over(&mut image, None, &shot.camera, &shot.settings)
                .map_err(|e| ended(e.to_string()))?;
            let read = Instant::now();
            writer.add(&image).map_err(ended)?;
            let encoded = Instant::now();
            times.render += rendered - frame_started;
            times.readback += read - rendered;
            times.encode += encoded - read;
            let done = index + 1;
            let rate = done as f64 / drawing_started.elapsed().as_secs_f64().max(1e-9);
            let bar_width = 30;
            let filled = done * bar_width / shots.len();
            eprint!(
                "\r[{}{}] frame {done}/{} ({rate:.1} frames/s)",
                "#".repeat(filled),
                " ".repeat(bar_width - filled),
                shots.len()
            );
            let _ = std::io::stderr().flush();
        }
        Ok(())
    };
    if let Err(error) = draw_frames() {
        writer.abandon();
        return Err(error);
    }
    eprintln!();
    let finish_started = Instant::now();
    writer.finish()?;
    times.encode += finish_started.elapsed();
    let frames = shots.len();
    let per_frame = |d: Duration| d.as_secs_f64() * 1000.0 / frames as f64;
    let written_rate = frames as f64 / drawing_started.elapsed().as_secs_f64().max(1e-9);
    let what = match drawing.channels() {
        Some(channels) => format!("composite of {} channels", channels.len()),
        None => format!("{} renderer", drawing.renderer().kind().name()),
    };
    let mut incomplete = Vec::new();
    if coarse_frames > 0 {
        incomplete.push(format!(
            "{coarse_frames} frames still coarse after --max-wait"
        ));
    }
    if unreadable_frames > 0 {
        incomplete.push(format!(
            "{unreadable_frames} frames drawn with unreadable bricks from coarser levels"
        ));
    }
    let notes = if incomplete.is_empty() {
        String::new()
    } else {
        format!("; incomplete: {}", incomplete.join(", "))
    };
    eprintln!(
        "wrote {} ({frames} frames, {}x{}, {} fps, {what}) on {} in {:.2} s: {written_rate:.1} frames/s written; per frame: render {:.1} ms, readback {:.1} ms, encode {:.1} ms{notes}",
        args.output.display(),
        size.0,
        size.1,
        args.fps,
        drawing.context().describe(),
        started.elapsed().as_secs_f64(),
        per_frame(times.render),
        per_frame(times.readback),
        per_frame(times.encode),
    );
    // Frames still coarse or drawn around unreadable bricks: the movie is incomplete, and the
    // exit code says so as `render`'s does.
    Ok(if coarse_frames + unreadable_frames > 0 {
        super::render::Rendered::Incomplete
    } else {
        super::render::Rendered::Complete
    })
}

/// The `--keyframes` views, read and checked: two or more, all of one volume.
fn read_keyframes(args: &MovieArgs) -> Result<Vec<(PathBuf, SavedView)>, String> {
    let Some(paths) = &args.keyframes else {
        return Ok(Vec::new());
    };
    if paths.len() < 2 {
        return Err(format!(
            "--keyframes needs two views or more (a movie from one view: --view {} --turntable)",
            paths
                .first()
                .map_or(String::new(), |p| p.display().to_string())
        ));
    }
    let views = paths
        .iter()
        .map(|path| {
            SavedView::read(path)
                .map(|view| (path.clone(), view))
                .map_err(|e| e.to_string())
        })
        .collect::<Result<Vec<_>, String>>()?;
    let (first_path, first) = &views[0];
    for (path, view) in &views[1..] {
        if !view.same_data(first) {
            return Err(format!(
                "{}: shows other data than {} (the keyframes of a movie show one volume)",
                path.display(),
                first_path.display()
            ));
        }
    }
    Ok(views)
}

/// The options keyframe (or start view) `saved`, read from `path`, holds under the options
/// `given` beside it.
fn under_options(
    args: &MovieArgs,
    given: &Given,
    path: &Path,
    saved: &SavedView,
) -> Result<(OpenOptions, DrawOptions), String> {
    let flags = (args.volume.open_options(), args.options.draw_options());
    view::under_options(saved, path, (&flags.0, &flags.1), given)
}

/// The composite's channels a keyframe shows: `opened`'s (as the first keyframe and the
/// options opened them) with the colors, windows and visibility `asked` (a keyframe's under
/// the options beside it); a view of more channels than these: `opened`'s.
fn key_channels(opened: &[ChannelState], asked: &ChannelRequest) -> Vec<ChannelState> {
    let mut channels = opened.to_vec();
    if asked.colors.len() <= channels.len() {
        asked.apply_to(&mut channels);
    }
    channels
}

/// What keyframe `saved` shows, under the options given beside it: its camera, its settings
/// for the drawing's volume, and its transfer function (the drawing's where it holds none or
/// the options choose the opacity).
fn key_shot(
    args: &MovieArgs,
    given: &Given,
    drawing: &Drawable,
    path: &Path,
    saved: &SavedView,
) -> Result<Shot, String> {
    let (_, draw) = under_options(args, given, path, saved)?;
    let transfer_saved = draw.transfer.saved().map_err(|e| e.to_string())?;
    Ok(Shot {
        camera: draw.camera,
        settings: draw.render_settings(drawing.depth(), transfer_saved.as_ref()),
        transfer: draw
            .transfer
            .saved_function()
            .unwrap_or_else(|| drawing.transfer()),
    })
}
