//! A precomputed volume's `info` document, checked, and the Zarr v3 documents it becomes.
//!
//! Each scale becomes an array of dimensions (channel,) z, y, x (neuroglancer lists x first
//! and channels last; the values' order in a chunk is the same), its chunks read by
//! [`super::chunk`]'s codec under its key encoding. The root becomes an OME-Zarr 0.5 group
//! whose `multiscales` list the scales finest first, their `resolution` (nanometers) as the
//! scale and `voxel_offset` as the translation; a segmentation's root carries `image-label`,
//! so it is read as labels (nearest samples, coarser levels by the mode).

use serde_json::{Map, Value, json};

use super::chunk::{CHUNK_CODEC, KEY_ENCODING};
use super::sharded::Sharding;
use crate::error::{escape, printable};

/// The types precomputed volumes hold.
const DATA_TYPES: [&str; 8] = [
    "uint8", "int8", "uint16", "int16", "uint32", "int32", "uint64", "float32",
];

/// The most scales and channels read.
const MAX_SCALES: usize = 64;
const MAX_CHANNELS: u64 = 64;

/// How a scale's chunks are stored.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Encoding {
    Raw,
    Jpeg,
    Png,
    /// neuroglancer's compressed_segmentation, of blocks of this size (x, y, z).
    CompressedSegmentation([u64; 3]),
}

impl Encoding {
    pub(super) fn name(&self) -> &'static str {
        match self {
            Self::Raw => "raw",
            Self::Jpeg => "jpeg",
            Self::Png => "png",
            Self::CompressedSegmentation(_) => "compressed_segmentation",
        }
    }
}

/// One scale (pyramid level).
#[derive(Debug, Clone)]
pub(super) struct Scale {
    /// Its path in the store (`4_4_40`).
    pub key: String,
    /// Voxels along x, y, z.
    pub size: [u64; 3],
    /// Voxel size along x, y, z, in nanometers.
    pub resolution: [f64; 3],
    /// The first voxel's index along x, y, z.
    pub voxel_offset: [i64; 3],
    /// The chunk along x, y, z (the first of `chunk_sizes`).
    pub chunk: [u64; 3],
    pub encoding: Encoding,
    /// Where the scale is sharded, how.
    pub sharding: Option<Sharding>,
}

/// The whole `info`.
#[derive(Debug, Clone)]
pub(super) struct Info {
    pub segmentation: bool,
    pub data_type: String,
    pub channels: u64,
    pub scales: Vec<Scale>,
}

fn triple<T>(
    value: Option<&Value>,
    what: &str,
    read: impl Fn(&Value) -> Option<T>,
) -> Result<[T; 3], String> {
    let list = value
        .and_then(Value::as_array)
        .filter(|l| l.len() == 3)
        .ok_or_else(|| format!("{what} is not a list of 3"))?;
    let items: Vec<T> = list
        .iter()
        .map(|v| read(v).ok_or_else(|| format!("{what} holds {}", printable(&v.to_string()))))
        .collect::<Result<_, _>>()?;
    items
        .try_into()
        .map_err(|_| format!("{what} is not a list of 3"))
}

/// Checks a scale key: a relative path inside the volume.
fn check_key(key: &str) -> Result<(), String> {
    let bad = key.is_empty()
        || key.starts_with('/')
        || key.len() > 256
        || key
            .split('/')
            .any(|part| part.is_empty() || part == "." || part == "..")
        || key.chars().any(char::is_control);
    if bad {
        Err(format!(
            "scale key '{}' is not a path inside the volume",
            escape(key)
        ))
    } else {
        Ok(())
    }
}

fn scale_of(value: &Value, index: usize) -> Result<Scale, String> {
    let what = |field: &str| format!("scale {index}'s '{field}'");
    let key = value
        .get("key")
        .and_then(Value::as_str)
        .ok_or_else(|| what("key"))
        .map_err(|w| format!("{w} is missing"))?
        .to_owned();
    check_key(&key)?;
    let size = triple(value.get("size"), &what("size"), Value::as_u64)?;
    let resolution = triple(value.get("resolution"), &what("resolution"), |v| {
        v.as_f64().filter(|f| f.is_finite() && *f > 0.0)
    })?;
    let voxel_offset = match value.get("voxel_offset") {
        None => [0; 3],
        offset => triple(offset, &what("voxel_offset"), |v| {
            v.as_i64().filter(|o| o.unsigned_abs() < 1 << 40)
        })?,
    };
    let chunk = triple(
        value
            .get("chunk_sizes")
            .and_then(Value::as_array)
            .and_then(|sizes| sizes.first()),
        &what("chunk_sizes"),
        |v| v.as_u64().filter(|&c| (1..=1 << 20).contains(&c)),
    )?;
    let encoding = match value.get("encoding").and_then(Value::as_str) {
        Some("raw") => Encoding::Raw,
        Some("jpeg") => Encoding::Jpeg,
        Some("png") => Encoding::Png,
        Some("compressed_segmentation") => Encoding::CompressedSegmentation(triple(
            value.get("compressed_segmentation_block_size"),
            &what("compressed_segmentation_block_size"),
            |v| v.as_u64().filter(|&b| (1..=1024).contains(&b)),
        )?),
        Some(other) => {
            return Err(format!(
                "scale {index}'s encoding '{}' is not read (raw, jpeg, png and compressed_segmentation are)",
                escape(other)
            ));
        }
        None => return Err(format!("{} is missing", what("encoding"))),
    };
    let sharding = match value.get("sharding") {
        None | Some(Value::Null) => None,
        Some(Value::Object(sharding)) => {
            Some(Sharding::parse(sharding).map_err(|problem| format!("scale {index}: {problem}"))?)
        }
        Some(_) => return Err(format!("{} is not an object", what("sharding"))),
    };
    Ok(Scale {
        key,
        size,
        resolution,
        voxel_offset,
        chunk,
        encoding,
        sharding,
    })
}

