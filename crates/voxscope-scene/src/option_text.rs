//! The options' text forms, parsed in one place for the command line's flags and the Python
//! module's keywords (`gpu_memory="2GiB"` is `--gpu-memory 2GiB`): each parser checks its
//! range and says what is wrong in one line naming the value.

use voxscope_octree::{Colormap, Preset};
use voxscope_render::{RenderMode, RendererKind};
use voxscope_stream::UploadPath;
use voxscope_volume::remote::MAX_MAX_REQUESTS;
use voxscope_volume::{DEFAULT_CHANNEL_COLORS, ValueWindow, channel_color_by_name};

/// Why an option's text was refused: displays as the one line the command line shows after
/// `invalid value 'TEXT' for '--option <VALUE>': `, and the Python module after its keyword
/// (the same words).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptionError {
    /// A channel that is neither a number nor `all`.
    #[error("channel '{0}' is not a number or 'all'")]
    Channel(String),
    /// `--max-requests` outside 1…[`MAX_MAX_REQUESTS`].
    #[error("'{0}' is not a number of requests from 1 to {MAX_MAX_REQUESTS}")]
    MaxRequests(String),
    /// A spacing that is not three comma-separated numbers.
    #[error("spacing '{0}' is not SX,SY,SZ")]
    SpacingNotTriple(String),
    /// A spacing of other than three positive numbers.
    #[error("spacing '{0}' needs three positive numbers")]
    SpacingNotPositive(String),
    /// A brick side other than 4, 8, 16 or 32.
    #[error("brick size '{0}' is not 4, 8, 16 or 32")]
    BrickSize(String),
    /// No colormap by that name.
    #[error("colormap '{0}' is not one of {names}", names = names(Colormap::ALL.iter().map(|c| c.name())))]
    Colormap(String),
    /// No preset by that name.
    #[error("preset '{0}' is not one of {names}", names = names(Preset::ALL.iter().map(|p| p.name())))]
    Preset(String),
    /// A shininess outside 1…128.
    #[error("shininess '{0}' is not a number from 1 to 128")]
    Shininess(String),
    /// A number outside 0…1.
    #[error("'{0}' is not a number from 0 to 1")]
    Unit(String),
    /// No color by that name, nor `#rrggbb`.
    #[error("color '{0}' is not one of {names} or #rrggbb", names = names(DEFAULT_CHANNEL_COLORS.iter().map(|(n, _)| *n)))]
    Color(String),
    /// A channel window without its first `:`.
    #[error("channel window '{0}' is not N:LOW:HIGH")]
    ChannelWindowForm(String),
    /// A channel window whose channel is not a number.
    #[error("channel window '{text}': '{channel}' is not a channel number")]
    ChannelNumber { text: String, channel: String },
    /// A channel window whose window is refused.
    #[error("channel window '{text}': {error}")]
    ChannelWindow {
        text: String,
        error: voxscope_volume::OptionError,
    },
    /// A size without its `x`.
    #[error("size '{0}' is not WxH")]
    SizeForm(String),
    /// A size whose sides are not numbers from 1 to 16384.
    #[error("size '{0}' needs W and H from 1 to 16384")]
    SizeRange(String),
    /// A byte count of an unknown unit.
    #[error("size '{0}' has an unknown unit (use K, M, G, T or KiB, MiB, GiB, TiB)")]
    ByteUnit(String),
    /// A byte count that is not a positive number.
    #[error("size '{0}' is not a positive number of bytes")]
    ByteCount(String),
    /// A byte count beyond 64 bits.
    #[error("size '{0}' is too large")]
    BytesTooLarge(String),
    /// A level-of-detail scale outside 0…64.
    #[error("lod scale '{0}' is not a number from 0 to 64")]
    LodScale(String),
    /// A label layer's opacity outside 0…1.
    #[error("'{0}' is not an opacity from 0 to 1")]
    Opacity(String),
    /// Copies or factors that are not `N` or `X,Y,Z`.
    #[error("'{0}' is not N or X,Y,Z")]
    Copies(String),
    /// A `--max-wait` that is negative or not a number.
    #[error("--max-wait {0} is not a number of seconds")]
    MaxWait(f64),
    /// A name that is none of `choices` for the option `what`.
    #[error("{what} '{text}' is not one of {}", choices.join(", "))]
    NotOneOf {
        what: &'static str,
        text: String,
        choices: Vec<&'static str>,
    },
}

/// `names`, comma-separated: the choices a message lists.
fn names<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
}

