//! The options' text forms, parsed in one place for the command line's flags and the Python
//! module's keywords (`gpu_memory="2GiB"` is `--gpu-memory 2GiB`): each parser checks its
//! range and says what is wrong in one line naming the value.

use voxscope_octree::{Colormap, Preset};
use voxscope_render::{RenderMode, RendererKind};
use voxscope_stream::UploadPath;
use voxscope_volume::{DEFAULT_CHANNEL_COLORS, ValueWindow, channel_color_by_name};

/// `--max-requests`: 1 to [`voxscope_volume::remote::MAX_MAX_REQUESTS`].
pub fn parse_max_requests(text: &str) -> Result<usize, String> {
    use voxscope_volume::remote::MAX_MAX_REQUESTS;
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=MAX_MAX_REQUESTS).contains(&n) => Ok(n),
        _ => Err(format!(
            "'{text}' is not a number of requests from 1 to {MAX_MAX_REQUESTS}"
        )),
    }
}

/// A voxel size `SX,SY,SZ`, three positive numbers.
pub fn parse_spacing(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("spacing '{text}' is not SX,SY,SZ"))?;
    match values[..] {
        [x, y, z] if [x, y, z].iter().all(|v| v.is_finite() && *v > 0.0) => Ok([x, y, z]),
        _ => Err(format!("spacing '{text}' needs three positive numbers")),
    }
}

/// A brick side: a power of two from 4 to 32.
pub fn parse_brick_size(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if n.is_power_of_two() && (4..=32).contains(&n) => Ok(n),
        _ => Err(format!("brick size '{text}' is not 4, 8, 16 or 32")),
    }
}

/// A colormap by name.
pub fn parse_colormap(text: &str) -> Result<Colormap, String> {
    Colormap::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = Colormap::ALL.iter().map(|c| c.name()).collect();
        format!("colormap '{text}' is not one of {}", names.join(", "))
    })
}

/// A preset by name.
pub fn parse_preset(text: &str) -> Result<Preset, String> {
    Preset::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
        format!("preset '{text}' is not one of {}", names.join(", "))
    })
}

/// The highlight's exponent, 1…128.
pub fn parse_shininess(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if (1.0..=128.0).contains(&v) => Ok(v),
        _ => Err(format!("shininess '{text}' is not a number from 1 to 128")),
    }
}

/// A number from 0 to 1 (a threshold, a shading share).
pub fn parse_unit(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{text}' is not a number from 0 to 1")),
    }
}

/// A color name of [`DEFAULT_CHANNEL_COLORS`] (`grey` too) or `#rrggbb`.
pub fn parse_color(text: &str) -> Result<[u8; 3], String> {
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
    let names: Vec<&str> = DEFAULT_CHANNEL_COLORS.iter().map(|(n, _)| *n).collect();
    Err(format!(
        "color '{text}' is not one of {} or #rrggbb",
        names.join(", ")
    ))
}

/// `N:LOW:HIGH`.
pub fn parse_channel_window(text: &str) -> Result<(usize, ValueWindow), String> {
    let (channel, window) = text
        .split_once(':')
        .ok_or_else(|| format!("channel window '{text}' is not N:LOW:HIGH"))?;
    let channel = channel
        .trim()
        .parse::<usize>()
        .map_err(|_| format!("channel window '{text}': '{channel}' is not a channel number"))?;
    let window = ValueWindow::parse(window).map_err(|e| format!("channel window '{text}': {e}"))?;
    Ok((channel, window))
}

/// `WxH`, each from 1 to 16384.
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once('x')
        .ok_or_else(|| format!("size '{text}' is not WxH"))?;
    match (w.parse::<u32>(), h.parse::<u32>()) {
        (Ok(w), Ok(h)) if (1..=16384).contains(&w) && (1..=16384).contains(&h) => Ok((w, h)),
        _ => Err(format!("size '{text}' needs W and H from 1 to 16384")),
    }
}

/// `N`, or `N` with a binary unit: `K`/`KiB`, `M`/`MiB`, `G`/`GiB`, `T`/`TiB` (`2GiB`, `512M`).
pub fn parse_bytes(text: &str) -> Result<u64, String> {
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
        _ => {
            return Err(format!(
                "size '{text}' has an unknown unit (use K, M, G, T or KiB, MiB, GiB, TiB)"
            ));
        }
    };
    let value: f64 = number
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v > 0.0)
        .ok_or_else(|| format!("size '{text}' is not a positive number of bytes"))?;
    let bytes = value * (1u64 << shift) as f64;
    if bytes >= u64::MAX as f64 {
        return Err(format!("size '{text}' is too large"));
    }
    Ok(bytes as u64)
}

/// The streaming renderer's level-of-detail scale, 0…64.
pub fn parse_lod_scale(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if (0.0..=64.0).contains(&v) => Ok(v),
        _ => Err(format!("lod scale '{text}' is not a number from 0 to 64")),
    }
}

/// A label layer's opacity, 0…1.
pub fn parse_opacity(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{text}' is not an opacity from 0 to 1")),
    }
}

/// `N` or `X,Y,Z` copies or factors (`--tile`, `--upsample`).
pub fn parse_copies(text: &str) -> Result<[usize; 3], String> {
    let numbers: Vec<usize> = text
        .split(',')
        .map(|n| n.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{text}' is not N or X,Y,Z"))?;
    match numbers[..] {
        [n] => Ok([n; 3]),
        [x, y, z] => Ok([x, y, z]),
        _ => Err(format!("'{text}' is not N or X,Y,Z")),
    }
}

/// The longest wait taken as given (about a century); a longer one waits that long.
const MAX_WAIT_SECONDS: f64 = 3.2e9;

/// How long a streamed frame may take (`--max-wait`): seconds, 0 or more.
pub fn max_wait(seconds: f64) -> Result<std::time::Duration, String> {
    if seconds.is_finite() && seconds >= 0.0 {
        Ok(std::time::Duration::from_secs_f64(
            seconds.min(MAX_WAIT_SECONDS),
        ))
    } else {
        Err(format!("--max-wait {seconds} is not a number of seconds"))
    }
}

/// One of `names` (each with its value), case-insensitive; else a line naming `what` and
/// the choices.
fn one_of<T: Copy>(what: &str, text: &str, names: &[(&str, T)]) -> Result<T, String> {
    names
        .iter()
        .find(|(name, _)| name.eq_ignore_ascii_case(text.trim()))
        .map(|(_, value)| *value)
        .ok_or_else(|| {
            let choices: Vec<&str> = names.iter().map(|(name, _)| *name).collect();
            format!("{what} '{text}' is not one of {}", choices.join(", "))
        })
}

/// `dvr` or `mip`.
pub fn parse_mode(text: &str) -> Result<RenderMode, String> {
    one_of(
        "mode",
        text,
        &[("dvr", RenderMode::Dvr), ("mip", RenderMode::Mip)],
    )
}

/// `gray` or `binary` (an opacity curve is `--opacity-points`).
pub fn parse_opacity_mode(text: &str) -> Result<voxscope_octree::OpacityMode, String> {
    use voxscope_octree::OpacityMode;
    one_of(
        "opacity",
        text,
        &[("gray", OpacityMode::Gray), ("binary", OpacityMode::Binary)],
    )
}

/// `octree`, `dense`, `bricks` or `stream`.
pub fn parse_renderer(text: &str) -> Result<RendererKind, String> {
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
pub fn parse_uploads(text: &str) -> Result<UploadPath, String> {
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
            parse_uploads("post"),
            Err("uploads 'post' is not one of scatter, copies, queue".to_owned())
        );
    }
}
