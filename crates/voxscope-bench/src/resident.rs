//! The streaming benchmark's last figures: the streaming renderer once everything a view
//! needs is resident, against the in-memory bricks renderer on the same views.

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::json;

use voxscope_octree::{BuildOptions, TransferFunction};
use voxscope_render::{
    Camera, GpuContext, GpuTimer, RenderMode, RenderSettings, RenderTarget, RendererKind,
    RendererOptions, Shading, VolumeRenderer, WarmUp, time_passes, warm_up,
};
use voxscope_scene::{StreamedVolume, refine};
use voxscope_stream::{Downsampling, MemorySource, StreamOptions, preview};

use crate::error::BenchError;
use crate::options::{BenchOptions, CAMERAS, MAX_WAIT};
use crate::resident_channels::{ChannelBench, resident_channels};
use crate::stats::percentile;

/// Bricks of the level read into memory for the comparison with the bricks renderer when the
/// pyramid is not in memory (512³ voxels).
const RESIDENT_BRICKS: u64 = 4096;

/// The streaming renderer, once everything a view needs is resident, against the bricks
/// renderer of the same volume in memory on the same views: the pyramid's finest level of at
/// most 512³ voxels (the whole volume when it is that small), both at full detail; then the
/// streaming renderer with the options' pixel LOD (`lod_scale` in the rows) beside the same
/// bricks renderer's figures.
pub fn resident_comparison(
    context: &GpuContext,
    options: &BenchOptions,
    prepared: &StreamedVolume,
    target: &RenderTarget,
    stream_options: StreamOptions,
    timer: Option<&GpuTimer>,
) -> Result<serde_json::Value, BenchError> {
    let ResidentLevel {
        bricks,
        source,
        dims,
        level,
        depth,
        values,
    } = ResidentLevel::read(context, prepared)?;
    let transfer: TransferFunction = prepared.transfer;
    let mut rows = Vec::new();
    // At full detail (no pixel LOD), as the bricks renderer draws; then, where the options ask
    // for it, with their pixel LOD (its far parts coarser: fewer samples than the bricks
    // renderer's, and rays that may want two levels).
    let lod_scales = if stream_options.lod_scale > 0.0 {
        vec![0.0, stream_options.lod_scale]
    } else {
        vec![0.0]
    };
    for lod_scale in lod_scales {
        let mut stream = VolumeRenderer::new_stream(
            context,
            source.clone(),
            StreamOptions {
                lod_scale,
                ..stream_options
            },
            &transfer,
        )?;
        for (mode_name, mode) in [("dvr-gray", RenderMode::Dvr), ("mip", RenderMode::Mip)] {
            let settings = RenderSettings {
                mode,
                density: options.density,
                shading: Shading::OFF,
                ..RenderSettings::full_detail(depth)
            };
            for (camera_name, distance) in CAMERAS {
                let camera = options.camera(distance);
                let refinement = refine(context, &mut stream, target, &camera, &settings, MAX_WAIT)
                    .map_err(BenchError::Scene)?;
                // What a window does next: it keeps updating while the streamer fills the level
                // every ray wants (or the two), after which frames walk it (`main_level`,
                // `main_levels`).
                let (filled, loaders_busy) =
                    settle_fill(context, &mut stream, target, &camera, &settings)?;
                let walked_before = stream
                    .renderer()
                    .stream_paths()
                    .map_or(0, |p| p.level_walk_frames);
                let stream_times = time_view(
                    context,
                    &stream,
                    target,
                    &camera,
                    &settings,
                    options.frames,
                    timer,
                )?;
                let walked = stream
                    .renderer()
                    .stream_paths()
                    .map_or(0, |p| p.level_walk_frames)
                    - walked_before;
                let walked_levels = stream
                    .renderer()
                    .stream_paths()
                    .and_then(|p| p.walk_level)
                    .map_or(0, |(_, levels, unwalkable)| {
                        levels * u32::from(unwalkable == 0)
                    });
                let bricks_times = time_view(
                    context,
                    &bricks,
                    target,
                    &camera,
                    &settings,
                    options.frames,
                    timer,
                )?;
                let (stream_gpu, bricks_gpu) = (&stream_times.gpu, &bricks_times.gpu);
                let (stream_ms, bricks_ms) =
                    (percentile(stream_gpu, 50.0), percentile(bricks_gpu, 50.0));
                let warm_up_s = [stream_times.warmed, bricks_times.warmed]
                    .map(|warmed| warmed.steady.then_some(warmed.seconds));
                rows.push(json!({
                    "mode": mode_name,
                    "camera": camera_name,
                    "lod_scale": lod_scale,
                    "complete": refinement.complete,
                    "level_filled": filled,
                    // Bricks still queued or loading when the timing began (0: the loaders idle).
                    "loaders_busy": loaders_busy,
                    "level_walk_frames": walked,
                    // How many levels the timed frames walked (0: segment by segment).
                    "walked_levels": if walked > 0 { walked_levels } else { 0 },
                    "stream_gpu_ms": stream_ms,
                    "stream_gpu_p95_ms": percentile(stream_gpu, 95.0),
                    // The first and second half's medians: a GPU whose clocks rise during the
                    // frames shows the first one higher.
                    "stream_gpu_halves_ms": halves(stream_gpu),
                    // Seconds each renderer's warm-up took until its frames' time was steady
                    // (null: it gave up at the limit).
                    "warm_up_s": warm_up_s,
                    "bricks_gpu_ms": bricks_ms,
                    "bricks_gpu_p95_ms": percentile(bricks_gpu, 95.0),
                    "stream_over_bricks": stream_ms / bricks_ms,
                    "stream_wall_ms_per_frame": stream_times.wall,
                    "bricks_wall_ms_per_frame": bricks_times.wall,
                }));
            }
        }
    }
    // The same level as N channels streamed together (`--composite-channels`).
    let channels = if options.composite_channels.is_empty() {
        serde_json::Value::Null
    } else {
        let bench = ChannelBench {
            context,
            options,
            target,
            timer,
            source: source.clone(),
            quantized: &values,
            transfer,
            depth,
        };
        resident_channels(&bench, stream_options, &options.composite_channels)?
    };
    Ok(json!({
        "dims": dims,
        "pyramid_level": level,
        "rows": rows,
        "channels": channels,
    }))
}

