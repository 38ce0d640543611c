//! A volume ready to look at, and the background jobs that make one: load, quantize, build
//! the octree, color it, upload it. Nothing here blocks the UI thread.

use std::sync::Arc;
use std::time::Instant;

use super::channels::{ChannelState, CompositeScene};
use super::jobs::{Counted, Job, JobError, Opened};
use super::settings::TransferChoice;
use voxscope_octree::{
    self, BuildOptions, Clip, Colormap, DataKind, MAX_DEPTH, Octree, Preset, TransferFunction,
    default_transfer,
};
use voxscope_render::{GpuContext, RendererKind, RendererOptions, VolumeRenderer};
use voxscope_stream::{
    BrickSource, Downsampling, MemorySource, StreamOptions, StreamStatus, ZarrSource,
};
use voxscope_volume::ome_zarr::{self, Pyramid, VOLUME_VOXEL_BUDGET};
use voxscope_volume::progress::Progress;
use voxscope_volume::remote::{RemoteOptions, RemoteStats};
use voxscope_volume::{
    self, LoadOptions, MAX_CHANNELS, QuantizedVolume, Selection, ValueScale, ValueWindow, Volume,
    VoxelData,
};

/// What to open: the embedded sample or a file path / synthetic spec.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VolumeSource {
    Sample,
    Spec(String),
}

impl VolumeSource {
    /// The spec as the command line and the recent list write it (`sample` for the sample).
    pub fn spec(&self) -> &str {
        match self {
            Self::Sample => "sample",
            Self::Spec(spec) => spec,
        }
    }

    /// The inverse of [`Self::spec`].
    pub fn from_spec(spec: &str) -> Self {
        if spec == "sample" {
            Self::Sample
        } else {
            Self::Spec(spec.to_owned())
        }
    }

    /// The Zarr store this source names (a folder or a URL), if it names one.
    pub fn zarr_spec(&self) -> Option<&str> {
        match self {
            Self::Sample => None,
            Self::Spec(spec) => Some(spec.as_str()).filter(|s| ome_zarr::is_zarr_spec(s)),
        }
    }

    fn load(&self, select: Selection) -> Result<Volume, JobError> {
        match self {
            Self::Sample => voxscope_volume::sample(),
            Self::Spec(spec) => voxscope_volume::load(
                spec,
                &LoadOptions {
                    select,
                    ..LoadOptions::default()
                },
            ),
        }
        .map_err(|e| JobError::Failed(e.to_string()))
    }
}

/// A loaded volume's CPU side: what every renderer is made from, shared with jobs.
pub struct VolumeData {
    pub source: VolumeSource,
    /// The volume's description; its voxels are dropped once quantized.
    pub volume: Volume,
    pub quantized: QuantizedVolume,
    pub octree: Octree,
    /// The window the volume opened with: the file's own (OME-Zarr's omero) where it has one,
    /// else the robust (0.5–99.5 %) window.
    pub default_window: ValueWindow,
    /// Histogram of the values in [`HISTOGRAM_BINS`] bins over the value range.
    pub histogram: Vec<u64>,
    /// CT, labels, or other: what the presets and defaults follow.
    pub kind: DataKind,
    pub load_seconds: f64,
    /// The full-resolution pyramid of a volume in memory longer than the voxel octree holds
    /// (1024 voxels a side): the streaming renderer draws it, and `volume`, `quantized` and
    /// `octree` are its finest level within [`PANEL_LEVEL_VOXELS`], as for a large OME-Zarr
    /// store.
    pub pyramid: Option<Arc<MemorySource>>,
}

/// Bins of the histogram the transfer panel draws.
pub const HISTOGRAM_BINS: usize = 256;

