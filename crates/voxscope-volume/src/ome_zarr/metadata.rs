//! The OME-Zarr attributes voxscope reads: `multiscales` (axes, datasets and their scale and
//! translation) and `omero` (channel names, colors, windows), versions 0.1 to 0.5.
//!
//! Parsed from JSON by hand rather than with a strict schema: real files carry extra keys,
//! older versions lack `axes` or transforms, and an error must name the key that is wrong
//! (`multiscales[0].datasets[1].coordinateTransformations[0]: scale has 2 values for 3 axes`).

use serde_json::{Map, Value};

use super::super::ValueWindow;
use super::super::error::{Problem, printable, quoted};

/// At most this many levels (2⁶⁴ voxels halve to one in 64 steps).
pub(crate) const MAX_LEVELS: usize = 64;

/// What an axis is, by its `type` (or, without one, by its name: `t`, `c`, `x`, `y`, `z`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AxisKind {
    Space,
    Time,
    Channel,
    /// A type OME-Zarr allows but voxscope does not interpret (its extent must be 1).
    Other(String),
}

/// One axis of the stored array, outermost first.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The axis name (`t`, `c`, `z`, `y`, `x`, or the file's own).
    pub name: String,
    /// Space, time, channel or another type.
    pub kind: AxisKind,
    /// The unit (`micrometer`, `second`), when the file gives one.
    pub unit: Option<String>,
}

/// One resolution level as the metadata describes it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Dataset {
    /// The array's path inside the group.
    pub path: String,
    /// Scale per axis (voxel size in the axis unit), when given.
    pub scale: Option<Vec<f64>>,
    /// Translation per axis (the first voxel's center), when given.
    pub translation: Option<Vec<f64>>,
}

/// The first `multiscales` entry of a group.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Multiscale {
    /// The OME-Zarr version (`0.4`, `0.5`), when given.
    pub version: Option<String>,
    /// The image's name, when given.
    pub name: Option<String>,
    /// The axes, when given (0.3 and later).
    pub axes: Option<Vec<Axis>>,
    /// Finest level first.
    pub datasets: Vec<Dataset>,
    /// Transforms applied to every level after its own: scale, translation.
    pub global_scale: Option<Vec<f64>>,
    pub global_translation: Option<Vec<f64>>,
    /// How the levels were computed (`type`: `gaussian`, `mean`, …).
    pub downscaling: Option<String>,
}

/// One channel of `omero`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OmeroChannel {
    /// The channel's name (`label`).
    pub label: Option<String>,
    /// Its display color, `RRGGBB`.
    pub color: Option<String>,
    /// The display window (`window.start` … `window.end`), in the data's values.
    pub window: Option<ValueWindow>,
    /// The data range the file states (`window.min` … `window.max`).
    pub range: Option<[f64; 2]>,
    /// Shown when the image opens (`active`; true where the file does not say).
    pub active: bool,
}

/// Where the OME attributes sit: `attributes.ome` (0.5) or the attributes themselves (≤ 0.4).
pub(crate) fn ome_attributes(attributes: &Map<String, Value>) -> &Map<String, Value> {
    match attributes.get("ome") {
        Some(Value::Object(ome)) => ome,
        _ => attributes,
    }
}

