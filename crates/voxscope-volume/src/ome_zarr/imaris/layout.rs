//! What an Imaris file holds, read from its HDF5 groups and attributes, and the Zarr v3
//! documents that show it to the Zarr reader.
//!
//! The layout (Imaris 5.5 and later, as Imaris, ImarisConvert and ImarisWriter write it):
//! `DataSet/ResolutionLevel L/TimePoint T/Channel C/Data`, a 3-D dataset (z, y, x) that may be
//! padded past the image; the image's size per level in the channel group's `ImageSizeX/Y/Z`;
//! `DataSetInfo/Image`'s `ExtMin0..2` and `ExtMax0..2` the image's physical extent (x, y, z;
//! edges, not voxel centers) and `Unit` its unit; `DataSetInfo/Channel C`'s `Name`, `Color`
//! (`r g b`, 0 to 1) and `ColorRange` (`low high`). Attributes are text.

use serde_json::{Value, json};

use super::hdf5::{self, MAX_CHUNK_BYTES};
use hdf5_reader::Hdf5File;

/// The most resolution levels, time points and channels read.
const MAX_LEVELS: usize = 32;
const MAX_TIME_POINTS: usize = 100_000;
const MAX_CHANNELS: usize = 64;

/// Chunks of a contiguous (unchunked) dataset: the boxes read at a time (z, y, x).
const CONTIGUOUS_CHUNK: [u64; 3] = [32, 256, 256];

/// One channel's display settings.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Channel {
    pub name: Option<String>,
    /// `RRGGBB`.
    pub color: Option<String>,
    pub range: Option<[f64; 2]>,
}

/// One resolution level.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Level {
    /// The image's voxels along z, y, x.
    pub size: [u64; 3],
    /// The boxes read at a time (the dataset's chunks), z, y, x.
    pub chunk: [u64; 3],
    /// The HDF5 filters of its chunks, in order.
    pub filters: Vec<&'static str>,
}

/// An Imaris file's image.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Layout {
    /// `DataSet` unless the root's `DataSetDirectoryName` says otherwise.
    pub data_set: String,
    pub levels: Vec<Level>,
    pub time_points: usize,
    pub channels: Vec<Channel>,
    /// The Zarr `data_type` of every `Data`.
    pub zarr_type: &'static str,
    /// The physical box the image fills, z, y, x (edges).
    pub extent_min: [f64; 3],
    pub extent_max: [f64; 3],
    /// The OME unit of the extent, where it is one.
    pub unit: Option<&'static str>,
    /// The root's `ImarisVersion`.
    pub version: Option<String>,
    pub name: Option<String>,
}

/// The numbers `N` of the children of the group at `path` named `PREFIX N`, if they are
/// `0..n` (at most `max`).
fn numbered(file: &Hdf5File, path: &str, prefix: &str, max: usize) -> Result<usize, String> {
    let group = file
        .group(path)
        .map_err(|_| format!("has no group {path}"))?;
    let (groups, _) = group
        .member_names()
        .map_err(|e| format!("{path}: {}", crate::error::printable(&e.to_string())))?;
    let mut numbers: Vec<usize> = groups
        .iter()
        .filter_map(|name| name.strip_prefix(prefix)?.strip_prefix(' ')?.parse().ok())
        .collect();
    numbers.sort_unstable();
    numbers.dedup();
    let count = numbers
        .iter()
        .enumerate()
        .take_while(|(i, n)| i == *n)
        .count();
    if count == 0 {
        return Err(format!("has no '{prefix} 0' in {path}"));
    }
    if count > max {
        return Err(format!(
            "has {count} '{prefix}' groups in {path}; at most {max} are read"
        ));
    }
    Ok(count)
}

/// A number from attribute text (`"2048"`, `" 0.5 "`), if finite.
fn number(text: Option<String>) -> Option<f64> {
    text?.trim().parse::<f64>().ok().filter(|v| v.is_finite())
}

