//! `--view V.ron`: a saved view ([`SavedView`], the scene layer's options as a file) under
//! the options given beside it on the command line, which win over the view's own.

use std::collections::HashSet;
use std::path::Path;

use clap::ArgMatches;
use clap::parser::ValueSource;
use voxscope_scene::{DrawOptions, OpenOptions, SavedView};

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

/// Takes one command-line option's value from the options the command line gave as a whole
/// into a view's.
type Take<T> = fn(&mut T, &T);

/// The options of the data, by their ids, and what each sets (`file` and `channels_from`
/// name the data together; `max_requests` is the network's, never a view's).
const OPEN_OPTIONS: &[(&str, Take<OpenOptions>)] = &[
    ("channel", |view, flags| view.channel = flags.channel),
    ("time", |view, flags| view.time = flags.time),
    ("raw", |view, flags| view.raw = flags.raw),
    ("spacing", |view, flags| view.spacing = flags.spacing),
];

/// The options of the drawing, by their ids, and what each sets. The opacity options also
/// drop the view's transfer function; `--threshold` applies to it.
const DRAW_OPTIONS: &[(&str, Take<DrawOptions>)] = &[
    ("opacity", |v, f| v.transfer.opacity = f.transfer.opacity),
    ("opacity_points", |v, f| {
        v.transfer.opacity = f.transfer.opacity
    }),
    ("preset", |v, f| v.transfer.preset = f.transfer.preset),
    ("tf", |v, f| v.transfer.tf.clone_from(&f.transfer.tf)),
    ("threshold", |v, f| {
        v.transfer.threshold = f.transfer.threshold
    }),
    ("window", |v, f| v.transfer.window = f.transfer.window),
    ("colormap", |v, f| v.transfer.colormap = f.transfer.colormap),
    ("density", |v, f| v.transfer.density = f.transfer.density),
    ("mode", |v, f| v.transfer.mode = f.transfer.mode),
    ("level", |v, f| v.transfer.level = f.transfer.level),
    ("pixel_lod", |v, f| {
        v.transfer.pixel_lod = f.transfer.pixel_lod
    }),
    ("no_opacity_correction", |v, f| {
        v.transfer.opacity_correction = f.transfer.opacity_correction;
    }),
    ("heatmap", |v, f| v.transfer.heatmap = f.transfer.heatmap),
    ("nearest", |v, f| {
        v.transfer.trilinear = f.transfer.trilinear
    }),
    ("shading", |v, f| {
        v.transfer.shading.enabled = f.transfer.shading.enabled;
    }),
    ("no_shading", |v, f| {
        v.transfer.shading.enabled = f.transfer.shading.enabled;
    }),
    ("ambient", |v, f| {
        v.transfer.shading.ambient = f.transfer.shading.ambient;
    }),
    ("diffuse", |v, f| {
        v.transfer.shading.diffuse = f.transfer.shading.diffuse;
    }),
    ("specular", |v, f| {
        v.transfer.shading.specular = f.transfer.shading.specular;
    }),
    ("shininess", |v, f| {
        v.transfer.shading.shininess = f.transfer.shading.shininess;
    }),
    ("clip_box", |v, f| v.clip.bounds = f.clip.bounds),
    ("clip_plane", |v, f| v.clip.plane = f.clip.plane),
    ("channel_colors", |v, f| {
        v.channels.colors.clone_from(&f.channels.colors);
    }),
    ("channel_window", |v, f| {
        v.channels.windows.clone_from(&f.channels.windows);
    }),
    ("channels", |v, f| {
        v.channels.chosen.clone_from(&f.channels.chosen);
    }),
    ("labels", |v, f| v.labels.names.clone_from(&f.labels.names)),
    ("labels_opacity", |v, f| v.labels.opacity = f.labels.opacity),
    ("labels_hide", |v, f| {
        v.labels.hide.clone_from(&f.labels.hide)
    }),
    ("renderer", |v, f| v.renderer = f.renderer),
    ("brick_size", |v, f| v.brick_size = f.brick_size),
    ("gpu_memory", |v, f| {
        v.stream.gpu_memory = f.stream.gpu_memory
    }),
    ("ram_cache", |v, f| v.stream.ram_cache = f.stream.ram_cache),
    ("upload_budget", |v, f| {
        v.stream.upload_bytes_per_frame = f.stream.upload_bytes_per_frame;
    }),
    ("lod_scale", |v, f| v.stream.lod_scale = f.stream.lod_scale),
    ("uploads", |v, f| v.stream.uploads = f.stream.uploads),
    ("atlas_zero", |v, f| {
        v.stream.atlas_zero = f.stream.atlas_zero
    }),
    ("no_level_walk", |v, f| {
        v.stream.level_walk = f.stream.level_walk
    }),
    ("max_wait", |v, f| v.max_wait = f.max_wait),
    ("size", |v, f| v.size = f.size),
    ("azimuth", |v, f| {
        v.camera.azimuth_deg = f.camera.azimuth_deg
    }),
    ("elevation", |v, f| {
        v.camera.elevation_deg = f.camera.elevation_deg
    }),
    ("distance", |v, f| v.camera.distance = f.camera.distance),
    ("fov", |v, f| v.camera.fov_y_deg = f.camera.fov_y_deg),
];