/// The first `multiscales` entry, if the attributes have one.
pub(crate) fn multiscale(attributes: &Map<String, Value>) -> Result<Option<Multiscale>, Problem> {
    let ome = ome_attributes(attributes);
    let Some(list) = ome.get("multiscales") else {
        return Ok(None);
    };
    let list = list.as_array().ok_or("'multiscales' is not a list")?;
    let first = list
        .first()
        .ok_or("'multiscales' is an empty list")?
        .as_object()
        .ok_or("multiscales[0] is not an object")?;
    let at = "multiscales[0]";
    let version = ome
        .get("version")
        .or_else(|| first.get("version"))
        .and_then(Value::as_str)
        .map(printable);
    let name = first.get("name").and_then(Value::as_str).map(printable);
    let axes = match first.get("axes") {
        None | Some(Value::Null) => None,
        Some(value) => Some(parse_axes(value, &format!("{at}.axes"))?),
    };
    let datasets_value = first
        .get("datasets")
        .ok_or_else(|| format!("{at} lacks 'datasets'"))?
        .as_array()
        .ok_or_else(|| format!("{at}.datasets is not a list"))?;
    if datasets_value.is_empty() {
        return Err(format!("{at}.datasets is empty"));
    }
    if datasets_value.len() > MAX_LEVELS {
        return Err(format!(
            "{at}.datasets lists {} levels; at most {MAX_LEVELS} are read",
            datasets_value.len()
        ));
    }
    let mut datasets = Vec::with_capacity(datasets_value.len());
    for (index, dataset) in datasets_value.iter().enumerate() {
        let at = format!("{at}.datasets[{index}]");
        let object = dataset
            .as_object()
            .ok_or_else(|| format!("{at} is not an object"))?;
        let path = object
            .get("path")
            .ok_or_else(|| format!("{at} lacks 'path'"))?
            .as_str()
            .ok_or_else(|| format!("{at}.path is not text"))?;
        check_path(path).map_err(|problem| format!("{at}.path {}: {problem}", quoted(path)))?;
        let (scale, translation) = match object.get("coordinateTransformations") {
            None | Some(Value::Null) => (None, None),
            Some(value) => parse_transforms(value, &format!("{at}.coordinateTransformations"))?,
        };
        datasets.push(Dataset {
            path: path.to_owned(),
            scale,
            translation,
        });
    }
    let (global_scale, global_translation) = match first.get("coordinateTransformations") {
        None | Some(Value::Null) => (None, None),
        Some(value) => parse_transforms(value, &format!("{at}.coordinateTransformations"))?,
    };
    let downscaling = first.get("type").and_then(Value::as_str).map(printable);
    Ok(Some(Multiscale {
        version,
        name,
        axes,
        datasets,
        global_scale,
        global_translation,
        downscaling,
    }))
}

/// A dataset path is relative and stays inside the group: no `..`, no absolute path, no
/// empty component (the store would otherwise be asked for keys outside the folder).
pub(crate) fn check_path(path: &str) -> Result<(), &'static str> {
    if path.is_empty() {
        return Err("is empty");
    }
    if path.starts_with('/') || path.contains('\\') {
        return Err("is not a relative path inside the group");
    }
    if path
        .split('/')
        .any(|part| part.is_empty() || part == "." || part == "..")
    {
        return Err("has an empty, '.' or '..' component");
    }
    Ok(())
}

fn parse_axes(value: &Value, at: &str) -> Result<Vec<Axis>, Problem> {
    let list = value
        .as_array()
        .ok_or_else(|| format!("{at} is not a list"))?;
    if !(2..=5).contains(&list.len()) {
        return Err(format!(
            "{at} has {} axes; OME-Zarr allows 2 to 5",
            list.len()
        ));
    }
    let mut axes = Vec::with_capacity(list.len());
    for (index, axis) in list.iter().enumerate() {
        let at = format!("{at}[{index}]");
        // 0.3 lists names only.
        let (name, kind, unit) = match axis {
            Value::String(name) => (name.as_str(), None, None),
            Value::Object(object) => {
                let name = object
                    .get("name")
                    .and_then(Value::as_str)
                    .ok_or_else(|| format!("{at} lacks a 'name'"))?;
                let kind = object.get("type").and_then(Value::as_str);
                let unit = object.get("unit").and_then(Value::as_str);
                (name, kind, unit)
            }
            _ => return Err(format!("{at} is neither a name nor an object")),
        };
        let kind = match kind {
            Some("space") => AxisKind::Space,
            Some("time") => AxisKind::Time,
            Some("channel") => AxisKind::Channel,
            Some(other) => AxisKind::Other(printable(other)),
            None => kind_by_name(name),
        };
        axes.push(Axis {
            name: printable(name),
            kind,
            unit: unit.map(printable),
        });
    }
    Ok(axes)
}

/// The kind an untyped axis has by its conventional name.
pub(crate) fn kind_by_name(name: &str) -> AxisKind {
    match name {
        "x" | "y" | "z" => AxisKind::Space,
        "t" => AxisKind::Time,
        "c" => AxisKind::Channel,
        other => AxisKind::Other(printable(other)),
    }
}

