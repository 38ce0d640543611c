//! N5's `attributes.json` as the Zarr v3 `zarr.json` the OME-Zarr reader opens.
//!
//! A dataset (an N5 array: `dimensions`, `blockSize`, `dataType`, `compression`) becomes a
//! Zarr v3 array of the reversed dimensions (N5 lists the fastest first, Zarr the slowest),
//! its blocks read by [`super::block`]'s codec and key encoding. A group's multiscale
//! conventions become OME-Zarr 0.5 `multiscales`, so the pyramid, its scales and units come
//! from one reader:
//! - **cosem / OpenOrganelle**: `multiscales[0].datasets[i]` with a `transform` of `axes`,
//!   `scale`, `translate` and `units` (C order unless `ordering` is `F`);
//! - **n5-viewer** (BigStitcher, Paintera's raw data): `scales` (downsampling factors, x
//!   first) over datasets `s0`, `s1`, …, with `pixelResolution` (`dimensions`, `unit`) or
//!   `resolution` on the group or its `s0`;
//! - **BigDataViewer**: a `setupN` group's `downsamplingFactors` over `timepointT/sI`; the
//!   container's root opens setup 0, time point 0.
//!
//! A coarser level made by averaging `f` voxels is offset by `(f - 1) / 2` voxels of the
//! finest level, as BigDataViewer and n5-viewer place it.

use serde_json::{Map, Value, json};

use super::block::{BLOCK_CODEC, KEY_ENCODING};
use crate::error::escape;

/// The numeric types N5 defines (its names are Zarr v3's).
const DATA_TYPES: [&str; 10] = [
    "uint8", "uint16", "uint32", "uint64", "int8", "int16", "int32", "int64", "float32", "float64",
];

/// The most dimensions a dataset may have.
const MAX_DIMENSIONS: usize = 32;

/// Reads a child's `attributes.json` (`None` where missing or unreadable): the translation of
/// a BigDataViewer root looks at its first setup.
pub(super) type ReadChild<'a> = &'a dyn Fn(&str) -> Option<Map<String, Value>>;

/// Whether `attributes` describe a dataset (an array) rather than a group.
pub(super) fn is_dataset(attributes: &Map<String, Value>) -> bool {
    attributes.contains_key("dimensions") && attributes.contains_key("dataType")
}

/// The Zarr v3 `zarr.json` of the node whose `attributes.json` is `attributes`.
pub(super) fn zarr_json(
    attributes: &Map<String, Value>,
    read_child: ReadChild,
) -> Result<Value, String> {
    if is_dataset(attributes) {
        dataset_json(attributes)
    } else {
        Ok(group_json(attributes, read_child))
    }
}

fn unsigned_list(attributes: &Map<String, Value>, name: &str) -> Result<Vec<u64>, String> {
    let list = attributes
        .get(name)
        .and_then(Value::as_array)
        .ok_or_else(|| format!("the dataset's '{name}' is not a list"))?;
    if list.is_empty() || list.len() > MAX_DIMENSIONS {
        return Err(format!(
            "the dataset's '{name}' has {} entries (1 to {MAX_DIMENSIONS} are read)",
            list.len()
        ));
    }
    list.iter()
        .map(|v| {
            v.as_u64()
                .ok_or_else(|| format!("the dataset's '{name}' holds {v}, not a count"))
        })
        .collect()
}

fn dataset_json(attributes: &Map<String, Value>) -> Result<Value, String> {
    let dimensions = unsigned_list(attributes, "dimensions")?;
    let block = unsigned_list(attributes, "blockSize")?;
    if block.len() != dimensions.len() {
        return Err(format!(
            "the dataset has {} dimensions and a block size of {}",
            dimensions.len(),
            block.len()
        ));
    }
    if block.contains(&0) || block.iter().any(|&b| b > u64::from(u32::MAX)) {
        return Err("the dataset's 'blockSize' has an empty or oversized extent".to_owned());
    }
    let data_type = attributes
        .get("dataType")
        .and_then(Value::as_str)
        .unwrap_or_default();
    if !DATA_TYPES.contains(&data_type) {
        return Err(format!(
            "the dataset's values are '{}'; N5 datasets of uint8/16/32/64, int8/16/32/64, float32 and float64 are read",
            escape(data_type)
        ));
    }
    let compression = match attributes.get("compression") {
        Some(Value::Object(compression)) => compression.clone(),
        Some(_) => return Err("the dataset's 'compression' is not an object".to_owned()),
        // N5 before 1.0: `compressionType`, a name with no settings.
        None => match attributes.get("compressionType").and_then(Value::as_str) {
            Some(kind) => Map::from_iter([("type".to_owned(), Value::from(kind))]),
            None => Map::new(),
        },
    };
    let reversed = |list: Vec<u64>| list.into_iter().rev().collect::<Vec<_>>();
    let mut kept = attributes.clone();
    for structural in [
        "dimensions",
        "blockSize",
        "dataType",
        "compression",
        "compressionType",
    ] {
        kept.remove(structural);
    }
    Ok(json!({
        "zarr_format": 3,
        "node_type": "array",
        "shape": reversed(dimensions),
        "data_type": data_type,
        "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": reversed(block)}},
        "chunk_key_encoding": {"name": KEY_ENCODING},
        "fill_value": 0,
        "codecs": [{"name": BLOCK_CODEC, "configuration": {"compression": compression}}],
        "attributes": kept,
    }))
}