/// The options of the command line that are not the view's: the output, the views
/// themselves, and the network's and the tests' settings.
#[cfg(test)]
const NOT_IN_VIEWS: &[&str] = &[
    "file",
    "channels_from",
    "field",
    "series",
    "max_requests",
    "output",
    "view",
    "save_view",
    "tile_size",
];

/// The options `view` holds (read from `path`) with those `given` on the command line over
/// them; `open` and `draw` are the command line's options as a whole. A view whose data file
/// is missing (and no file given instead) is an error naming both.
pub fn under_options(
    view: &SavedView,
    path: &Path,
    (open, draw): (&OpenOptions, &DrawOptions),
    given: &Given,
) -> Result<(OpenOptions, DrawOptions), String> {
    let mut opened = OpenOptions {
        max_requests: open.max_requests,
        ..view.open.clone()
    };
    if given.any(&["file", "channels_from"]) {
        opened.source.clone_from(&open.source);
        opened.channels_from.clone_from(&open.channels_from);
    } else if let Some(missing) = view.open.missing_path() {
        return Err(format!(
            "{}: its data {missing} does not exist (give the volume beside --view to use another)",
            path.display()
        ));
    }
    for (id, take) in OPEN_OPTIONS {
        if given.has(id) {
            take(&mut opened, open);
        }
    }
    let mut drawn = view.draw.clone();
    for (id, take) in DRAW_OPTIONS {
        if given.has(id) {
            take(&mut drawn, draw);
        }
    }
    if given.any(&OPACITY_OPTIONS) {
        drawn.transfer.saved = None;
    } else if given.has("threshold")
        && let Some(saved) = &mut drawn.transfer.saved
    {
        saved.transfer.threshold = draw.transfer.threshold;
    }
    Ok((opened, drawn))
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::*;
    use crate::cli::Cli;

    /// A new option of `render` is either a view's (and a view under it takes it) or named
    /// as not one: none is silently dropped under `--view`.
    #[test]
    fn every_render_option_is_taken_over_a_view_or_is_not_a_views() {
        let command = Cli::command();
        let render = command.find_subcommand("render").expect("a render command");
        for arg in render.get_arguments() {
            let id = arg.get_id().as_str();
            let known = OPEN_OPTIONS.iter().any(|(name, _)| *name == id)
                || DRAW_OPTIONS.iter().any(|(name, _)| *name == id)
                || NOT_IN_VIEWS.contains(&id)
                || id == "help";
            assert!(
                known,
                "render's --{id} is neither a view's option nor named as not one"
            );
        }
    }
}
