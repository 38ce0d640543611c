//! What to open and how to draw it, as plain values: the one model that the command line's
//! options, the Python module's keywords and the app's state map into. [`OpenOptions`] names
//! the volume (file or URL, channel, time point, raw layout, spacing); [`DrawOptions`] says
//! how it is drawn (the transfer function and render settings, clipping, the channels' colors
//! and windows, label overlays, the renderer and its budgets, the camera and image size, how
//! long a streamed frame may take). The rules that turn them into a transfer function, render
//! settings and a renderer are written here once; [`crate::Drawable`] draws them.

use std::path::PathBuf;
use std::time::Duration;

use serde::{Deserialize, Serialize};
use voxscope_octree::{Clip, Colormap, OpacityMode, Preset};
use voxscope_render::{
    Camera, DEFAULT_BRICK_SIZE, RenderMode, RenderSettings, RendererKind, Shading,
};
use voxscope_stream::StreamOptions;
use voxscope_volume::ome_zarr::{LabelImage, Pyramid};
use voxscope_volume::{LoadOptions, RawLayout, Selection, ValueWindow, Volume};

use crate::option_text::OptionError;
use crate::{
    ChannelRequest, DEFAULT_LABEL_OPACITY, SavedTransfer, SceneError, TransferRequest, VolumeSource,
};

/// Seconds `render` waits at most for a streamed still to complete (`--max-wait`'s default).
pub const DEFAULT_MAX_WAIT_SECONDS: f64 = 30.0;

/// Which channel of a multi-channel file is drawn: one, or all of them composited. Written
/// as the command line reads it (`"2"`, `"all"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum ChannelChoice {
    Index(usize),
    All,
}

impl ChannelChoice {
    /// `N` or `all` (as the command line and saved views write it).
    pub fn parse(text: &str) -> Result<Self, OptionError> {
        if text.eq_ignore_ascii_case("all") {
            return Ok(Self::All);
        }
        text.parse()
            .map(Self::Index)
            .map_err(|_| OptionError::Channel(text.to_owned()))
    }
}

impl From<ChannelChoice> for String {
    fn from(choice: ChannelChoice) -> Self {
        match choice {
            ChannelChoice::Index(index) => index.to_string(),
            ChannelChoice::All => "all".to_owned(),
        }
    }
}

impl TryFrom<String> for ChannelChoice {
    type Error = OptionError;

    fn try_from(text: String) -> Result<Self, OptionError> {
        Self::parse(text.trim())
    }
}

/// Which volume to open, and how to read it. A view file holds it as `open` (without
/// `max_requests`, which is the network's, not the view's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OpenOptions {
    /// A file, folder, URL or `synthetic:KIND:SIZE`; `None` is the built-in sample.
    pub source: Option<String>,
    /// Read the file as headerless voxels of this layout (`XxYxZ:TYPE:le|be` in a file).
    #[serde(with = "raw_layout_text")]
    pub raw: Option<RawLayout>,
    /// The voxel size, instead of the file's.
    pub spacing: Option<[f64; 3]>,
    /// The channel of a multi-channel image; `None` leaves it to the file (several channels
    /// are then their composite where the caller draws one).
    pub channel: Option<ChannelChoice>,
    /// Files opened together as the channels of one volume, instead of `source`.
    pub channels_from: Option<Vec<String>>,
    /// The time point of a time series.
    pub time: usize,
    /// A URL's store: requests in flight at once, at most.
    #[serde(skip)]
    pub max_requests: usize,
}

impl Default for OpenOptions {
    fn default() -> Self {
        Self {
            source: None,
            raw: None,
            spacing: None,
            channel: None,
            channels_from: None,
            time: 0,
            max_requests: voxscope_volume::remote::DEFAULT_MAX_REQUESTS,
        }
    }
}

impl OpenOptions {
    /// The source, or the built-in sample without one.
    pub fn volume_source(&self) -> VolumeSource {
        match &self.source {
            Some(spec) => VolumeSource::from_spec(spec),
            None => VolumeSource::Sample,
        }
    }

    /// The source's name in messages (the sample's name without one).
    pub fn name(&self) -> &str {
        self.source
            .as_deref()
            .unwrap_or(voxscope_volume::SAMPLE_NAME)
    }

