//! `voxscope info`: the volume and its octree, as a table or as JSON.

use clap::Args;
use serde_json::json;

use super::args::load_error_text;
use super::{Prepared, TransferArgs, VolumeArgs};
use voxscope_octree::{MAX_DEPTH, Node, full_tree_nodes, level_statistics};
use voxscope_scene::beyond_octree;
use voxscope_volume::ome_zarr::{Pyramid, is_zarr_spec};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume, format_dims};

#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// Transparent/opaque counts follow this transfer function.
    #[command(flatten)]
    pub transfer: TransferArgs,
    /// The channels' colors and windows, as `render` composites them.
    #[command(flatten)]
    pub channels: super::composite::ChannelArgs,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &InfoArgs) -> Result<(), String> {
    let volume_args = &args.volume;
    // A bad --tf file fails before anything is read.
    args.transfer.saved()?;
    // A Zarr store's pyramid first: its levels, channels and axes, whichever level opens.
    let mut store = match &volume_args.file {
        Some(spec) if volume_args.raw.is_none() && is_zarr_spec(spec) => {
            let options = volume_args.load_options();
            let pyramid = Pyramid::open_spec(spec, options.select, options.remote)
                .map_err(|e| e.to_string())?;
            Some((pyramid, spec))
        }
        _ => None,
    };
    // A store's level, and each of its channels, are read from that one open (a URL's
    // metadata is fetched once); channels chosen (--channels) are read alone.
    let chosen = args.channels.channels.clone().unwrap_or_default();
    let read = match store.as_mut() {
        _ if !chosen.is_empty() => volume_args
            .open_options()
            .chosen_channels(&chosen)
            .map_err(|e| e.to_string())?,
        Some((pyramid, spec))
            if volume_args.channels_from.is_none() && volume_args.raw.is_none() =>
        {
            let options = volume_args.load_options();
            let read = if pyramid.channels > 1 && volume_args.wants_composite() {
                voxscope_volume::load_opened_channels(pyramid, spec, &options)
            } else {
                voxscope_volume::load_opened(pyramid, spec, &options).map(|v| vec![v])
            };
            Some(read.map_err(|e| load_error_text(&e))?)
        }
        _ => volume_args.composite_channels()?,
    };
    // Several channels: each one's range, window and color; the table below is channel 0's.
    let (volume, channels) = match read {
        Some(channels) if channels.len() > 1 => {
            let first = channels[0].clone();
            (first, args.channels.prepare(channels, &args.transfer)?)
        }
        Some(mut channels) => (channels.pop().ok_or("no channel was read")?, Vec::new()),
        None => (volume_args.load()?, Vec::new()),
    };
    let pyramid = store.map(|(pyramid, _)| pyramid);
    if beyond_octree(volume.dims) {
        print_beyond_octree(&volume, pyramid.as_ref(), args.json);
        return Ok(());
    }
    let prepared = Prepared::from_volume(volume, &args.transfer)?;
    if args.json {
        let mut json = info_json(&prepared);
        if !channels.is_empty() {
            json["composite"] = composite_json(&channels);
        }
        if let Some(pyramid) = &pyramid {
            json["pyramid"] = pyramid_json(pyramid);
        }
        outln!("{json}");
    } else {
        if let Some(pyramid) = &pyramid {
            out!("{}", pyramid_table(pyramid));
        }
        // A pyramid's table lists its channels and time points already.
        out!("{}", info_table(&prepared, pyramid.is_none()));
        if !channels.is_empty() {
            out!("{}", composite_table(&channels));
        }
    }
    Ok(())
}