impl VolumeData {
    /// The value of `voxel` in the data's units, from the quantized levels the GPU holds
    /// (exact for integer data spanning up to 65 536 values; within half a level step, a
    /// 65 535th of the range, otherwise).
    pub fn value_at(&self, voxel: [usize; 3]) -> Option<f64> {
        let [x, y, z] = voxel;
        let dims = self.quantized.dims;
        if x >= dims[0] || y >= dims[1] || z >= dims[2] {
            return None;
        }
        let level = *self.quantized.levels.get(x + dims[0] * (y + dims[1] * z))?;
        Some(self.quantized.quantization.value(level))
    }

    /// What the status bar says of `voxel`: its indices, position and value.
    pub fn describe_voxel(&self, voxel: [usize; 3]) -> Option<String> {
        let value = self.value_at(voxel)?;
        let spacing = self.volume.spacing;
        let unit = self.volume.spatial_unit();
        let value_unit = if self.kind == DataKind::Ct { " HU" } else { "" };
        let [i, j, k] = voxel;
        Some(format!(
            "voxel ({i}, {j}, {k}) · ({:.1}, {:.1}, {:.1}) {unit} · value {}{value_unit}",
            i as f64 * spacing[0],
            j as f64 * spacing[1],
            k as f64 * spacing[2],
            super::transfer_editor::format_value(value),
        ))
    }
    /// Bytes it holds in memory: the value levels and the octree's nodes.
    pub fn cpu_bytes(&self) -> u64 {
        (self.quantized.levels.len() * 2 + self.octree.nodes.len() * 8) as u64
    }

    /// The value at the center of histogram bin `bin`'s left edge.
    pub fn bin_value(&self, bin: f64) -> f64 {
        let [low, high] = self.quantized.value_range;
        low + (high - low) * bin / HISTOGRAM_BINS as f64
    }
}

fn display_histogram(quantized: &QuantizedVolume) -> Vec<u64> {
    let [low, high] = quantized.value_range;
    let span = (high - low).max(f64::MIN_POSITIVE);
    let mut bins = vec![0u64; HISTOGRAM_BINS];
    for (level, &count) in quantized.histogram.counts.iter().enumerate() {
        if count > 0 {
            let value = quantized.quantization.value(level as u16);
            let bin = ((value - low) / span * HISTOGRAM_BINS as f64) as usize;
            bins[bin.min(HISTOGRAM_BINS - 1)] += count;
        }
    }
    bins
}

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
        let composite = self.composite.as_ref().map_or(self.data.cpu_bytes(), |c| {
            c.volume.gpu_bytes() + c.cpu_bytes()
        });
        gpu + composite
    }

    /// The deepest max level: the octree's depth, or the streamed pyramid's (a streamed
    /// OME-Zarr store is finer than the level held in memory for the panels).
    pub fn depth(&self) -> u32 {
        self.renderer
            .stream()
            .map_or(self.data.octree.depth, |s| s.streamer().shape().depth())
    }

    /// Per axis, the view's voxels (the volume in memory) per voxel of the renderer: 1 but for
    /// a streamed OME-Zarr store, whose full resolution is finer than the level in memory.
    pub fn voxel_scale(&self) -> [f64; 3] {
        let Some(stream) = self.renderer.stream() else {
            return [1.0; 3];
        };
        let streamed = stream.streamer().shape().dims();
        std::array::from_fn(|a| self.data.volume.dims[a] as f64 / streamed[a] as f64)
    }
}

/// Bricks of the finest coarse level a streamed store's first frames draw, read before they
/// are asked for (`ZarrSource::warm_first_image`; the CLI's preview reads as many).
const FIRST_IMAGE_BRICKS: u64 = 64;

/// Voxels of the level the app reads whole beside a streamed OME-Zarr store, for what the
/// panels show (histogram, statistics, slices, probe values): 256³.
pub const PANEL_LEVEL_VOXELS: u64 = 1 << 24;

/// Another frame (channel and time point) of the volume on screen, shown with the transfer
/// function it has now (the camera, level and clipping stay as they are).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameChange {
    pub selection: Selection,
    pub transfer: TransferFunction,
    /// Every channel of the time point as the composite (`selection.channel` is then 0).
    pub composite: bool,
    /// The composite's channel settings as they are now (empty for one channel).
    pub channels: Vec<ChannelState>,
}

