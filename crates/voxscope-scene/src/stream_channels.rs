//! A store's channels streamed together: up to [`MAX_CHANNELS`] of them (the ones asked for,
//! else its `omero` list's active ones, else its first ones), each a [`ZarrSource`] over the
//! one opened store, made one pyramid ([`ChannelSources`]) that the streaming renderer draws
//! as the composite. Each channel opens as the in-memory composite's do
//! ([`ChannelState::opening_with`]): its `omero` name, color and window, else the palette's
//! color and the window of its coarse preview.

use std::sync::Arc;
use std::time::Instant;

use voxscope_octree::{self as octree, DataKind};
use voxscope_render::{GpuContext, RendererKind, RendererOptions, VolumeRenderer};
use voxscope_stream::{BrickSource, ChannelSources, StreamOptions, ZarrSource, preview};
use voxscope_volume::ome_zarr::Pyramid;
use voxscope_volume::progress::Progress;
use voxscope_volume::{ChannelInfo, LoadOptions, MAX_CHANNELS, QuantizedVolume, ValueWindow};

use crate::prepare::{FrameChange, Opened, panel_level};
use crate::streaming::{PREVIEW_BRICKS, StreamedVolume};
use crate::{
    ChannelRequest, ChannelState, CompositeScene, Scene, SceneError, TransferRequest, VolumeData,
    VolumeSource,
};

/// One channel of a streamed composite: which of the file's, what the file says of it, and
/// its coarse level read whole (its histogram and default window).
pub struct StreamedChannel {
    /// Its number in the file.
    pub index: usize,
    pub info: ChannelInfo,
    pub preview: QuantizedVolume,
    pub kind: DataKind,
}

/// A store's channels opened for streaming together.
pub struct StreamedChannels {
    /// The pyramid of every channel drawn ([`ChannelSources`]); its transfer function is
    /// channel 0's (each channel has its own: [`Self::states`]).
    pub volume: StreamedVolume,
    pub channels: Vec<StreamedChannel>,
}

impl StreamedChannels {
    /// The store `source` names, opened at the time point `options` select, where it has
    /// several channels to stream together (`None`: not a Zarr store, or one channel).
    pub fn store_of_channels(
        source: &VolumeSource,
        options: &LoadOptions,
    ) -> Result<Option<Pyramid>, SceneError> {
        if source.zarr_spec().is_none() || options.raw.is_some() {
            return Ok(None);
        }
        let pyramid = Pyramid::open_spec(source.spec(), options.select, options.remote)?;
        Ok((pyramid.channels > 1).then_some(pyramid))
    }

    /// Opens the channels `request` chooses (else the file's opening channels) of `pyramid`.
    pub fn open(
        pyramid: Pyramid,
        request: &ChannelRequest,
        transfer: &TransferRequest,
    ) -> Result<Self, SceneError> {
        let started = Instant::now();
        request.check(pyramid.channels)?;
        let indices = if request.chosen.is_empty() {
            pyramid.opening_channels(MAX_CHANNELS)
        } else {
            request.chosen.clone()
        };
        if indices.len() > MAX_CHANNELS {
            return Err(SceneError::failed(format!(
                "{}: {} channels chosen; at most {MAX_CHANNELS} are drawn together",
                pyramid.source,
                indices.len()
            )));
        }
        let series = pyramid.series();
        let channels = indices
            .iter()
            .map(|&index| {
                Ok(ChannelOf {
                    index,
                    info: series.channels.get(index).cloned().unwrap_or_default(),
                    pyramid: pyramid.of_channel(index)?,
                })
            })
            .collect::<Result<Vec<_>, SceneError>>()?;
        Self::assemble(&pyramid.source, channels, transfer, started)
    }