/// The pyramid level compared, in memory: drawn by the bricks renderer, and as the streaming
/// renderer's source.
struct ResidentLevel {
    bricks: VolumeRenderer,
    source: Arc<dyn voxscope_stream::BrickSource>,
    dims: [usize; 3],
    /// Its level in the pyramid.
    level: usize,
    /// Its octree's depth.
    depth: u32,
    /// Its quantization (its levels are the source's now).
    values: voxscope_volume::QuantizedVolume,
}

impl ResidentLevel {
    /// The finest level of `prepared`'s pyramid within [`RESIDENT_BRICKS`], read, its octree
    /// built for the bricks renderer and its voxels handed to a source in memory.
    fn read(context: &GpuContext, prepared: &StreamedVolume) -> Result<Self, BenchError> {
        let (mut volume, level) =
            preview(&*prepared.source, RESIDENT_BRICKS).map_err(|error| BenchError::Preview {
                volume: prepared.source.name().to_owned(),
                error,
            })?;
        let scale = prepared.source.shape().levels[level].scale as f64;
        let spacing = prepared.source.spacing().map(|s| s * scale);
        let mut octree =
            voxscope_octree::build(&volume, BuildOptions::default()).map_err(|error| {
                BenchError::Build {
                    volume: prepared.source.name().to_owned(),
                    error,
                }
            })?;
        let transfer = prepared.transfer;
        voxscope_octree::recolor(&mut octree, &transfer);
        let bricks = VolumeRenderer::new(
            context,
            RendererOptions {
                kind: RendererKind::Bricks,
                brick_size: 32,
                ..Default::default()
            },
            &octree,
            &volume,
            spacing,
            octree.depth,
            &transfer,
        )?;
        // The bricks renderer holds its own copy on the GPU: the octree and the voxels in RAM go
        // now (the voxels to the streaming renderer's source), not kept twice.
        let depth = octree.depth;
        drop(octree);
        let source: Arc<dyn voxscope_stream::BrickSource> = Arc::new(
            MemorySource::from_levels(
                "resident",
                std::mem::take(&mut volume.levels),
                volume.dims,
                volume.quantization,
                spacing,
                Downsampling::Mean,
            )
            // One line naming the pyramid, whatever the source's error type.
            .map_err(|e| BenchError::Pyramid(e.to_string()))?,
        );
        Ok(Self {
            bricks,
            source,
            dims: volume.dims,
            level,
            depth,
            values: volume,
        })
    }
}