/// The axes an array of `ndim` dimensions has when the file names none: OME-Zarr's order,
/// `t c z y x` from the right.
pub(crate) fn default_axes(ndim: usize) -> Vec<Axis> {
    let names = ["t", "c", "z", "y", "x"];
    names[names.len().saturating_sub(ndim)..]
        .iter()
        .map(|name| Axis {
            name: (*name).to_owned(),
            kind: kind_by_name(name),
            unit: None,
        })
        .collect()
}

type Transforms = (Option<Vec<f64>>, Option<Vec<f64>>);

fn parse_transforms(value: &Value, at: &str) -> Result<Transforms, Problem> {
    let list = value
        .as_array()
        .ok_or_else(|| format!("{at} is not a list"))?;
    let mut scale = None;
    let mut translation = None;
    for (index, transform) in list.iter().enumerate() {
        let at = format!("{at}[{index}]");
        let object = transform
            .as_object()
            .ok_or_else(|| format!("{at} is not an object"))?;
        let kind = object
            .get("type")
            .and_then(Value::as_str)
            .ok_or_else(|| format!("{at} lacks a 'type'"))?;
        match kind {
            "identity" => {}
            "scale" | "translation" => {
                if object.contains_key("path") && !object.contains_key(kind) {
                    return Err(format!(
                        "{at}: a {kind} stored in an array ('path') is not supported"
                    ));
                }
                let values = numbers(object.get(kind), &format!("{at}.{kind}"))?;
                if kind == "scale" {
                    if values.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                        return Err(format!("{at}.scale has a value that is not positive"));
                    }
                    if scale.replace(values).is_some() {
                        return Err(format!("{at}: a second scale"));
                    }
                } else if translation.replace(values).is_some() {
                    return Err(format!("{at}: a second translation"));
                }
            }
            other => {
                return Err(format!(
                    "{at}: transformation type {} is not supported (scale, translation, identity)",
                    quoted(other)
                ));
            }
        }
    }
    Ok((scale, translation))
}

fn numbers(value: Option<&Value>, at: &str) -> Result<Vec<f64>, Problem> {
    let list = value
        .and_then(Value::as_array)
        .ok_or_else(|| format!("{at} is not a list of numbers"))?;
    if list.len() > 5 {
        return Err(format!(
            "{at} has {} values; at most 5 axes exist",
            list.len()
        ));
    }
    list.iter()
        .map(|v| {
            v.as_f64().filter(|v| v.is_finite()).ok_or_else(|| {
                format!("{at} holds {}, not a finite number", quoted(&v.to_string()))
            })
        })
        .collect()
}

/// The `omero` channels, if the attributes have them. Malformed entries are skipped field by
/// field (`omero` is display advice, transitional in the specification; a wrong color must not
/// stop a volume from opening).
pub(crate) fn omero_channels(attributes: &Map<String, Value>) -> Vec<OmeroChannel> {
    const MAX_CHANNELS: usize = 1 << 16;
    let Some(channels) = ome_attributes(attributes)
        .get("omero")
        .and_then(|omero| omero.get("channels"))
        .and_then(Value::as_array)
    else {
        return Vec::new();
    };
    channels
        .iter()
        .take(MAX_CHANNELS)
        .map(|channel| {
            let label = channel.get("label").and_then(Value::as_str).map(printable);
            let color = channel
                .get("color")
                .and_then(Value::as_str)
                .filter(|c| c.len() == 6 && c.chars().all(|ch| ch.is_ascii_hexdigit()))
                .map(|c| c.to_uppercase());
            let window = channel.get("window");
            let number = |key: &str| {
                window
                    .and_then(|w| w.get(key))
                    .and_then(Value::as_f64)
                    .filter(|v| v.is_finite())
            };
            let display = match (number("start"), number("end")) {
                (Some(low), Some(high)) if high > low => Some(ValueWindow { low, high }),
                _ => None,
            };
            let range = match (number("min"), number("max")) {
                (Some(low), Some(high)) if high >= low => Some([low, high]),
                _ => None,
            };
            OmeroChannel {
                label,
                color,
                window: display,
                range,
                // (Shown unless the file says `false`.)
                active: channel.get("active").and_then(Value::as_bool) != Some(false),
            }
        })
        .collect()
}

