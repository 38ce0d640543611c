//! `voxscope slice`: one planar slice at one pixel per voxel, oriented as the app shows it,
//! drawn on the GPU from the volume a renderer holds.

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};

use super::args::RendererArg;
use super::prepare::default_renderer;
use super::render::check_output;
use super::{Prepared, TransferArgs, VolumeArgs};
use voxscope_octree::Colormap;
use voxscope_render::{
    DEFAULT_BRICK_SIZE, HeadlessStart, RenderTarget, RendererOptions, SliceConvention, SliceFrame,
    SliceSettings, VolumeRenderer, read_image,
};
use voxscope_scene::option_text::{parse_brick_size, parse_colormap};
use voxscope_volume::ValueWindow;

#[derive(Debug, Args)]
pub struct SliceArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// The axis the slice is across: x (sagittal for patient data), y (coronal) or z (axial).
    #[arg(long, value_enum)]
    pub axis: AxisArg,
    /// The slice's voxel index along --axis, in the displayed (RAS-reordered) order, as `probe`
    /// and the app count (default: the middle).
    #[arg(long)]
    pub index: Option<usize>,
    /// Value window LOW:HIGH in the data's own units (default: as `render`'s, the 0.5–99.5
    /// percentiles or the data kind's preset).
    #[arg(long, value_name = "LOW:HIGH", allow_hyphen_values = true, value_parser = ValueWindow::parse)]
    pub window: Option<ValueWindow>,
    /// Colors of the windowed value: grays, viridis, inferno, magma, plasma, cividis or labels
    /// (default: grays; labels for label volumes).
    #[arg(long, value_parser = parse_colormap)]
    pub colormap: Option<Colormap>,
    /// Which renderer's copy of the volume the slice reads (default: the one `render` picks:
    /// octree, or bricks where the octree does not fit this GPU's storage buffers).
    #[arg(long, value_enum)]
    pub renderer: Option<RendererArg>,
    /// Voxels along a brick's side (bricks renderer): 4, 8, 16 or 32.
    #[arg(long, default_value_t = DEFAULT_BRICK_SIZE, value_parser = parse_brick_size)]
    pub brick_size: usize,
    /// Interpolate trilinearly between voxel centers instead of taking the nearest voxel. At
    /// one pixel per voxel every pixel center is a voxel center, so both give each voxel's
    /// own value; the app's zoomed views are where they differ.
    #[arg(long)]
    pub linear: bool,
    /// Output PNG.
    #[arg(short, long, value_name = "FILE.png")]
    pub output: PathBuf,
}

/// The axis a slice is across.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AxisArg {
    X,
    Y,
    Z,
}

impl AxisArg {
    fn index(self) -> usize {
        match self {
            Self::X => 0,
            Self::Y => 1,
            Self::Z => 2,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::X => "x",
            Self::Y => "y",
            Self::Z => "z",
        }
    }
}

pub fn run(args: &SliceArgs) -> Result<(), String> {
    check_output(&args.output, args.volume.file.as_deref())?;
    let started = Instant::now();
    let transfer_args = TransferArgs {
        window: args.window,
        colormap: args.colormap,
        ..TransferArgs::defaults()
    };
    // The GPU starts while the volume is read.
    let gpu = HeadlessStart::begin();
    let prepared = Prepared::new(&args.volume, &transfer_args)?;
    let volume = &prepared.data.volume;
    let axis = args.axis.index();
    let side = volume.dims[axis];
    let index = args.index.unwrap_or(side / 2);
    if index >= side {
        return Err(format!(
            "{}: --index {index} is outside the {} axis, which has {side} voxels (0 to {})",
            volume.name,
            args.axis.name(),
            side - 1
        ));
    }
    let convention = SliceConvention::of_volume(volume);
    let (frame, size) = SliceFrame::voxel_grid(convention, axis, index, volume.dims);
    let context = gpu.finish().map_err(|e| e.to_string())?;
    let limit = context.limits.max_texture_dimension_2d;
    if size.iter().any(|&s| s > limit) {
        return Err(format!(
            "{}: the slice is {}x{} pixels but this GPU ({}) allows {limit} per side",
            volume.name, size[0], size[1], context.adapter_info.name
        ));
    }
    let kind = match args.renderer {
        Some(super::args::RendererArg::Stream) => {
            return Err(format!(
                "{}: the stream renderer draws no slices yet; use --renderer bricks or dense",
                volume.name
            ));
        }
        Some(renderer) => renderer.into(),
        None => default_renderer(
            &context,
            &prepared.data.octree,
            prepared.data.octree.depth,
            "slicing",
        ),
    };
    let renderer = VolumeRenderer::new(
        &context,
        RendererOptions {
            kind,
            brick_size: args.brick_size,
            ..Default::default()
        },
        &prepared.data.octree,
        &prepared.data.quantized,
        volume.spacing,
        prepared.data.octree.depth,
        &prepared.transfer,
    )
    .map_err(|e| format!("{}: {e}", volume.name))?;
    let target = RenderTarget::new(&context, size[0], size[1]);
    let settings = SliceSettings {
        frame,
        window: prepared.transfer.window,
        colormap: prepared.transfer.colormap,
        nearest: !args.linear,
    };
    renderer.render_slice(&context, &target, &settings);
    let image = read_image(&context, &target).map_err(|e| e.to_string())?;
    image
        .save(&args.output)
        .map_err(|e| format!("cannot write {}: {e}", args.output.display()))?;
    let labels = frame.edge_labels(convention);
    eprintln!(
        "wrote {} ({} slice {index} of {side}, {}x{} pixels, {} left, {} up; {} renderer) on {} in {:.2} s",
        args.output.display(),
        convention.view_name(axis),
        size[0],
        size[1],
        labels.left,
        labels.top,
        renderer.kind().name(),
        context.describe(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