/// One level of a multiscale: its path, and its scale and translation along x, y, z.
struct Level {
    path: String,
    scale: [f64; 3],
    translation: [f64; 3],
}

/// A group's multiscale, in the terms OME-Zarr's metadata needs.
struct Multiscale {
    levels: Vec<Level>,
    unit: Option<String>,
    name: Option<String>,
}

fn group_json(attributes: &Map<String, Value>, read_child: ReadChild) -> Value {
    let mut kept = attributes.clone();
    if let Some(multiscale) = cosem(attributes)
        .or_else(|| n5_viewer(attributes, read_child))
        .or_else(|| big_data_viewer(attributes, "", read_child))
        .or_else(|| {
            // A BigDataViewer container's root: its first setup, first time point.
            let setup = read_child("setup0")?;
            big_data_viewer(&setup, "setup0/", read_child)
        })
    {
        kept.insert("ome".to_owned(), ome_multiscales(&multiscale));
    }
    json!({"zarr_format": 3, "node_type": "group", "attributes": kept})
}

/// OME-Zarr 0.5 `ome` attributes of a 3D multiscale (x, y, z space axes, z slowest).
fn ome_multiscales(multiscale: &Multiscale) -> Value {
    let axes: Vec<Value> = ["z", "y", "x"]
        .iter()
        .map(|name| {
            let mut axis = json!({"name": name, "type": "space"});
            if let Some(unit) = &multiscale.unit {
                axis["unit"] = Value::from(unit.as_str());
            }
            axis
        })
        .collect();
    let datasets: Vec<Value> = multiscale
        .levels
        .iter()
        .map(|level| {
            let zyx = |v: [f64; 3]| vec![v[2], v[1], v[0]];
            json!({
                "path": level.path,
                "coordinateTransformations": [
                    {"type": "scale", "scale": zyx(level.scale)},
                    {"type": "translation", "translation": zyx(level.translation)},
                ],
            })
        })
        .collect();
    let mut multiscale_json = json!({"axes": axes, "datasets": datasets});
    if let Some(name) = &multiscale.name {
        multiscale_json["name"] = Value::from(name.as_str());
    }
    json!({"version": "0.5", "multiscales": [multiscale_json]})
}

/// A list of three numbers.
fn triple(value: Option<&Value>) -> Option<[f64; 3]> {
    let list = value?.as_array()?;
    if list.len() != 3 {
        return None;
    }
    let mut out = [0.0; 3];
    for (slot, v) in out.iter_mut().zip(list) {
        *slot = v.as_f64().filter(|f| f.is_finite())?;
    }
    Some(out)
}

/// OME-Zarr's name of a unit N5 writers abbreviate (others kept as written).
fn unit_name(unit: &str) -> String {
    crate::ome_zarr::units::ome_unit(unit).map_or_else(|| unit.to_owned(), str::to_owned)
}