    /// The stores `pyramids` (one channel each: the one each was opened at, `--channels-from`'s
    /// files) streamed together as channels 0, 1, … (at most [`MAX_CHANNELS`]; one grid).
    pub fn open_stores(
        pyramids: Vec<Pyramid>,
        transfer: &TransferRequest,
    ) -> Result<Self, SceneError> {
        let started = Instant::now();
        if pyramids.is_empty() || pyramids.len() > MAX_CHANNELS {
            return Err(SceneError::failed(format!(
                "{} stores given as channels; 1 to {MAX_CHANNELS} are drawn together",
                pyramids.len()
            )));
        }
        let name = pyramids
            .iter()
            .map(|p| p.source.as_str())
            .collect::<Vec<_>>()
            .join(",");
        let channels = pyramids
            .into_iter()
            .enumerate()
            .map(|(index, pyramid)| ChannelOf {
                index,
                info: pyramid
                    .series()
                    .channels
                    .get(pyramid.selected.channel)
                    .cloned()
                    .unwrap_or_default(),
                pyramid,
            })
            .collect();
        Self::assemble(&name, channels, transfer, started)
    }

    /// `channels` as one pyramid, called `name`: each channel's source and coarse preview
    /// (read together: a URL's round trips at once), the first one's transfer function.
    fn assemble(
        name: &str,
        channels: Vec<ChannelOf>,
        transfer: &TransferRequest,
        started: Instant,
    ) -> Result<Self, SceneError> {
        let opened: Vec<Result<OpenedChannel, SceneError>> = std::thread::scope(|scope| {
            let handles: Vec<_> = channels
                .into_iter()
                .map(|channel| scope.spawn(move || channel.open()))
                .collect();
            handles
                .into_iter()
                .map(|handle| {
                    handle
                        .join()
                        .unwrap_or_else(|_| Err(SceneError::failed("a channel's open panicked")))
                })
                .collect()
        });
        let mut sources: Vec<Arc<dyn BrickSource>> = Vec::new();
        let mut channels = Vec::new();
        let mut first_pyramid = None;
        for result in opened {
            let OpenedChannel {
                channel,
                zarr,
                pyramid,
            } = result?;
            channels.push(channel);
            sources.push(zarr);
            first_pyramid.get_or_insert(pyramid);
        }
        let together: Arc<dyn BrickSource> = Arc::new(ChannelSources::new(name, sources)?);
        let first = &channels[0];
        let window = first.window();
        let volume = StreamedVolume {
            source: together,
            pyramid: first_pyramid,
            transfer: crate::opening_transfer(&first.preview, first.kind, window, transfer),
            open_seconds: started.elapsed().as_secs_f64(),
            preview: first.preview.clone(),
            kind: first.kind,
            default_window: window,
        };
        Ok(Self { volume, channels })
    }

    /// Each channel's color, window and transfer function as `transfer` and `request` ask
    /// (what is not asked: the file's, else the defaults; a color or window asked for file
    /// channel N goes to channel N).
    pub fn states(
        &self,
        transfer: &TransferRequest,
        request: &ChannelRequest,
    ) -> Vec<ChannelState> {
        self.channels
            .iter()
            .map(|channel| channel.state(transfer, request))
            .collect()
    }
}

/// One channel to open: its number, what its file says of it, and its store opened at it.
struct ChannelOf {
    index: usize,
    info: ChannelInfo,
    pyramid: Pyramid,
}

/// A channel opened: what it is, its source and its store.
struct OpenedChannel {
    channel: StreamedChannel,
    zarr: Arc<ZarrSource>,
    pyramid: Arc<Pyramid>,
}

impl ChannelOf {
    /// Its source and its coarse level read whole.
    fn open(self) -> Result<OpenedChannel, SceneError> {
        let pyramid = Arc::new(self.pyramid);
        let zarr = Arc::new(ZarrSource::new(Arc::clone(&pyramid))?);
        let (preview, _) = preview(&*zarr, PREVIEW_BRICKS)
            .map_err(|e| SceneError::failed(format!("{}: {e}", zarr.name())))?;
        let kind = DataKind::of(&preview, None, false);
        let channel = StreamedChannel {
            index: self.index,
            info: self.info,
            preview,
            kind,
        };
        Ok(OpenedChannel {
            channel,
            zarr,
            pyramid,
        })
    }
}

