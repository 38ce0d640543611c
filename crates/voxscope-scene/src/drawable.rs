//! What `render`, `movie` and Python's `render`/`Renderer` draw: a volume made ready on the GPU
//! from a source and [`DrawOptions`] (one volume for its renderer, the composite of its
//! channels, or a pyramid streamed into the GPU budget, with label overlays), and frames of it
//! for any camera, settings and transfer function: drawn whole or in tiles beyond the device's
//! limits, a streamed one refined until nothing visible is missing or its deadline.
//!
//! The rules live here once: which renderer draws what ([`Drawable::open`]), what a channel
//! chosen alone is drawn in, when labels can be drawn over it. The front ends word the
//! notices and errors.

use std::borrow::Borrow;
use std::sync::Arc;
use std::time::Instant;

use voxscope_octree::{self as octree, DataKind, MAX_DEPTH, TransferFunction};
use voxscope_render::{GpuContext, RendererKind, RendererOptions, VolumeRenderer};
use voxscope_volume::ome_zarr::{self, Pyramid};
use voxscope_volume::{QuantizedVolume, Volume, format_dims};

use crate::channels::{layers, write_states};
use crate::label_open::{open_overlays, open_streamed_overlays};
use crate::{
    ChannelChoice, ChannelState, CompositeScene, DrawOptions, LabelOverlay, OpenOptions,
    OpenedStream, Progress, SavedTransfer, Scene, SceneError, StreamedChannels, StreamedVolume,
    UploadedLabels, VolumeData, VolumeSource, beyond_octree, opening_transfer, renderer_for_octree,
};

/// One channel ready to draw: its values, quantized, and the volume that describes them (its
/// voxels dropped or never copied).
pub struct Channel {
    pub volume: Volume,
    pub quantized: QuantizedVolume,
}

impl Channel {
    /// `volume` quantized, described without its voxels (which stay with the caller).
    pub fn of_volume(volume: &Volume) -> Self {
        Self {
            quantized: QuantizedVolume::new(volume),
            volume: Volume {
                name: volume.name.clone(),
                format: volume.format,
                dims: volume.dims,
                spacing: volume.spacing,
                data: volume.data.emptied(),
                value_scale: volume.value_scale,
                orientation: volume.orientation.clone(),
                metadata: volume.metadata.clone(),
                default_window: volume.default_window,
                series: volume.series.clone(),
            },
        }
    }

    /// `volume` quantized, its voxels dropped.
    pub fn from_volume(mut volume: Volume) -> Self {
        let quantized = QuantizedVolume::new(&volume);
        volume.data = volume.data.emptied();
        Self { volume, quantized }
    }
}

/// A composite's channel: its values (its own, or the app's data on screen) and kind.
struct CompositeChannel {
    values: ChannelValues,
    kind: DataKind,
}

enum ChannelValues {
    Own(Box<Channel>),
    Shared(Arc<VolumeData>),
}

impl CompositeChannel {
    fn volume(&self) -> &Volume {
        match &self.values {
            ChannelValues::Own(channel) => &channel.volume,
            ChannelValues::Shared(data) => &data.volume,
        }
    }

    fn quantized(&self) -> &QuantizedVolume {
        match &self.values {
            ChannelValues::Own(channel) => &channel.quantized,
            ChannelValues::Shared(data) => &data.quantized,
        }
    }
}

/// What is on the GPU.
enum Drawn {
    /// One volume in memory.
    Volume {
        data: Arc<VolumeData>,
        renderer: VolumeRenderer,
        applied: TransferFunction,
        /// The octree's nodes are uploaded through this level (deeper frames draw it).
        upload_level: u32,
    },
    /// Several channels drawn together (or one in its color), by the dense renderer.
    Composite {
        channels: Vec<CompositeChannel>,
        renderer: VolumeRenderer,
        applied: Vec<ChannelState>,
        /// The file index of a single channel drawn alone in its color.
        alone: Option<usize>,
    },
    /// A pyramid streamed into the GPU budget: one channel, or several together (`composite`).
    Stream {
        streamed: Box<StreamedVolume>,
        renderer: VolumeRenderer,
        applied: TransferFunction,
        composite: Option<StreamComposite>,
    },
}

