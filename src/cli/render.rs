//! `voxscope render`: one image, no window.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use super::args::scene_error_text;
use super::view::{self, Given};
use super::{RenderOptions, VolumeArgs};
use voxscope_render::{HeadlessStart, RenderTarget, RendererKind, read_image};
use voxscope_scene::{
    DrawOptions, Drawable, OpenOptions, Refinement, SavedView, SceneError, describe_missing,
};

#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    #[command(flatten)]
    pub options: RenderOptions,
    /// Output PNG.
    #[arg(short, long, value_name = "FILE.png")]
    pub output: PathBuf,
    /// A view saved by --save-view: its data, camera, transfer function and every rendering
    /// choice; options given beside it win over its own.
    #[arg(long, value_name = "V.ron")]
    pub view: Option<PathBuf>,
    /// Also write the view of this render (RON): `render --view` draws it again.
    #[arg(long, value_name = "V.ron")]
    pub save_view: Option<PathBuf>,
    /// Draw in square tiles of this side even where the image fits the device (tests).
    #[arg(long, hide = true, value_name = "PIXELS", value_parser = clap::value_parser!(u32).range(16..=16384))]
    pub tile_size: Option<u32>,
}

/// How a render (or a movie) that wrote its image ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rendered {
    /// The image holds everything the view shows (complete, or complete at the GPU budget).
    Complete,
    /// Some bricks the view needed could not be read (drawn from a coarser level, listed on
    /// stderr), or were still on their way when `--max-wait` ran out: the process exits with
    /// [`super::EXIT_INCOMPLETE`].
    Incomplete,
}

pub fn run(args: &RenderArgs, given: &Given) -> Result<Rendered, String> {
    let (open, draw) = resolved(args, given)?;
    check_output(&args.output, open.source.as_deref())?;
    args.options.check()?;
    let started = Instant::now();
    let mut drawing = open_drawable(&open, &draw)?;
    let camera = draw.camera;
    let settings = drawing.render_settings(&draw);
    let size = draw.size;
    // Seconds from the start to the first frame's drawing (a streamed render's first image
    // is this and the refinement's first frame).
    let mut drawing_began = 0.0;
    let side = drawing.tile_side(size, args.tile_size);
    let (mut image, refinement) = match side {
        Some(side) => {
            let (image, tiles) = drawing
                .draw_tiled(size, side, &camera, &settings, draw.max_wait)
                .map_err(|e| e.to_string())?;
            let why = if args.tile_size.is_some() {
                "as --tile-size asks".to_owned()
            } else {
                format!("{}x{} is beyond one target of this device", size.0, size.1)
            };
            eprintln!("drawn in tiles of {side}x{side} pixels ({why})");
            (image, merged(tiles))
        }
        None => {
            let target = RenderTarget::new(drawing.context(), size.0, size.1);
            drawing_began = started.elapsed().as_secs_f64();
            let refinement = drawing
                .draw_complete(&target, &camera, &settings, draw.max_wait)
                .map_err(|e| e.to_string())?;
            let image = read_image(drawing.context(), &target).map_err(|e| e.to_string())?;
            (image, refinement)
        }
    };
    drawing
        .draw_labels_over(&mut image, side, &camera, &settings)
        .map_err(|e| e.to_string())?;
    image
        .save(&args.output)
        .map_err(|e| format!("cannot write {}: {e}", args.output.display()))?;
    if let Some(path) = &args.save_view {
        SavedView::of(&open, &draw, &drawing)
            .write(path)
            .map_err(|e| e.to_string())?;
    }
    let seconds = started.elapsed().as_secs_f64();
    let written = format!(
        "wrote {} ({}x{}",
        args.output.display(),
        image.width(),
        image.height()
    );
    let names: Vec<&str> = drawing.labels().iter().map(|l| l.name.as_str()).collect();
    let labels = if names.is_empty() {
        String::new()
    } else {
        format!(", labels {} over it", names.join(", "))
    };
    let depth = drawing.depth();
    let channels = drawing.channels().map(|channels| {
        let colors: Vec<String> = channels
            .iter()
            .map(|c| c.color)
            .map(|c| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]))
            .collect();
        match channels {
            [one] => format!("{} in {}", one.name, colors.join("")),
            _ => format!(
                "composite of {} channels ({})",
                channels.len(),
                colors.join(", ")
            ),
        }
    });
    if let Some(refinement) = refinement {
        // A streamed composite says its channels beside the stream's report.
        let described = match &channels {
            Some(what) => format!(", {what}{labels}"),
            None => labels,
        };
        return Ok(report_stream(
            &written,
            &described,
            &drawing,
            depth,
            &settings,
            &refinement,
            Seconds {
                whole: seconds,
                first_image: drawing_began + refinement.first_frame_seconds,
            },
        ));
    }
    if let Some(what) = channels {
        eprintln!(
            "{written}, {what}, dense renderer{labels}) on {} in {seconds:.2} s",
            drawing.context().describe(),
        );
        return Ok(Rendered::Complete);
    }
    eprintln!(
        "{written}, {} renderer, level {}/{depth}{labels}) on {} in {seconds:.2} s",
        drawing.renderer().kind().name(),
        settings.max_level,
        drawing.context().describe(),
    );
    Ok(Rendered::Complete)
}

