//! One volume on the GPU drawn by one of the renderers ([`Renderer`]), with what every one of
//! them shares: the slices' color tables and the constructors that choose the renderer. What
//! the command line, the benchmark and the app switch between. It holds the volume's buffers
//! and textures alone; the pipelines that draw and recolor it are the device's
//! (`pipeline_cache.rs`), built once, whatever the number of volumes and renderers.

use super::raycaster::ProbeTarget;
use super::renderer::{FramePass, Renderer};
use super::slice::{SliceColorCache, SliceSource};
use super::{
    Camera, ChannelLayer, CompositeVolume, DenseVolume, GpuBricks, GpuContext, GpuVolume,
    RenderError, RenderSettings, RenderTarget, SliceSettings, StreamVolume,
};
use std::sync::Arc;
use voxscope_octree::{BrickLayout, Octree, TransferFunction};
use voxscope_stream::{
    BrickSource, Downsampling, MemorySource, StreamOptions, StreamStatus, Streamer,
};
use voxscope_volume::{Quantization, QuantizedVolume};

/// The renderers voxscope has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum RendererKind {
    /// The paper's octree: 8-byte nodes, voxel leaves, empty-space skipping, LOD cut.
    Octree,
    /// One 3D texture, fixed one-voxel steps, hardware filtering (the peers' baseline).
    Dense,
    /// The octree down to bricks (32³ voxels unless chosen otherwise), marched in a 3D atlas.
    Bricks,
    /// A pyramid of 32³ bricks streamed into an atlas of a fixed GPU budget through a page
    /// table: volumes of any size ([`VolumeRenderer::new_stream`], [`VolumeRenderer::update`]).
    Stream,
    /// Up to eight channels on one grid drawn together, each in its color (the dense march;
    /// [`VolumeRenderer::new_composite`]).
    Composite,
}

/// Voxels along a brick's side in the bricks renderer, unless chosen otherwise.
pub const DEFAULT_BRICK_SIZE: usize = 32;

/// The structural choices of a renderer (changing them means uploading again).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RendererOptions {
    pub kind: RendererKind,
    /// Voxels along a brick's side (bricks renderer; a power of two).
    pub brick_size: usize,
    /// GPU memory the streaming renderer may hold, in bytes ([`StreamOptions::gpu_memory`]).
    pub gpu_memory: u64,
}

impl Default for RendererOptions {
    /// The paper's octree; 32³ bricks and the streaming renderer's default budget if chosen.
    fn default() -> Self {
        RendererKind::Octree.into()
    }
}

impl From<RendererKind> for RendererOptions {
    fn from(kind: RendererKind) -> Self {
        Self {
            kind,
            brick_size: DEFAULT_BRICK_SIZE,
            gpu_memory: StreamOptions::default().gpu_memory,
        }
    }
}

impl RendererKind {
    /// The renderers of a volume held whole in memory, which draw without being driven: the
    /// ones the app lists. [`Self::Stream`] needs [`VolumeRenderer::update`] every frame.
    pub const ALL: [RendererKind; 3] = [Self::Octree, Self::Dense, Self::Bricks];

    /// `octree`, `dense`, `bricks`, `stream`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Octree => "octree",
            Self::Dense => "dense",
            Self::Bricks => "bricks",
            Self::Stream => "stream",
            Self::Composite => "composite",
        }
    }
}

/// What frames of a max level draw: the octree's nodes, a pyramid level, or every voxel (what
/// the app's Octree panel says under the max-level slider).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LevelDetail {
    /// The octree's nodes down to this level, each one color (the paper's level of detail).
    Nodes { level: u32 },
    /// Pyramid level `level`: the volume reduced 2^level times per axis by the mean (`dims`
    /// voxels), filtered, one sample per voxel of that level.
    Pyramid { level: u32, dims: [usize; 3] },
    /// Every voxel.
    Full,
}

/// A volume uploaded for one renderer, drawn with the device's pipelines.
pub struct VolumeRenderer {
    renderer: Box<dyn Renderer>,
    /// What the value levels mean (for the slices' colors).
    quantization: Quantization,
    /// The slices' color tables, made on the first slice of each window and colormap.
    slice_colors: SliceColorCache,
}

