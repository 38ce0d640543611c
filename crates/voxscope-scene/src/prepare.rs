//! Opening a volume: load the frame asked for (or open a large store for streaming), prepare
//! every channel of a composite, choose the transfer function, upload. The job behind the
//! app's File ▸ Open, drops, recent files, its command line and the channel and time controls.

use std::sync::Arc;
use std::time::Instant;

use voxscope_octree::{self as octree, DataKind, LevelStatistics, MAX_DEPTH, TransferFunction};
use voxscope_render::{GpuContext, RendererKind, RendererOptions};
use voxscope_stream::{BrickSource, Downsampling, MemorySource};
use voxscope_volume::ome_zarr::{Pyramid, VOLUME_VOXEL_BUDGET};
use voxscope_volume::progress::Progress;
use voxscope_volume::remote::RemoteOptions;
use voxscope_volume::{MAX_CHANNELS, QuantizedVolume, Selection, ValueScale, Volume, VoxelData};

use crate::scene::{OctreeColors, upload_colored};
use crate::{
    ChannelState, CompositeScene, Scene, SceneError, TransferRequest, VolumeData, VolumeSource,
    opening_transfer,
};

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

/// A volume opened in the background: the scene and its per-level statistics.
pub struct Opened {
    pub scene: Scene,
    pub statistics: Vec<LevelStatistics>,
    /// Another frame of the volume on screen: the view stays as it is.
    pub frame_change: bool,
    /// The composite's channel settings as the scene was drawn with them (empty for one
    /// channel): a new volume's defaults, or the ones the frame change carried.
    pub channels: Vec<ChannelState>,
    /// What the user should know (the composite did not fit and one channel is shown).
    pub notice: Option<String>,
}