/// `r g b` (0 to 1) as `RRGGBB`.
fn color_hex(text: &str) -> Option<String> {
    let parts: Vec<f64> = text
        .split_whitespace()
        .map(|p| p.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()?;
    let [r, g, b] = parts[..] else { return None };
    let byte = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    Some(format!("{:02X}{:02X}{:02X}", byte(r), byte(g), byte(b)))
}

impl Layout {
    /// Reads the layout of `file`, checking every level's `Data` of the first time point and
    /// channel (others are checked as they are read).
    pub(super) fn read(file: &Hdf5File) -> Result<Self, String> {
        let attribute = |path: &str, name: &str| hdf5::attribute_text(file, path, name);
        let data_set = attribute("/", "DataSetDirectoryName")
            .filter(|name| !name.is_empty() && !name.contains('/'))
            .unwrap_or_else(|| "DataSet".to_owned());
        let info = attribute("/", "DataSetInfoDirectoryName")
            .filter(|name| !name.is_empty() && !name.contains('/'))
            .unwrap_or_else(|| "DataSetInfo".to_owned());
        if file.group(&data_set).is_err() {
            return Err(format!(
                "is an HDF5 file without Imaris's {data_set} group; voxscope reads HDF5 files written by Imaris (.ims)"
            ));
        }
        let level_count = numbered(file, &data_set, "ResolutionLevel", MAX_LEVELS)?;
        let first_level = format!("{data_set}/ResolutionLevel 0");
        let time_points = numbered(file, &first_level, "TimePoint", MAX_TIME_POINTS)?;
        let channel_count = numbered(
            file,
            &format!("{first_level}/TimePoint 0"),
            "Channel",
            MAX_CHANNELS,
        )?;

        let image = format!("{info}/Image");
        let mut zarr_type = None;
        let mut levels = Vec::with_capacity(level_count);
        for level in 0..level_count {
            let group = format!("{data_set}/ResolutionLevel {level}/TimePoint 0/Channel 0");
            let data = file
                .dataset(&format!("{group}/Data"))
                .map_err(|_| format!("has no dataset {group}/Data"))?;
            let stored = hdf5::zarr_type(data.dtype())
                .ok_or_else(|| format!("{group}/Data holds {}", hdf5::type_text(data.dtype())))?;
            if *zarr_type.get_or_insert(stored) != stored {
                return Err(format!(
                    "{group}/Data holds {stored} where level 0 holds {}",
                    zarr_type.unwrap_or_default()
                ));
            }
            let shape = data.shape();
            let [dz, dy, dx] = shape[..] else {
                return Err(format!(
                    "{group}/Data has {} dimensions, not 3",
                    shape.len()
                ));
            };
            // The image inside the (padded) dataset: the channel's ImageSize, else
            // DataSetInfo/Image's X, Y, Z for level 0, else the dataset's shape.
            let stated = |axis: &str, fallback: &str| {
                number(attribute(&group, &format!("ImageSize{axis}")))
                    .or_else(|| (level == 0).then(|| number(attribute(&image, fallback)))?)
            };
            let size: [u64; 3] = std::array::from_fn(|a| {
                let stored = [dz, dy, dx][a];
                match stated(["Z", "Y", "X"][a], ["Z", "Y", "X"][a]) {
                    Some(n) if n >= 1.0 => (n as u64).min(stored),
                    _ => stored,
                }
            });
            if size.contains(&0) {
                return Err(format!("{group}/Data is empty ({dz} x {dy} x {dx})"));
            }
            let chunk: [u64; 3] = match data.chunks() {
                Some(chunks) if chunks.len() == 3 && !chunks.contains(&0) => {
                    std::array::from_fn(|a| u64::from(chunks[a]))
                }
                Some(_) => return Err(format!("{group}/Data has malformed chunks")),
                None => std::array::from_fn(|a| CONTIGUOUS_CHUNK[a].min(size[a])),
            };
            let bytes = chunk
                .iter()
                .try_fold(hdf5::element_bytes(stored) as u64, |n, &c| n.checked_mul(c));
            if bytes.is_none_or(|bytes| bytes > MAX_CHUNK_BYTES as u64) {
                return Err(format!(
                    "{group}/Data has chunks of {} x {} x {} voxels, more than {} MiB; voxscope reads chunks up to that size",
                    chunk[2],
                    chunk[1],
                    chunk[0],
                    MAX_CHUNK_BYTES >> 20
                ));
            }
            let filters = hdf5::filters(file, &data).map_err(|e| format!("{group}/Data {e}"))?;
            levels.push(Level {
                size,
                chunk,
                filters,
            });
        }

        let finest = levels[0].size;
        let extent = |name: &str, a: usize| number(attribute(&image, &format!("{name}{a}")));
        let (mut extent_min, mut extent_max) = ([0.0; 3], [0.0; 3]);
        for (zyx, xyz) in [(0, 2), (1, 1), (2, 0)] {
            let (low, high) = match (extent("ExtMin", xyz), extent("ExtMax", xyz)) {
                (Some(low), Some(high)) if high > low => (low, high),
                // Without a usable extent: voxels of 1 from 0.
                _ => (0.0, finest[zyx] as f64),
            };
            extent_min[zyx] = low;
            extent_max[zyx] = high;
        }
        let channels = (0..channel_count)
            .map(|c| {
                let group = format!("{info}/Channel {c}");
                let range = attribute(&group, "ColorRange").and_then(|text| {
                    let values: Vec<f64> = text
                        .split_whitespace()
                        .filter_map(|p| p.parse().ok())
                        .collect();
                    match values[..] {
                        [low, high] if low.is_finite() && high.is_finite() && high > low => {
                            Some([low, high])
                        }
                        _ => None,
                    }
                });
                Channel {
                    name: attribute(&group, "Name").filter(|n| !n.is_empty()),
                    color: attribute(&group, "Color").and_then(|text| color_hex(&text)),
                    range,
                }
            })
            .collect();
        Ok(Self {
            data_set,
            levels,
            time_points,
            channels,
            zarr_type: zarr_type.unwrap_or("uint8"),
            extent_min,
            extent_max,
            unit: attribute(&image, "Unit").and_then(|unit| super::super::units::ome_unit(&unit)),
            version: attribute("/", "ImarisVersion").filter(|v| !v.is_empty()),
            name: attribute(&image, "Name")
                .filter(|n| !n.is_empty() && n != "(name not specified)"),
        })
    }

    /// The dimensions ahead of z, y, x: `t` where several time points, `c` where several
    /// channels.
    fn leading(&self) -> Vec<(&'static str, u64)> {
        let mut leading = Vec::new();
        if self.time_points > 1 {
            leading.push(("t", self.time_points as u64));
        }
        if self.channels.len() > 1 {
            leading.push(("c", self.channels.len() as u64));
        }
        leading
    }

    /// The HDF5 path of level `level`'s dataset for time point `t` and channel `c`.
    pub(super) fn data_path(&self, level: usize, t: u64, c: u64) -> String {
        format!(
            "{}/ResolutionLevel {level}/TimePoint {t}/Channel {c}/Data",
            self.data_set
        )
    }

    /// Splits the coordinates of a chunk of a level array into time point, channel and the
    /// z, y, x chunk; `None` where the count or a range is wrong.
    pub(super) fn chunk_of(&self, level: usize, coords: &[u64]) -> Option<(u64, u64, [u64; 3])> {
        let leading = self.leading();
        let info = self.levels.get(level)?;
        if coords.len() != leading.len() + 3 {
            return None;
        }
        let (mut t, mut c) = (0, 0);
        for (&(axis, count), &at) in leading.iter().zip(coords) {
            if at >= count {
                return None;
            }
            match axis {
                "t" => t = at,
                _ => c = at,
            }
        }
        let zyx: [u64; 3] = std::array::from_fn(|a| coords[leading.len() + a]);
        let inside = (0..3).all(|a| zyx[a] < info.size[a].div_ceil(info.chunk[a]));
        inside.then_some((t, c, zyx))
    }

    /// The Zarr v3 `zarr.json` of level `level`'s array.
    pub(super) fn array_json(&self, level: &Level) -> Value {
        let leading = self.leading();
        let shape: Vec<u64> = leading.iter().map(|&(_, n)| n).chain(level.size).collect();
        let chunk: Vec<u64> = leading.iter().map(|_| 1).chain(level.chunk).collect();
        json!({
            "zarr_format": 3,
            "node_type": "array",
            "shape": shape,
            "data_type": self.zarr_type,
            "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": chunk}},
            "chunk_key_encoding": {"name": "default", "configuration": {"separator": "/"}},
            "fill_value": 0,
            "codecs": [{"name": "bytes", "configuration": {"endian": "little"}}],
            "attributes": {},
        })
    }

    /// The Zarr v3 `zarr.json` of the root: an OME-Zarr 0.5 image of the levels (`0`, `1`,
    /// …), each placed so that the image fills the extent, with the channels' `omero`.
    pub(super) fn root_json(&self) -> Value {
        let leading = self.leading();
        let mut axes: Vec<Value> = leading
            .iter()
            .map(|&(axis, _)| match axis {
                "t" => json!({"name": "t", "type": "time"}),
                _ => json!({"name": "c", "type": "channel"}),
            })
            .collect();
        for axis in ["z", "y", "x"] {
            let mut value = json!({"name": axis, "type": "space"});
            if let Some(unit) = self.unit {
                value["unit"] = json!(unit);
            }
            axes.push(value);
        }
        let datasets: Vec<Value> = self
            .levels
            .iter()
            .enumerate()
            .map(|(index, level)| {
                let spacing: [f64; 3] = std::array::from_fn(|a| {
                    (self.extent_max[a] - self.extent_min[a]) / level.size[a] as f64
                });
                // The first voxel's center, half a voxel inside the extent's edge.
                let first: [f64; 3] =
                    std::array::from_fn(|a| self.extent_min[a] + spacing[a] / 2.0);
                let ones = leading.iter().map(|_| 1.0);
                let zeros = leading.iter().map(|_| 0.0);
                json!({"path": index.to_string(), "coordinateTransformations": [
                    {"type": "scale", "scale": ones.chain(spacing).collect::<Vec<f64>>()},
                    {"type": "translation", "translation": zeros.chain(first).collect::<Vec<f64>>()},
                ]})
            })
            .collect();
        let mut multiscale = json!({"axes": axes, "datasets": datasets});
        if let Some(name) = &self.name {
            multiscale["name"] = json!(name);
        }
        let (low, high) = window_limits(self.zarr_type);
        let channels: Vec<Value> = self
            .channels
            .iter()
            .enumerate()
            .map(|(c, channel)| {
                let mut value = json!({
                    "label": channel.name.clone().unwrap_or_else(|| format!("Channel {c}")),
                    "active": true,
                });
                if let Some(color) = &channel.color {
                    value["color"] = json!(color);
                }
                if let Some([start, end]) = channel.range {
                    value["window"] = json!({"start": start, "end": end, "min": low.min(start), "max": high.max(end)});
                }
                value
            })
            .collect();
        json!({"zarr_format": 3, "node_type": "group", "attributes": {"ome": {
            "version": "0.5",
            "multiscales": [multiscale],
            "omero": {"channels": channels},
        }}})
    }
}