/// Reads and checks an `info` document.
pub(super) fn parse(document: &Map<String, Value>) -> Result<Info, String> {
    let segmentation = match document.get("type").and_then(Value::as_str) {
        Some("image") | None => false,
        Some("segmentation") => true,
        Some(other) => {
            return Err(format!(
                "is a precomputed volume of type '{}'; image and segmentation volumes are read",
                escape(other)
            ));
        }
    };
    let data_type = document
        .get("data_type")
        .and_then(Value::as_str)
        .unwrap_or_default();
    if !DATA_TYPES.contains(&data_type) {
        return Err(format!(
            "info's data_type '{}' is not one precomputed volumes hold ({})",
            escape(data_type),
            DATA_TYPES.join(", ")
        ));
    }
    let channels = document
        .get("num_channels")
        .and_then(Value::as_u64)
        .unwrap_or(1);
    if !(1..=MAX_CHANNELS).contains(&channels) {
        return Err(format!(
            "info's num_channels is {channels}; 1 to {MAX_CHANNELS} are read"
        ));
    }
    let scales = document
        .get("scales")
        .and_then(Value::as_array)
        .filter(|s| !s.is_empty() && s.len() <= MAX_SCALES)
        .ok_or_else(|| format!("info's scales are not a list of 1 to {MAX_SCALES}"))?;
    let mut scales: Vec<Scale> = scales
        .iter()
        .enumerate()
        .map(|(i, s)| scale_of(s, i))
        .collect::<Result<_, _>>()?;
    // Finest first (writers list them so; neuroglancer does not require it).
    scales.sort_by(|a, b| {
        let volume = |s: &Scale| s.resolution.iter().product::<f64>();
        volume(a).total_cmp(&volume(b))
    });
    if data_type != "uint8" && scales.iter().any(|s| s.encoding == Encoding::Jpeg) {
        return Err("info's jpeg scales must hold uint8 values".to_owned());
    }
    Ok(Info {
        segmentation,
        data_type: data_type.to_owned(),
        channels,
        scales,
    })
}

impl Info {
    /// The scale at store path `key`.
    pub(super) fn scale(&self, key: &str) -> Option<&Scale> {
        self.scales.iter().find(|s| s.key == key)
    }

    /// The most bytes one stored chunk of `scale` may have: its voxels' bytes, three times
    /// over (compressed_segmentation of few labels per block can be larger than its
    /// labels), and 64 KiB for headers.
    pub(super) fn max_chunk_bytes(&self, scale: &Scale) -> u64 {
        let value_bytes: u64 = match self.data_type.as_str() {
            "uint8" | "int8" => 1,
            "uint16" | "int16" => 2,
            "uint64" => 8,
            _ => 4,
        };
        let voxels: u64 = scale.chunk.iter().product();
        voxels
            .saturating_mul(self.channels)
            .saturating_mul(value_bytes)
            .saturating_mul(3)
            .saturating_add(64 << 10)
    }

    /// The dimensions an array lists, slowest first: (channel,) z, y, x.
    fn reversed(&self, xyz: [u64; 3]) -> Vec<u64> {
        let mut dims = Vec::with_capacity(4);
        if self.channels > 1 {
            dims.push(self.channels);
        }
        dims.extend(xyz.iter().rev());
        dims
    }