/// Loads `source` (the frame `frame` names, else the first) and prepares everything to draw
/// it with `options`: a multi-channel file as the composite of its channels, a store larger
/// than memory streamed, a volume longer than the octree holds streamed from a pyramid of its
/// own. A new volume's transfer function is [`opening_transfer`]'s for `request` (what fits
/// the data unless the request asks otherwise: the app asks for the function the user pinned,
/// nothing else of the volume before); a composite's channels open with the file's colors
/// and windows whatever the request's saved function. A frame change keeps the transfer
/// functions it carries.
pub fn prepare_scene(
    source: &VolumeSource,
    frame: Option<FrameChange>,
    request: &TransferRequest,
    gpu: &GpuContext,
    options: RendererOptions,
    progress: &Progress,
) -> Result<Opened, SceneError> {
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
            let pyramid = Pyramid::open_spec(spec, select, RemoteOptions::default())?;
            let large = pyramid.levels[0].voxel_count() > VOLUME_VOXEL_BUDGET as u64;
            (large || options.kind == RendererKind::Stream).then_some(pyramid)
        }
        None => None,
    };
    // A store's channels stream together (the streamed composite).
    if let Some(pyramid) = &streamed
        && composite_wanted
        && pyramid.channels > 1
    {
        let asked = crate::stream_channels::Asked {
            source,
            frame: frame.as_ref(),
            request,
            options,
        };
        return crate::stream_channels::prepare_streamed(pyramid, asked, gpu, progress, started);
    }
    let mut notice = None;
    let volume = match &streamed {
        Some(pyramid) => {
            options.kind = RendererKind::Stream;
            let (volume, fallback) = panel_level(pyramid)?;
            notice = fallback;
            volume
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
    // The channels a composite opens with: every one, or of a file of more than are drawn
    // together those it does not mark inactive (the first of them the scene's data).
    let opening = volume.series.opening_channels(MAX_CHANNELS);
    let channel_count = opening.len();
    let composite =
        streamed.is_none() && pyramid.is_none() && composite_wanted && channel_count > 1;
    let volume = match opening.first() {
        Some(&first) if composite && first != volume.series.selected.channel => {
            source.load(Selection {
                channel: first,
                ..select
            })?
        }
        _ => volume,
    };
    let mut data = VolumeData::prepare(source, volume, started, progress)?;
    data.pyramid = pyramid;
    // The other channels of a composite: read, quantized, built like the first.
    let mut channels = Vec::new();
    for &channel in opening
        .iter()
        .skip(1)
        .take(if composite { channel_count } else { 0 })
    {
        let other = source.load(Selection { channel, ..select })?;
        channels.push(Arc::new(VolumeData::prepare(
            source,
            other,
            Instant::now(),
            progress,
        )?));
    }
    // One function for every channel of a composite would draw them all alike: each opens
    // with its own window (the file's, else its values').
    let channel_request = TransferRequest {
        saved: None,
        ..*request
    };
    let states: Vec<ChannelState> = match &frame {
        Some(frame) if composite && frame.channels.len() == channel_count => frame.channels.clone(),
        _ if composite => std::iter::once(&data)
            .chain(channels.iter().map(Arc::as_ref))
            .zip(&opening)
            .map(|(data, &index)| ChannelState::opening(data, index, &channel_request))
            .collect(),
        _ => Vec::new(),
    };
    let transfer = match (&frame, states.first()) {
        (_, Some(first)) => first.transfer,
        (Some(frame), None) => frame.transfer,
        (None, None) => opening_transfer(&data.quantized, data.kind, data.default_window, request),
    };
    progress.begin("coloring");
    octree::recolor(&mut data.octree, &transfer);
    let statistics = octree::level_statistics(&data.octree);
    data.load_seconds = started.elapsed().as_secs_f64();
    progress.check()?;
    let data = Arc::new(data);
    // (The octree was colored by `transfer` just now; the upload recolors nothing, and the
    // app recolors the renderer on its UI thread as it takes the scene: the bricks
    // renderer's coarse colors are the GPU recolor's.)
    let colored = OctreeColors::Uploaded;
    let mut scene =
        match upload_colored(Arc::clone(&data), gpu, options, transfer, colored, progress) {
            Ok(scene) => scene,
            // The voxel octree of a large volume can exceed a storage buffer; bricks store the
            // same volume in a fraction of the memory.
            Err(error) if error.does_not_fit() && options.kind == RendererKind::Octree => {
                let bricks = RendererOptions {
                    kind: RendererKind::Bricks,
                    ..options
                };
                upload_colored(data, gpu, bricks, transfer, colored, progress)?
            }
            Err(error) => return Err(error),
        };
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

/// The level the panels read whole beside a streamed store: the finest within
/// [`PANEL_LEVEL_VOXELS`], else (a chunk of it cannot be read) the next coarser one that can
/// be, with a notice saying so: a damaged chunk costs the panels detail, not the open.
pub(crate) fn panel_level(pyramid: &Pyramid) -> Result<(Volume, Option<String>), SceneError> {
    let finest = pyramid.finest_within(PANEL_LEVEL_VOXELS);
    let mut first_error = None;
    for level in finest..pyramid.levels.len() {
        match pyramid.level_volume(level) {
            Ok(volume) => {
                let notice = first_error.map(|error: voxscope_volume::LoadError| {
                    format!(
                        "the panels show level {level}: level {finest} cannot be read ({})",
                        error.problem
                    )
                });
                return Ok((volume, notice));
            }
            Err(error) if error.kind == voxscope_volume::LoadErrorKind::Invalid => {
                return Err(error.into());
            }
            Err(error) => {
                first_error.get_or_insert(error);
            }
        }
    }
    Err(first_error
        .map(SceneError::from)
        .unwrap_or_else(|| SceneError::failed("the store has no level to read")))
}

/// The pyramid of `volume` (quantized, each level 2× coarser, by the mean or for labels the
/// mode), and its finest level within [`PANEL_LEVEL_VOXELS`] as a volume of its own (its
/// voxels the levels, mapped back to the data's units by the value scale) for the panels.
fn in_memory_pyramid(
    volume: Volume,
    progress: &Progress,
) -> Result<(Volume, Arc<MemorySource>), SceneError> {
    progress.begin("quantizing");
    let quantized = QuantizedVolume::new(&volume);
    let how = downsampling_of(DataKind::of_volume(&volume, &quantized));
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
    )?;
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
            SceneError::Failed(format!("{}: no pyramid level {panel_level}", volume.name))
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

/// How the coarser levels of a pyramid of data of `kind` are reduced: labels by their mode (a
/// mean of labels is another label, and their maximum lets the largest label grow over the
/// others level by level), everything else by the mean.
pub(crate) fn downsampling_of(kind: DataKind) -> Downsampling {
    Downsampling::of_values(kind.is_labels())
}