/// An HCS plate's layout (OME-Zarr 0.4/0.5 `plate`): its rows, columns and wells.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plate {
    /// The plate's name, if it has one.
    pub name: Option<String>,
    /// Row names (`A`, `B`, …).
    pub rows: Vec<String>,
    /// Column names (`1`, `2`, …).
    pub columns: Vec<String>,
    /// Each well's path (`A/1`) and its fields' paths (`0`, `1`, … from its `well` metadata),
    /// in the plate's order.
    pub wells: Vec<(String, Vec<String>)>,
    /// The field opened, `ROW/COLUMN/FIELD`.
    pub field: String,
}

/// The plate's wells at most read (a 1536-well plate's).
pub(crate) const MAX_WELLS: usize = 1536;

/// The `plate` of a group's attributes, if it has one: its name, rows, columns and well
/// paths (fields not yet read).
pub(crate) fn plate(attributes: &Map<String, Value>) -> Result<Option<Plate>, Problem> {
    let Some(plate) = ome_attributes(attributes).get("plate") else {
        return Ok(None);
    };
    let plate = plate.as_object().ok_or("'plate' is not an object")?;
    let names = |key: &str| -> Result<Vec<String>, Problem> {
        let list = plate
            .get(key)
            .and_then(Value::as_array)
            .ok_or_else(|| format!("plate.{key} is not a list"))?;
        list.iter()
            .enumerate()
            .map(|(i, entry)| {
                entry
                    .get("name")
                    .and_then(Value::as_str)
                    .map(printable)
                    .ok_or_else(|| format!("plate.{key}[{i}] has no name"))
            })
            .collect()
    };
    let rows = names("rows")?;
    let columns = names("columns")?;
    let wells = plate
        .get("wells")
        .and_then(Value::as_array)
        .ok_or("plate.wells is not a list")?;
    if wells.len() > MAX_WELLS {
        return Err(format!(
            "the plate lists {} wells; at most {MAX_WELLS} are read",
            wells.len()
        ));
    }
    let wells = wells
        .iter()
        .enumerate()
        .map(|(i, well)| {
            let path = well
                .get("path")
                .and_then(Value::as_str)
                .ok_or_else(|| format!("plate.wells[{i}] has no path"))?;
            check_path(path).map_err(|e| format!("plate.wells[{i}].path: {e}"))?;
            Ok((path.to_owned(), Vec::new()))
        })
        .collect::<Result<Vec<_>, Problem>>()?;
    if wells.is_empty() {
        return Err("the plate lists no wells".to_owned());
    }
    Ok(Some(Plate {
        name: plate.get("name").and_then(Value::as_str).map(printable),
        rows,
        columns,
        wells,
        field: String::new(),
    }))
}

/// The fields (image paths) of a well group's `well` metadata.
pub(crate) fn well_fields(
    attributes: &Map<String, Value>,
    well: &str,
) -> Result<Vec<String>, Problem> {
    let images = ome_attributes(attributes)
        .get("well")
        .and_then(|w| w.get("images"))
        .and_then(Value::as_array)
        .ok_or_else(|| format!("well {} has no 'well' images list", quoted(well)))?;
    images
        .iter()
        .enumerate()
        .map(|(i, image)| {
            let path = image
                .get("path")
                .and_then(Value::as_str)
                .ok_or_else(|| format!("well {}: images[{i}] has no path", quoted(well)))?;
            check_path(path)
                .map_err(|e| format!("well {}: images[{i}].path: {e}", quoted(well)))?;
            Ok(path.to_owned())
        })
        .collect()
}

/// One label image of an OME-Zarr image (its `labels/` group's `labels` list): a segmentation
/// on the image's grid, with the colors its `image-label` metadata gives.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LabelImage {
    /// Its name in the `labels` list (its group's name inside `labels/`).
    pub name: String,
    /// Its group's path inside the store (`labels/cells`; inside a plate's field or a
    /// bioformats2raw series, that image's path first).
    pub path: String,
    /// `image-label` `colors`: a label value and its RGBA (0–255), in the file's order.
    pub colors: Vec<LabelColor>,
    /// `image-label` `version`, if given.
    pub version: Option<String>,
    /// `image-label` `source.image` (the image it labels, relative to it), if given.
    pub source_image: Option<String>,
}

/// A label value's color from `image-label` `colors`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelColor {
    /// The label value (`label-value`).
    pub value: f64,
    /// Its red, green, blue and alpha, 0–255 (`rgba`).
    pub rgba: [u8; 4],
}

