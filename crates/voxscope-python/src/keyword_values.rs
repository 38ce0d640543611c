//! Keyword values read into the scene layer's options: each keyword's text (as
//! [`crate::keywords`] wrote it) set into [`DrawOptions`], [`OpenOptions`] or
//! [`ConvertOptions`] by the parser its command-line option uses, and a refused value worded
//! as the command line words that option's (`invalid value 'X' for '--name <VALUE>': why`).

use voxscope_scene::{ChannelChoice, ConvertOptions, DrawOptions, OpenOptions};

/// The text of `word` (`--name=TEXT`), or whether a flag is on (`--name`: true,
/// `--no-name`: false).
enum WordValue<'a> {
    Text(&'a str),
    Flag(bool),
}

fn word_value(word: &str) -> WordValue<'_> {
    match word.split_once('=') {
        Some((_, text)) => WordValue::Text(text),
        None => WordValue::Flag(!word.starts_with("--no-")),
    }
}

/// Why a keyword's value was refused, worded as the command line words its option's
/// ([`Self::message`]).
pub(crate) enum Refused {
    /// The value's text, and what its parser said (an enum's name says nothing more).
    Value { text: String, why: Option<String> },
    /// A whole line.
    Line(String),
}

impl Refused {
    /// The value `text` refused by its parser, which says why.
    fn value<E: std::fmt::Display>(text: &str) -> impl FnOnce(E) -> Self + '_ {
        move |why| Self::Value {
            text: text.to_owned(),
            why: Some(why.to_string()),
        }
    }

    /// The name `text` refused by its parser (an enum's: its name says nothing more).
    fn name<E>(text: &str) -> impl FnOnce(E) -> Self + '_ {
        move |_| Self::Value {
            text: text.to_owned(),
            why: None,
        }
    }

    /// The command line's line for the option `option` (`--name <VALUE>`, as
    /// `keywords::shown` writes it): `invalid value 'X' for '--name <VALUE>': why`.
    pub(crate) fn message(self, option: &str) -> String {
        match self {
            Self::Value { text, why } => {
                let mut line = format!("invalid value '{text}' for '{option}'");
                if let Some(why) = why {
                    line.push_str(": ");
                    line.push_str(&why);
                }
                line
            }
            Self::Line(line) => line,
        }
    }
}

/// A number of type `T`.
fn number<T: std::str::FromStr>(text: &str) -> Result<T, Refused>
where
    T::Err: std::fmt::Display,
{
    text.parse().map_err(|e: T::Err| Refused::Value {
        text: text.to_owned(),
        why: Some(e.to_string()),
    })
}

/// Sets keyword `name`'s `word` (as [`write`] wrote it) into `options`.
pub(crate) fn set_option(options: &mut DrawOptions, name: &str, word: &str) -> Result<(), Refused> {
    use voxscope_octree::{Clip, OpacityCurve, OpacityMode};
    use voxscope_scene::option_text as parse;
    use voxscope_volume::ValueWindow;
    let t = match word_value(word) {
        WordValue::Text(text) => text,
        WordValue::Flag(on) => {
            match name {
                "pixel_lod" => options.transfer.pixel_lod = on,
                "opacity_correction" => options.transfer.opacity_correction = on,
                "heatmap" => options.transfer.heatmap = on,
                "nearest" => options.transfer.trilinear = !on,
                "shading" => options.transfer.shading.enabled = on,
                _ => return Err(Refused::Line(format!("{name}= takes a value"))),
            }
            return Ok(());
        }
    };
    let transfer = &mut options.transfer;
    match name {
        "mode" => transfer.mode = Some(parse::parse_mode(t).map_err(Refused::name(t))?),
        "opacity" => {
            transfer.opacity = Some(parse::parse_opacity_mode(t).map_err(Refused::name(t))?);
        }
        "opacity_points" => {
            transfer.opacity = Some(OpacityMode::Points(
                OpacityCurve::parse(t).map_err(Refused::value(t))?,
            ));
        }
        "preset" => transfer.preset = Some(parse::parse_preset(t).map_err(Refused::value(t))?),
        "tf" => transfer.tf = Some(t.into()),
        "threshold" => transfer.threshold = parse::parse_unit(t).map_err(Refused::value(t))?,
        "window" => transfer.window = Some(ValueWindow::parse(t).map_err(Refused::value(t))?),
        "colormap" => {
            transfer.colormap = Some(parse::parse_colormap(t).map_err(Refused::value(t))?)
        }
        "density" => transfer.density = Some(number(t)?),
        "level" => transfer.level = Some(number(t)?),
        "ambient" => transfer.shading.ambient = parse::parse_unit(t).map_err(Refused::value(t))?,
        "diffuse" => transfer.shading.diffuse = parse::parse_unit(t).map_err(Refused::value(t))?,
        "specular" => {
            transfer.shading.specular = parse::parse_unit(t).map_err(Refused::value(t))?
        }
        "shininess" => {
            transfer.shading.shininess = parse::parse_shininess(t).map_err(Refused::value(t))?
        }
        "clip_box" => options.clip.bounds = Some(Clip::parse_box(t).map_err(Refused::value(t))?),
        "clip_plane" => options.clip.plane = Some(Clip::parse_plane(t).map_err(Refused::value(t))?),
        "channel_colors" => {
            // One value each, as the option's comma list is.
            options.channels.colors = t
                .split(',')
                .map(|color| parse::parse_color(color).map_err(Refused::value(color)))
                .collect::<Result<_, _>>()?;
        }
        "channels" => {
            options.channels.chosen = t
                .split(',')
                .map(|n| n.trim().parse::<usize>().map_err(Refused::value(n)))
                .collect::<Result<_, _>>()?;
        }
        "labels" => {
            options.labels.names = t.split(',').map(|n| n.trim().to_owned()).collect();
        }
        "labels_opacity" => {
            options.labels.opacity = parse::parse_opacity(t).map_err(Refused::value(t))?
        }
        "labels_hide" => {
            options.labels.hide = t
                .split(',')
                .map(|v| number::<f64>(v.trim()))
                .collect::<Result<_, _>>()?;
        }
        "channel_window" => options
            .channels
            .windows
            .push(parse::parse_channel_window(t).map_err(Refused::value(t))?),
        "renderer" => options.renderer = Some(parse::parse_renderer(t).map_err(Refused::name(t))?),
        "brick_size" => {
            options.brick_size = parse::parse_brick_size(t).map_err(Refused::value(t))?
        }
        "gpu_memory" => {
            options.stream.gpu_memory = parse::parse_bytes(t).map_err(Refused::value(t))?
        }
        "ram_cache" => {
            options.stream.ram_cache = parse::parse_bytes(t).map_err(Refused::value(t))?
        }
        "upload_budget" => {
            options.stream.upload_bytes_per_frame =
                parse::parse_bytes(t).map_err(Refused::value(t))?;
        }
        "uploads" => options.stream.uploads = parse::parse_uploads(t).map_err(Refused::name(t))?,
        "lod_scale" => {
            options.stream.lod_scale = parse::parse_lod_scale(t).map_err(Refused::value(t))?
        }
        "max_wait" => {
            options.max_wait =
                parse::max_wait(number(t)?).map_err(|e| Refused::Line(e.to_string()))?;
        }
        "size" => options.size = parse::parse_size(t).map_err(Refused::value(t))?,
        "azimuth" => options.camera.azimuth_deg = number(t)?,
        "elevation" => options.camera.elevation_deg = number(t)?,
        "distance" => options.camera.distance = number(t)?,
        "fov" => options.camera.fov_y_deg = number(t)?,
        _ => return Err(Refused::Line(format!("{name}= is not a drawing keyword"))),
    }
    Ok(())
}

