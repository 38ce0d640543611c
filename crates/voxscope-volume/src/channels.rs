//! Several channels of one time point as volumes on one grid: every channel of a
//! multi-channel file, or several single-channel files opened together.

use super::{LoadError, LoadOptions, Selection, Volume, format_dims, load};

/// The most channels shown together (the composite renderer's textures hold 8).
pub const MAX_CHANNELS: usize = 8;

/// The colors channels take where the file names none, in napari's order for additive
/// channels: green, magenta, cyan, yellow, red, blue, orange, gray (the command line's
/// `--channel-colors` names them).
pub const DEFAULT_CHANNEL_COLORS: [(&str, [u8; 3]); MAX_CHANNELS] = [
    ("green", [0, 255, 0]),
    ("magenta", [255, 0, 255]),
    ("cyan", [0, 255, 255]),
    ("yellow", [255, 255, 0]),
    ("red", [255, 0, 0]),
    ("blue", [0, 0, 255]),
    ("orange", [255, 165, 0]),
    ("gray", [255, 255, 255]),
];

/// The color of a name in [`DEFAULT_CHANNEL_COLORS`] (`grey` too), any case.
pub fn channel_color_by_name(name: &str) -> Option<[u8; 3]> {
    let name = name.trim().to_lowercase();
    let name = if name == "grey" {
        "gray"
    } else {
        name.as_str()
    };
    DEFAULT_CHANNEL_COLORS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, rgb)| *rgb)
}

/// Channel `index`'s color: the file's (`info`, OME or omero) where it names one, else
/// [`DEFAULT_CHANNEL_COLORS`] in turn.
pub fn channel_color(info: Option<&super::ChannelInfo>, index: usize) -> [u8; 3] {
    info.and_then(|c| c.color)
        .unwrap_or(DEFAULT_CHANNEL_COLORS[index % DEFAULT_CHANNEL_COLORS.len()].1)
}

/// The channels of `spec` an image opens with, at `options.select.time` (one volume for a
/// one-channel file): every channel, or of a file of more than [`MAX_CHANNELS`] those it does
/// not mark inactive (OME-Zarr `omero` `active`), at most [`MAX_CHANNELS`]
/// ([`super::Series::opening_channels`]).
pub fn load_all_channels(spec: &str, options: &LoadOptions) -> Result<Vec<Volume>, LoadError> {
    let at = |channel| LoadOptions {
        select: Selection {
            channel,
            time: options.select.time,
        },
        ..options.clone()
    };
    let first = load(spec, &at(0))?;
    let mut first = Some(first);
    let opening = first
        .as_ref()
        .map_or_else(Vec::new, |f| f.series.opening_channels(MAX_CHANNELS));
    opening
        .into_iter()
        .map(|channel| match first.take_if(|_| channel == 0) {
            Some(volume) => Ok(volume),
            None => load(spec, &at(channel)),
        })
        .collect()
}

/// The channels numbered `numbers` in `spec`'s file, in that order, at `options.select.time`
/// (`--channels 1,8` in memory); none: those it opens with ([`load_all_channels`]).
pub fn load_channels(
    spec: &str,
    options: &LoadOptions,
    numbers: &[usize],
) -> Result<Vec<Volume>, LoadError> {
    if numbers.is_empty() {
        return load_all_channels(spec, options);
    }
    let at = |channel| LoadOptions {
        select: Selection {
            channel,
            time: options.select.time,
        },
        ..options.clone()
    };
    // The first one tells the file's channels: the rest are checked before one is read.
    let first = load(spec, &at(numbers[0]))?;
    let count = first.series.channel_count();
    if numbers.len() > MAX_CHANNELS {
        return Err(LoadError::new(
            spec,
            format!(
                "{} channels chosen; at most {MAX_CHANNELS} are drawn together",
                numbers.len()
            ),
        ));
    }
    if let Some(&beyond) = numbers.iter().find(|&&n| n >= count) {
        return Err(LoadError::new(
            spec,
            format!(
                "there is no channel {beyond} ({count} channels, 0 to {})",
                count - 1
            ),
        ));
    }
    if let Some(twice) = numbers
        .iter()
        .enumerate()
        .find_map(|(i, n)| numbers[..i].contains(n).then_some(*n))
    {
        return Err(LoadError::new(
            spec,
            format!("channel {twice} is chosen twice"),
        ));
    }
    let mut volumes = vec![first];
    for &channel in &numbers[1..] {
        volumes.push(load(spec, &at(channel))?);
    }
    Ok(volumes)
}

/// [`load_all_channels`] of a Zarr store already opened as `pyramid`: each channel read from
/// that one open (`pyramid`'s selection is put back after).
pub fn load_opened_channels(
    pyramid: &mut super::ome_zarr::Pyramid,
    spec: &str,
    options: &LoadOptions,
) -> Result<Vec<Volume>, LoadError> {
    pyramid.check_channel_axis()?;
    let selected = pyramid.selected;
    let channels = pyramid
        .opening_channels(MAX_CHANNELS)
        .into_iter()
        .map(|channel| {
            let select = Selection {
                channel,
                time: options.select.time,
            };
            pyramid.selected = select;
            let options = LoadOptions {
                select,
                ..options.clone()
            };
            super::registry::load_opened(pyramid, spec, &options)
        })
        .collect();
    pyramid.selected = selected;
    channels
}

/// The files `specs` (each its frame `options.select`) as the channels of one volume: they
/// must share their dimensions; the first one's spacing and orientation are the volume's.
pub fn load_as_channels(specs: &[String], options: &LoadOptions) -> Result<Vec<Volume>, LoadError> {
    if specs.is_empty() || specs.len() > MAX_CHANNELS {
        return Err(LoadError::new(
            specs.join(","),
            format!(
                "{} files given as channels; 1 to {MAX_CHANNELS} are shown together",
                specs.len()
            ),
        ));
    }
    let mut channels: Vec<Volume> = Vec::with_capacity(specs.len());
    for spec in specs {
        let volume = load(spec, options)?;
        if let Some(first) = channels.first()
            && first.dims != volume.dims
        {
            return Err(LoadError::new(
                spec,
                format!(
                    "dimensions {} differ from {}'s {}; channels need one grid",
                    format_dims(volume.dims),
                    first.name,
                    format_dims(first.dims)
                ),
            ));
        }
        channels.push(volume);
    }
    Ok(channels)
}