fn pyramid_json(p: &Pyramid) -> serde_json::Value {
    json!({
        "format": p.format,
        "ome_version": p.ome_version,
        "zarr_format": p.zarr_format,
        "name": p.name,
        "data_type": p.stored_type,
        "read_as": p.voxel_type.name(),
        "axes": p.axes.iter().map(|a| json!({
            "name": a.name,
            "type": format!("{:?}", a.kind).to_lowercase(),
            "unit": a.unit,
        })).collect::<Vec<_>>(),
        "channels": p.channels,
        "time_points": p.time_points,
        "channel": p.selected.channel,
        "time": p.selected.time,
        "omero": p.omero.iter().map(|c| json!({
            "label": c.label,
            "color": c.color,
            "window": c.window.map(|w| [w.low, w.high]),
            "range": c.range,
        })).collect::<Vec<_>>(),
        "downscaling": p.downscaling,
        "labels": p.label_images().iter().map(|l| json!({
            "name": l.name,
            "path": l.path,
            "colors": l.colors.iter().map(|c| json!({"value": c.value, "rgba": c.rgba})).collect::<Vec<_>>(),
            "version": l.version,
            "source_image": l.source_image,
        })).collect::<Vec<_>>(),
        "levels": p.levels.iter().map(|l| json!({
            "path": l.path,
            "dims": l.dims,
            "spacing": l.spacing,
            "origin": l.origin,
            "chunk": l.chunk,
            "shard": l.shard,
            "codec": l.codec,
            "fill_value": l.fill_value,
        })).collect::<Vec<_>>(),
    })
}

fn pyramid_table(p: &Pyramid) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "zarr         {}{}",
        p.format_description(),
        p.name
            .as_ref()
            .map(|n| format!(", image '{n}'"))
            .unwrap_or_default()
    );
    let axes: Vec<String> = p
        .axes
        .iter()
        .map(|a| match &a.unit {
            Some(unit) => format!("{} ({unit})", a.name),
            None => a.name.clone(),
        })
        .collect();
    let _ = writeln!(out, "axes         {}", axes.join(", "));
    let _ = writeln!(
        out,
        "data type    {}{}",
        p.stored_type,
        if p.stored_type == p.voxel_type.name() {
            String::new()
        } else {
            format!(" (read as {})", p.voxel_type.name())
        }
    );
    let _ = writeln!(
        out,
        "time points  {} (showing {})",
        p.time_points, p.selected.time
    );
    let _ = writeln!(
        out,
        "channels     {} (showing {})",
        p.channels, p.selected.channel
    );
    for (index, channel) in p.omero.iter().enumerate() {
        let window = channel
            .window
            .map(|w| format!(", window {} … {}", w.low, w.high))
            .unwrap_or_default();
        let _ = writeln!(
            out,
            "  channel {index}  {}{}{window}",
            channel.label.as_deref().unwrap_or("(no label)"),
            channel
                .color
                .as_ref()
                .map(|c| format!(", color #{c}"))
                .unwrap_or_default()
        );
    }
    let labels = p.label_images();
    if !labels.is_empty() {
        let listed: Vec<String> = labels
            .iter()
            .map(|label| match label.colors.len() {
                0 => format!("{} (labels palette)", label.name),
                1 => format!("{} (1 color)", label.name),
                n => format!("{} ({n} colors)", label.name),
            })
            .collect();
        let _ = writeln!(
            out,
            "labels       {} (render --labels NAME draws one over the image): {}",
            labels.len(),
            listed.join(", ")
        );
    }
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "{:>5} {:<8} {:>16} {:>12} {:>12} {:>26} {:>26}  codec",
        "level", "path", "dims", "chunk", "shard", "spacing", "origin"
    );
    for (index, l) in p.levels.iter().enumerate() {
        let triple = |v: [f64; 3]| format!("{} x {} x {}", v[0], v[1], v[2]);
        let _ = writeln!(
            out,
            "{:>5} {:<8} {:>16} {:>12} {:>12} {:>26} {:>26}  {}",
            index,
            if l.path.is_empty() { "/" } else { &l.path },
            format_dims(l.dims),
            format_dims(l.chunk),
            l.shard.map(format_dims).unwrap_or_else(|| "-".to_owned()),
            triple(l.spacing),
            triple(l.origin),
            l.codec
        );
    }
    let _ = writeln!(out);
    out
}

/// `info` of a volume longer than the voxel octree holds: the volume, and that it streams.
fn print_beyond_octree(volume: &Volume, pyramid: Option<&Pyramid>, as_json: bool) {
    let quantized = QuantizedVolume::new(volume);
    let window = volume
        .default_window
        .unwrap_or_else(|| quantized.robust_window());
    let streamed = format!(
        "none: {} is beyond the voxel octree's {} a side; render draws it with the streaming renderer, from memory",
        format_dims(volume.dims),
        1u32 << MAX_DEPTH
    );
    if as_json {
        let mut json = json!({
            "volume": volume_json(volume, &quantized),
            "octree": null,
            "octree_note": streamed,
        });
        if let Some(pyramid) = pyramid {
            json["pyramid"] = pyramid_json(pyramid);
        }
        outln!("{json}");
    } else {
        if let Some(pyramid) = pyramid {
            out!("{}", pyramid_table(pyramid));
        }
        out!(
            "{}",
            volume_lines(volume, &quantized, window, pyramid.is_none())
        );
        outln!("octree       {streamed}");
    }
}

