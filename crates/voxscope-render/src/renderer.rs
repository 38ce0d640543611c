//! One interface for every renderer: a volume uploaded for one way of drawing it (the octree,
//! dense, bricks, the streaming renderer, the composite of channels) is a [`Renderer`]. The
//! app's panes, `render`, `bench`, the probe and the tests draw, probe, recolor, measure and
//! drive any of them through it ([`super::VolumeRenderer`] holds one), so what differs
//! between renderers lives in their own files and nothing above dispatches on the kind.
//!
//! The pipelines a renderer draws with are the device's ([`GpuContext`]'s cache); a renderer
//! holds its volume's buffers and textures alone.

use voxscope_octree::TransferFunction;
use voxscope_stream::{AtlasZero, StreamStatus, Streamer, UploadPath};

use super::pipeline::Variant;
use super::raycaster::{
    Frame, ProbeTarget, RayPass, VolumeShape, encode_frame_region, frame_variant, probe_variant,
};
use super::slice::SliceSource;
use super::{
    Camera, ChannelLayer, GpuContext, ImageRegion, LevelDetail, RenderError, RenderSettings,
    RenderTarget, RendererKind,
};

/// What a frame (or a part of one) is drawn into and with: the target, camera and settings,
/// the pixels asked for, and where the pass's GPU timestamps go.
pub struct FramePass<'a> {
    pub target: &'a RenderTarget,
    pub camera: &'a Camera,
    pub settings: &'a RenderSettings,
    pub region: ImageRegion,
    pub timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'a>>,
}

impl<'a> FramePass<'a> {
    /// The whole of `target`.
    pub fn whole(
        target: &'a RenderTarget,
        camera: &'a Camera,
        settings: &'a RenderSettings,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'a>>,
    ) -> Self {
        Self {
            target,
            camera,
            settings,
            region: ImageRegion::whole(target.width, target.height),
            timestamp_writes,
        }
    }

    /// This pass over the whole target, whatever region it asked for (a renderer that draws
    /// whole frames only).
    pub fn of_whole_target(self) -> Self {
        Self {
            region: ImageRegion::whole(self.target.width, self.target.height),
            ..self
        }
    }

    /// Records this pass of `volume` with the ray caster `caster` into `encoder`: what every
    /// renderer's [`Renderer::encode_region`] shares.
    pub(crate) fn encode_with<V: VolumeShape, P: RayPass<V>>(
        self,
        caster: &P,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        volume: &V,
    ) {
        let frame = Frame {
            volume,
            target: self.target,
            camera: self.camera,
            settings: self.settings,
        };
        encode_frame_region(
            caster,
            context,
            encoder,
            &frame,
            self.region,
            self.timestamp_writes,
        );
    }
}

/// A volume on the GPU that frames are drawn from.
pub trait Renderer: Send {
    /// Which renderer this is.
    fn kind(&self) -> RendererKind;

    /// What frames of max level `max_level` draw (what the app's Octree panel says under the
    /// max-level slider).
    fn level_detail(&self, max_level: u32) -> LevelDetail;