/// Sets `open()`'s keyword `name`'s `word` into `options`.
pub(crate) fn set_open_option(
    options: &mut OpenOptions,
    name: &str,
    word: &str,
) -> Result<(), Refused> {
    use voxscope_scene::option_text as parse;
    let WordValue::Text(t) = word_value(word) else {
        return Err(Refused::Line(format!("{name}= takes a value")));
    };
    match name {
        "raw" => {
            options.raw = Some(voxscope_volume::RawLayout::parse(t).map_err(Refused::value(t))?)
        }
        "spacing" => options.spacing = Some(parse::parse_spacing(t).map_err(Refused::value(t))?),
        "channel" => options.channel = Some(ChannelChoice::parse(t).map_err(Refused::value(t))?),
        "time" => options.time = number(t)?,
        "max_requests" => {
            options.max_requests = parse::parse_max_requests(t).map_err(Refused::value(t))?
        }
        _ => return Err(Refused::Line(format!("{name}= is not an open() keyword"))),
    }
    Ok(())
}

/// Sets `convert()`'s keyword `name`'s `word` into `options`.
pub(crate) fn set_convert_option(
    options: &mut ConvertOptions,
    name: &str,
    word: &str,
) -> Result<(), Refused> {
    use voxscope_scene::option_text as parse;
    use voxscope_volume::ome_zarr::{Compression, ZarrVersion};
    let t = match word_value(word) {
        WordValue::Text(text) => text,
        WordValue::Flag(on) if name == "labels" => {
            options.labels = on;
            return Ok(());
        }
        WordValue::Flag(_) => return Err(Refused::Line(format!("{name}= takes a value"))),
    };
    match name {
        "raw" => {
            options.raw = Some(voxscope_volume::RawLayout::parse(t).map_err(Refused::value(t))?)
        }
        "spacing" => options.spacing = Some(parse::parse_spacing(t).map_err(Refused::value(t))?),
        "channel" => options.channel = number(t)?,
        "time" => options.time = number(t)?,
        "max_requests" => {
            options.max_requests = parse::parse_max_requests(t).map_err(Refused::value(t))?
        }
        "format" => {
            options.version = match t {
                "0.4" => ZarrVersion::V04,
                "0.5" => ZarrVersion::V05,
                _ => {
                    return Err(Refused::Value {
                        text: t.to_owned(),
                        why: None,
                    });
                }
            }
        }
        "chunk" => options.chunk = number(t)?,
        "shard" => options.shard = number(t)?,
        "compression" => options.compression = Compression::parse(t).map_err(Refused::value(t))?,
        "unit" => options.unit = Some(t.to_owned()),
        "tile" => options.tile = Some(parse::parse_copies(t).map_err(Refused::value(t))?),
        "upsample" => options.upsample = Some(parse::parse_copies(t).map_err(Refused::value(t))?),
        "noise" => options.noise = number(t)?,
        _ => return Err(Refused::Line(format!("{name}= is not a convert() keyword"))),
    }
    Ok(())
}
