//! `--view V.ron` and `--save-view V.ron`: a saved view ([`SavedView`]) under the options given
//! beside it on the command line, and the view of what a render drew.

use std::collections::HashSet;
use std::path::Path;

use clap::ArgMatches;
use clap::parser::ValueSource;
use voxscope_octree::TransferFunction;
use voxscope_render::RendererKind;
use voxscope_scene::{
    Drawable, SavedTransfer, SavedView, VIEW_VERSION, ViewChannel, ViewData, ViewStream,
};
use voxscope_volume::{Endian, RawLayout};

use super::args::{ChannelChoice, RendererArg};
use super::{RenderOptions, VolumeArgs};

/// The options given on the command line (not left at their defaults), by their ids (the
/// field names: `azimuth`, `opacity_points`, `file`).
#[derive(Debug, Clone, Default)]
pub struct Given(HashSet<String>);

impl Given {
    /// The options `matches` holds from the command line.
    pub fn of(matches: Option<&ArgMatches>) -> Self {
        let Some(matches) = matches else {
            return Self::default();
        };
        Self(
            matches
                .ids()
                .filter(|id| {
                    matches!(
                        matches.value_source(id.as_str()),
                        Some(ValueSource::CommandLine | ValueSource::EnvVariable)
                    )
                })
                .map(|id| id.as_str().to_owned())
                .collect(),
        )
    }

    /// Whether option `id` was given.
    pub fn has(&self, id: &str) -> bool {
        self.0.contains(id)
    }

    /// Whether any of `ids` was given.
    pub fn any(&self, ids: &[&str]) -> bool {
        ids.iter().any(|id| self.has(id))
    }
}

/// The options that choose the transfer function's opacity (they replace a view's function).
pub const OPACITY_OPTIONS: [&str; 4] = ["opacity", "opacity_points", "preset", "tf"];

/// Sets what `view` holds into `volume` and `options`, except where an option was `given`
/// beside it. A view whose data file is missing (and no file given instead) is an error
/// naming both.
pub fn apply(
    view: &SavedView,
    path: &Path,
    volume: &mut VolumeArgs,
    options: &mut RenderOptions,
    given: &Given,
) -> Result<(), String> {
    if !given.any(&["file", "channels_from"]) {
        if let Some(missing) = view.data.missing_path() {
            return Err(format!(
                "{}: its data {missing} does not exist (give the volume beside --view to use another)",
                path.display()
            ));
        }
        volume.file = view.data.source.clone();
        volume.channels_from =
            (!view.data.channels_from.is_empty()).then(|| view.data.channels_from.clone());
    }
    let bad = |what: &str, e: String| format!("{}: {what}: {e}", path.display());
    if !given.has("channel") {
        volume.channel = view
            .data
            .channel
            .as_deref()
            .map(ChannelChoice::parse)
            .transpose()
            .map_err(|e| bad("channel", e))?;
    }
    if !given.has("time") {
        volume.time = view.data.time;
    }
    if !given.has("raw") {
        volume.raw = view
            .data
            .raw
            .as_deref()
            .map(RawLayout::parse)
            .transpose()
            .map_err(|e| bad("raw", e))?;
    }
    if !given.has("spacing") {
        volume.spacing = view.data.spacing;
    }
    let transfer = &mut options.transfer;
    let settings = view.settings;
    if let Some(function) = view.transfer
        && !given.any(&OPACITY_OPTIONS)
    {
        let mut function = function;
        if given.has("threshold") {
            function.threshold = transfer.threshold;
        }
        transfer.view_transfer = Some(SavedTransfer {
            transfer: function,
            density: settings.map_or(1.0, |s| s.density),
            mode: settings.map_or(voxscope_render::RenderMode::Dvr, |s| s.mode),
        });
    }
    if let Some(settings) = settings {
        let keep = |id: &str| !given.has(id);
        if keep("level") {
            transfer.level = Some(settings.max_level);
        }
        if keep("pixel_lod") {
            transfer.pixel_lod = settings.pixel_lod;
        }
        if keep("no_opacity_correction") {
            transfer.no_opacity_correction = !settings.opacity_correction;
        }
        if keep("heatmap") {
            transfer.heatmap = settings.heatmap;
        }
        if keep("nearest") {
            transfer.nearest = !settings.trilinear;
        }
        if !given.any(&["shading", "no_shading"]) {
            transfer.no_shading = !settings.shading.enabled;
            transfer.shading = settings.shading.enabled;
        }
        let shading = settings.shading;
        for (id, value, slot) in [
            ("ambient", shading.ambient, &mut transfer.ambient),
            ("diffuse", shading.diffuse, &mut transfer.diffuse),
            ("specular", shading.specular, &mut transfer.specular),
            ("shininess", shading.shininess, &mut transfer.shininess),
        ] {
            if keep(id) {
                *slot = Some(value);
            }
        }
        if keep("clip_box") {
            options.clip.clip_box = settings.clip.bounds;
        }
        if keep("clip_plane") {
            options.clip.clip_plane = settings.clip.plane;
        }
    }
    if !view.channels.is_empty() {
        if !given.has("channel_colors") {
            options.channels.channel_colors = Some(view.channels.iter().map(|c| c.color).collect());
        }
        if !given.has("channel_window") {
            options.channels.channel_window = view
                .channels
                .iter()
                .enumerate()
                .map(|(index, c)| (index, c.transfer.window))
                .collect();
        }
    }
    if !given.has("renderer") {
        options.renderer = view.renderer.and_then(renderer_arg);
    }
    if !given.has("brick_size")
        && let Some(size) = view.brick_size
    {
        options.brick_size = size;
    }
    if let Some(stream) = view.stream {
        let stream_options = &mut options.stream;
        if !given.has("gpu_memory") {
            stream_options.gpu_memory = stream.gpu_memory;
        }
        if !given.has("ram_cache") {
            stream_options.ram_cache = stream.ram_cache;
        }
        if !given.has("upload_budget") {
            stream_options.upload_budget = stream.upload_budget;
        }
        if !given.has("lod_scale") {
            stream_options.lod_scale = stream.lod_scale;
        }
        if !given.has("max_wait") {
            options.max_wait = stream.max_wait;
        }
    }
    if !given.has("size") {
        options.size = (view.size[0], view.size[1]);
    }
    let camera = view.camera;
    if !given.has("azimuth") {
        options.azimuth = camera.azimuth_deg;
    }
    if !given.has("elevation") {
        options.elevation = camera.elevation_deg;
    }
    if !given.has("distance") {
        options.distance = camera.distance;
    }
    if !given.has("fov") {
        options.fov = camera.fov_y_deg;
    }
    options.pan = camera.pan;
    Ok(())
}

