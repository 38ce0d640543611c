//! `voxscope movie`: a turntable or a path through keyframe views, drawn frame by frame on the
//! GPU (each frame complete before it is written) into a GIF, WebP, APNG, MP4 or a folder of
//! numbered PNGs.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;

use super::view::{self, Given};
use super::{RenderOptions, VolumeArgs};
use crate::movie_writer::{MovieFormat, MovieWriter};
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

/// What drawing the movie's frames came to.
struct FrameTally {
    /// When the first frame began.
    drawing_started: Instant,
    /// Frames drawn and written.
    frames: usize,
    times: StageTimes,
    /// Frames still coarse at `--max-wait`.
    coarse_frames: usize,
    /// Frames drawn around unreadable bricks, from coarser levels.
    unreadable_frames: usize,
}

impl FrameTally {
    /// Frames still coarse or drawn around unreadable bricks: the movie is incomplete, and
    /// the exit code says so as `render`'s does.
    fn rendered(&self) -> super::render::Rendered {
        if self.coarse_frames + self.unreadable_frames > 0 {
            super::render::Rendered::Incomplete
        } else {
            super::render::Rendered::Complete
        }
    }
}

/// The frames of a movie: the camera, settings and transfer function of each, and the
/// composite's channels of each (empty for one volume).
struct MovieFrames {
    shots: Vec<Shot>,
    channels: Vec<Vec<ChannelState>>,
}

pub fn run(args: &MovieArgs, given: &Given) -> Result<super::render::Rendered, String> {
    let started = Instant::now();
    let format = MovieFormat::of(&args.output)?;
    let keyframes = read_keyframes(args)?;
    let (open, draw) = start_options(args, given, &keyframes)?;
    args.options.check()?;
    let mut drawing = super::render::open_drawable(&open, &draw)?;
    let frames = MovieFrames {
        channels: channel_frames(args, given, &drawing, &keyframes)?,
        shots: shots(args, given, &drawing, &draw, &keyframes)?,
    };
    let mut writer = format.create(&args.output, draw.size, args.fps, frames.shots.len())?;
    // A frame that fails leaves no half-written movie.
    let mut tally = match draw_frames(&mut drawing, writer.as_mut(), &frames, &draw) {
        Ok(tally) => tally,
        Err(error) => {
            writer.abandon();
            return Err(error);
        }
    };
    eprintln!();
    let finish_started = Instant::now();
    writer.finish()?;
    tally.times.encode += finish_started.elapsed();
    say_written(args, &drawing, draw.size, &tally, started);
    Ok(tally.rendered())
}

/// The options the movie opens its volume and draws under: the start view's (`--view`, else
/// the first keyframe's) under the options given beside it, else the options alone.
fn start_options(
    args: &MovieArgs,
    given: &Given,
    keyframes: &[(PathBuf, SavedView)],
) -> Result<(OpenOptions, DrawOptions), String> {
    let start_view = match (&args.view, keyframes.first()) {
        (Some(path), _) => Some((
            path.clone(),
            SavedView::read(path).map_err(|e| e.to_string())?,
        )),
        (None, Some(first)) => Some(first.clone()),
        (None, None) => None,
    };
    Ok(match &start_view {
        Some((path, saved)) => under_options(args, given, path, saved)?,
        None => (args.volume.open_options(), args.options.draw_options()),
    })
}

/// The composite's channels per frame, each channel's color and window following the
/// keyframes (empty for one volume).
fn channel_frames(
    args: &MovieArgs,
    given: &Given,
    drawing: &Drawable,
    keyframes: &[(PathBuf, SavedView)],
) -> Result<Vec<Vec<ChannelState>>, String> {
    Ok(match drawing.channels() {
        Some(channels) if keyframes.len() > 1 => {
            let numbers = drawing.channel_indices();
            let keys: Vec<Vec<ChannelState>> = keyframes
                .iter()
                .map(|(path, saved)| {
                    under_options(args, given, path, saved)
                        .map(|(_, key)| key_channels(channels, numbers.as_deref(), &key.channels))
                })
                .collect::<Result<_, String>>()?;
            keyframe_channels(&keys, args.frames.unwrap_or(SEGMENT_FRAMES) as usize)
        }
        _ => Vec::new(),
    })
}