    /// Records one frame into `encoder`, its parameters in a buffer of its own, so frames of
    /// several renderers and targets may share an encoder.
    fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let pass = FramePass::whole(target, camera, settings, timestamp_writes);
        self.encode_region(context, encoder, pass);
    }

    /// Records the pixels `pass.region` of one frame ([`Self::encode`] of a part of the
    /// image; the rest of the target keeps what it holds), for a caller that draws a slow
    /// frame in parts so that no submission keeps the device busy for long. A renderer that
    /// draws whole frames only ([`Self::draws_regions`] false: the streaming renderer, whose
    /// rays' requests and usage marks are a frame's) draws all of it. Each renderer names its
    /// ray caster and [`FramePass::encode_with`] does the rest.
    fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    );

    /// Whether [`Self::encode_region`] draws its region alone.
    fn draws_regions(&self) -> bool {
        false
    }

    /// Records and submits one frame ([`Self::encode`] in an encoder of its own).
    fn render(
        &self,
        context: &GpuContext,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
    ) {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::frame"),
            });
        self.encode(context, &mut encoder, target, camera, settings, None);
        context.queue.submit([encoder.finish()]);
    }

    /// Records the probe of one pixel (one ray of the frame `probe` describes, its answer
    /// written to `probe.output`); `false` where this renderer has no probe.
    fn encode_probe(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        probe: &ProbeTarget<'_>,
    ) -> bool;

    /// Applies a new transfer function: writes the lookup table and records whatever else it
    /// takes (the octree's recolor) into `encoder`.
    fn set_transfer(
        &mut self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError>;

    /// Builds, where not built yet, the device's pipelines that frames with `settings` (and,
    /// with `probe`, their probes) need: so that a caller compiles them where it likes (the
    /// app's loading thread) rather than at the first frame.
    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool);

    /// GPU memory of each buffer and texture, by name.
    fn gpu_bytes(&self) -> Vec<(&'static str, u64)>;

    /// What slices read, where this renderer holds every voxel (not the streaming renderer
    /// nor the composite yet).
    fn slice_source(&self) -> Option<SliceSource<'_>> {
        None
    }

    /// The per-frame step of the streaming renderer, before drawing (see
    /// [`StreamVolume::step`]); `None` for the renderers that need none. Never waits.
    fn update(&mut self, _context: &GpuContext) -> Option<StreamStatus> {
        None
    }

    /// What streams this renderer's bricks through its GPU budget (the pyramid's shape, the
    /// counters, the RAM cache, the bricks that failed, the budget's cut, the source), where
    /// it streams; `None` for the renderers that hold every voxel on the GPU.
    fn streamer(&self) -> Option<&Streamer> {
        None
    }

    /// [`Self::streamer`], to steer: prefetch into, apply a cut, change when uploads go.
    fn streamer_mut(&mut self) -> Option<&mut Streamer> {
        None
    }

    /// Reads the levels a streaming renderer keeps resident (once, after it is made; the
    /// first [`Self::update`] uploads them). Nothing for the others, which hold every voxel.
    fn read_pinned(&mut self) -> Result<(), RenderError> {
        Ok(())
    }

    /// How a streaming renderer's uploads and frames go (what `bench` reports beside its
    /// timings); `None` for the others.
    fn stream_paths(&self) -> Option<StreamPaths> {
        None
    }

    /// How many channels frames composite: 1 but for the composite.
    fn channel_count(&self) -> usize {
        1
    }

    /// Gives each channel of a renderer of several its transfer function and color
    /// (`layers`, as many as [`Self::channel_count`]; their values are not read again) and
    /// shows those `shown` marks (a hidden one adds nothing and hides nothing). A renderer of
    /// one channel takes its transfer function through [`Self::set_transfer`] and refuses.
    fn set_channels(
        &self,
        _context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        shown: &[bool],
    ) -> Result<(), RenderError> {
        Err(RenderError::Invalid(format!(
            "the {} renderer draws one channel, not {} ({} shown)",
            self.kind().name(),
            layers.len(),
            shown.iter().filter(|&&s| s).count()
        )))
    }

    /// Of the blocks empty-space skipping divides the volume into, how many frames march
    /// (some shown channel is visible there) and how many there are: the composite's.
    fn skipped_blocks(&self) -> Option<(usize, usize)> {
        None
    }
}

/// How a streaming renderer's uploads and frames go: the path uploads take, how the atlas
/// was zeroed, how many frames the level walk drew, and its state (`StreamVolume`'s
/// `walk_level_state`: finest level copied flat, how many levels, bricks it could not take).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamPaths {
    pub upload_path: UploadPath,
    pub atlas_zero: AtlasZero,
    pub level_walk_frames: u64,
    pub walk_level: Option<(u32, u32, usize)>,
}

/// What frames of max level `max_level` draw of a volume of `depth` levels and `dims` voxels
/// that samples pyramid level `sampled` there (0: its own nodes or every voxel).
pub(crate) fn level_detail(
    depth: u32,
    dims: [usize; 3],
    sampled: u32,
    max_level: u32,
) -> LevelDetail {
    if max_level >= depth {
        LevelDetail::Full
    } else if sampled > 0 {
        LevelDetail::Pyramid {
            level: sampled,
            dims: dims.map(|d| d.div_ceil(1 << sampled)),
        }
    } else {
        LevelDetail::Nodes { level: max_level }
    }
}

/// The pipeline variants frames with `settings` draw with (and, with `probe`, probe with);
/// `coarse` where they sample a coarser pyramid level, `labels` for a label volume.
pub(crate) fn pipeline_variants(
    settings: &RenderSettings,
    probe: bool,
    coarse: bool,
    labels: bool,
) -> Vec<Variant> {
    let mut variants = vec![frame_variant(settings)];
    if probe {
        variants.push(probe_variant(settings));
    }
    for variant in &mut variants {
        variant.coarse = coarse;
        variant.labels = labels;
    }
    variants
}
