//! View files of version 1 (written before the options model): what they held, read into a
//! [`SavedView`] of today. A field a file lacks takes its default, as it did then.

use std::time::Duration;

use serde::Deserialize;
use voxscope_octree::TransferFunction;
use voxscope_render::{Camera, DEFAULT_BRICK_SIZE, RenderMode, RenderSettings, RendererKind};
use voxscope_stream::StreamOptions;
use voxscope_volume::RawLayout;

use crate::{
    ChannelChoice, ChannelRequest, DrawOptions, OpenOptions, SavedTransfer, SavedView,
    TransferOptions, ViewProblem, ViewRuler,
};

/// A version 1 view file.
#[derive(Deserialize)]
#[serde(default)]
struct ViewV1 {
    data: DataV1,
    camera: Camera,
    size: [u32; 2],
    transfer: Option<TransferFunction>,
    channels: Vec<ChannelV1>,
    settings: Option<RenderSettings>,
    renderer: Option<RendererKind>,
    brick_size: Option<usize>,
    stream: Option<StreamV1>,
    rulers: Vec<ViewRuler>,
    layout: Option<String>,
}

impl Default for ViewV1 {
    fn default() -> Self {
        Self {
            data: DataV1::default(),
            camera: Camera::default(),
            size: [1024, 768],
            transfer: None,
            channels: Vec::new(),
            settings: None,
            renderer: None,
            brick_size: None,
            stream: None,
            rulers: Vec::new(),
            layout: None,
        }
    }
}

#[derive(Default, Deserialize)]
#[serde(default)]
struct DataV1 {
    source: Option<String>,
    channels_from: Vec<String>,
    channel: Option<String>,
    time: usize,
    raw: Option<String>,
    spacing: Option<[f64; 3]>,
}

#[derive(Deserialize)]
struct ChannelV1 {
    color: [u8; 3],
    transfer: TransferFunction,
    #[serde(default = "shown")]
    visible: bool,
}

fn shown() -> bool {
    true
}

#[derive(Clone, Copy, Deserialize)]
struct StreamV1 {
    gpu_memory: u64,
    ram_cache: u64,
    upload_budget: u64,
    lod_scale: f32,
    max_wait: f64,
}

/// Reads a version 1 file's text: `Err` where it is no RON of that version, `Ok(Err)` where a
/// value in it is not one a view can hold.
pub fn parse(text: &str) -> Result<Result<SavedView, ViewProblem>, ron::error::SpannedError> {
    ron::from_str::<ViewV1>(text).map(ViewV1::into_view)
}

impl ViewV1 {
    fn into_view(self) -> Result<SavedView, ViewProblem> {
        let invalid = |what: &str, e: String| ViewProblem::Invalid(format!("{what}: {e}"));
        let data = self.data;
        let open = OpenOptions {
            source: data.source,
            channels_from: (!data.channels_from.is_empty()).then_some(data.channels_from),
            channel: data
                .channel
                .as_deref()
                .map(|text| ChannelChoice::parse(text.trim()))
                .transpose()
                .map_err(|e| invalid("channel", e.to_string()))?,
            time: data.time,
            raw: data
                .raw
                .as_deref()
                .map(RawLayout::parse)
                .transpose()
                .map_err(|e| invalid("raw", e.to_string()))?,
            spacing: data.spacing,
            ..OpenOptions::default()
        };
        let settings = self.settings;
        let saved = self.transfer.map(|transfer| SavedTransfer {
            transfer,
            density: settings.map_or(1.0, |s| s.density),
            mode: settings.map_or(RenderMode::Dvr, |s| s.mode),
        });
        let transfer = match settings {
            Some(settings) => TransferOptions::drawn(saved, &settings),
            None => TransferOptions {
                saved,
                ..TransferOptions::default()
            },
        };
        let stream_defaults = StreamOptions::default();
        let (stream, max_wait) = match self.stream {
            Some(s) => (
                StreamOptions {
                    gpu_memory: s.gpu_memory,
                    ram_cache: s.ram_cache,
                    upload_bytes_per_frame: s.upload_budget,
                    lod_scale: s.lod_scale,
                    ..stream_defaults
                },
                Duration::try_from_secs_f64(s.max_wait).map_err(|_| {
                    invalid(
                        "max_wait",
                        format!("{} is not a number of seconds from 0 up", s.max_wait),
                    )
                })?,
            ),
            None => (stream_defaults, DrawOptions::default().max_wait),
        };
        let channels = &self.channels;
        let draw = DrawOptions {
            transfer,
            clip: settings.map_or(voxscope_octree::Clip::NONE, |s| s.clip),
            channels: ChannelRequest {
                colors: channels.iter().map(|c| c.color).collect(),
                windows: channels
                    .iter()
                    .enumerate()
                    .map(|(index, c)| (index, c.transfer.window))
                    .collect(),
                hidden: (0..channels.len())
                    .filter(|&i| !channels[i].visible)
                    .collect(),
                chosen: Vec::new(),
            },
            // The app wrote the composite's renderer, which the channels choose.
            renderer: self
                .renderer
                .filter(|kind| *kind != RendererKind::Composite),
            brick_size: self.brick_size.unwrap_or(DEFAULT_BRICK_SIZE),
            stream,
            max_wait,
            camera: self.camera,
            size: (self.size[0], self.size[1]),
            ..DrawOptions::default()
        };
        Ok(SavedView {
            version: crate::VIEW_VERSION,
            open,
            draw,
            rulers: self.rulers,
            layout: self.layout,
        })
    }
}