/// `--max-requests`: 1 to [`voxscope_volume::remote::MAX_MAX_REQUESTS`].
pub fn parse_max_requests(text: &str) -> Result<usize, OptionError> {
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=MAX_MAX_REQUESTS).contains(&n) => Ok(n),
        _ => Err(OptionError::MaxRequests(text.to_owned())),
    }
}

/// A voxel size `SX,SY,SZ`, three positive numbers.
pub fn parse_spacing(text: &str) -> Result<[f64; 3], OptionError> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| OptionError::SpacingNotTriple(text.to_owned()))?;
    match values[..] {
        [x, y, z] if [x, y, z].iter().all(|v| v.is_finite() && *v > 0.0) => Ok([x, y, z]),
        _ => Err(OptionError::SpacingNotPositive(text.to_owned())),
    }
}

/// A brick side: a power of two from 4 to 32.
pub fn parse_brick_size(text: &str) -> Result<usize, OptionError> {
    match text.parse::<usize>() {
        Ok(n) if n.is_power_of_two() && (4..=32).contains(&n) => Ok(n),
        _ => Err(OptionError::BrickSize(text.to_owned())),
    }
}

/// A colormap by name.
pub fn parse_colormap(text: &str) -> Result<Colormap, OptionError> {
    Colormap::from_name(text).ok_or_else(|| OptionError::Colormap(text.to_owned()))
}

/// A preset by name.
pub fn parse_preset(text: &str) -> Result<Preset, OptionError> {
    Preset::from_name(text).ok_or_else(|| OptionError::Preset(text.to_owned()))
}

/// The highlight's exponent, 1…128.
pub fn parse_shininess(text: &str) -> Result<f32, OptionError> {
    match text.parse::<f32>() {
        Ok(v) if (1.0..=128.0).contains(&v) => Ok(v),
        _ => Err(OptionError::Shininess(text.to_owned())),
    }
}

/// A number from 0 to 1 (a threshold, a shading share).
pub fn parse_unit(text: &str) -> Result<f32, OptionError> {
    match text.parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(OptionError::Unit(text.to_owned())),
    }
}

/// A color name of [`DEFAULT_CHANNEL_COLORS`] (`grey` too) or `#rrggbb`.
pub fn parse_color(text: &str) -> Result<[u8; 3], OptionError> {
    if let Some(rgb) = channel_color_by_name(text) {
        return Ok(rgb);
    }
    let name = text.trim().to_lowercase();
    if let Some(hex) = name.strip_prefix('#')
        && hex.len() == 6
        && let Ok(value) = u32::from_str_radix(hex, 16)
    {
        let [_, r, g, b] = value.to_be_bytes();
        return Ok([r, g, b]);
    }
    Err(OptionError::Color(text.to_owned()))
}

/// `N:LOW:HIGH`.
pub fn parse_channel_window(text: &str) -> Result<(usize, ValueWindow), OptionError> {
    let (channel, window) = text
        .split_once(':')
        .ok_or_else(|| OptionError::ChannelWindowForm(text.to_owned()))?;
    let channel = channel
        .trim()
        .parse::<usize>()
        .map_err(|_| OptionError::ChannelNumber {
            text: text.to_owned(),
            channel: channel.to_owned(),
        })?;
    let window = ValueWindow::parse(window).map_err(|error| OptionError::ChannelWindow {
        text: text.to_owned(),
        error,
    })?;
    Ok((channel, window))
}

/// `WxH`, each from 1 to 16384.
pub fn parse_size(text: &str) -> Result<(u32, u32), OptionError> {
    let (w, h) = text
        .split_once('x')
        .ok_or_else(|| OptionError::SizeForm(text.to_owned()))?;
    match (w.parse::<u32>(), h.parse::<u32>()) {
        (Ok(w), Ok(h)) if (1..=16384).contains(&w) && (1..=16384).contains(&h) => Ok((w, h)),
        _ => Err(OptionError::SizeRange(text.to_owned())),
    }
}

/// `N`, or `N` with a binary unit: `K`/`KiB`, `M`/`MiB`, `G`/`GiB`, `T`/`TiB` (`2GiB`, `512M`).
pub fn parse_bytes(text: &str) -> Result<u64, OptionError> {
    let trimmed = text.trim();
    let split = trimmed
        .find(|c: char| !c.is_ascii_digit() && c != '.')
        .unwrap_or(trimmed.len());
    let (number, unit) = trimmed.split_at(split);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kib" => 10,
        "m" | "mib" => 20,
        "g" | "gib" => 30,
        "t" | "tib" => 40,
        _ => return Err(OptionError::ByteUnit(text.to_owned())),
    };
    let value: f64 = number
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v > 0.0)
        .ok_or_else(|| OptionError::ByteCount(text.to_owned()))?;
    let bytes = value * (1u64 << shift) as f64;
    if bytes >= u64::MAX as f64 {
        return Err(OptionError::BytesTooLarge(text.to_owned()));
    }
    Ok(bytes as u64)
}