/// The label images an image lists at most (and the colors one label image gives at most).
pub(crate) const MAX_LABEL_IMAGES: usize = 256;
pub(crate) const MAX_LABEL_COLORS: usize = 1 << 16;

/// The names of a `labels/` group's `labels` list (as given; invalid names are left out).
pub(crate) fn label_names(attributes: &Map<String, Value>) -> Vec<String> {
    let Some(list) = ome_attributes(attributes)
        .get("labels")
        .and_then(Value::as_array)
    else {
        return Vec::new();
    };
    list.iter()
        .filter_map(Value::as_str)
        .filter(|name| check_path(name).is_ok() && !name.contains('/'))
        .take(MAX_LABEL_IMAGES)
        .map(str::to_owned)
        .collect()
}

/// The `image-label` of a label image's group attributes, into `label` (colors that are not a
/// value with four numbers 0–255 are left out).
pub(crate) fn image_label(attributes: &Map<String, Value>, label: &mut LabelImage) {
    let Some(image_label) = ome_attributes(attributes)
        .get("image-label")
        .and_then(Value::as_object)
    else {
        return;
    };
    label.version = image_label
        .get("version")
        .and_then(Value::as_str)
        .map(printable);
    label.source_image = image_label
        .get("source")
        .and_then(|s| s.get("image"))
        .and_then(Value::as_str)
        .map(printable);
    let colors = image_label.get("colors").and_then(Value::as_array);
    label.colors = colors
        .into_iter()
        .flatten()
        .take(MAX_LABEL_COLORS)
        .filter_map(|entry| {
            let value = entry.get("label-value").and_then(Value::as_f64)?;
            let rgba = entry.get("rgba").and_then(Value::as_array)?;
            let channels: Vec<u8> = rgba
                .iter()
                .map(|c| c.as_f64().filter(|c| (0.0..=255.0).contains(c)))
                .map(|c| c.map(|c| c.round() as u8))
                .collect::<Option<_>>()?;
            Some(LabelColor {
                value,
                rgba: <[u8; 4]>::try_from(channels).ok()?,
            })
        })
        .collect();
}

/// A bioformats2raw root's series (its images `0`, `1`, … or those its `OME` group's `series`
/// lists) and which one is open.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bioformats2raw {
    /// Each series in order: its group's path, its name (the OME-XML `Image`'s `Name`, when
    /// `OME/METADATA.ome.xml` says) and its finest level's shape, x first, with the axes'
    /// names (`None` when its metadata could not be read).
    pub series: Vec<SeriesEntry>,
    /// The index of the series opened.
    pub opened: usize,
    /// Whether the series was asked for (`--series N`, or its own path) rather than opened as
    /// the root's first.
    pub chosen: bool,
}

/// One series of a bioformats2raw root.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SeriesEntry {
    /// The image group's path (`0`, `1`, …).
    pub path: String,
    /// Its OME-XML name, when there is one.
    pub name: Option<String>,
    /// Its finest level's shape, x first, and the axes' names in that order.
    pub dims: Option<(Vec<u64>, Vec<String>)>,
}

/// The series a bioformats2raw root lists at most.
pub(crate) const MAX_SERIES: usize = 4096;

/// The `series` list of a bioformats2raw `OME` group's attributes, if it has one.
pub(crate) fn series_paths(
    attributes: &Map<String, Value>,
) -> Result<Option<Vec<String>>, Problem> {
    let Some(list) = ome_attributes(attributes).get("series") else {
        return Ok(None);
    };
    let list = list.as_array().ok_or("OME 'series' is not a list")?;
    if list.len() > MAX_SERIES {
        return Err(format!(
            "OME 'series' lists {} series; at most {MAX_SERIES} are read",
            list.len()
        ));
    }
    list.iter()
        .enumerate()
        .map(|(i, entry)| {
            let path = entry
                .as_str()
                .ok_or_else(|| format!("OME 'series'[{i}] is not a path"))?;
            check_path(path).map_err(|e| format!("OME 'series'[{i}]: {e}"))?;
            Ok(path.to_owned())
        })
        .collect::<Result<Vec<_>, Problem>>()
        .map(Some)
}