impl VolumeRenderer {
    /// Uploads what `kind` needs: the octree (colored as it is, through `max_level`) or the
    /// quantized voxels. Builds the device's pipelines for `kind` if this is its first use, so
    /// that the compile happens here (the app's loading thread) and not at the first frame.
    /// (The composite of several channels is [`Self::new_composite`].)
    pub fn new(
        context: &GpuContext,
        options: impl Into<RendererOptions>,
        octree: &Octree,
        quantized: &QuantizedVolume,
        spacing: [f64; 3],
        max_level: u32,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let options = options.into();
        context.build_pipelines(options.kind);
        let renderer: Box<dyn Renderer> = match options.kind {
            RendererKind::Octree => Box::new(GpuVolume::upload(
                context, octree, spacing, max_level, transfer,
            )?),
            RendererKind::Dense => Box::new(DenseVolume::upload(
                context,
                quantized,
                spacing,
                transfer,
                octree.labels,
            )?),
            RendererKind::Bricks => {
                let layout = BrickLayout::new(
                    octree,
                    quantized,
                    options.brick_size,
                    context.limits.max_texture_dimension_3d as usize,
                )
                .map_err(|e| RenderError::DoesNotFit(e.to_string()))?;
                Box::new(GpuBricks::upload(
                    context,
                    &layout,
                    quantized,
                    spacing,
                    octree.depth,
                    transfer,
                )?)
            }
            RendererKind::Stream => {
                let how = Downsampling::of_values(octree.labels);
                let source = MemorySource::new("volume", quantized, spacing, how)
                    .map_err(|e| RenderError::Invalid(e.to_string()))?;
                let stream = StreamOptions {
                    gpu_memory: options.gpu_memory,
                    ..StreamOptions::default()
                };
                Box::new(StreamVolume::new(
                    context,
                    Arc::new(source),
                    stream,
                    transfer,
                )?)
            }
            RendererKind::Composite => {
                return Err(RenderError::Invalid(
                    "the composite is made of channels (VolumeRenderer::new_composite)".into(),
                ));
            }
        };
        Ok(Self::from_renderer(renderer, octree.quantization))
    }

    /// The streaming renderer of `source` (an in-memory volume's pyramid, a procedural one, a
    /// file's), within `options`' GPU and RAM budgets: the coarsest levels are read now, the
    /// rest as rays ask for them. Drive it with [`Self::update`] once per frame.
    pub fn new_stream(
        context: &GpuContext,
        source: Arc<dyn BrickSource>,
        options: StreamOptions,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let mut renderer = Self::new_stream_unread(context, source, options, transfer)?;
        renderer.read_pinned()?;
        Ok(renderer)
    }

    /// [`Self::new_stream`] without reading anything ([`StreamVolume::allocate`]): a store's
    /// first chunks may still be on their way while it is made. [`Self::read_pinned`] must
    /// follow before the first [`Self::update`].
    pub fn new_stream_unread(
        context: &GpuContext,
        source: Arc<dyn BrickSource>,
        options: StreamOptions,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        // The ray caster; the uploads' scatter pipeline of the atlas's format is built with
        // the atlas.
        context.stream_raycaster();
        let quantization = source.quantization();
        let volume = StreamVolume::allocate(context, source, options, transfer)?;
        Ok(Self::from_renderer(Box::new(volume), quantization))
    }

    /// The composite of `layers` (1 to 8 channels on one grid, each its transfer function and
    /// color) with the voxel size `spacing`; its channels' tables are set by
    /// [`Self::set_channels`].
    pub fn new_composite(
        context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        spacing: [f64; 3],
    ) -> Result<Self, RenderError> {
        context.build_pipelines(RendererKind::Composite);
        let volume = CompositeVolume::upload(context, layers, spacing)?;
        let quantization = layers.first().map_or(
            Quantization {
                offset: 0.0,
                step: 1.0,
            },
            |layer| layer.quantized.quantization,
        );
        Ok(Self::from_renderer(Box::new(volume), quantization))
    }

    /// `renderer`, its value levels meaning what `quantization` says.
    pub fn from_renderer(renderer: Box<dyn Renderer>, quantization: Quantization) -> Self {
        Self {
            renderer,
            quantization,
            slice_colors: SliceColorCache::default(),
        }
    }

    /// The renderer itself.
    pub fn renderer(&self) -> &dyn Renderer {
        self.renderer.as_ref()
    }

    /// The per-frame step of the streaming renderer, before drawing: takes in what earlier
    /// frames' rays asked for and used (read back without waiting), loads on worker threads,
    /// uploads within the frame's budget. `None` for the other renderers (nothing to stream).
    /// Never waits on I/O or the GPU.
    pub fn update(&mut self, context: &GpuContext) -> Option<StreamStatus> {
        self.renderer.update(context)
    }

    /// What streams this renderer's bricks ([`Renderer::streamer`]), where it streams.
    pub fn streamer(&self) -> Option<&Streamer> {
        self.renderer.streamer()
    }

    /// [`Self::streamer`], to steer.
    pub fn streamer_mut(&mut self) -> Option<&mut Streamer> {
        self.renderer.streamer_mut()
    }

    /// A streaming renderer's always-resident levels read ([`Renderer::read_pinned`]);
    /// nothing for the others.
    pub fn read_pinned(&mut self) -> Result<(), RenderError> {
        self.renderer.read_pinned()
    }

