//! `voxscope render`: one image, no window.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;

use super::args::{ChannelArg, RendererArg};
use super::composite::PreparedChannel;
use super::prepare::default_renderer;
use super::stream::open_streamed;
use super::{Prepared, RenderOptions, VolumeArgs};
use voxscope_octree::MAX_DEPTH;
use voxscope_render::{
    ChannelLayer, GpuContext, RenderTarget, RendererOptions, VolumeRenderer, read_image,
};
use voxscope_scene::{SavedTransfer, StreamedVolume, beyond_octree, describe_missing, refine};
use voxscope_volume::{Volume, format_dims};

#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    #[command(flatten)]
    pub options: RenderOptions,
    /// Output PNG.
    #[arg(short, long, value_name = "FILE.png")]
    pub output: PathBuf,
}

/// How a render that wrote its image ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rendered {
    /// The image holds everything the view shows (or what `--max-wait` allowed).
    Complete,
    /// Some bricks the view needed could not be read: drawn from a coarser level, listed on
    /// stderr; the process exits with [`super::EXIT_INCOMPLETE`].
    Incomplete,
}

pub fn run(args: &RenderArgs) -> Result<Rendered, String> {
    check_output(&args.output, args.volume.file.as_deref())?;
    let options = &args.options;
    options.check()?;
    if options.renderer == Some(RendererArg::Stream) {
        let (streamed, saved) = open_streamed(&args.volume, &options.transfer)?;
        return run_stream(args, streamed, saved, Instant::now());
    }
    let started = Instant::now();
    let volume = match args.volume.composite_channels()? {
        Some(channels) if channels.len() > 1 => {
            return run_composite(args, channels).map(|()| Rendered::Complete);
        }
        Some(mut channels) => channels.pop().ok_or("no channel was read")?,
        None => args.volume.load()?,
    };
    // `--channel N` of a file of several channels: drawn as the composite draws it, in the
    // channel's color and window, where the options or the file give it a color and the
    // dense renderer can draw it; else in the channel's window, by the renderer asked for.
    let mut transfer_args = options.transfer.clone();
    if let Some(ChannelArg::Index(index)) = args.volume.channel {
        if options.channels.colors_channel(&volume, index)? {
            if matches!(options.renderer, None | Some(RendererArg::Dense))
                && !beyond_octree(volume.dims)
            {
                let channel = options
                    .channels
                    .prepare_one(volume, index, &options.transfer)?;
                return draw_composite(args, vec![channel], started).map(|()| Rendered::Complete);
            }
            eprintln!(
                "channel {index} is drawn in grays: its color needs the dense renderer (--renderer dense)"
            );
        }
        if let Some(window) = options.channels.window_of(index) {
            transfer_args.window = Some(window);
        }
    }
    let options = &RenderOptions {
        transfer: transfer_args,
        ..options.clone()
    };
    // Longer than the voxel octree holds: bricks are streamed from memory.
    if beyond_octree(volume.dims) && matches!(options.renderer, None | Some(RendererArg::Bricks)) {
        eprintln!(
            "{}: {} voxels are beyond the voxel octree's {} a side: drawn by the streaming renderer, from memory",
            volume.name,
            format_dims(volume.dims),
            1u32 << MAX_DEPTH
        );
        let saved = options.transfer.saved()?;
        let streamed =
            StreamedVolume::from_volume(volume, &options.transfer.request(saved.as_ref()), started)
                .map_err(|e| e.to_string())?;
        return run_stream(args, streamed, saved, started);
    }
    let prepared = Prepared::from_volume(volume, &options.transfer)?;
    let mut settings = options
        .transfer
        .render_settings(prepared.data.octree.depth, prepared.saved.as_ref());
    settings.clip = options.clip.clip();
    let context = GpuContext::new_headless().map_err(|e| e.to_string())?;
    let kind = match options.renderer {
        Some(renderer) => renderer.into(),
        None => default_renderer(
            &context,
            &prepared.data.octree,
            settings.max_level,
            "rendering",
        ),
    };
    let renderer = VolumeRenderer::new(
        &context,
        RendererOptions {
            kind,
            brick_size: options.brick_size,
            ..Default::default()
        },
        &prepared.data.octree,
        &prepared.data.quantized,
        prepared.data.volume.spacing,
        settings.max_level,
        &prepared.transfer,
    )
    .map_err(|e| format!("{}: {e}", prepared.data.volume.name))?;
    let target = RenderTarget::new(&context, options.size.0, options.size.1);
    let camera = options.camera();
    renderer.render(&context, &target, &camera, &settings);
    let image = read_image(&context, &target).map_err(|e| e.to_string())?;
    image
        .save(&args.output)
        .map_err(|e| format!("cannot write {}: {e}", args.output.display()))?;
    eprintln!(
        "wrote {} ({}x{}, {} renderer, level {}/{}) on {} in {:.2} s",
        args.output.display(),
        target.width,
        target.height,
        renderer.kind().name(),
        settings.max_level,
        prepared.data.octree.depth,
        context.describe(),
        started.elapsed().as_secs_f64()
    );
    Ok(Rendered::Complete)
}