/// The range of values a type holds, for the `omero` windows' `min` and `max` (floats: the
/// window's own ends, by the callers' `min`/`max`).
fn window_limits(zarr_type: &str) -> (f64, f64) {
    match zarr_type {
        "uint8" => (0.0, 255.0),
        "int8" => (-128.0, 127.0),
        "uint16" => (0.0, 65535.0),
        "int16" => (-32768.0, 32767.0),
        "uint32" => (0.0, u32::MAX as f64),
        "int32" => (i32::MIN as f64, i32::MAX as f64),
        _ => (f64::INFINITY, f64::NEG_INFINITY),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> Layout {
        Layout {
            data_set: "DataSet".into(),
            levels: vec![
                Level {
                    size: [7, 9, 10],
                    chunk: [4, 5, 6],
                    filters: vec!["shuffle", "deflate"],
                },
                Level {
                    size: [4, 5, 5],
                    chunk: [4, 5, 6],
                    filters: vec![],
                },
            ],
            time_points: 1,
            channels: vec![Channel::default(); 2],
            zarr_type: "uint16",
            extent_min: [10.0, 20.0, 30.0],
            extent_max: [24.0, 24.5, 35.0],
            unit: Some("micrometer"),
            version: Some("5.5.0".into()),
            name: None,
        }
    }

    #[test]
    fn levels_fill_the_extent_from_their_first_voxel_center() {
        let root = layout().root_json();
        let datasets = &root["attributes"]["ome"]["multiscales"][0]["datasets"];
        assert_eq!(
            datasets[0]["coordinateTransformations"][0]["scale"],
            json!([1.0, 2.0, 0.5, 0.5])
        );
        assert_eq!(
            datasets[0]["coordinateTransformations"][1]["translation"],
            json!([0.0, 11.0, 20.25, 30.25])
        );
        assert_eq!(
            datasets[1]["coordinateTransformations"][0]["scale"],
            json!([1.0, 3.5, 0.9, 1.0])
        );
        let array = layout().array_json(&layout().levels[0]);
        assert_eq!(array["shape"], json!([2, 7, 9, 10]));
        assert_eq!(
            array["chunk_grid"]["configuration"]["chunk_shape"],
            json!([1, 4, 5, 6])
        );
    }

    #[test]
    fn chunk_coordinates_are_checked() {
        let mut layout = layout();
        layout.time_points = 3;
        assert_eq!(
            layout.chunk_of(0, &[2, 1, 1, 1, 1]),
            Some((2, 1, [1, 1, 1]))
        );
        assert_eq!(layout.chunk_of(0, &[3, 1, 1, 1, 1]), None);
        assert_eq!(layout.chunk_of(0, &[0, 0, 2, 0, 0]), None);
        assert_eq!(layout.chunk_of(0, &[0, 0, 0, 0]), None);
        assert_eq!(layout.chunk_of(2, &[0, 0, 0, 0, 0]), None);
    }

    #[test]
    fn colors_and_numbers_read_as_imaris_writes_them() {
        assert_eq!(color_hex("1.000 0.500 0.000").as_deref(), Some("FF8000"));
        assert_eq!(color_hex("1 0"), None);
        assert_eq!(color_hex("1 x 0"), None);
        assert_eq!(number(Some(" 2048 ".into())), Some(2048.0));
        assert_eq!(number(Some("NaN".into())), None);
    }
}