    /// Gives a composite's channels their tables and colors, `shown` those drawn
    /// ([`Renderer::set_channels`]).
    pub fn set_channels(
        &self,
        context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        shown: &[bool],
    ) -> Result<(), RenderError> {
        self.renderer.set_channels(context, layers, shown)
    }

    /// What frames of max level `max_level` draw with this renderer.
    pub fn level_detail(&self, max_level: u32) -> LevelDetail {
        self.renderer.level_detail(max_level)
    }

    /// Which renderer this is.
    pub fn kind(&self) -> RendererKind {
        self.renderer.kind()
    }

    /// Applies a new transfer function: writes the lookup table and, for the octree and
    /// bricks, records the GPU recolor into `encoder` (topology untouched).
    pub fn set_transfer(
        &mut self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        self.renderer
            .set_transfer(context, encoder, transfer, timestamp_writes)
    }

    /// Records one frame into `encoder`. Frames of several renderers and targets may share an
    /// encoder: each carries its own parameters. (The lookup table is the volume's: a
    /// [`Self::set_transfer`] between two frames of one encoder applies to both.)
    pub fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        self.renderer
            .encode(context, encoder, target, camera, settings, timestamp_writes);
    }

    /// Records the pixels `pass.region` of one frame into `encoder` (the rest of its target
    /// keeps what it holds): a slow device's frame drawn band by band. A renderer that draws
    /// whole frames only ([`Self::draws_regions`] false) draws all of it.
    pub fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    ) {
        self.renderer.encode_region(context, encoder, pass);
    }

    /// Whether [`Self::encode_region`] draws its region alone (every renderer but the
    /// streaming one, whose rays' requests are a whole frame's).
    pub fn draws_regions(&self) -> bool {
        self.renderer.draws_regions()
    }

    /// Builds, where not built yet, the device's pipelines this renderer draws `settings` with
    /// (the shaded or clipped variants where they shade or clip) and, with `probe`, its probe
    /// pipelines: so that a caller that knows its settings compiles them where it likes (the
    /// app's loading thread) rather than at the first frame that needs them.
    pub fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        self.renderer.prepare_pipelines(context, settings, probe);
    }

    /// Records the probe of one pixel ([`super::GpuProbe`]); `false` where this renderer has
    /// no probe (every renderer has one now; the trait keeps the answer for one without).
    pub(crate) fn encode_probe(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        probe: &ProbeTarget<'_>,
    ) -> bool {
        self.renderer.encode_probe(context, encoder, probe)
    }

    /// Records and submits one frame.
    pub fn render(
        &self,
        context: &GpuContext,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
    ) {
        self.renderer.render(context, target, camera, settings);
    }

    /// Records one planar slice of the volume into `target` (see [`super::SliceFrame`]): the
    /// value at each pixel's point, from what this renderer holds (the dense texture; the
    /// bricks' cell grid and atlas; the octree's leaves), through `settings`' window and
    /// colormap, opaque; transparent black outside the volume. The slice pipeline is built on
    /// the device's first slice. A color table is made once per window and colormap (the
    /// last four are kept, for views with windows of their own); slices of several windows may
    /// share an encoder. The streaming renderer and the composite record nothing ([`Self::has_slices`]).
    pub fn encode_slice(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
        settings: &SliceSettings,
    ) {
        let Some(source) = self.slice_source() else {
            return;
        };
        let colors = self.slice_colors.get(
            context,
            self.quantization,
            settings.window,
            settings.colormap,
        );
        context
            .slicer()
            .encode(context, encoder, &source, &colors, target, settings);
    }

    /// Whether [`Self::encode_slice`] draws: every renderer of one in-memory volume; not the
    /// streaming renderer yet (its slices would need the slice shader to read the page table)
    /// nor the composite.
    pub fn has_slices(&self) -> bool {
        self.slice_source().is_some()
    }

    /// Records and submits one slice ([`Self::encode_slice`]).
    pub fn render_slice(
        &self,
        context: &GpuContext,
        target: &RenderTarget,
        settings: &SliceSettings,
    ) {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::slice"),
            });
        self.encode_slice(context, &mut encoder, target, settings);
        context.queue.submit([encoder.finish()]);
    }

    /// Whether slices show every voxel's own value: true unless the octree is on the GPU only
    /// down to a level above the voxels (a device too small for all of it), where a slice
    /// shows the middle of each deepest node's value range.
    pub fn exact_slices(&self) -> bool {
        self.slice_source().is_some_and(|source| source.is_exact())
    }

    fn slice_source(&self) -> Option<SliceSource<'_>> {
        self.renderer.slice_source()
    }

    /// GPU memory of each of this renderer's buffers and textures, by name.
    pub fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        let mut bytes = self.renderer.gpu_bytes();
        let slice_colors = self.slice_colors.gpu_bytes();
        if slice_colors > 0 {
            bytes.push(("slice_colors", slice_colors));
        }
        bytes
    }
}