fn info_json(p: &Prepared) -> serde_json::Value {
    let levels = level_statistics(&p.data.octree);
    json!({
        "volume": volume_json(&p.data.volume, &p.data.quantized),
        "octree": {
            "depth": p.data.octree.depth,
            "side": p.data.octree.side(),
            "node_bytes": std::mem::size_of::<Node>(),
            "total_nodes": p.data.octree.nodes.len(),
            "total_bytes": p.data.octree.node_bytes(),
            "full_tree_nodes": full_tree_nodes(p.data.octree.depth),
            "collapsed_uniform": p.data.octree.collapsed,
            "build_seconds": p.data.octree.build_seconds,
            "recolor_seconds": p.recolor_time.as_secs_f64(),
            "recolor_device": "cpu",
            "levels": levels,
        },
        "transfer": p.transfer,
    })
}

fn volume_json(volume: &Volume, quantized: &QuantizedVolume) -> serde_json::Value {
    json!({
            "file": volume.name,
            "format": volume.format,
            "dims": volume.dims,
            "voxel_type": volume.voxel_type().name(),
            "spacing": volume.spacing,
            "value_range": quantized.value_range,
            "value_scale": {"slope": volume.value_scale.slope, "intercept": volume.value_scale.intercept},
            "robust_window": [quantized.robust_window().low, quantized.robust_window().high],
            "orientation": volume.orientation.describe(),
            "voxels": volume.voxel_count(),
            "metadata": volume.metadata.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<String, serde_json::Value>>(),
            "channels": volume.series.channels.iter().enumerate().map(|(index, c)| json!({
                "index": index,
                "name": c.name,
                "color": c.color.map(hex_color),
                "window": c.window.map(|w| [w.low, w.high]),
            })).collect::<Vec<_>>(),
            "time_points": volume.series.time_points,
            "channel": volume.series.selected.channel,
            "time": volume.series.selected.time,
    })
}

/// The number of the composite's `index`th channel: in its file, where every channel is one
/// file's (a file of more channels than are drawn together opens some of them); its place
/// among `--channels-from`'s files otherwise.
fn channel_number(channels: &[super::composite::PreparedChannel], index: usize) -> usize {
    let one_file = channels
        .iter()
        .all(|c| c.volume.name == channels[0].volume.name);
    if one_file {
        channels[index].volume.series.selected.channel
    } else {
        index
    }
}

/// Each channel of a composite: name, color, value range and window.
fn composite_json(channels: &[super::composite::PreparedChannel]) -> serde_json::Value {
    json!(
        channels
            .iter()
            .enumerate()
            .map(|(index, c)| {
                let series = &c.volume.series;
                json!({
                    "index": channel_number(channels, index),
                    "file": c.volume.name,
                    "name": series.channels.get(series.selected.channel).and_then(|i| i.name.clone()),
                    "color": hex_color(c.state.color),
                    "value_range": c.quantized.value_range,
                    "window": [c.state.transfer.window.low, c.state.transfer.window.high],
                })
            })
            .collect::<Vec<_>>()
    )
}

/// The composite's channels, one line each, after the table of channel 0.
fn composite_table(channels: &[super::composite::PreparedChannel]) -> String {
    use std::fmt::Write;
    let mut out = format!(
        "\ncomposite of {} channels (render draws them together)\n",
        channels.len()
    );
    for (index, c) in channels.iter().enumerate() {
        let series = &c.volume.series;
        let name = series
            .channels
            .get(series.selected.channel)
            .and_then(|i| i.name.as_deref())
            .unwrap_or("(no name)");
        let [low, high] = c.quantized.value_range;
        let index = channel_number(channels, index);
        let _ = writeln!(
            out,
            "  channel {index}  {name}  {}  range {low} … {high}  window {} … {}",
            hex_color(c.state.color),
            c.state.transfer.window.low,
            c.state.transfer.window.high
        );
    }
    out
}