/// Loads `source` (the frame `frame` names, else the first) and prepares everything to draw
/// it with `options`: the job behind File ▸ Open, drops, recent files, the command line and
/// the channel and time controls.
pub fn prepare_scene(
    source: &VolumeSource,
    frame: Option<FrameChange>,
    choice: TransferChoice,
    gpu: &GpuContext,
    options: RendererOptions,
    progress: &Progress,
) -> Result<Opened, JobError> {
    let select = frame
        .as_ref()
        .map_or_else(Selection::default, |f| f.selection);
    // A multi-channel file opens as the composite of its channels.
    let composite_wanted = frame.as_ref().is_none_or(|f| f.composite);
    let started = Instant::now();
    progress.begin("reading");
    // An OME-Zarr store larger than the in-memory budget streams at full resolution; the panels
    // read a coarse level whole. (Opening the store twice costs its metadata alone.)
    let mut options = options;
    let streamed = match source.zarr_spec() {
        Some(spec) => {
            let pyramid = Pyramid::open_spec(spec, select, RemoteOptions::default())
                .map_err(|e| JobError::Failed(e.to_string()))?;
            let large = pyramid.levels[0].voxel_count() > VOLUME_VOXEL_BUDGET as u64;
            (large || options.kind == RendererKind::Stream).then_some(pyramid)
        }
        None => None,
    };
    let volume = match &streamed {
        Some(pyramid) => {
            options.kind = RendererKind::Stream;
            pyramid
                .level_volume(pyramid.finest_within(PANEL_LEVEL_VOXELS))
                .map_err(|e| JobError::Failed(e.to_string()))?
        }
        None => source.load(select)?,
    };
    progress.check()?;
    // A volume in memory longer than the voxel octree holds streams from a pyramid of its own.
    let (volume, pyramid) = if volume.dims.iter().any(|&d| d > 1 << MAX_DEPTH) {
        let (panel, pyramid) = in_memory_pyramid(volume, progress)?;
        options.kind = RendererKind::Stream;
        (panel, Some(pyramid))
    } else {
        (volume, None)
    };
    let channel_count = volume.series.channel_count();
    let composite = streamed.is_none()
        && pyramid.is_none()
        && composite_wanted
        && (2..=MAX_CHANNELS).contains(&channel_count);
    let mut data = prepare_data(source, volume, started, progress)?;
    data.pyramid = pyramid;
    // The other channels of a composite: read, quantized, built like the first.
    let mut channels = Vec::new();
    for channel in 1..if composite { channel_count } else { 0 } {
        let other = source.load(Selection { channel, ..select })?;
        channels.push(Arc::new(prepare_data(
            source,
            other,
            Instant::now(),
            progress,
        )?));
    }
    let states: Vec<ChannelState> = match &frame {
        Some(frame) if composite && frame.channels.len() == channel_count => frame.channels.clone(),
        _ if composite => std::iter::once(&data)
            .chain(channels.iter().map(Arc::as_ref))
            .enumerate()
            .map(|(index, data)| ChannelState::opening(data, index, choice))
            .collect(),
        _ => Vec::new(),
    };
    let transfer = match (&frame, states.first()) {
        (_, Some(first)) => first.transfer,
        (Some(frame), None) => frame.transfer,
        (None, None) => opening_transfer(choice, &data.quantized, data.kind, data.default_window),
    };
    progress.begin("coloring");
    voxscope_octree::recolor(&mut data.octree, &transfer);
    let statistics = voxscope_octree::level_statistics(&data.octree);
    data.load_seconds = started.elapsed().as_secs_f64();
    progress.check()?;
    let data = Arc::new(data);
    let mut scene = match upload(Arc::clone(&data), gpu, options, transfer, progress) {
        Ok(scene) => scene,
        // The voxel octree of a large volume can exceed a storage buffer; bricks store the
        // same volume in a fraction of the memory.
        Err(JobError::Failed(_)) if options.kind == RendererKind::Octree => {
            let bricks = RendererOptions {
                kind: RendererKind::Bricks,
                ..options
            };
            upload(data, gpu, bricks, transfer, progress)?
        }
        Err(error) => return Err(error),
    };
    let mut notice = None;
    if composite {
        progress.begin("uploading the composite");
        channels.insert(0, Arc::clone(&scene.data));
        match CompositeScene::new(gpu, channels, &states) {
            Ok(composite) => scene.composite = Some(composite),
            Err(error) => {
                notice = Some(format!(
                    "{}: the composite of {channel_count} channels does not fit this GPU ({error}); showing channel 0",
                    scene.data.volume.name
                ))
            }
        }
    }
    progress.check()?;
    Ok(Opened {
        scene,
        statistics,
        frame_change: frame.is_some(),
        channels: states,
        notice,
    })
}