/// A volume on the GPU `G` (owned, or shared: `Arc<GpuContext>`), ready to draw frames of.
pub struct Drawable<G: Borrow<GpuContext> = GpuContext> {
    gpu: G,
    drawn: Drawn,
    /// The label overlays drawn over each image, in order.
    labels: Vec<UploadedLabels>,
    /// The saved transfer function (a `tf` file's or a view's) the settings follow.
    saved: Option<SavedTransfer>,
    /// What the user should be told of how it is drawn (bricks where the octree does not
    /// fit), said once ([`Self::open`] says them as they are decided instead).
    pub notices: Vec<String>,
}

impl<G: Borrow<GpuContext>> Drawable<G> {
    /// Reads, prepares and uploads what `open` and `options` name, as `render` draws it: the
    /// streaming renderer when asked, the composite of several channels, a volume beyond the
    /// octree streamed from memory, or one volume for its renderer. `gpu` gives the device
    /// (started while the volume is read); `progress` follows the octree's build (its stage
    /// is empty again once the build is over); `say` hears how it is drawn (bricks where the
    /// octree does not fit, a channel in grays, a volume streamed from memory) when it is
    /// decided.
    pub fn open(
        open: &OpenOptions,
        options: &DrawOptions,
        gpu: impl FnOnce() -> Result<G, SceneError>,
        progress: &Progress,
        say: &mut dyn FnMut(String),
    ) -> Result<Self, SceneError> {
        if options.renderer == Some(RendererKind::Stream) {
            // A bad `tf` file fails before the volume is read.
            let saved = options.transfer.saved()?;
            // A store's channels stream together unless one is chosen alone; so do stores
            // given as channels.
            let alone = matches!(open.channel, Some(ChannelChoice::Index(_)));
            let load = open.load_options();
            let channels: Option<Box<dyn FnOnce(&_) -> _>> = match &open.channels_from {
                Some(specs) if specs.iter().all(|s| ome_zarr::is_zarr_spec(s)) => {
                    let pyramids = specs
                        .iter()
                        .map(|spec| Pyramid::open_spec(spec, load.select, load.remote))
                        .collect::<Result<Vec<_>, _>>()?;
                    Some(Box::new(move |request: &_| {
                        StreamedChannels::open_stores(pyramids, request)
                    }))
                }
                Some(_) => None,
                None if !alone => {
                    StreamedChannels::store_of_channels(&open.volume_source(), &load)?.map(
                        |pyramid| -> Box<dyn FnOnce(&_) -> _> {
                            Box::new(move |request: &_| {
                                StreamedChannels::open(pyramid, &options.channels, request)
                            })
                        },
                    )
                }
                None => None,
            };
            if let Some(channels) = channels {
                let mut drawable = Self::streamed_channels(channels, options, saved, gpu)?;
                drawable.open_labels(open, options)?;
                return Ok(drawable);
            }
            refuse_chosen(options)?;
            // The renderer is made while the store's first chunks are on their way.
            let opened = StreamedVolume::open_with_renderer(
                &open.volume_source(),
                &open.load_options(),
                &options.transfer.request(saved.as_ref()),
                options.stream,
                gpu,
            )?;
            let mut drawable = Self::streamed(opened, saved);
            drawable.open_labels(open, options)?;
            return Ok(drawable);
        }
        // Chosen channels are a file's: not of files given as channels, nor beside --channel N.
        if open.channels_from.is_some() || !open.wants_composite() {
            refuse_chosen(options)?;
        }
        let refuse_labels = |what: &'static str| match options.labels.names.first() {
            Some(name) => Err(SceneError::LabelsRefused {
                name: name.clone(),
                over: what,
            }),
            None => Ok(()),
        };
        let chosen = &options.channels.chosen;
        let loaded = match open.chosen_channels(chosen)? {
            Some(channels) if channels.len() > 1 || !chosen.is_empty() => {
                let channels = channels.into_iter().map(Channel::from_volume).collect();
                let mut drawable = Self::composite(gpu, channels, options, None)?;
                drawable.open_labels(open, options)?;
                return Ok(drawable);
            }
            Some(mut channels) => channels
                .pop()
                .ok_or_else(|| SceneError::failed("no channel was read"))?,
            None => open.load()?,
        };
        // A channel of a file of several channels, chosen alone: drawn as the composite draws
        // it, in the channel's color and window, where the options or the file give it a
        // color and the dense renderer can draw it; else in the channel's window, by the
        // renderer asked for.
        let mut options = options.clone();
        if let Some(ChannelChoice::Index(index)) = open.channel {
            if colors_channel(&options.channels, &loaded, index)? {
                if matches!(options.renderer, None | Some(RendererKind::Dense))
                    && !beyond_octree(loaded.dims)
                {
                    let channel = Channel::from_volume(loaded);
                    let mut drawable = Self::composite(gpu, vec![channel], &options, Some(index))?;
                    drawable.open_labels(open, &options)?;
                    return Ok(drawable);
                }
                say(format!(
                    "channel {index} is drawn in grays: its color needs the dense renderer (--renderer dense)"
                ));
            }
            if let Some(window) = options.channels.window_of(index) {
                options.transfer.window = Some(window);
            }
        }
        // Longer than the voxel octree holds: bricks are streamed from memory.
        if beyond_octree(loaded.dims)
            && matches!(options.renderer, None | Some(RendererKind::Bricks))
        {
            say(format!(
                "{}: {} voxels are beyond the voxel octree's {} a side: drawn by the streaming renderer, from memory",
                loaded.name,
                format_dims(loaded.dims),
                1u32 << MAX_DEPTH
            ));
            refuse_labels("a volume streamed from memory")?;
            let saved = options.transfer.saved()?;
            let request = options.transfer.request(saved.as_ref());
            let streamed = StreamedVolume::from_volume(loaded, &request, Instant::now())?;
            let opened = streamed.with_renderer(gpu()?, options.stream)?;
            return Ok(Self::streamed(opened, saved));
        }
        let saved = options.transfer.saved()?;
        let request = options.transfer.request(saved.as_ref());
        let source = VolumeSource::from_spec(&loaded.name);
        let prepared = VolumeData::prepare(&source, loaded, Instant::now(), progress);
        // The build is over: nothing more to report as its progress.
        progress.begin("");
        let data = prepared?;
        let overlays = open_overlays(&options.labels.names, open, data.volume.dims)?;
        let mut drawable = Self::volume(gpu()?, data, &options, saved, &request)?;
        for notice in drawable.notices.drain(..) {
            say(notice);
        }
        drawable.upload_overlays(overlays, &options)?;
        Ok(drawable)
    }

    /// Opens the label overlays `options` name (`options.labels`) of the image `open` names
    /// (its label images by name, or label files on its grid) and uploads them to be drawn over
    /// this volume's pictures: streamed beside a streamed image, else read whole.
    pub fn open_labels(
        &mut self,
        open: &OpenOptions,
        options: &DrawOptions,
    ) -> Result<(), SceneError> {
        if options.labels.names.is_empty() {
            return Ok(());
        }
        if let Drawn::Stream {
            streamed,
            composite: None,
            ..
        } = &self.drawn
            && streamed.pyramid.is_none()
        {
            return Err(SceneError::LabelsRefused {
                name: options.labels.names[0].clone(),
                over: "a volume streamed from memory",
            });
        }
        if self.is_streamed() {
            // (A label file over a streamed store: one line.)
            self.labels = open_streamed_overlays(
                &options.labels,
                open,
                self.gpu.borrow(),
                options.stream,
                options.max_wait,
            )?;
            return Ok(());
        }
        let dims = match &self.drawn {
            Drawn::Volume { data, .. } => data.volume.dims,
            Drawn::Composite { channels, .. } => channels[0].volume().dims,
            Drawn::Stream { streamed, .. } => streamed.source.shape().dims(),
        };
        let overlays = open_overlays(&options.labels.names, open, dims)?;
        self.upload_overlays(overlays, options)
    }

    /// Uploads `overlays` to be drawn over this volume's (or composite's) pictures, for a
    /// renderer of its kind and through the level it is drawn at, as `options` show them.
    fn upload_overlays(
        &mut self,
        overlays: Vec<LabelOverlay>,
        options: &DrawOptions,
    ) -> Result<(), SceneError> {
        let mut renderer = self.renderer_options(options);
        if let Drawn::Composite { .. } = self.drawn {
            // The composite is the dense march's: its labels are marched the same way.
            renderer.kind = RendererKind::Dense;
        }
        let (spacing, level) = (self.data_spacing(), self.upload_level());
        self.labels = overlays
            .into_iter()
            .map(|overlay| {
                overlay
                    .layer(&options.labels.hide, options.labels.opacity, spacing)
                    .and_then(|layer| layer.upload(self.gpu.borrow(), renderer, level))
                    .map_err(SceneError::from)
            })
            .collect::<Result<_, _>>()?;
        Ok(())
    }

    /// The channels given (quantized already) drawn as `options` ask: one volume (streamed
    /// when asked or longer than the octree holds), or the composite of several.
    pub fn of_channels(
        gpu: G,
        source: &VolumeSource,
        mut channels: Vec<Channel>,
        options: &DrawOptions,
    ) -> Result<Self, SceneError> {
        // Chosen channels are drawn where they are the ones given (a file's, read by
        // `OpenOptions::chosen_channels`), and refused where they are not.
        let numbers: Vec<usize> = channels
            .iter()
            .map(|c| c.volume.series.selected.channel)
            .collect();
        if options.channels.chosen != numbers {
            refuse_chosen(options)?;
        }
        if channels.len() > 1 || !options.channels.chosen.is_empty() {
            return Self::composite(|| Ok(gpu), channels, options, None);
        }
        let channel = channels
            .pop()
            .ok_or_else(|| SceneError::Invalid("no channel to draw".into()))?;
        let saved = options.transfer.saved()?;
        let started = Instant::now();
        let request = options.transfer.request(saved.as_ref());
        let streams = options.renderer == Some(RendererKind::Stream)
            || (beyond_octree(channel.volume.dims)
                && matches!(options.renderer, None | Some(RendererKind::Bricks)));
        if streams {
            let streamed = StreamedVolume::from_quantized(
                &channel.volume,
                channel.quantized,
                &request,
                started,
            )?;
            let opened = streamed.with_renderer(gpu, options.stream)?;
            return Ok(Self::streamed(opened, saved));
        }
        let data = VolumeData::from_quantized(
            source,
            channel.volume,
            channel.quantized,
            started,
            &Progress::new(),
        )?;
        Self::volume(gpu, data, options, saved, &request)
    }

    /// A streamed volume with its renderer; `saved` is the `tf` file its transfer function
    /// came from.
    pub fn streamed(opened: OpenedStream<G>, saved: Option<SavedTransfer>) -> Self {
        let OpenedStream {
            volume,
            gpu,
            renderer,
            ..
        } = opened;
        Self {
            gpu,
            drawn: Drawn::Stream {
                applied: volume.transfer,
                streamed: Box::new(volume),
                renderer,
                composite: None,
            },
            labels: Vec::new(),
            saved,
            notices: Vec::new(),
        }
    }

    /// What the app shows (its [`Scene`], uploaded for a renderer of this drawable's own):
    /// drawn with the transfer function it was uploaded with until told another.
    pub fn of_scene(gpu: G, scene: Scene) -> Self {
        let upload_level = scene.data.octree.depth;
        Self {
            gpu,
            drawn: Drawn::Volume {
                data: scene.data,
                renderer: scene.renderer,
                applied: scene.applied_transfer,
                upload_level,
            },
            labels: Vec::new(),
            saved: None,
            notices: Vec::new(),
        }
    }

    /// The app's composite ([`CompositeScene`]) of its channels on screen, drawn in memory
    /// (a streamed one: [`Self::of_store_channels`]).
    pub fn of_composite(gpu: G, composite: CompositeScene) -> Result<Self, SceneError> {
        let (channels, renderer, applied) = composite.into_parts();
        let Some(renderer) = renderer else {
            return Err(SceneError::failed(
                "a streamed composite is drawn from its store, not from memory",
            ));
        };
        let channels = channels
            .into_iter()
            .map(|data| CompositeChannel {
                kind: data.kind,
                values: ChannelValues::Shared(data),
            })
            .collect();
        Ok(Self {
            gpu,
            drawn: Drawn::Composite {
                channels,
                renderer,
                applied,
                alone: None,
            },
            labels: Vec::new(),
            saved: None,
            notices: Vec::new(),
        })
    }

    /// One volume in memory, colored by what `request` asks, uploaded for the renderer asked
    /// for (by default the octree, or bricks where it does not fit, said in a notice).
    fn volume(
        gpu: G,
        mut data: VolumeData,
        options: &DrawOptions,
        saved: Option<SavedTransfer>,
        request: &crate::TransferRequest,
    ) -> Result<Self, SceneError> {
        let context = gpu.borrow();
        let transfer = opening_transfer(&data.quantized, data.kind, data.default_window, request);
        octree::recolor(&mut data.octree, &transfer);
        let settings = options.render_settings(data.octree.depth, saved.as_ref());
        let mut notices = Vec::new();
        let kind = match options.renderer {
            Some(kind) => kind,
            None => renderer_for_octree(context, &data.octree, settings.max_level).unwrap_or_else(
                |(kind, reason)| {
                    notices.push(format!("{reason}; rendering with bricks"));
                    kind
                },
            ),
        };
        let renderer = VolumeRenderer::new(
            context,
            RendererOptions {
                kind,
                brick_size: options.brick_size,
                gpu_memory: options.stream.gpu_memory,
            },
            &data.octree,
            &data.quantized,
            data.volume.spacing,
            settings.max_level,
            &transfer,
        )
        .map_err(|e| SceneError::render(&data.volume.name, e))?;
        Ok(Self {
            gpu,
            drawn: Drawn::Volume {
                data: Arc::new(data),
                renderer,
                applied: transfer,
                upload_level: settings.max_level,
            },
            labels: Vec::new(),
            saved,
            notices,
        })
    }

    /// The composite of `channels` (the dense renderer's), each channel's color and window as
    /// `options` ask; `alone` is the index in its file of a channel drawn alone in its color.
    /// What was asked is checked (the renderer, the channels' colors and windows, the `tf`
    /// file) before `gpu` is asked for the device.
    fn composite(
        gpu: impl FnOnce() -> Result<G, SceneError>,
        channels: Vec<Channel>,
        options: &DrawOptions,
        alone: Option<usize>,
    ) -> Result<Self, SceneError> {
        if let Some(renderer) = options.renderer
            && renderer != RendererKind::Dense
        {
            return Err(SceneError::CompositeNeedsDense {
                channels: channels.len(),
                renderer,
            });
        }
        let channels: Vec<CompositeChannel> = channels
            .into_iter()
            .map(|channel| CompositeChannel {
                kind: DataKind::of_volume(&channel.volume, &channel.quantized),
                values: ChannelValues::Own(Box::new(channel)),
            })
            .collect();
        check_channels(&channels, options, alone)?;
        let saved = options.transfer.saved()?;
        let states = channel_states(&channels, options, saved.as_ref(), alone)?;
        let spacing = channels[0].volume().spacing;
        let gpu = gpu()?;
        let quantized = || channels.iter().map(CompositeChannel::quantized);
        let name = &channels[0].volume().name;
        let renderer =
            VolumeRenderer::new_composite(gpu.borrow(), &layers(quantized(), &states), spacing)
                .map_err(|e| SceneError::render(name, e))?;
        if states.iter().any(|s| !s.visible) {
            write_states(gpu.borrow(), &renderer, quantized(), &states)
                .map_err(|e| SceneError::render(name, e))?;
        }
        Ok(Self {
            gpu,
            drawn: Drawn::Composite {
                channels,
                renderer,
                applied: states,
                alone,
            },
            labels: Vec::new(),
            saved,
            notices: Vec::new(),
        })
    }
}

#[path = "drawable_channels.rs"]
mod channel_rules;
#[path = "drawable_frames.rs"]
mod frames;
#[path = "drawable_streamed.rs"]
mod streamed;

use channel_rules::{
    channel_numbers, channel_states, check_channels, colors_channel, of_one_file, refuse_chosen,
};
use streamed::StreamComposite;
