//! A volume ready to look at: its data and the renderer drawing it, made by [`upload`] (and
//! [`crate::prepare_scene`], which loads first).

use std::sync::Arc;
use std::time::Instant;

use voxscope_octree::{self as octree, Clip, LevelStatistics, TransferFunction};
use voxscope_render::{GpuContext, RendererKind, RendererOptions, VolumeRenderer};
use voxscope_stream::{BrickSource, StreamOptions, StreamStatus, ZarrSource};
use voxscope_volume::ome_zarr::Pyramid;
use voxscope_volume::progress::Progress;
use voxscope_volume::remote::{RemoteOptions, RemoteStats};

use crate::{CompositeScene, Job, SceneError, VolumeData};

/// Bricks of the finest coarse level a streamed store's first frames draw, read before they
/// are asked for (`ZarrSource::warm_first_image`; the command line's preview reads as many).
pub(crate) const FIRST_IMAGE_BRICKS: u64 = 64;

/// A volume on screen: its data and the renderer drawing it.
pub struct Scene {
    pub data: Arc<VolumeData>,
    pub renderer: VolumeRenderer,
    pub options: RendererOptions,
    /// The transfer function the renderer's colors currently follow.
    pub applied_transfer: TransferFunction,
    /// Wall time of the last upload.
    pub upload_seconds: f64,
    /// The streaming renderer's latest update (`None` for the other renderers).
    pub stream_status: Option<StreamStatus>,
    /// The network store a streamed URL reads from, as last sampled.
    pub network: Option<NetworkState>,
    /// The composite of every channel, which the 3D views draw (a multi-channel file shown
    /// as "All (composite)"); `None` when one channel is shown.
    pub composite: Option<CompositeScene>,
}

/// What a streamed URL's store has done, and its recent rate.
#[derive(Debug, Clone, Copy)]
pub struct NetworkState {
    pub stats: RemoteStats,
    /// Bytes received a second over the last half second or more.
    pub bytes_per_s: f64,
    sampled_at: Instant,
    sampled_bytes: u64,
}

impl NetworkState {
    /// The state after `stats`, read now, following `previous`.
    pub fn follow(previous: Option<NetworkState>, stats: RemoteStats) -> Self {
        let now = Instant::now();
        match previous {
            Some(previous) if now.duration_since(previous.sampled_at).as_secs_f64() < 0.5 => {
                Self { stats, ..previous }
            }
            Some(previous) => {
                let seconds = now.duration_since(previous.sampled_at).as_secs_f64();
                Self {
                    stats,
                    bytes_per_s: stats.bytes.saturating_sub(previous.sampled_bytes) as f64
                        / seconds,
                    sampled_at: now,
                    sampled_bytes: stats.bytes,
                }
            }
            None => Self {
                stats,
                bytes_per_s: 0.0,
                sampled_at: now,
                sampled_bytes: stats.bytes,
            },
        }
    }
}

impl Scene {
    /// Bytes this scene holds on the GPU and in memory (what a prefetched frame costs).
    pub fn bytes(&self) -> u64 {
        let gpu: u64 = self.renderer.gpu_bytes().iter().map(|(_, b)| b).sum();
        let composite = self
            .composite
            .as_ref()
            .map_or(self.data.cpu_bytes(), |c| c.gpu_bytes() + c.cpu_bytes());
        gpu + composite
    }

    /// Recolors the renderer on the GPU to [`Self::applied_transfer`] (one submission): the
    /// octree's CPU colors may follow another transfer function (the load's), and the bricks
    /// renderer's coarse colors are the GPU recolor's (a brick's voxels averaged).
    pub fn recolor(&mut self, gpu: &GpuContext) -> Result<(), SceneError> {
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::scene_recolor"),
            });
        let transfer = self.applied_transfer;
        self.renderer
            .set_transfer(gpu, &mut encoder, &transfer, None)
            .map_err(|e| SceneError::render(&self.data.volume.name, e))?;
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// The renderer the 3D views draw: the composite where one is shown, else the volume's.
    pub fn view_renderer(&self) -> &VolumeRenderer {
        self.composite.as_ref().map_or(&self.renderer, |composite| {
            composite.renderer(&self.renderer)
        })
    }

    /// The deepest max level: the octree's depth, or the streamed pyramid's (a streamed
    /// OME-Zarr store is finer than the level held in memory for the panels).
    pub fn depth(&self) -> u32 {
        self.renderer
            .streamer()
            .map_or(self.data.octree.depth, |s| s.shape().depth())
    }

    /// Per axis, the view's voxels (the volume in memory) per voxel of the renderer: 1 but for
    /// a streamed OME-Zarr store, whose full resolution is finer than the level in memory.
    pub fn voxel_scale(&self) -> [f64; 3] {
        let Some(streamer) = self.renderer.streamer() else {
            return [1.0; 3];
        };
        let streamed = streamer.shape().dims();
        std::array::from_fn(|a| self.data.volume.dims[a] as f64 / streamed[a] as f64)
    }
}

