//! `voxscope probe`: the value of one voxel, where it is, and in which units, for scripts.

use clap::Args;
use serde_json::json;

use super::VolumeArgs;
use voxscope_volume::{Orientation, Volume, format_dims};

#[derive(Debug, Args)]
pub struct ProbeArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// The voxel I,J,K in the displayed order (RAS-reordered, as `slice` and the app use).
    #[arg(long, value_name = "I,J,K", value_parser = parse_index)]
    pub at: [usize; 3],
    /// Label volumes to read the voxel's label from, beside its value: label images of the
    /// OME-Zarr image by name, or label files on its grid (default: every label image the
    /// image lists).
    #[arg(long, value_name = "NAME|FILE", value_delimiter = ',')]
    pub labels: Vec<String>,
    /// Print one JSON object instead of lines.
    #[arg(long)]
    pub json: bool,
}

/// What `probe` reports of one voxel.
#[derive(Debug, Clone, PartialEq)]
pub struct Probed {
    /// The voxel in the displayed (RAS-reordered) order.
    pub index: [usize; 3],
    /// The same voxel in the file's own index order.
    pub stored_index: [usize; 3],
    /// The voxel's center relative to the first voxel's, in the file's unit.
    pub position: [f64; 3],
    /// The value in the data's own units (scale and intercept applied).
    pub value: f64,
    /// The values' unit where the file says (`HU` for CT).
    pub unit: Option<String>,
}

/// One channel's value at the probed voxel, of a file of several.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelValue {
    /// Its number in the file.
    pub index: usize,
    /// The file's name for it, if any.
    pub name: Option<String>,
    pub value: f64,
    pub unit: Option<String>,
}

pub fn run(args: &ProbeArgs) -> Result<(), String> {
    let open = args.volume.open_options();
    // A file of several channels: every channel it opens with (all, or its active ones) is
    // read at the voxel, unless --channel chose one.
    let channels = match open.composite_channels().map_err(|e| e.to_string())? {
        Some(channels) if !channels.is_empty() => channels,
        _ => vec![args.volume.load()?],
    };
    let volume = &channels[0];
    let probed = probe(volume, args.at)?;
    let channel_values = if channels.len() > 1 {
        // Files given as channels (--channels-from) are numbered in their order, named by file.
        let as_files = args.volume.channels_from.is_some();
        channels
            .iter()
            .enumerate()
            .map(|(position, channel)| {
                channel_value(channel, args.at, as_files.then_some(position))
            })
            .collect::<Result<Vec<_>, _>>()?
    } else {
        Vec::new()
    };
    let names = if args.labels.is_empty() {
        open.label_images()
            .map(|(_, labels)| labels.into_iter().map(|label| label.name).collect())
            .unwrap_or_default()
    } else {
        args.labels.clone()
    };
    let labels: Vec<(String, f64)> = voxscope_scene::open_overlays(&names, &open, volume.dims)
        .map_err(|e| e.to_string())?
        .iter()
        .map(|overlay| (overlay.name.clone(), overlay.value_at(probed.index)))
        .collect();
    if args.json {
        let labels: serde_json::Map<String, serde_json::Value> = labels
            .iter()
            .map(|(name, value)| (name.clone(), json!(value)))
            .collect();
        outln!(
            "{}",
            json!({
                "file": volume.name,
                "dims": volume.dims,
                "index": probed.index,
                "stored_index": probed.stored_index,
                "position": probed.position,
                "position_unit": volume.spatial_unit(),
                "value": probed.value,
                "unit": probed.unit,
                "channels": channel_values.iter().map(|c| json!({
                    "index": c.index,
                    "name": c.name,
                    "value": c.value,
                    "unit": c.unit,
                })).collect::<Vec<_>>(),
                "labels": labels,
            })
        );
    } else {
        let [i, j, k] = probed.index;
        let [x, y, z] = probed.position;
        let [si, sj, sk] = probed.stored_index;
        outln!("voxel      ({i}, {j}, {k}) displayed · ({si}, {sj}, {sk}) as stored");
        outln!(
            "position   {} from the first voxel",
            volume.with_unit(format!("({x:.3}, {y:.3}, {z:.3})"))
        );
        if channel_values.is_empty() {
            match &probed.unit {
                Some(unit) => outln!("value      {} {unit}", probed.value),
                None => outln!("value      {}", probed.value),
            }
        }
        for channel in &channel_values {
            let unit = channel
                .unit
                .as_deref()
                .map_or(String::new(), |u| format!(" {u}"));
            let name = channel.name.as_deref().unwrap_or("");
            outln!("channel {}  {}{unit} {name}", channel.index, channel.value);
        }
        for (name, value) in &labels {
            outln!("label      {value} ({name})");
        }
    }
    Ok(())
}

/// The voxel `index` (displayed order) of `volume`; an index outside the volume is an error
/// naming the dimensions.
pub fn probe(volume: &Volume, index: [usize; 3]) -> Result<Probed, String> {
    let [i, j, k] = index;
    let value = volume.value(i, j, k).ok_or_else(|| {
        format!(
            "{}: voxel ({i}, {j}, {k}) is outside its {} voxels",
            volume.name,
            format_dims(volume.dims)
        )
    })?;
    Ok(Probed {
        index,
        stored_index: stored_index(volume, index),
        position: std::array::from_fn(|a| index[a] as f64 * volume.spacing[a]),
        value,
        unit: value_unit(volume),
    })
}

/// Channel `volume`'s value at `index`, numbered and named by its file (`file_number`: a file
/// given as a channel, numbered so and named by the file).
fn channel_value(
    volume: &Volume,
    index: [usize; 3],
    file_number: Option<usize>,
) -> Result<ChannelValue, String> {
    let probed = probe(volume, index)?;
    let channel = volume.series.selected.channel;
    let (index, name) = match file_number {
        Some(number) => (number, Some(volume.name.clone())),
        None => (
            channel,
            volume
                .series
                .channels
                .get(channel)
                .and_then(|c| c.name.clone()),
        ),
    };
    Ok(ChannelValue {
        index,
        name,
        value: probed.value,
        unit: probed.unit,
    })
}

/// Where displayed voxel `index` sits in the file: each stored axis ran along one RAS axis,
/// forwards or backwards (`Orientation::Reoriented`'s letters, e.g. `LIA`).
pub fn stored_index(volume: &Volume, index: [usize; 3]) -> [usize; 3] {
    let Orientation::Reoriented { stored } = &volume.orientation else {
        return index;
    };
    let mut result = index;
    for (axis, letter) in stored.chars().enumerate().take(3) {
        let (world, forward) = match letter {
            'R' => (0, true),
            'L' => (0, false),
            'A' => (1, true),
            'P' => (1, false),
            'S' => (2, true),
            _ => (2, false),
        };
        let displayed = index[world];
        result[axis] = if forward {
            displayed
        } else {
            volume.dims[world] - 1 - displayed
        };
    }
    result
}

/// The unit of the values, where the file gives one.
fn value_unit(volume: &Volume) -> Option<String> {
    if volume
        .metadata_value("modality")
        .is_some_and(|m| m.eq_ignore_ascii_case("CT"))
    {
        return Some("HU".to_owned());
    }
    volume
        .metadata_value("value unit")
        .or_else(|| volume.metadata_value("units"))
        .map(str::to_owned)
}

fn parse_index(text: &str) -> Result<[usize; 3], String> {
    let values: Vec<usize> = text
        .split(',')
        .map(|v| v.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{text}' is not I,J,K (three whole numbers)"))?;
    <[usize; 3]>::try_from(values).map_err(|_| format!("'{text}' is not I,J,K (three numbers)"))
}