/// `render` of several channels: the dense renderer's composite.
fn run_composite(args: &RenderArgs, channels: Vec<Volume>) -> Result<(), String> {
    let started = Instant::now();
    let options = &args.options;
    if let Some(renderer) = options.renderer
        && renderer != RendererArg::Dense
    {
        return Err(format!(
            "the composite of {} channels is drawn by the dense renderer; --renderer {} draws one channel (--channel N)",
            channels.len(),
            voxscope_render::RendererKind::from(renderer).name()
        ));
    }
    let prepared = options.channels.prepare(channels, &options.transfer)?;
    draw_composite(args, prepared, started)
}

/// Draws `prepared` (one channel or several) with the dense renderer's composite and writes
/// the image.
fn draw_composite(
    args: &RenderArgs,
    prepared: Vec<PreparedChannel>,
    started: Instant,
) -> Result<(), String> {
    let options = &args.options;
    let saved = options.transfer.saved()?;
    let mut settings = options.transfer.render_settings(0, saved.as_ref());
    settings.clip = options.clip.clip();
    let context = GpuContext::new_headless().map_err(|e| e.to_string())?;
    let layers: Vec<ChannelLayer<'_>> = prepared.iter().map(PreparedChannel::layer).collect();
    let name = &prepared[0].volume.name;
    let renderer = VolumeRenderer::new_composite(&context, &layers, prepared[0].volume.spacing)
        .map_err(|e| format!("{name}: {e}"))?;
    let target = RenderTarget::new(&context, options.size.0, options.size.1);
    let camera = options.camera();
    renderer.render(&context, &target, &camera, &settings);
    let image = read_image(&context, &target).map_err(|e| e.to_string())?;
    image
        .save(&args.output)
        .map_err(|e| format!("cannot write {}: {e}", args.output.display()))?;
    let colors: Vec<String> = prepared
        .iter()
        .map(|c| c.state.color)
        .map(|c| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]))
        .collect();
    let what = match &prepared[..] {
        [one] => format!("{} in {}", one.state.name, colors.join("")),
        _ => format!(
            "composite of {} channels ({})",
            prepared.len(),
            colors.join(", ")
        ),
    };
    eprintln!(
        "wrote {} ({}x{}, {what}, dense renderer) on {} in {:.2} s",
        args.output.display(),
        target.width,
        target.height,
        context.describe(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `render --renderer stream` (and `bricks` beyond the octree): draws `prepared`'s pyramid,
/// opened since `started`, until nothing visible is missing (or `--max-wait`), writes the
/// image. `saved` is the --tf file.
fn run_stream(
    args: &RenderArgs,
    prepared: StreamedVolume,
    saved: Option<SavedTransfer>,
    started: Instant,
) -> Result<Rendered, String> {
    let name = prepared.source.name().to_owned();
    let options = &args.options;
    let mut settings = options
        .transfer
        .render_settings(prepared.depth(), saved.as_ref());
    settings.clip = options.clip.clip();
    let context = GpuContext::new_headless().map_err(|e| e.to_string())?;
    let mut renderer = VolumeRenderer::new_stream(
        &context,
        prepared.source.clone(),
        prepared.stream_options(options.stream.options()),
        &prepared.transfer,
    )
    .map_err(|e| format!("{name}: {e}"))?;
    let target = RenderTarget::new(&context, options.size.0, options.size.1);
    let camera = options.camera();
    let refinement = refine(
        &context,
        &mut renderer,
        &target,
        &camera,
        &settings,
        Duration::from_secs_f64(options.max_wait),
    )
    .map_err(|e| e.to_string())?;
    let image = read_image(&context, &target).map_err(|e| e.to_string())?;
    image
        .save(&args.output)
        .map_err(|e| format!("cannot write {}: {e}", args.output.display()))?;
    // Each brick that could not be read once (or, when many, one line per cause).
    for line in refinement.failure_lines() {
        eprintln!("{line}");
    }
    let counters = &refinement.status.counters;
    let unreadable = refinement.unreadable.len();
    let state = if refinement.complete && unreadable > 0 {
        format!("settled after {} frames", refinement.frames)
    } else if refinement.complete {
        match &refinement.status.budget {
            Some(budget) => format!(
                "complete at the budget after {} frames ({} in {} MiB of atlas)",
                refinement.frames,
                budget.describe(),
                (counters.slot_bytes * budget.fit as u64) >> 20
            ),
            None => format!("complete after {} frames", refinement.frames),
        }
    } else {
        format!(
            "still coarse after {:.1} s (--max-wait): {}",
            refinement.seconds,
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
    } else {
        (String::new(), Rendered::Complete)
    };
    eprintln!(
        "wrote {} ({}x{}, stream renderer, level {}/{}) on {} in {:.2} s: {} bricks read ({:.1} MiB), {} of {} atlas slots used; {state}{ending}",
        args.output.display(),
        target.width,
        target.height,
        settings.max_level,
        prepared.depth(),
        context.describe(),
        started.elapsed().as_secs_f64(),
        counters.loads,
        counters.bytes_read as f64 / (1 << 20) as f64,
        counters.slots_used,
        counters.slots,
    );
    Ok(rendered)
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
