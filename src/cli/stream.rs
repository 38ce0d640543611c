//! The streaming renderer on the command line: its options (`--gpu-memory`, `--ram-cache`,
//! …) and opening what the volume options name as a pyramid (the scene layer's
//! [`StreamedVolume`]).

use std::borrow::Borrow;

use clap::Args;
use voxscope_scene::option_text::{parse_bytes, parse_lod_scale};

use super::args::scene_error_text;
use super::{TransferArgs, VolumeArgs};
use voxscope_render::GpuContext;
use voxscope_scene::{OpenedStream, SavedTransfer, SceneError, StreamedVolume};
use voxscope_stream::{AtlasZero, StreamOptions, UploadPath};

/// The streaming renderer's budgets (`--renderer stream`, `bench --stream`).
#[derive(Debug, Clone, Args)]
pub struct StreamArgs {
    /// Streaming renderer: GPU memory for everything it holds (the brick atlas, page table,
    /// request buffers and the uploads' staging), e.g. 2GiB or 512MiB; bounded by the GPU's
    /// largest 3D texture.
    #[arg(long, value_name = "SIZE", default_value = "1GiB", value_parser = parse_bytes)]
    pub gpu_memory: u64,
    /// Streaming renderer: decoded bricks kept in RAM.
    #[arg(long, value_name = "SIZE", default_value = "2GiB", value_parser = parse_bytes)]
    pub ram_cache: u64,
    /// Streaming renderer: bricks uploaded to the GPU per frame at most, in bytes. Within it, a
    /// frame uploads what the measured upload cost lets it do in about 4 ms.
    #[arg(long, value_name = "SIZE", default_value = "256MiB", value_parser = parse_bytes)]
    pub upload_budget: u64,
    /// Streaming renderer: the pixel footprint is multiplied by this to pick each segment's
    /// level (1: no voxel larger than a pixel's footprint; 2: one level coarser; 0: always the
    /// max level).
    #[arg(long, value_name = "F", default_value_t = 1.0, value_parser = parse_lod_scale)]
    pub lod_scale: f32,
    /// Streaming renderer: how bricks reach the GPU's atlas. scatter: staged whole, written
    /// into their cells by a compute pass (copies where the GPU cannot); copies: one copy
    /// command per run of cells; queue: a queue write per brick.
    #[arg(long, value_name = "PATH", default_value = "scatter")]
    pub uploads: UploadsArg,
    /// Streaming renderer: how the GPU's atlas is zeroed before its first use. shader: a
    /// compute pass over an atlas made without wgpu's zero fill (Vulkan, scattered uploads);
    /// wgpu: wgpu's fill at its first use, buffer copies slice by slice; auto: shader on a GPU,
    /// wgpu on a CPU (lavapipe). The same image.
    #[arg(long, value_name = "HOW", default_value = "auto")]
    pub atlas_zero: AtlasZeroArg,
    /// Streaming renderer: draw every ray segment by segment through the hashed page table,
    /// never walking a level's entries copied flat (the same image; for comparison).
    #[arg(long)]
    pub no_level_walk: bool,
}

/// `--uploads`: [`UploadPath`] on the command line.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum UploadsArg {
    Scatter,
    Copies,
    Queue,
}

impl From<UploadsArg> for UploadPath {
    fn from(arg: UploadsArg) -> Self {
        match arg {
            UploadsArg::Scatter => UploadPath::Scatter,
            UploadsArg::Copies => UploadPath::Copies,
            UploadsArg::Queue => UploadPath::Queue,
        }
    }
}

/// `--atlas-zero`: [`AtlasZero`] on the command line.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum AtlasZeroArg {
    Auto,
    Shader,
    Wgpu,
}

impl From<AtlasZeroArg> for AtlasZero {
    fn from(arg: AtlasZeroArg) -> Self {
        match arg {
            AtlasZeroArg::Auto => AtlasZero::Auto,
            AtlasZeroArg::Shader => AtlasZero::Shader,
            AtlasZeroArg::Wgpu => AtlasZero::Wgpu,
        }
    }
}

impl StreamArgs {
    /// The streamer's options (workers: the machine's cores less one).
    pub fn options(&self) -> StreamOptions {
        StreamOptions {
            gpu_memory: self.gpu_memory,
            ram_cache: self.ram_cache,
            upload_bytes_per_frame: self.upload_budget,
            lod_scale: self.lod_scale,
            uploads: self.uploads.into(),
            atlas_zero: self.atlas_zero.into(),
            level_walk: !self.no_level_walk,
            ..StreamOptions::default()
        }
    }
}

/// Opens what `volume_args` names as a pyramid for streaming ([`StreamedVolume::open`]),
/// with the transfer function `transfer_args` ask for; and the --tf file, whose opacity scale
/// and mode apply too.
pub fn open_streamed(
    volume_args: &VolumeArgs,
    transfer_args: &TransferArgs,
) -> Result<(StreamedVolume, Option<SavedTransfer>), String> {
    // A bad --tf file fails before the volume is read.
    let transfer = transfer_args.options();
    let saved = transfer.saved().map_err(|e| e.to_string())?;
    let streamed = StreamedVolume::open(
        &volume_args.source(),
        &volume_args.load_options(),
        &transfer.request(saved.as_ref()),
    )
    .map_err(|error| scene_error_text(&error))?;
    Ok((streamed, saved))
}

/// [`open_streamed`] with the stream renderer of the volume, made with `stream`'s options on
/// the GPU `gpu` gives while the first image's chunks are on their way
/// ([`StreamedVolume::open_with_renderer`]).
pub fn open_streamed_with_renderer<G: Borrow<GpuContext>>(
    volume_args: &VolumeArgs,
    transfer_args: &TransferArgs,
    stream: StreamOptions,
    gpu: impl FnOnce() -> Result<G, SceneError>,
) -> Result<(OpenedStream<G>, Option<SavedTransfer>), String> {
    let transfer = transfer_args.options();
    let saved = transfer.saved().map_err(|e| e.to_string())?;
    let opened = StreamedVolume::open_with_renderer(
        &volume_args.source(),
        &volume_args.load_options(),
        &transfer.request(saved.as_ref()),
        stream,
        gpu,
    )
    .map_err(|error| scene_error_text(&error))?;
    Ok((opened, saved))
}