/// The streaming renderer's level-of-detail scale, 0…64.
pub fn parse_lod_scale(text: &str) -> Result<f32, OptionError> {
    match text.parse::<f32>() {
        Ok(v) if (0.0..=64.0).contains(&v) => Ok(v),
        _ => Err(OptionError::LodScale(text.to_owned())),
    }
}

/// A label layer's opacity, 0…1.
pub fn parse_opacity(text: &str) -> Result<f32, OptionError> {
    match text.trim().parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(OptionError::Opacity(text.to_owned())),
    }
}

/// `N` or `X,Y,Z` copies or factors (`--tile`, `--upsample`).
pub fn parse_copies(text: &str) -> Result<[usize; 3], OptionError> {
    let numbers: Vec<usize> = text
        .split(',')
        .map(|n| n.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| OptionError::Copies(text.to_owned()))?;
    match numbers[..] {
        [n] => Ok([n; 3]),
        [x, y, z] => Ok([x, y, z]),
        _ => Err(OptionError::Copies(text.to_owned())),
    }
}

/// The longest wait taken as given (about a century); a longer one waits that long.
const MAX_WAIT_SECONDS: f64 = 3.2e9;

/// How long a streamed frame may take (`--max-wait`): seconds, 0 or more.
pub fn max_wait(seconds: f64) -> Result<std::time::Duration, OptionError> {
    if seconds.is_finite() && seconds >= 0.0 {
        Ok(std::time::Duration::from_secs_f64(
            seconds.min(MAX_WAIT_SECONDS),
        ))
    } else {
        Err(OptionError::MaxWait(seconds))
    }
}

/// One of `names` (each with its value), case-insensitive; else a line naming `what` and
/// the choices.
fn one_of<T: Copy>(
    what: &'static str,
    text: &str,
    names: &[(&'static str, T)],
) -> Result<T, OptionError> {
    names
        .iter()
        .find(|(name, _)| name.eq_ignore_ascii_case(text.trim()))
        .map(|(_, value)| *value)
        .ok_or_else(|| OptionError::NotOneOf {
            what,
            text: text.to_owned(),
            choices: names.iter().map(|(name, _)| *name).collect(),
        })
}

/// `dvr` or `mip`.
pub fn parse_mode(text: &str) -> Result<RenderMode, OptionError> {
    one_of(
        "mode",
        text,
        &[("dvr", RenderMode::Dvr), ("mip", RenderMode::Mip)],
    )
}

/// `gray` or `binary` (an opacity curve is `--opacity-points`).
pub fn parse_opacity_mode(text: &str) -> Result<voxscope_octree::OpacityMode, OptionError> {
    use voxscope_octree::OpacityMode;
    one_of(
        "opacity",
        text,
        &[("gray", OpacityMode::Gray), ("binary", OpacityMode::Binary)],
    )
}

/// `octree`, `dense`, `bricks` or `stream`.
pub fn parse_renderer(text: &str) -> Result<RendererKind, OptionError> {
    one_of(
        "renderer",
        text,
        &[
            ("octree", RendererKind::Octree),
            ("dense", RendererKind::Dense),
            ("bricks", RendererKind::Bricks),
            ("stream", RendererKind::Stream),
        ],
    )
}

/// `scatter`, `copies` or `queue`.
pub fn parse_uploads(text: &str) -> Result<UploadPath, OptionError> {
    one_of(
        "uploads",
        text,
        &[
            ("scatter", UploadPath::Scatter),
            ("copies", UploadPath::Copies),
            ("queue", UploadPath::Queue),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_take_binary_units() {
        assert_eq!(parse_bytes("1024"), Ok(1024));
        assert_eq!(parse_bytes("2GiB"), Ok(2 << 30));
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("1.5 KiB"), Ok(1536));
        for bad in ["", "GiB", "-1G", "3 parsecs", "0"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn names_are_case_insensitive_and_a_wrong_one_lists_the_choices() {
        assert_eq!(parse_mode("MIP"), Ok(RenderMode::Mip));
        assert_eq!(parse_renderer("bricks"), Ok(RendererKind::Bricks));
        assert_eq!(
            parse_uploads("post").map_err(|e| e.to_string()),
            Err("uploads 'post' is not one of scatter, copies, queue".to_owned())
        );
    }
}