/// The `Name` of each `Image` of an OME-XML document, in order (`None` where one has none);
/// empty when the text is not XML.
pub(crate) fn ome_xml_image_names(text: &str) -> Vec<Option<String>> {
    let Ok(document) = roxmltree::Document::parse(text) else {
        return Vec::new();
    };
    document
        .root_element()
        .children()
        .filter(|node| node.is_element() && node.tag_name().name() == "Image")
        .take(MAX_SERIES)
        .map(|image| image.attribute("Name").map(printable))
        .collect()
}

/// Whether the group is a bioformats2raw container (its images are groups `0`, `1`, …) without
/// multiscales of its own.
pub(crate) fn bioformats2raw_image(attributes: &Map<String, Value>) -> bool {
    ome_attributes(attributes).contains_key("bioformats2raw.layout")
        && !ome_attributes(attributes).contains_key("multiscales")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attributes(text: &str) -> Map<String, Value> {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn reads_0_4_and_0_5_and_names_what_is_wrong() {
        let v04 = attributes(
            r#"{"multiscales": [{"version": "0.4", "name": "n", "extra": 1,
                "axes": [{"name": "c", "type": "channel"}, {"name": "z", "type": "space", "unit": "micrometer"}, "y", {"name": "x"}],
                "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 0.5, 0.25, 0.25]}]},
                             {"path": "1", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 0.5, 0.5]}, {"type": "translation", "translation": [0, 0.25, 0.125, 0.125]}]}]}]}"#,
        );
        let m = multiscale(&v04).unwrap().unwrap();
        assert_eq!(m.version.as_deref(), Some("0.4"));
        let axes = m.axes.unwrap();
        assert_eq!(axes[0].kind, AxisKind::Channel);
        assert_eq!(axes[1].unit.as_deref(), Some("micrometer"));
        assert_eq!(axes[2].kind, AxisKind::Space);
        assert_eq!(
            m.datasets[1].translation.as_deref(),
            Some(&[0.0, 0.25, 0.125, 0.125][..])
        );

        let v05 = attributes(
            r#"{"ome": {"version": "0.5", "multiscales": [{"axes": ["z", "y", "x"], "datasets": [{"path": "s0"}]}]}}"#,
        );
        let m = multiscale(&v05).unwrap().unwrap();
        assert_eq!(m.version.as_deref(), Some("0.5"));
        assert_eq!(m.datasets[0].path, "s0");

        let bad = |text: &str| multiscale(&attributes(text)).unwrap_err();
        assert_eq!(
            bad(r#"{"multiscales": []}"#),
            "'multiscales' is an empty list"
        );
        assert_eq!(
            bad(r#"{"multiscales": [{"datasets": [{"path": "../x"}]}]}"#),
            "multiscales[0].datasets[0].path '../x': has an empty, '.' or '..' component"
        );
        assert_eq!(
            bad(
                r#"{"multiscales": [{"datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, -2, 1]}]}]}]}"#
            ),
            "multiscales[0].datasets[0].coordinateTransformations[0].scale has a value that is not positive"
        );
        assert!(bad(r#"{"multiscales": [{"datasets": [{"path": "0", "coordinateTransformations": [{"type": "affine"}]}]}]}"#).contains("'affine' is not supported"));
        assert!(multiscale(&attributes("{}")).unwrap().is_none());
    }

    #[test]
    fn omero_channels_keep_what_is_valid() {
        let channels = omero_channels(&attributes(
            r#"{"omero": {"channels": [{"label": "DAPI", "color": "0000ff", "window": {"start": 10, "end": 200, "min": 0, "max": 255}},
                                       {"color": "blue", "window": {"start": 5, "end": 5}},
                                       {"label": "off", "active": false}]}}"#,
        ));
        assert_eq!(channels.len(), 3);
        assert_eq!(channels[0].color.as_deref(), Some("0000FF"));
        assert_eq!(
            channels[0].window,
            Some(ValueWindow {
                low: 10.0,
                high: 200.0
            })
        );
        assert_eq!(channels[0].range, Some([0.0, 255.0]));
        // Shown unless the file says `active: false`.
        assert_eq!(
            channels[1],
            OmeroChannel {
                active: true,
                ..OmeroChannel::default()
            }
        );
        assert!(channels[0].active && !channels[2].active);
    }
}