    /// These options as a view file stores them: URLs without user name, password, query or
    /// fragment (credentials and tokens stay out of files that are shared), paths as given.
    pub fn stored(&self) -> Self {
        let stored = |spec: &String| {
            if spec.contains("://") {
                voxscope_volume::remote::redact_url(spec)
            } else {
                spec.clone()
            }
        };
        Self {
            source: self.source.as_ref().map(stored),
            channels_from: self
                .channels_from
                .as_ref()
                .map(|specs| specs.iter().map(stored).collect()),
            max_requests: Self::default().max_requests,
            ..self.clone()
        }
    }

    /// The first path these options name that does not exist (URLs, `synthetic:` and the
    /// sample are not checked: they are not files).
    pub fn missing_path(&self) -> Option<&str> {
        self.source
            .iter()
            .chain(self.channels_from.iter().flatten())
            .map(String::as_str)
            .find(|spec| {
                !spec.contains("://")
                    && !spec.starts_with("synthetic:")
                    && !std::path::Path::new(spec).exists()
            })
    }

    /// The options for [`voxscope_volume::load`].
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            raw: self.raw,
            spacing: self.spacing,
            select: Selection {
                channel: match self.channel {
                    Some(ChannelChoice::Index(channel)) => channel,
                    Some(ChannelChoice::All) | None => 0,
                },
                time: self.time,
            },
            remote: voxscope_volume::remote::RemoteOptions {
                max_requests: self.max_requests,
                ..Default::default()
            },
        }
    }

    /// Reads the source (the channel and time point chosen), or the built-in sample without
    /// one (a source named `sample` is a file of that name, as the command line reads it).
    pub fn load(&self) -> Result<Volume, SceneError> {
        Ok(match &self.source {
            Some(spec) => voxscope_volume::load(spec, &self.load_options())?,
            None => voxscope_volume::sample()?,
        })
    }

    /// Whether the channels are left to the file (no channel number chosen): a file of several
    /// channels is then their composite.
    pub fn wants_composite(&self) -> bool {
        !matches!(self.channel, Some(ChannelChoice::Index(_)))
    }

    /// The channels to composite, when these options ask for a composite or leave it to the
    /// file: every channel of the source at the time point, or the `channels_from` files.
    /// `None` when one channel was chosen.
    pub fn composite_channels(&self) -> Result<Option<Vec<Volume>>, SceneError> {
        self.chosen_channels(&[])
    }

    /// [`Self::composite_channels`], of the file's channels `chosen` (in that order) where
    /// any are (`--channels`); files given as channels are each one.
    pub fn chosen_channels(&self, chosen: &[usize]) -> Result<Option<Vec<Volume>>, SceneError> {
        let options = self.load_options();
        if let Some(specs) = &self.channels_from {
            return Ok(Some(voxscope_volume::load_as_channels(specs, &options)?));
        }
        match &self.source {
            Some(spec) if self.wants_composite() => Ok(Some(voxscope_volume::load_channels(
                spec, &options, chosen,
            )?)),
            _ => Ok(None),
        }
    }

    /// The label images of the OME-Zarr image these options open (none for other files), with
    /// the pyramid they belong to.
    pub fn label_images(&self) -> Option<(Pyramid, Vec<LabelImage>)> {
        let spec = self.source.as_deref()?;
        if self.raw.is_some() || !voxscope_volume::ome_zarr::is_zarr_spec(spec) {
            return None;
        }
        let options = self.load_options();
        let pyramid = Pyramid::open_spec(spec, options.select, options.remote).ok()?;
        let labels = pyramid.label_images();
        Some((pyramid, labels))
    }
}