/// The medians of the first and the second half of `values` (of a single value, it twice).
fn halves(values: &[f64]) -> [f64; 2] {
    let (first, second) = values.split_at(values.len() / 2);
    let first = if first.is_empty() { second } else { first };
    [percentile(first, 50.0), percentile(second, 50.0)]
}

/// Updates `stream` on one view until its level fill is done and its loaders are idle (at
/// most [`MAX_WAIT`]), drawing only when an update changed what frames draw, as a window does;
/// returns the bricks placed, and how many were still queued or loading at the end (loaders
/// busy on the CPU while the GPU is timed slow its frames' submission).
fn settle_fill(
    context: &GpuContext,
    stream: &mut VolumeRenderer,
    target: &RenderTarget,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<(u64, usize), BenchError> {
    let started = Instant::now();
    let before = stream
        .streamer()
        .map_or(0, |s| s.resident_keys().count() as u64);
    let busy = loop {
        let status = stream.update(context).ok_or(BenchError::NotStreaming)?;
        let busy = status.queued + status.loading;
        if (status.filling == 0 && status.uploads == 0 && status.complete && busy == 0)
            || started.elapsed() >= MAX_WAIT
        {
            break busy;
        }
        // A window draws again only when the update changed what frames draw.
        if status.uploads > 0 || status.table_changed {
            stream.render(context, target, camera, settings);
            context.wait_idle()?;
        } else {
            std::thread::sleep(Duration::from_millis(1));
        }
    };
    let after = stream
        .streamer()
        .map_or(0, |s| s.resident_keys().count() as u64);
    Ok((after.saturating_sub(before), busy))
}

/// What [`time_view`] measured.
pub(crate) struct ViewTimes {
    /// GPU milliseconds of each frame.
    pub gpu: Vec<f64>,
    /// Wall milliseconds per frame of a batch of them as an app sees it (encode, submit, and the
    /// GPU's completion).
    wall: f64,
    /// The warm-up before them.
    warmed: WarmUp,
}

/// GPU milliseconds of `frames` frames of one fixed view, after [`warm_up`], and the wall time
/// per frame of a batch of them.
pub(crate) fn time_view(
    context: &GpuContext,
    renderer: &VolumeRenderer,
    target: &RenderTarget,
    camera: &Camera,
    settings: &RenderSettings,
    frames: u32,
    timer: Option<&GpuTimer>,
) -> Result<ViewTimes, BenchError> {
    let submit = |writes| {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::bench_resident_frame"),
            });
        renderer.encode(context, &mut encoder, target, camera, settings, writes);
        context.queue.submit([encoder.finish()]);
    };
    // Until the frames' time is steady: the GPU idled at low clocks while the level filled.
    let warmed = warm_up(context, timer, |_, writes| submit(writes))?;
    let started = Instant::now();
    for _ in 0..frames {
        submit(None);
    }
    context.wait_idle()?;
    let wall = started.elapsed().as_secs_f64() * 1e3 / frames.max(1) as f64;
    let gpu = time_passes(context, timer, frames, |_, writes| submit(writes))?;
    Ok(ViewTimes { gpu, wall, warmed })
}