/// The pyramid of `volume` (quantized, each level 2× coarser, by the mean or for labels the
/// maximum), and its finest level within [`PANEL_LEVEL_VOXELS`] as a volume of its own (its
/// voxels the levels, mapped back to the data's units by the value scale) for the panels.
fn in_memory_pyramid(
    volume: Volume,
    progress: &Progress,
) -> Result<(Volume, Arc<MemorySource>), JobError> {
    progress.begin("quantizing");
    let quantized = QuantizedVolume::new(&volume);
    let how = match DataKind::of_volume(&volume, &quantized) {
        DataKind::Labels(_) => Downsampling::Max,
        _ => Downsampling::Mean,
    };
    progress.check()?;
    progress.begin("building the pyramid");
    let quantization = quantized.quantization;
    let pyramid = MemorySource::from_levels(
        &volume.name,
        quantized.levels,
        quantized.dims,
        quantization,
        volume.spacing,
        how,
    )
    .map_err(JobError::Failed)?;
    let levels = &pyramid.shape().levels;
    let panel_level = levels
        .iter()
        .position(|level| {
            level.dims.iter().map(|&d| d as u64).product::<u64>() <= PANEL_LEVEL_VOXELS
                && level.dims.iter().all(|&d| d <= 1 << MAX_DEPTH)
        })
        .unwrap_or(levels.len() - 1);
    let shape = levels[panel_level];
    let voxels = pyramid
        .level(panel_level)
        .ok_or_else(|| {
            JobError::Failed(format!("{}: no pyramid level {panel_level}", volume.name))
        })?
        .to_vec();
    let panel = Volume {
        dims: shape.dims,
        spacing: volume.spacing.map(|s| s * shape.scale as f64),
        data: VoxelData::U16(voxels),
        value_scale: ValueScale {
            slope: quantization.step,
            intercept: quantization.offset,
        },
        ..volume
    };
    Ok((panel, Arc::new(pyramid)))
}

/// Quantizes `volume`, builds its octree (colored later) and histogram: what the panels and
/// every renderer read. `started` is when its reading began.
fn prepare_data(
    source: &VolumeSource,
    mut volume: Volume,
    started: Instant,
    progress: &Progress,
) -> Result<VolumeData, JobError> {
    progress.begin("quantizing");
    let quantized = QuantizedVolume::new(&volume);
    volume.data = volume.data.emptied();
    progress.check()?;
    let octree =
        voxscope_octree::build_with_progress(&quantized, BuildOptions::default(), progress)
            .map_err(|e| JobError::from_build(&volume.name, e))?;
    // The file's own window (the channel's in OME metadata, OME-Zarr's omero) where it has
    // one, else the percentiles.
    let channel_window = volume
        .series
        .channels
        .get(volume.series.selected.channel)
        .and_then(|c| c.window);
    let default_window = channel_window
        .or(volume.default_window)
        .unwrap_or_else(|| quantized.robust_window());
    let histogram = display_histogram(&quantized);
    let kind = DataKind::of_volume(&volume, &quantized);
    Ok(VolumeData {
        source: source.clone(),
        volume,
        quantized,
        octree,
        default_window,
        histogram,
        kind,
        load_seconds: started.elapsed().as_secs_f64(),
        pyramid: None,
    })
}