/// What is asked of the transfer function and the render settings. Without a choice of
/// opacity (`opacity`, `preset`, a `tf` file or a saved view's function), the data decides:
/// CT opens with the ct-soft-tissue preset, label volumes with the labels colormap, the rest
/// with alpha = gray over the default window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TransferOptions {
    /// How opacity follows the value: gray, binary at `threshold`, or a curve.
    pub opacity: Option<OpacityMode>,
    /// A volume-rendering preset.
    pub preset: Option<Preset>,
    /// A transfer function saved by the app (RON), read when drawing starts.
    pub tf: Option<PathBuf>,
    /// The binary threshold on the windowed value, 0…1.
    pub threshold: f32,
    /// The value window in the data's units (default: 0.5–99.5 percentiles).
    pub window: Option<ValueWindow>,
    /// The colors of the windowed value (default: grays; labels for label volumes).
    pub colormap: Option<Colormap>,
    /// The global opacity scale (default: the `tf` file's, else 1).
    pub density: Option<f32>,
    /// DVR or MIP (default: the `tf` file's, else DVR).
    pub mode: Option<RenderMode>,
    /// The deepest octree level drawn (default: the voxels).
    pub level: Option<u32>,
    /// Also stop descending where a node projects to less than a pixel.
    pub pixel_lod: bool,
    /// Correct each sample's alpha for its path length.
    pub opacity_correction: bool,
    /// Draw nodes visited per ray as a heat map.
    pub heatmap: bool,
    /// Filter trilinearly (the dense renderer); else the nearest voxel.
    pub trilinear: bool,
    /// The headlight's shading.
    pub shading: Shading,
    /// A saved view's transfer function, taken like a `tf` file's (`function` in a view
    /// file).
    #[serde(rename = "function")]
    pub saved: Option<SavedTransfer>,
}

impl Default for TransferOptions {
    fn default() -> Self {
        Self {
            opacity: None,
            preset: None,
            tf: None,
            threshold: 0.3,
            window: None,
            colormap: None,
            density: None,
            mode: None,
            level: None,
            pixel_lod: false,
            opacity_correction: true,
            heatmap: false,
            trilinear: true,
            shading: Shading::default(),
            saved: None,
        }
    }
}

impl TransferOptions {
    /// The `tf` file's transfer function, read, if one is named; else a saved view's.
    pub fn saved(&self) -> Result<Option<SavedTransfer>, SceneError> {
        match self.tf.as_deref() {
            Some(path) => SavedTransfer::read(path)
                .map(Some)
                .map_err(SceneError::TransferFile),
            None => Ok(self.saved),
        }
    }

    /// The options that draw `saved` (a transfer function as drawn, its opacity scale and
    /// mode; `None`: the data's own) with `settings`' level, shading and interpolation: what
    /// a saved view holds.
    pub fn drawn(saved: Option<SavedTransfer>, settings: &RenderSettings) -> Self {
        Self {
            threshold: saved.map_or(Self::default().threshold, |s| s.transfer.threshold),
            level: Some(settings.max_level),
            pixel_lod: settings.pixel_lod,
            opacity_correction: settings.opacity_correction,
            heatmap: settings.heatmap,
            trilinear: settings.trilinear,
            shading: settings.shading,
            saved,
            ..Self::default()
        }
    }

    /// The saved (or a view's) transfer function with the window and colormap asked over it;
    /// `None` without one (the data's own is then drawn).
    pub fn saved_function(&self) -> Option<voxscope_octree::TransferFunction> {
        self.saved.map(|saved| {
            let mut transfer = saved.transfer;
            if let Some(window) = self.window {
                transfer.window = window;
            }
            if let Some(colormap) = self.colormap {
                transfer.colormap = colormap;
            }
            transfer
        })
    }

    /// What these options ask of the transfer function a volume opens with
    /// ([`crate::opening_transfer`] applies it); `saved` is [`Self::saved`]'s.
    pub fn request(&self, saved: Option<&SavedTransfer>) -> TransferRequest {
        TransferRequest {
            saved: saved.map(|s| s.transfer),
            preset: self.preset,
            opacity: self.opacity,
            threshold: Some(self.threshold),
            colormap: self.colormap,
            window: self.window,
            mip: self.mode == Some(RenderMode::Mip),
        }
    }

    /// Render settings for an octree (or pyramid) `depth` deep, the level clamped to it;
    /// `saved`'s opacity scale and mode apply unless given here. No clip.
    pub fn render_settings(&self, depth: u32, saved: Option<&SavedTransfer>) -> RenderSettings {
        RenderSettings {
            mode: self
                .mode
                .unwrap_or_else(|| saved.map_or(RenderMode::Dvr, |s| s.mode)),
            max_level: self.level.unwrap_or(depth).min(depth),
            pixel_lod: self.pixel_lod,
            opacity_correction: self.opacity_correction,
            density: self
                .density
                .unwrap_or_else(|| saved.map_or(1.0, |s| s.density)),
            heatmap: self.heatmap,
            trilinear: self.trilinear,
            shading: self.shading,
            clip: Clip::NONE,
        }
    }
}