/// What `volume` and `options` name, read, prepared and uploaded as `render` and `movie` draw
/// it: the GPU starts while the volume is read (for the streaming renderer, which is what a
/// store's `--renderer stream` always draws, it builds the renderer's pipelines too); a long
/// octree build reports its progress on stderr, and how it is drawn is said there once.
pub(super) fn open_drawable(open: &OpenOptions, draw: &DrawOptions) -> Result<Drawable, String> {
    let streams = draw.renderer == Some(RendererKind::Stream);
    let gpu = HeadlessStart::begin_for(streams.then_some(RendererKind::Stream));
    super::prepare::reporting_progress(|progress| {
        Drawable::open(
            open,
            draw,
            || gpu.finish().map_err(SceneError::Gpu),
            progress,
            &mut |notice| eprintln!("{notice}"),
        )
    })
    .map_err(|e| scene_error_text(&e))
}

/// A streamed image's tiles' refinements as one: complete when every tile is, every tile's
/// frames, time and failures; the streamer's status after the last. `None` for no tiles (an
/// image that does not stream).
fn merged(tiles: Vec<Refinement>) -> Option<Refinement> {
    tiles.into_iter().reduce(|mut all, tile| {
        all.frames += tile.frames;
        all.seconds += tile.seconds;
        all.complete &= tile.complete;
        all.errors.extend(tile.errors);
        all.unreadable.extend(tile.unreadable);
        all.other_failures += tile.other_failures;
        all.parts.add(&tile.parts);
        all.status = tile.status;
        all
    })
}

/// What `args` open and draw, under its `--view` (the options `given` on the command line
/// win over the view's).
fn resolved(args: &RenderArgs, given: &Given) -> Result<(OpenOptions, DrawOptions), String> {
    let (open, draw) = (args.volume.open_options(), args.options.draw_options());
    match &args.view {
        Some(path) => {
            let saved = SavedView::read(path).map_err(|e| e.to_string())?;
            view::under_options(&saved, path, (&open, &draw), given)
        }
        None => Ok((open, draw)),
    }
}

/// How long a streamed render took, and until its first image.
struct Seconds {
    whole: f64,
    first_image: f64,
}

/// What a streamed render says on stderr (each brick that could not be read, then the
/// summary) and how it ended.
fn report_stream(
    written: &str,
    labels: &str,
    drawing: &Drawable,
    depth: u32,
    settings: &voxscope_render::RenderSettings,
    refinement: &Refinement,
    Seconds {
        whole: seconds,
        first_image: first_image_seconds,
    }: Seconds,
) -> Rendered {
    // Each brick that could not be read once (or, when many, one line per cause).
    for line in refinement.failure_lines() {
        eprintln!("{line}");
    }
    let counters = &refinement.status.counters;
    let unreadable = refinement.unreadable.len();
    let state = if refinement.complete && unreadable > 0 {
        format!("settled after {} frames", refinement.frames)
    } else if refinement.complete {
        refinement
            .completed_at_budget()
            .unwrap_or_else(|| format!("complete after {} frames", refinement.frames))
    } else {
        format!(
            "still coarse after {:.1} s (--max-wait) and {} frames: {}",
            refinement.seconds,
            refinement.frames,
            describe_missing(&refinement.status)
        )
    };
    let (ending, rendered) = if unreadable > 0 {
        (
            format!(
                "; incomplete: {unreadable} brick{} unreadable",
                if unreadable == 1 { "" } else { "s" }
            ),
            Rendered::Incomplete,
        )
    } else if !refinement.complete {
        // --max-wait ran out with bricks on their way: a script must tell this image from a
        // complete one as it tells one drawn around unreadable bricks.
        (
            "; incomplete: still coarse".to_owned(),
            Rendered::Incomplete,
        )
    } else {
        (String::new(), Rendered::Complete)
    };
    // The most the process held (Linux): the RAM budget, the device's, and what every
    // process with a GPU holds.
    let peak = voxscope_bench::memory::resident()
        .map(|r| {
            format!(
                ", peak memory {:.0} MiB",
                voxscope_bench::memory::mib(r.peak)
            )
        })
        .unwrap_or_default();
    // A URL's store: what crossed the network (metadata, indexes and chunks) and how many
    // requests were on the wire together.
    let network = drawing
        .renderer()
        .streamer()
        .and_then(|streamer| streamer.source().remote_stats())
        .map(|stats| {
            format!(
                "; network: {} requests, {:.1} MB, at most {} in flight",
                stats.requests,
                stats.bytes as f64 / 1e6,
                stats.peak_in_flight
            )
        })
        .unwrap_or_default();
    // A store's chunks: each brick's read decodes those not kept from the bricks before.
    let decoded = match counters.chunks_decoded {
        0 => String::new(),
        1 => " from 1 chunk decoded".to_string(),
        n => format!(" from {n} chunks decoded"),
    };
    eprintln!(
        "{written}, stream renderer, level {}/{depth}{labels}) on {} in {seconds:.2} s (first image after {first_image_seconds:.2} s): {} bricks read ({:.1} MiB){decoded}, {} of {} atlas slots used{peak}{network}; {state}{ending}",
        settings.max_level,
        drawing.context().describe(),
        counters.loads,
        counters.bytes_read as f64 / (1 << 20) as f64,
        counters.slots_used,
        counters.slots,
    );
    rendered
}

/// The output must be a .png and never the input volume itself.
pub(super) fn check_output(output: &Path, input: Option<&str>) -> Result<(), String> {
    let is_png = output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !is_png {
        return Err(format!(
            "{}: the output must be a .png file",
            output.display()
        ));
    }
    if let Some(input) = input {
        let same = match (std::fs::canonicalize(input), std::fs::canonicalize(output)) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if same {
            return Err(format!(
                "{}: refusing to overwrite the input volume",
                output.display()
            ));
        }
    }
    Ok(())
}