impl StreamedChannel {
    /// Its color, window and transfer function as `transfer` and `request` ask
    /// ([`ChannelState::opening_with`]).
    pub fn state(&self, transfer: &TransferRequest, request: &ChannelRequest) -> ChannelState {
        ChannelState::opening_with(
            Some(&self.info),
            self.info.window,
            &self.preview,
            self.kind,
            self.index,
            transfer,
            request,
        )
    }

    /// The window it opens with: the file's, else its preview's robust window.
    pub fn window(&self) -> ValueWindow {
        crate::default_window(self.info.window, &self.preview)
    }
}

/// What the app asked of a store it opens ([`prepare_streamed`]).
pub(crate) struct Asked<'a> {
    pub source: &'a VolumeSource,
    /// The frame change it follows, with the channels' states it keeps.
    pub frame: Option<&'a FrameChange>,
    pub request: &'a TransferRequest,
    pub options: RendererOptions,
}

/// The app's open of a store of several channels: its opening channels streamed together by
/// the scene's renderer, each channel's panel level read whole for the panels (histogram,
/// window presets, slices), the first one the scene's data. Nothing is submitted (a job
/// thread's open: see `scene::upload_colored`).
pub(crate) fn prepare_streamed(
    pyramid: &Pyramid,
    asked: Asked<'_>,
    gpu: &GpuContext,
    progress: &Progress,
    started: Instant,
) -> Result<Opened, SceneError> {
    let chosen = pyramid.opening_channels(MAX_CHANNELS);
    let mut notice = None;
    let mut prepared = Vec::new();
    let mut sources: Vec<Arc<dyn BrickSource>> = Vec::new();
    for &index in &chosen {
        let channel = pyramid.of_channel(index)?;
        let (volume, fallback) = panel_level(&channel)?;
        notice = notice.or(fallback);
        progress.check()?;
        prepared.push(VolumeData::prepare(
            asked.source,
            volume,
            started,
            progress,
        )?);
        sources.push(Arc::new(ZarrSource::new(Arc::new(channel))?));
    }
    // Each channel opens with its own window (the file's, else its values').
    let request = TransferRequest {
        saved: None,
        ..*asked.request
    };
    let states: Vec<ChannelState> = match asked.frame {
        Some(frame) if frame.channels.len() == chosen.len() => frame.channels.clone(),
        _ => prepared
            .iter()
            .zip(&chosen)
            .map(|(data, &index)| ChannelState::opening(data, index, &request))
            .collect(),
    };
    let transfer = states[0].transfer;
    octree::recolor(&mut prepared[0].octree, &transfer);
    let statistics = octree::level_statistics(&prepared[0].octree);
    let channels: Vec<Arc<VolumeData>> = prepared.into_iter().map(Arc::new).collect();
    progress.begin("uploading to the GPU");
    let uploading = Instant::now();
    let together: Arc<dyn BrickSource> = Arc::new(ChannelSources::new(&pyramid.source, sources)?);
    let stream = StreamOptions {
        gpu_memory: asked.options.gpu_memory,
        ..StreamOptions::default()
    };
    let failed = |e| SceneError::render(&pyramid.source, e);
    let renderer = VolumeRenderer::new_stream(gpu, together, stream, &transfer).map_err(failed)?;
    let composite =
        CompositeScene::streamed(gpu, &renderer, channels.clone(), &states).map_err(failed)?;
    let scene = Scene {
        data: Arc::clone(&channels[0]),
        renderer,
        options: RendererOptions {
            kind: RendererKind::Stream,
            ..asked.options
        },
        applied_transfer: transfer,
        upload_seconds: uploading.elapsed().as_secs_f64(),
        stream_status: None,
        network: None,
        composite: Some(composite),
    };
    Ok(Opened {
        scene,
        statistics,
        frame_change: asked.frame.is_some(),
        channels: states,
        notice,
    })
}