/// Label overlays drawn over the image: label images of the opened OME-Zarr image by name, or
/// label files on the image's grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LabelOptions {
    /// The label images' names or files, drawn in this order.
    pub names: Vec<String>,
    /// The labels' opacity over the image, 0…1.
    pub opacity: f32,
    /// Label values not drawn.
    pub hide: Vec<f64>,
}

impl Default for LabelOptions {
    fn default() -> Self {
        Self {
            names: Vec::new(),
            opacity: DEFAULT_LABEL_OPACITY,
            hide: Vec::new(),
        }
    }
}

/// How a volume is drawn, and one frame of it: everything `render` takes but the volume and
/// the output file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DrawOptions {
    pub transfer: TransferOptions,
    pub clip: Clip,
    /// The composite's channels' colors and windows (a channel chosen alone takes its own).
    pub channels: ChannelRequest,
    pub labels: LabelOptions,
    /// The renderer asked for; `None` chooses (the octree, else bricks where it does not fit;
    /// the streaming renderer beyond the octree's size).
    pub renderer: Option<RendererKind>,
    /// Voxels along a brick's side (the bricks renderer).
    pub brick_size: usize,
    /// The streaming renderer's budgets.
    pub stream: StreamOptions,
    /// How long a streamed frame may take to complete before it is read as it is (seconds
    /// in a file).
    #[serde(with = "seconds")]
    pub max_wait: Duration,
    pub camera: Camera,
    /// The image's width and height in pixels.
    pub size: (u32, u32),
}

impl Default for DrawOptions {
    fn default() -> Self {
        Self {
            transfer: TransferOptions::default(),
            clip: Clip::NONE,
            channels: ChannelRequest::default(),
            labels: LabelOptions::default(),
            renderer: None,
            brick_size: DEFAULT_BRICK_SIZE,
            stream: StreamOptions::default(),
            max_wait: Duration::from_secs_f64(DEFAULT_MAX_WAIT_SECONDS),
            camera: Camera::default(),
            size: (1024, 768),
        }
    }
}

impl DrawOptions {
    /// The render settings of a frame of a volume `depth` deep: the transfer options' and the
    /// clip.
    pub fn render_settings(&self, depth: u32, saved: Option<&SavedTransfer>) -> RenderSettings {
        RenderSettings {
            clip: self.clip,
            ..self.transfer.render_settings(depth, saved)
        }
    }
}

/// A raw layout as `--raw` reads it, `XxYxZ:TYPE:le|be`.
mod raw_layout_text {
    use serde::{Deserialize, Deserializer, Serializer};
    use voxscope_volume::{Endian, RawLayout};

    pub fn serialize<S: Serializer>(layout: &Option<RawLayout>, out: S) -> Result<S::Ok, S::Error> {
        match layout {
            Some(layout) => {
                let [x, y, z] = layout.dims;
                let endian = match layout.endian {
                    Endian::Little => "le",
                    Endian::Big => "be",
                };
                out.serialize_some(&format!(
                    "{x}x{y}x{z}:{}:{endian}",
                    layout.voxel_type.name()
                ))
            }
            None => out.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(input: D) -> Result<Option<RawLayout>, D::Error> {
        Option::<String>::deserialize(input)?
            .map(|text| {
                RawLayout::parse(&text).map_err(|e| serde::de::Error::custom(format!("raw: {e}")))
            })
            .transpose()
    }
}

/// A duration as seconds, a number from 0 up.
mod seconds {
    use std::time::Duration;

    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(duration: &Duration, out: S) -> Result<S::Ok, S::Error> {
        out.serialize_f64(duration.as_secs_f64())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(input: D) -> Result<Duration, D::Error> {
        let seconds = f64::deserialize(input)?;
        Duration::try_from_secs_f64(seconds).map_err(|_| {
            serde::de::Error::custom(format!("{seconds} is not a number of seconds from 0 up"))
        })
    }
}