/// The transfer function a volume opens with: its kind's default (a CT preset, labels) where
/// it has one, else the user's `choice` over `window` (the file's, or the robust one) — unless
/// that choice only makes sense for other data (a curve outside these values, the labels
/// colormap), when a percentile ramp stands in.
pub fn opening_transfer(
    choice: TransferChoice,
    quantized: &QuantizedVolume,
    kind: DataKind,
    window: ValueWindow,
) -> TransferFunction {
    if let Some(transfer) = default_transfer(quantized, kind) {
        return transfer;
    }
    let [low, high] = quantized.value_range;
    let foreign_curve = choice.opacity.curve().is_some_and(|curve| {
        let [first, last] = curve.span();
        last < low || first > high
    });
    if foreign_curve || choice.colormap == Colormap::Labels {
        let colormap = match choice.colormap {
            Colormap::Labels => Colormap::Grays,
            colormap => colormap,
        };
        return Preset::Ramp.transfer(quantized, colormap);
    }
    choice.with_window(window)
}

/// Uploads `data` for the renderer `options` names, colored by `transfer`.
pub fn upload(
    data: Arc<VolumeData>,
    gpu: &GpuContext,
    options: RendererOptions,
    transfer: TransferFunction,
    progress: &Progress,
) -> Result<Scene, JobError> {
    progress.begin("uploading to the GPU");
    let started = Instant::now();
    let failed = |e: String| JobError::Failed(format!("{}: {e}", data.volume.name));
    let stream = StreamOptions {
        gpu_memory: options.gpu_memory,
        ..StreamOptions::default()
    };
    let mut renderer = match (&data.pyramid, data.source.zarr_spec()) {
        // A volume longer than the octree holds streams from its pyramid in memory.
        (Some(pyramid), _) if options.kind == RendererKind::Stream => {
            let pyramid: Arc<dyn BrickSource> = pyramid.clone();
            VolumeRenderer::new_stream(gpu, pyramid, stream, &transfer)
                .map_err(|e| failed(e.to_string()))?
        }
        // A Zarr store streams from the file (or the URL), at its own full resolution.
        (_, Some(spec)) if options.kind == RendererKind::Stream => {
            let pyramid =
                Pyramid::open_spec(spec, data.volume.series.selected, RemoteOptions::default())
                    .map_err(|e| JobError::Failed(e.to_string()))?;
            let source = ZarrSource::new(Arc::new(pyramid)).map_err(JobError::Failed)?;
            // The coarse levels the first frames draw, their chunks fetched together (a URL's
            // round trips), on this loading thread.
            source.warm_first_image(FIRST_IMAGE_BRICKS);
            VolumeRenderer::new_stream(gpu, Arc::new(source), stream, &transfer)
                .map_err(|e| failed(e.to_string()))?
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
        .map_err(|e| failed(e.to_string()))?,
    };
    // The CPU colors of `data.octree` follow the transfer function of the load, which may not
    // be `transfer` (after a renderer switch): recolor on the GPU so the scene matches it.
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::scene_recolor"),
        });
    renderer
        .set_transfer(gpu, &mut encoder, &transfer, None)
        .map_err(|e| failed(e.to_string()))?;
    gpu.queue.submit([encoder.finish()]);
    Ok(Scene {
        data,
        renderer,
        options,
        applied_transfer: transfer,
        upload_seconds: started.elapsed().as_secs_f64(),
        stream_status: None,
        network: None,
        composite: None,
    })
}

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
            voxscope_octree::level_statistics_within(&data.octree, &transfer, &clip),
        ))
    })
}