/// Uploads `data` for the renderer `options` names, colored by `transfer` (recolored on the
/// GPU: `data.octree`'s colors may follow another transfer function).
pub fn upload(
    data: Arc<VolumeData>,
    gpu: &GpuContext,
    options: RendererOptions,
    transfer: TransferFunction,
    progress: &Progress,
) -> Result<Scene, SceneError> {
    upload_colored(data, gpu, options, transfer, OctreeColors::Other, progress)
}

/// What `data.octree`'s colors follow, for [`upload_colored`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OctreeColors {
    /// The transfer function uploaded, or the caller recolors the scene's renderer
    /// (`set_transfer` to its `applied_transfer`) before drawing it: nothing recolored or
    /// submitted here.
    Uploaded,
    /// Another one (or not known): recolored on the GPU, one submission.
    Other,
}

/// [`upload`], recoloring only where `colors` says the octree's colors are another transfer
/// function's. A job thread of the app submits nothing to the window's device, as a
/// submission while its surface is configured fails the configuration (docs/architecture.md):
/// its open and renderer-switch jobs leave the recolor to the UI thread.
pub fn upload_colored(
    data: Arc<VolumeData>,
    gpu: &GpuContext,
    options: RendererOptions,
    transfer: TransferFunction,
    colors: OctreeColors,
    progress: &Progress,
) -> Result<Scene, SceneError> {
    progress.begin("uploading to the GPU");
    let started = Instant::now();
    let failed = |e| SceneError::render(&data.volume.name, e);
    let stream = StreamOptions {
        gpu_memory: options.gpu_memory,
        ..StreamOptions::default()
    };
    let renderer = match (&data.pyramid, data.source.zarr_spec()) {
        // A volume longer than the octree holds streams from its pyramid in memory.
        (Some(pyramid), _) if options.kind == RendererKind::Stream => {
            let pyramid: Arc<dyn BrickSource> = pyramid.clone();
            VolumeRenderer::new_stream(gpu, pyramid, stream, &transfer).map_err(failed)?
        }
        // A Zarr store streams from the file (or the URL), at its own full resolution.
        (_, Some(spec)) if options.kind == RendererKind::Stream => {
            let pyramid =
                Pyramid::open_spec(spec, data.volume.series.selected, RemoteOptions::default())?;
            let source = ZarrSource::new(Arc::new(pyramid))?.of_labels(data.kind.is_labels());
            let source = Arc::new(source);
            // The coarse levels the first frames draw, their chunks fetched together (a URL's
            // round trips) on a thread of their own, while this loading thread makes the
            // renderer; then it reads the always-resident ones from those chunks.
            let mut renderer = source
                .warm_first_image_while(FIRST_IMAGE_BRICKS, || {
                    VolumeRenderer::new_stream_unread(gpu, source.clone(), stream, &transfer)
                })
                .map_err(failed)?;
            renderer.read_pinned().map_err(failed)?;
            renderer
        }
        _ => VolumeRenderer::new(
            gpu,
            options,
            &data.octree,
            &data.quantized,
            data.volume.spacing,
            data.octree.depth,
            &transfer,
        )
        .map_err(failed)?,
    };
    let mut scene = Scene {
        data,
        renderer,
        options,
        applied_transfer: transfer,
        upload_seconds: started.elapsed().as_secs_f64(),
        stream_status: None,
        network: None,
        composite: None,
    };
    // The CPU colors of `data.octree` follow the transfer function of the load, which may not
    // be `transfer` (after a renderer switch): recolor on the GPU so the scene matches it.
    if colors == OctreeColors::Other {
        scene.recolor(gpu)?;
    }
    Ok(scene)
}

/// Per-level statistics counted under a transfer function, within a clip.
pub type Counted = (TransferFunction, Clip, Vec<LevelStatistics>);

/// Per-level statistics under `transfer` within `clip`, on another thread.
pub fn statistics_job(
    data: Arc<VolumeData>,
    transfer: TransferFunction,
    clip: Clip,
    wake: impl Fn() + Send + 'static,
) -> Job<Counted> {
    Job::spawn("counting nodes".into(), wake, move |_| {
        Ok((
            transfer,
            clip,
            octree::level_statistics_within(&data.octree, &transfer, &clip),
        ))
    })
}