/// The camera, settings and transfer function of each frame: a turn from the first view, or
/// the path through the keyframes.
fn shots(
    args: &MovieArgs,
    given: &Given,
    drawing: &Drawable,
    draw: &DrawOptions,
    keyframes: &[(PathBuf, SavedView)],
) -> Result<Vec<Shot>, String> {
    Ok(if keyframes.is_empty() {
        let first = Shot {
            camera: draw.camera,
            settings: drawing.render_settings(draw),
            transfer: drawing.transfer(),
        };
        turntable(&first, args.frames.unwrap_or(TURNTABLE_FRAMES) as usize)
    } else {
        let keys = keyframes
            .iter()
            .map(|(path, saved)| key_shot(args, given, drawing, path, saved))
            .collect::<Result<Vec<Shot>, String>>()?;
        keyframe_path(&keys, args.frames.unwrap_or(SEGMENT_FRAMES) as usize)
    })
}

/// Draws the frames one by one, each complete (or at `--max-wait`) before it is read back
/// and added to `writer`, with a progress line on stderr.
fn draw_frames(
    drawing: &mut Drawable,
    writer: &mut dyn MovieWriter,
    frames: &MovieFrames,
    draw: &DrawOptions,
) -> Result<FrameTally, String> {
    let size = draw.size;
    let target = RenderTarget::new(drawing.context(), size.0, size.1);
    let mut tally = FrameTally {
        drawing_started: Instant::now(),
        frames: 0,
        times: StageTimes::default(),
        coarse_frames: 0,
        unreadable_frames: 0,
    };
    let shots = &frames.shots;
    for (index, shot) in shots.iter().enumerate() {
        let frame_started = Instant::now();
        drawing
            .set_transfer(&shot.transfer)
            .map_err(|e| end_progress_line(e.to_string()))?;
        if let Some(channels) = frames.channels.get(index) {
            drawing
                .set_channels(channels)
                .map_err(|e| end_progress_line(e.to_string()))?;
        }
        let drawn = drawing
            .draw_complete(&target, &shot.camera, &shot.settings, draw.max_wait)
            .map_err(|e| end_progress_line(e.to_string()))?;
        if drawn.is_none() {
            // The frame's render time is the GPU's, not its submission's.
            drawing
                .context()
                .wait_idle()
                .map_err(|e| end_progress_line(e.to_string()))?;
        }
        if let Some(refinement) = drawn {
            tally.coarse_frames += usize::from(!refinement.complete);
            tally.unreadable_frames += usize::from(!refinement.unreadable.is_empty());
        }
        let rendered = Instant::now();
        let mut image =
            read_image(drawing.context(), &target).map_err(|e| end_progress_line(e.to_string()))?;
        drawing
            .draw_labels_over(&mut image, None, &shot.camera, &shot.settings)
            .map_err(|e| end_progress_line(e.to_string()))?;
        let read = Instant::now();
        writer.add(&image).map_err(end_progress_line)?;
        let encoded = Instant::now();
        tally.times.render += rendered - frame_started;
        tally.times.readback += read - rendered;
        tally.times.encode += encoded - read;
        tally.frames = index + 1;
        show_progress(tally.frames, shots.len(), &tally);
    }
    Ok(tally)
}

/// An error ends the progress line before it is said.
fn end_progress_line(error: String) -> String {
    eprintln!();
    error
}

/// The progress line, drawn over itself: a bar of `done` frames of `total`, and the rate.
fn show_progress(done: usize, total: usize, tally: &FrameTally) {
    let rate = done as f64 / tally.drawing_started.elapsed().as_secs_f64().max(1e-9);
    let bar_width = 30;
    let filled = done * bar_width / total;
    eprint!(
        "\r[{}{}] frame {done}/{} ({rate:.1} frames/s)",
        "#".repeat(filled),
        " ".repeat(bar_width - filled),
        total
    );
    let _ = std::io::stderr().flush();
}

/// The line that says what was written, how fast, and where the movie is incomplete.
fn say_written(
    args: &MovieArgs,
    drawing: &Drawable,
    size: (u32, u32),
    tally: &FrameTally,
    started: Instant,
) {
    let times = &tally.times;
    let (frames, coarse_frames, unreadable_frames) =
        (tally.frames, tally.coarse_frames, tally.unreadable_frames);
    let per_frame = |d: Duration| d.as_secs_f64() * 1000.0 / frames as f64;
    let written_rate = frames as f64 / tally.drawing_started.elapsed().as_secs_f64().max(1e-9);
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
/// the options beside it): by the file's channel number where the keyframe chose channels (a
/// streamed composite's, `numbers` in order), else by position; a view of more channels than
/// these: `opened`'s.
fn key_channels(
    opened: &[ChannelState],
    numbers: Option<&[usize]>,
    asked: &ChannelRequest,
) -> Vec<ChannelState> {
    let mut channels = opened.to_vec();
    match numbers {
        Some(numbers) if !asked.chosen.is_empty() => {
            asked.apply_to_numbered(&mut channels, numbers);
        }
        _ if asked.colors.len() <= channels.len() => asked.apply_to(&mut channels),
        _ => {}
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