    /// The Zarr v3 `zarr.json` of scale `scale`.
    pub(super) fn array_json(&self, scale: &Scale) -> Value {
        let mut encoding = json!({"encoding": scale.encoding.name(), "channels": self.channels});
        if let Encoding::CompressedSegmentation(block) = &scale.encoding {
            encoding["block_size"] = json!(block);
        }
        json!({
            "zarr_format": 3,
            "node_type": "array",
            "shape": self.reversed(scale.size),
            "data_type": self.data_type,
            "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": self.reversed(scale.chunk)}},
            "chunk_key_encoding": {"name": KEY_ENCODING, "configuration": {
                "chunk": scale.chunk, "offset": scale.voxel_offset, "size": scale.size,
            }},
            "fill_value": 0,
            "codecs": [{"name": CHUNK_CODEC, "configuration": encoding}],
            "attributes": {},
        })
    }

    /// The Zarr v3 `zarr.json` of the volume's root: an OME-Zarr 0.5 image of its scales.
    pub(super) fn root_json(&self, name: Option<&str>) -> Value {
        let mut axes = Vec::new();
        if self.channels > 1 {
            axes.push(json!({"name": "c", "type": "channel"}));
        }
        for axis in ["z", "y", "x"] {
            axes.push(json!({"name": axis, "type": "space", "unit": "nanometer"}));
        }
        let finest = self.scales[0].resolution;
        let datasets: Vec<Value> = self
            .scales
            .iter()
            .map(|scale| {
                // The first voxel's center: voxel i spans [i, i + 1) resolutions, and a
                // coarser voxel's center lies half its extra size further.
                let at = |a: usize| {
                    scale.voxel_offset[a] as f64 * scale.resolution[a]
                        + (scale.resolution[a] - finest[a]) / 2.0
                };
                let mut factors = Vec::new();
                let mut offsets = Vec::new();
                if self.channels > 1 {
                    factors.push(1.0);
                    offsets.push(0.0);
                }
                factors.extend([2, 1, 0].map(|a| scale.resolution[a]));
                offsets.extend([2, 1, 0].map(at));
                json!({"path": scale.key, "coordinateTransformations": [
                    {"type": "scale", "scale": factors},
                    {"type": "translation", "translation": offsets},
                ]})
            })
            .collect();
        let mut multiscale = json!({"axes": axes, "datasets": datasets});
        if let Some(name) = name {
            multiscale["name"] = Value::from(name);
        }
        let mut ome = json!({"version": "0.5", "multiscales": [multiscale]});
        if self.segmentation {
            ome["image-label"] = json!({"version": "0.5"});
        }
        json!({"zarr_format": 3, "node_type": "group", "attributes": {"ome": ome}})
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(value: Value) -> Result<Info, String> {
        parse(value.as_object().unwrap())
    }

    fn scale(key: &str, resolution: [f64; 3]) -> Value {
        json!({"key": key, "size": [10, 9, 7], "resolution": resolution,
               "voxel_offset": [3, 2, 1], "chunk_sizes": [[6, 5, 4]], "encoding": "raw"})
    }

    #[test]
    fn scales_become_levels_finest_first_placed_by_their_offset() {
        let parsed = info(
            json!({"type": "image", "data_type": "uint8", "num_channels": 1,
            "scales": [scale("8_8_40", [8.0, 8.0, 40.0]), scale("4_4_40", [4.0, 4.0, 40.0])]}),
        )
        .unwrap();
        assert_eq!(parsed.scales[0].key, "4_4_40");
        let root = parsed.root_json(None);
        let datasets = &root["attributes"]["ome"]["multiscales"][0]["datasets"];
        let fine = &datasets[0]["coordinateTransformations"];
        assert_eq!(fine[0]["scale"], json!([40.0, 4.0, 4.0]));
        assert_eq!(fine[1]["translation"], json!([40.0, 8.0, 12.0]));
        // Twice the voxel size: its first center half a finest voxel further.
        let coarse = &datasets[1]["coordinateTransformations"];
        assert_eq!(coarse[1]["translation"], json!([40.0, 18.0, 26.0]));
        let array = parsed.array_json(&parsed.scales[0]);
        assert_eq!(array["shape"], json!([7, 9, 10]));
        assert_eq!(
            array["chunk_grid"]["configuration"]["chunk_shape"],
            json!([4, 5, 6])
        );
    }

    #[test]
    fn channels_and_segmentations_are_marked() {
        let parsed = info(json!({"type": "segmentation", "data_type": "uint64",
            "num_channels": 3, "scales": [scale("a", [1.0; 3])]}))
        .unwrap();
        let root = parsed.root_json(Some("cells"));
        assert!(root["attributes"]["ome"].get("image-label").is_some());
        assert_eq!(
            root["attributes"]["ome"]["multiscales"][0]["axes"][0]["type"],
            "channel"
        );
        assert_eq!(
            parsed.array_json(&parsed.scales[0])["shape"],
            json!([3, 7, 9, 10])
        );
    }

    #[test]
    fn bad_documents_are_named() {
        let bad = |value: Value| info(value).unwrap_err();
        let error = bad(json!({"data_type": "bool", "scales": []}));
        assert!(error.contains("data_type 'bool'"), "{error}");
        let error = bad(json!({"data_type": "uint8", "scales": []}));
        assert!(error.contains("scales are not a list"), "{error}");
        let mut escape = scale("../x", [1.0; 3]);
        let error = bad(json!({"data_type": "uint8", "scales": [escape.clone()]}));
        assert!(error.contains("not a path inside"), "{error}");
        escape["key"] = json!("a");
        escape["encoding"] = json!("compresso");
        let error = bad(json!({"data_type": "uint8", "scales": [escape.clone()]}));
        assert!(error.contains("encoding 'compresso'"), "{error}");
        escape["encoding"] = json!("raw");
        escape["chunk_sizes"] = json!([[0, 1, 1]]);
        let error = bad(json!({"data_type": "uint8", "scales": [escape]}));
        assert!(error.contains("chunk_sizes"), "{error}");
    }
}