/// cosem's `multiscales`: every level's `transform` (`axes`, `scale`, `translate`, `units`).
fn cosem(attributes: &Map<String, Value>) -> Option<Multiscale> {
    let multiscale = attributes.get("multiscales")?.as_array()?.first()?;
    let mut unit = None;
    let levels = multiscale
        .get("datasets")?
        .as_array()?
        .iter()
        .map(|dataset| {
            let path = dataset.get("path")?.as_str()?.to_owned();
            let transform = dataset.get("transform")?;
            let mut axes: Vec<&str> = transform
                .get("axes")?
                .as_array()?
                .iter()
                .map(|a| a.as_str())
                .collect::<Option<_>>()?;
            let mut scale: Vec<f64> = numbers(transform.get("scale"))?;
            let mut translate: Vec<f64> =
                numbers(transform.get("translate")).unwrap_or_else(|| vec![0.0; axes.len()]);
            let mut units: Vec<&str> = transform
                .get("units")
                .and_then(Value::as_array)
                .map(|u| u.iter().filter_map(Value::as_str).collect())
                .unwrap_or_default();
            if transform.get("ordering").and_then(Value::as_str) == Some("F") {
                axes.reverse();
                scale.reverse();
                translate.reverse();
                units.reverse();
            }
            if scale.len() != axes.len() || translate.len() != axes.len() {
                return None;
            }
            let mut level = Level {
                path,
                scale: [1.0; 3],
                translation: [0.0; 3],
            };
            for (i, axis) in axes.iter().enumerate() {
                let Some(a) = ["x", "y", "z"].iter().position(|n| n == axis) else {
                    continue;
                };
                level.scale[a] = scale[i];
                level.translation[a] = translate[i];
                if let Some(u) = units.get(i) {
                    unit.get_or_insert_with(|| unit_name(u));
                }
            }
            Some(level)
        })
        .collect::<Option<Vec<_>>>()?;
    (!levels.is_empty()).then(|| Multiscale {
        levels,
        unit,
        name: multiscale
            .get("name")
            .and_then(Value::as_str)
            .map(str::to_owned),
    })
}

fn numbers(value: Option<&Value>) -> Option<Vec<f64>> {
    value?
        .as_array()?
        .iter()
        .map(|v| v.as_f64().filter(|f| f.is_finite()))
        .collect()
}

/// The voxel size and unit of `attributes`: `pixelResolution` (`dimensions`, `unit`), or
/// `resolution` (no unit).
fn resolution(attributes: &Map<String, Value>) -> Option<([f64; 3], Option<String>)> {
    if let Some(pixel) = attributes.get("pixelResolution") {
        let size = triple(pixel.get("dimensions"))?;
        let unit = pixel.get("unit").and_then(Value::as_str).map(unit_name);
        return Some((size, unit));
    }
    Some((triple(attributes.get("resolution"))?, None))
}

/// Levels of downsampling `factors` (x first) over the finest voxel size `size`.
fn levels_of(factors: &[[f64; 3]], path: impl Fn(usize) -> String, size: [f64; 3]) -> Vec<Level> {
    factors
        .iter()
        .enumerate()
        .map(|(i, f)| Level {
            path: path(i),
            scale: std::array::from_fn(|a| size[a] * f[a]),
            translation: std::array::from_fn(|a| size[a] * (f[a] - 1.0) / 2.0),
        })
        .collect()
}

fn factor_list(value: Option<&Value>) -> Option<Vec<[f64; 3]>> {
    let list = value?.as_array()?;
    let factors: Vec<[f64; 3]> = list
        .iter()
        .map(|f| triple(Some(f)))
        .collect::<Option<_>>()?;
    let valid = !factors.is_empty()
        && factors.len() <= 64
        && factors.iter().flatten().all(|f| (1.0..=1e6).contains(f));
    valid.then_some(factors)
}

/// n5-viewer's `scales` over `s0`, `s1`, …
fn n5_viewer(attributes: &Map<String, Value>, read_child: ReadChild) -> Option<Multiscale> {
    let factors = factor_list(attributes.get("scales"))?;
    let (size, unit) = resolution(attributes)
        .or_else(|| resolution(&read_child("s0")?))
        .unwrap_or(([1.0; 3], None));
    Some(Multiscale {
        levels: levels_of(&factors, |i| format!("s{i}"), size),
        unit,
        name: None,
    })
}