/// `#rrggbb`.
fn hex_color([r, g, b]: [u8; 3]) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// The `channels` and `time points` lines: how many, which is shown, the channels' names and
/// colors where the file gives them.
fn series_lines(series: &voxscope_volume::Series) -> String {
    let described = series
        .channels
        .iter()
        .any(|c| c.name.is_some() || c.color.is_some());
    let mut channels = format!(
        "channels     {} (showing {})",
        series.channel_count(),
        series.selected.channel
    );
    if described {
        let listed: Vec<String> = series
            .channels
            .iter()
            .enumerate()
            .map(|(index, c)| {
                let name = c.name.as_deref().unwrap_or("(no name)");
                match c.color {
                    Some(color) => format!("{index} {name} {}", hex_color(color)),
                    None => format!("{index} {name}"),
                }
            })
            .collect();
        channels.push_str(&format!(": {}", listed.join(", ")));
    }
    format!(
        "{channels}\ntime points  {} (showing {})\n",
        series.time_points, series.selected.time
    )
}

/// The volume's lines of the table: file, format, dims, type, spacing, values, metadata, the
/// series (unless a pyramid's table listed it) and the window.
fn volume_lines(
    volume: &Volume,
    quantized: &QuantizedVolume,
    window: ValueWindow,
    with_series: bool,
) -> String {
    use std::fmt::Write;
    let [low, high] = quantized.value_range;
    let mut out = String::new();
    let _ = writeln!(out, "file         {}", volume.name);
    let _ = writeln!(
        out,
        "format       {} ({})",
        volume.format,
        volume.orientation.describe()
    );
    let _ = writeln!(
        out,
        "dimensions   {}  ({} voxels)",
        format_dims(volume.dims),
        volume.voxel_count()
    );
    let _ = writeln!(out, "voxel type   {}", volume.voxel_type().name());
    let [sx, sy, sz] = volume.spacing;
    let _ = writeln!(out, "spacing      {sx} x {sy} x {sz}");
    let _ = writeln!(out, "value range  {low} … {high}");
    for (key, value) in &volume.metadata {
        let _ = writeln!(out, "{key:<12} {value}");
    }
    if with_series {
        out.push_str(&series_lines(&volume.series));
    }
    let _ = writeln!(out, "window       {} … {}", window.low, window.high);
    out
}

fn info_table(p: &Prepared, with_series: bool) -> String {
    use std::fmt::Write;
    let octree = &p.data.octree;
    let mut out = volume_lines(
        &p.data.volume,
        &p.data.quantized,
        p.transfer.window,
        with_series,
    );
    let _ = writeln!(
        out,
        "octree       depth {}, cube {}³, 8-byte nodes{}",
        octree.depth,
        octree.side(),
        if octree.collapsed {
            ", uniform subtrees collapsed"
        } else {
            ""
        }
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "{:>5} {:>12} {:>12} {:>12} {:>12} {:>14} {:>14}",
        "level", "nodes", "leaves", "transparent", "opaque", "bytes", "full tree"
    );
    let levels = level_statistics(octree);
    for s in &levels {
        let _ = writeln!(
            out,
            "{:>5} {:>12} {:>12} {:>12} {:>12} {:>14} {:>14}",
            s.level, s.nodes, s.leaves, s.transparent, s.opaque, s.bytes, s.full_tree_nodes
        );
    }
    let sum = |f: fn(&voxscope_octree::LevelStatistics) -> u64| levels.iter().map(f).sum::<u64>();
    let _ = writeln!(
        out,
        "{:>5} {:>12} {:>12} {:>12} {:>12} {:>14} {:>14}",
        "total",
        sum(|s| s.nodes),
        sum(|s| s.leaves),
        sum(|s| s.transparent),
        sum(|s| s.opaque),
        sum(|s| s.bytes),
        full_tree_nodes(octree.depth)
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "stored       {} nodes, {:.1} MiB ({:.1}% of the full tree's {} nodes, eq. 1)",
        octree.nodes.len(),
        octree.node_bytes() as f64 / (1 << 20) as f64,
        100.0 * octree.nodes.len() as f64 / full_tree_nodes(octree.depth) as f64,
        full_tree_nodes(octree.depth)
    );
    let _ = writeln!(
        out,
        "build        {:.3} s    recolor {:.1} ms (CPU)",
        octree.build_seconds,
        p.recolor_time.as_secs_f64() * 1e3
    );
    out
}