/// The transfer function a keyframe `view` shows under the options `given` beside it:
/// `opened` (the first keyframe's, as the data opened with the options) where the options
/// choose the opacity or the view has none, else the view's with the window, colormap and
/// threshold given over it.
pub fn transfer_of(
    view: &SavedView,
    opened: &TransferFunction,
    options: &RenderOptions,
    given: &Given,
) -> TransferFunction {
    let Some(mut transfer) = view.transfer.filter(|_| !given.any(&OPACITY_OPTIONS)) else {
        return *opened;
    };
    let asked = &options.transfer;
    if given.has("window")
        && let Some(window) = asked.window
    {
        transfer.window = window;
    }
    if given.has("colormap")
        && let Some(colormap) = asked.colormap
    {
        transfer.colormap = colormap;
    }
    if given.has("threshold") {
        transfer.threshold = asked.threshold;
    }
    transfer
}

fn renderer_arg(kind: RendererKind) -> Option<RendererArg> {
    match kind {
        RendererKind::Octree => Some(RendererArg::Octree),
        RendererKind::Dense => Some(RendererArg::Dense),
        RendererKind::Bricks => Some(RendererArg::Bricks),
        RendererKind::Stream => Some(RendererArg::Stream),
        RendererKind::Composite => None,
    }
}

/// `XxYxZ:TYPE:le|be`, as `--raw` reads it.
fn raw_text(layout: &RawLayout) -> String {
    let [x, y, z] = layout.dims;
    let endian = match layout.endian {
        Endian::Little => "le",
        Endian::Big => "be",
    };
    format!("{x}x{y}x{z}:{}:{endian}", layout.voxel_type.name())
}

/// The view of what `drawing` drew for `volume` and `options` (`render --save-view`).
pub fn view_of(volume: &VolumeArgs, options: &RenderOptions, drawing: &Drawable) -> SavedView {
    let channels = drawing
        .channels()
        .unwrap_or_default()
        .iter()
        .map(|c| ViewChannel {
            color: c.color,
            transfer: c.transfer,
            visible: c.visible,
        })
        .collect();
    // The renderer asked for where the data chose it (streamed beyond the octree, or the
    // composite), else the one that drew.
    let renderer = if drawing.is_streamed() || drawing.channels().is_some() {
        options.renderer.map(Into::into)
    } else {
        Some(drawing.renderer().kind())
    };
    let stream = &options.stream;
    SavedView {
        version: VIEW_VERSION,
        data: ViewData {
            source: volume.file.as_deref().map(ViewData::stored_source),
            channels_from: volume
                .channels_from
                .iter()
                .flatten()
                .map(|spec| ViewData::stored_source(spec))
                .collect(),
            channel: volume.channel.map(|channel| match channel {
                ChannelChoice::Index(index) => index.to_string(),
                ChannelChoice::All => "all".to_owned(),
            }),
            time: volume.time,
            raw: volume.raw.as_ref().map(raw_text),
            spacing: volume.spacing,
        },
        camera: options.camera(),
        size: [options.size.0, options.size.1],
        transfer: Some(drawing.transfer()),
        channels,
        settings: Some(drawing.render_settings(&options.draw_options())),
        renderer,
        brick_size: Some(options.brick_size),
        stream: Some(ViewStream {
            gpu_memory: stream.gpu_memory,
            ram_cache: stream.ram_cache,
            upload_budget: stream.upload_budget,
            lod_scale: stream.lod_scale,
            max_wait: options.max_wait,
        }),
        rulers: Vec::new(),
        layout: None,
    }
}