/// BigDataViewer's setup group (`downsamplingFactors`) at `prefix` (`""` or `setup0/`): its
/// time point 0.
fn big_data_viewer(
    attributes: &Map<String, Value>,
    prefix: &str,
    read_child: ReadChild,
) -> Option<Multiscale> {
    let factors = factor_list(attributes.get("downsamplingFactors"))?;
    let level_path = |i: usize| format!("{prefix}timepoint0/s{i}");
    let (size, unit) = resolution(attributes)
        .or_else(|| resolution(&read_child(&level_path(0))?))
        .unwrap_or(([1.0; 3], None));
    Some(Multiscale {
        levels: levels_of(&factors, level_path, size),
        unit,
        name: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(value: Value) -> Map<String, Value> {
        value.as_object().cloned().unwrap()
    }

    fn none(_: &str) -> Option<Map<String, Value>> {
        None
    }

    #[test]
    fn a_dataset_becomes_a_zarr_array_of_reversed_dimensions() {
        let attributes = object(json!({
            "dimensions": [100, 50, 20], "blockSize": [64, 32, 16], "dataType": "uint16",
            "compression": {"type": "gzip", "level": -1}, "pixelResolution": {"unit": "um"}
        }));
        let document = zarr_json(&attributes, &none).unwrap();
        assert_eq!(document["shape"], json!([20, 50, 100]));
        assert_eq!(
            document["chunk_grid"]["configuration"]["chunk_shape"],
            json!([16, 32, 64])
        );
        assert_eq!(
            document["codecs"][0]["configuration"]["compression"]["type"],
            "gzip"
        );
        assert_eq!(
            document["attributes"],
            json!({"pixelResolution": {"unit": "um"}})
        );
    }

    #[test]
    fn bad_datasets_are_named() {
        let bad = |value: Value| zarr_json(&object(value), &none).unwrap_err();
        let error = bad(json!({"dimensions": [1, 2], "blockSize": [1], "dataType": "uint8"}));
        assert!(
            error.contains("2 dimensions and a block size of 1"),
            "{error}"
        );
        let error = bad(json!({"dimensions": [1], "blockSize": [0], "dataType": "uint8"}));
        assert!(error.contains("empty or oversized"), "{error}");
        let error = bad(json!({"dimensions": [1], "blockSize": [1], "dataType": "object"}));
        assert!(error.contains("'object'"), "{error}");
        let error = bad(json!({"dimensions": [-1], "blockSize": [1], "dataType": "uint8"}));
        assert!(error.contains("not a count"), "{error}");
    }

    #[test]
    fn n5_viewer_scales_become_ome_levels_offset_by_their_averaging() {
        let attributes = object(json!({
            "n5": "2.5.1", "scales": [[1, 1, 1], [2, 2, 1]],
            "pixelResolution": {"dimensions": [0.5, 0.5, 2.0], "unit": "um"}
        }));
        let document = zarr_json(&attributes, &none).unwrap();
        let ome = &document["attributes"]["ome"]["multiscales"][0];
        assert_eq!(ome["axes"][0]["unit"], "micrometer");
        let s1 = &ome["datasets"][1];
        assert_eq!(s1["path"], "s1");
        assert_eq!(
            s1["coordinateTransformations"][0]["scale"],
            json!([2.0, 1.0, 1.0])
        );
        assert_eq!(
            s1["coordinateTransformations"][1]["translation"],
            json!([0.0, 0.25, 0.25])
        );
    }

    #[test]
    fn cosem_transforms_are_read_by_axis_name() {
        let attributes = object(json!({"multiscales": [{"name": "fibsem", "datasets": [
            {"path": "s0", "transform": {"axes": ["z", "y", "x"], "scale": [3.0, 4.0, 5.0],
             "translate": [1.0, 2.0, 3.0], "units": ["nm", "nm", "nm"]}}
        ]}]}));
        let document = zarr_json(&attributes, &none).unwrap();
        let ome = &document["attributes"]["ome"]["multiscales"][0];
        assert_eq!(ome["name"], "fibsem");
        assert_eq!(ome["axes"][2]["unit"], "nanometer");
        let s0 = &ome["datasets"][0]["coordinateTransformations"];
        assert_eq!(s0[0]["scale"], json!([3.0, 4.0, 5.0]));
        assert_eq!(s0[1]["translation"], json!([1.0, 2.0, 3.0]));
    }

    #[test]
    fn a_big_data_viewer_root_opens_its_first_setup() {
        let setup =
            object(json!({"downsamplingFactors": [[1, 1, 1], [2, 2, 2]], "dataType": "uint16"}));
        let read = |path: &str| (path == "setup0").then(|| setup.clone());
        let document = zarr_json(&object(json!({"n5": "2.2.0"})), &read).unwrap();
        let datasets = &document["attributes"]["ome"]["multiscales"][0]["datasets"];
        assert_eq!(datasets[1]["path"], "setup0/timepoint0/s1");
    }
}
