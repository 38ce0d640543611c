//! Walking a Zarr hierarchy to a [`Pyramid`]: the root node (an OME-Zarr group, a
//! bioformats2raw container, a plain array), each level's array, their agreement.

use serde_json::{Map, Value};
use zarrs::array::{Array, ArrayMetadata};
use zarrs::storage::{ReadableStorageTraits, StoreKey};

use super::super::error::{Problem, printable, quoted};
use super::levels::{layout_of, level_info, type_name};
use super::metadata::{self, Axis, AxisKind};
use super::{MAX_METADATA_BYTES, Pyramid, PyramidOptions, ReadableStorage, Stored};
use level_arrays::{axes_of, check_selection, leading_extent, level_infos, open_arrays};

mod level_arrays;

/// Reads a metadata document (JSON object) at `key`, if present, after checking its size.
fn read_json(store: &ReadableStorage, key: &str) -> Result<Option<Map<String, Value>>, Problem> {
    let store_key = StoreKey::new(key).map_err(|e| format!("store key {}: {e}", quoted(key)))?;
    match store.size_key(&store_key) {
        Ok(Some(size)) if size > MAX_METADATA_BYTES => {
            return Err(format!(
                "{key} is {size} bytes; metadata of more than {MAX_METADATA_BYTES} bytes is not read"
            ));
        }
        Ok(Some(_)) => {}
        Ok(None) => return Ok(None),
        Err(e) => return Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    }
    let bytes = match store.get(&store_key) {
        Ok(Some(bytes)) => bytes,
        Ok(None) => return Ok(None),
        Err(e) => return Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    };
    let value: Value =
        serde_json::from_slice(&bytes).map_err(|e| format!("{key} is not valid JSON: {e}"))?;
    match value {
        Value::Object(map) => Ok(Some(map)),
        _ => Err(format!("{key} is not a JSON object")),
    }
}

/// What sits at a node: a group with its attributes, an array, or nothing.
enum Node {
    Group {
        attributes: Map<String, Value>,
        zarr_format: u8,
    },
    Array {
        zarr_format: u8,
    },
    Missing,
}

fn node(store: &ReadableStorage, prefix: &str) -> Result<Node, Problem> {
    if let Some(json) = read_json(store, &format!("{prefix}zarr.json"))? {
        return match json.get("node_type").and_then(Value::as_str) {
            Some("group") => Ok(Node::Group {
                attributes: match json.get("attributes") {
                    Some(Value::Object(map)) => map.clone(),
                    _ => Map::new(),
                },
                zarr_format: 3,
            }),
            Some("array") => Ok(Node::Array { zarr_format: 3 }),
            _ => Err(format!(
                "{prefix}zarr.json has no node_type 'group' or 'array'"
            )),
        };
    }
    if store
        .size_key(&key(&format!("{prefix}.zarray"))?)
        .map_err(|e| e.to_string())?
        .is_some()
    {
        return Ok(Node::Array { zarr_format: 2 });
    }
    if store
        .size_key(&key(&format!("{prefix}.zgroup"))?)
        .map_err(|e| e.to_string())?
        .is_some()
    {
        let attributes = read_json(store, &format!("{prefix}.zattrs"))?.unwrap_or_default();
        return Ok(Node::Group {
            attributes,
            zarr_format: 2,
        });
    }
    Ok(Node::Missing)
}

fn key(text: &str) -> Result<StoreKey, Problem> {
    StoreKey::new(text).map_err(|e| format!("store key {}: {e}", quoted(text)))
}

/// Asks a store to fetch the metadata documents at these keys together, ahead of their reads
/// (a URL's store: one round trip for all of them); a folder's does nothing.
pub(super) type Warm<'a> = &'a dyn Fn(&[String]);

/// The documents that tell what sits at the node `prefix` (`""` or `"0/"`).
fn node_documents(prefix: &str) -> Vec<String> {
    crate::remote::NODE_DOCUMENTS
        .iter()
        .map(|name| format!("{prefix}{name}"))
        .collect()
}

/// Levels whose documents a URL's first round trip asks for beside the root's, at the paths
/// most stores give them (`0`, `1`, …: ome-zarr-py's, `convert`'s): a store whose levels are
/// named so opens in one round trip of metadata instead of two. The guesses that miss cost a
/// request each, in the same round trip; levels past these, or named otherwise, are asked for
/// in the second as before.
const GUESSED_LEVELS: usize = 8;

/// The documents of the first round trip of a URL's store that may have `max_requests` in
/// flight: the root's ([`node_documents`]), and the guesses, those of as many of the
/// [`GUESSED_LEVELS`] (Zarr v3's `zarr.json`, v2's `.zarray` and `.zattrs`) as fit in the
/// same wave of requests.
pub(super) fn first_documents(max_requests: usize) -> (Vec<String>, Vec<String>) {
    let root = node_documents("");
    let per_level = array_documents("0", 2).len();
    // The last guesses: an N5 container's and a precomputed volume's root documents.
    let levels = (max_requests.saturating_sub(root.len() + 2) / per_level).min(GUESSED_LEVELS);
    let mut guesses: Vec<String> = (0..levels)
        .flat_map(|level| array_documents(&level.to_string(), 2))
        .collect();
    guesses.push(super::n5::ATTRIBUTES.to_owned());
    guesses.push(super::precomputed::INFO.to_owned());
    (root, guesses)
}

/// Whether the root of `store` is answered to hold no Zarr document (not: a Zarr node, or
/// documents that could not be read).
pub(super) fn zarr_root_is_missing(store: &ReadableStorage) -> bool {
    matches!(node(store, ""), Ok(Node::Missing))
}

/// The documents zarrs reads to open the array at `full` (a path in the store, `""` for the
/// root): `zarr.json`, and for Zarr v2 (where that is missing) `.zarray` and `.zattrs`.
fn array_documents(full: &str, zarr_format: u8) -> Vec<String> {
    let names: &[&str] = if zarr_format == 3 {
        &["zarr.json"]
    } else {
        &["zarr.json", ".zarray", ".zattrs"]
    };
    names.iter().map(|name| document_key(full, name)).collect()
}

fn document_key(full: &str, name: &str) -> String {
    if full.is_empty() {
        name.to_owned()
    } else {
        format!("{full}/{name}")
    }
}

/// Opens the hierarchy at the root of `store`: its root node, then every level's array, each
/// step's documents handed to `warm` before they are read.
pub(super) fn open_root(
    store: ReadableStorage,
    source: &str,
    options: PyramidOptions,
    warm: Warm,
    series: Option<&str>,
) -> Result<Pyramid, Problem> {
    warm(&node_documents(""));
    let mut plate = None;
    let mut bioformats2raw = None;
    let (attributes, zarr_format, prefix) = match node(&store, "")? {
        Node::Missing => {
            return Err(
                "is not a Zarr store: no zarr.json, .zgroup or .zarray at its root".to_owned(),
            );
        }
        Node::Array { zarr_format } => {
            let opening = Opening {
                source,
                options,
                zarr_format,
                prefix: "",
                warm,
            };
            return open_levels(store, &opening, None, Map::new());
        }
        Node::Group {
            attributes,
            zarr_format,
        } => {
            if metadata::bioformats2raw_image(&attributes) {
                // bioformats2raw.layout 3: the images are groups 0, 1, … (or those OME's
                // `series` lists); the first is read unless another is asked for.
                let mut found = series_list(&store, warm)?;
                let count = found.series.len();
                let opened = match series {
                    None => 0,
                    Some(path) => found
                        .series
                        .iter()
                        .position(|entry| entry.path == path)
                        .ok_or_else(|| {
                            format!(
                                "series {} does not exist (the bioformats2raw container has {count} series{})",
                                printable(path),
                                if count > 0 {
                                    format!(", 0 to {}", count - 1)
                                } else {
                                    String::new()
                                }
                            )
                        })?,
                };
                found.opened = opened;
                found.chosen = series.is_some();
                let path = found
                    .series
                    .get(opened)
                    .map(|entry| entry.path.clone())
                    .ok_or("is a bioformats2raw container without an image group '0'")?;
                let group = format!("{path}/");
                bioformats2raw = Some(found);
                match node(&store, &group)? {
                    Node::Group {
                        attributes,
                        zarr_format,
                    } => (attributes, zarr_format, ""),
                    _ => {
                        return Err(format!(
                            "is a bioformats2raw container whose series {} is not an image group",
                            quoted(&path)
                        ));
                    }
                }
            } else if series.is_some() {
                return Err("is not a bioformats2raw container of series".to_owned());
            } else if let Some(found) = metadata::plate(&attributes)? {
                // An HCS plate: the first well's first field opens (another is opened by
                // its own path, `--field ROW/COLUMN/FIELD`); every well's fields are listed.
                let found = plate_fields(&store, found, warm)?;
                let field = format!("{}/", found.field);
                warm(&node_documents(&field));
                let image = match node(&store, &field)? {
                    Node::Group {
                        attributes,
                        zarr_format,
                    } => (attributes, zarr_format),
                    _ => {
                        return Err(format!(
                            "is a plate whose field {} is not an image group",
                            quoted(&found.field)
                        ));
                    }
                };
                plate = Some(found);
                (image.0, image.1, "")
            } else {
                (attributes, zarr_format, "")
            }
        }
    };
    let field_prefix = plate.as_ref().map(|p| format!("{}/", p.field)).or_else(|| {
        bioformats2raw
            .as_ref()
            .map(|b: &metadata::Bioformats2raw| format!("{}/", b.series[b.opened].path))
    });
    let prefix = field_prefix.as_deref().unwrap_or(prefix);
    let multiscale = metadata::multiscale(&attributes)?.ok_or(
        "is a Zarr group without OME-Zarr 'multiscales' metadata (open an array inside it, or an OME-Zarr image)",
    )?;
    let opening = Opening {
        source,
        options,
        zarr_format,
        prefix,
        warm,
    };
    let mut pyramid = open_levels(store, &opening, Some(multiscale), attributes)?;
    pyramid.plate = plate;
    pyramid.bioformats2raw = bioformats2raw;
    Ok(pyramid)
}

/// The label images the `labels/` group of the image at `prefix` (`""` or `A/1/0/`) lists,
/// each with its `image-label` (none where the group is missing or unreadable: labels are
/// extras, never a reason the image does not open).
/// `warm` fetches documents ahead (a URL's, each step in one round trip).
pub(super) fn label_images(
    store: &ReadableStorage,
    prefix: &str,
    warm: Warm,
) -> Vec<metadata::LabelImage> {
    let group = format!("{prefix}labels/");
    warm(&node_documents(&group));
    let Ok(Node::Group { attributes, .. }) = node(store, &group) else {
        return Vec::new();
    };
    let names = metadata::label_names(&attributes);
    let documents: Vec<String> = names
        .iter()
        .flat_map(|name| node_documents(&format!("{group}{name}/")))
        .collect();
    warm(&documents);
    names
        .into_iter()
        .map(|name| {
            let mut label = metadata::LabelImage {
                path: format!("{group}{name}"),
                name,
                ..Default::default()
            };
            if let Ok(Node::Group { attributes, .. }) = node(store, &format!("{}/", label.path)) {
                metadata::image_label(&attributes, &mut label);
            }
            label
        })
        .collect()
}

/// The series of a bioformats2raw container: the paths its `OME` group's `series` lists (if
/// any), else its groups `0`, `1`, … as far as they go; named from `OME/METADATA.ome.xml` where it
/// names them, each with its finest level's shape (the first [`DESCRIBED_SERIES`]).
fn series_list(store: &ReadableStorage, warm: Warm) -> Result<metadata::Bioformats2raw, Problem> {
    warm(&node_documents("OME/"));
    let listed = match node(store, "OME/") {
        Ok(Node::Group { attributes, .. }) => metadata::series_paths(&attributes)?,
        _ => None,
    };
    let paths = match listed {
        Some(paths) if !paths.is_empty() => paths,
        _ => {
            let mut paths = Vec::new();
            while paths.len() < metadata::MAX_SERIES {
                let path = paths.len().to_string();
                warm(&node_documents(&format!("{path}/")));
                match node(store, &format!("{path}/")) {
                    Ok(Node::Group { .. }) => paths.push(path),
                    _ => break,
                }
            }
            paths
        }
    };
    let names = read_text(store, "OME/METADATA.ome.xml")
        .ok()
        .flatten()
        .map(|text| metadata::ome_xml_image_names(&text))
        .unwrap_or_default();
    // The described series' groups in one round trip, then their finest levels' documents in
    // one more.
    let described: Vec<String> = paths
        .iter()
        .take(DESCRIBED_SERIES)
        .flat_map(|path| node_documents(&format!("{path}/")))
        .collect();
    warm(&described);
    let finest: Vec<Option<(String, metadata::Multiscale)>> = paths
        .iter()
        .take(DESCRIBED_SERIES)
        .map(|path| series_finest_level(store, path))
        .collect();
    let documents: Vec<String> = finest
        .iter()
        .flatten()
        .flat_map(|(level, _)| ["zarr.json", ".zarray"].map(|name| document_key(level, name)))
        .collect();
    warm(&documents);
    let mut finest = finest.into_iter();
    let series = paths
        .into_iter()
        .enumerate()
        .map(|(index, path)| metadata::SeriesEntry {
            name: names.get(index).cloned().flatten(),
            dims: finest
                .next()
                .flatten()
                .and_then(|(level, multiscale)| level_shape(store, &level, &multiscale)),
            path,
        })
        .collect();
    Ok(metadata::Bioformats2raw {
        series,
        opened: 0,
        chosen: false,
    })
}

/// The series of a bioformats2raw container whose shapes are read (their documents, a few
/// requests each for a URL's store).
const DESCRIBED_SERIES: usize = 64;

/// A series' finest level's path in the store, and the series' multiscale (`None` when its
/// metadata cannot be read).
fn series_finest_level(
    store: &ReadableStorage,
    path: &str,
) -> Option<(String, metadata::Multiscale)> {
    let Ok(Node::Group { attributes, .. }) = node(store, &format!("{path}/")) else {
        return None;
    };
    let multiscale = metadata::multiscale(&attributes).ok().flatten()?;
    let level = format!("{path}/{}", multiscale.datasets.first()?.path);
    Some((level, multiscale))
}

/// The shape of the array at `level` of `multiscale`, x first, and its axes' names in that
/// order (`None` when its metadata cannot be read).
fn level_shape(
    store: &ReadableStorage,
    level: &str,
    multiscale: &metadata::Multiscale,
) -> Option<(Vec<u64>, Vec<String>)> {
    let document = match read_json(store, &format!("{level}/zarr.json")).ok()? {
        Some(document) => document,
        None => read_json(store, &format!("{level}/.zarray")).ok()??,
    };
    let mut shape: Vec<u64> = document
        .get("shape")?
        .as_array()?
        .iter()
        .map(Value::as_u64)
        .collect::<Option<_>>()?;
    let mut names: Vec<String> = match &multiscale.axes {
        Some(axes) if axes.len() == shape.len() => axes.iter().map(|a| a.name.clone()).collect(),
        _ => Vec::new(),
    };
    shape.reverse();
    names.reverse();
    Some((shape, names))
}

/// The text of the document at `key`, if there is one (at most [`MAX_METADATA_BYTES`]).
fn read_text(store: &ReadableStorage, key: &str) -> Result<Option<String>, Problem> {
    let store_key = StoreKey::new(key).map_err(|e| format!("store key {}: {e}", quoted(key)))?;
    match store.size_key(&store_key) {
        Ok(Some(size)) if size > MAX_METADATA_BYTES => {
            return Err(format!("{key} is {size} bytes; not read"));
        }
        Ok(Some(_)) => {}
        Ok(None) => return Ok(None),
        Err(e) => return Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    }
    match store.get(&store_key) {
        Ok(Some(bytes)) => Ok(Some(String::from_utf8_lossy(&bytes).into_owned())),
        Ok(None) => Ok(None),
        Err(e) => Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    }
}

/// Whether the store's root is a bioformats2raw container (its series are opened by
/// [`open_root`]'s `series`).
pub(super) fn is_bioformats2raw_root(store: &ReadableStorage) -> bool {
    matches!(
        node(store, ""),
        Ok(Node::Group { attributes, .. }) if metadata::bioformats2raw_image(&attributes)
    )
}

/// Reads the fields of every well of `plate` (their documents fetched together first) and
/// names the field that opens: the first well's first.
fn plate_fields(
    store: &ReadableStorage,
    mut plate: metadata::Plate,
    warm: Warm,
) -> Result<metadata::Plate, Problem> {
    let documents: Vec<String> = plate
        .wells
        .iter()
        .flat_map(|(well, _)| node_documents(&format!("{well}/")))
        .collect();
    warm(&documents);
    // A well that cannot be read lists no fields (the plate still opens); the first must.
    for (index, (well, fields)) in plate.wells.iter_mut().enumerate() {
        let read = match node(store, &format!("{well}/")) {
            Ok(Node::Group { attributes, .. }) => metadata::well_fields(&attributes, well),
            Ok(_) => Err(format!(
                "is a plate whose well {} is not a group",
                quoted(well)
            )),
            Err(problem) => Err(problem),
        };
        match read {
            Ok(read) => *fields = read,
            Err(problem) if index == 0 => return Err(problem),
            Err(_) => {}
        }
    }
    let (well, fields) = &plate.wells[0];
    let first = fields
        .first()
        .ok_or_else(|| format!("is a plate whose well {} has no fields", quoted(well)))?;
    plate.field = format!("{well}/{first}");
    Ok(plate)
}

/// What [`open_levels`] knows from the root: where the image is, and how it was asked for.
struct Opening<'a> {
    source: &'a str,
    options: PyramidOptions,
    /// The Zarr version of the image's group (or root array).
    zarr_format: u8,
    /// The image group's path in the store (`""`, `"0/"`).
    prefix: &'a str,
    warm: Warm<'a>,
}

fn open_levels(
    store: ReadableStorage,
    opening: &Opening,
    multiscale: Option<metadata::Multiscale>,
    attributes: Map<String, Value>,
) -> Result<Pyramid, Problem> {
    let Opening {
        source,
        options,
        zarr_format,
        prefix,
        ..
    } = *opening;
    let paths: Vec<String> = match &multiscale {
        Some(m) => m.datasets.iter().map(|d| d.path.clone()).collect(),
        None => vec![String::new()],
    };
    let arrays = open_arrays(&store, opening, &paths)?;
    let axes = axes_of(multiscale.as_ref(), &arrays[0])?;
    let first = &arrays[0].array;
    let layout = layout_of(&axes)?;
    let stored = Stored::of(first.data_type()).ok_or_else(|| {
        format!(
            "{} holds {} values; voxscope reads uint8/16/32/64, int8/16/32/64, float32 and float64",
            arrays[0].shown,
            printable(&type_name(first.data_type()))
        )
    })?;
    let stored_type = type_name(first.data_type());
    let time_points = leading_extent(first, layout.time);
    let channels = leading_extent(first, layout.channel);
    check_selection(&axes, first, options, time_points, channels)?;
    let levels = level_infos(&arrays, &layout, stored, multiscale.as_ref())?;

    let levels_len = levels.len();
    let units = std::array::from_fn(|a| layout.space[a].and_then(|d| axes[d].unit.clone()));
    let version = multiscale.as_ref().and_then(|m| m.version.clone());
    Ok(Pyramid {
        source: source.to_owned(),
        format: if multiscale.is_some() {
            "OME-Zarr"
        } else {
            "Zarr"
        },
        ome_version: version,
        zarr_format,
        name: multiscale.as_ref().and_then(|m| m.name.clone()),
        levels,
        axes,
        units,
        channels: channels as usize,
        time_points: time_points as usize,
        selected: options,
        omero: metadata::omero_channels(&attributes),
        voxel_type: stored.voxel_type(),
        stored_type,
        downscaling: multiscale.as_ref().and_then(|m| m.downscaling.clone()),
        stored,
        layout,
        arrays: std::sync::Arc::new(arrays.into_iter().map(|level| level.array).collect()),
        range_paths: range_paths(&attributes, prefix, levels_len),
        image_prefix: prefix.to_owned(),
        label_image: metadata::ome_attributes(&attributes).contains_key("image-label"),
        store,
        remote: None,
        read_ahead: None,
        reader_pool: None,
        shard_batch_busy: std::sync::Arc::default(),
        chunks_are_objects: true,
        plate: None,
        bioformats2raw: None,
    })
}

/// A Zarr v2 array rebuilt from its Zarr v3 form, so that its codecs come from zarrs's plugin
/// registry (where [`guard`]'s bounded decoders are): zarrs builds a v2 `blosc` compressor
/// directly, bypassing the registry. The chunk keys stay v2's. An array whose metadata has no
/// v3 form is kept as opened.
fn through_codec_plugins(
    array: Array<dyn ReadableStorageTraits>,
    store: &ReadableStorage,
    path: &str,
) -> Array<dyn ReadableStorageTraits> {
    let ArrayMetadata::V2(v2) = array.metadata() else {
        return array;
    };
    match zarrs::convert::array_metadata_v2_to_v3(v2) {
        Ok(v3) => {
            Array::new_with_metadata(store.clone(), &format!("/{path}"), ArrayMetadata::V3(v3))
                .unwrap_or(array)
        }
        Err(_) => array,
    }
}

/// `voxscope.chunk_ranges.paths`, one per level, when present and valid paths.
fn range_paths(attributes: &Map<String, Value>, prefix: &str, levels: usize) -> Vec<String> {
    let paths: Vec<String> = attributes
        .get("voxscope")
        .and_then(|v| v.pointer("/chunk_ranges/paths"))
        .and_then(Value::as_array)
        .map(|list| {
            list.iter()
                .filter_map(Value::as_str)
                .filter(|p| metadata::check_path(p).is_ok())
                .map(|p| format!("{prefix}{p}"))
                .collect()
        })
        .unwrap_or_default();
    if paths.len() == levels {
        paths
    } else {
        Vec::new()
    }
}

/// Whether the document at `key` is there, after checking that it is small enough to read.
fn read_size_checked(store: &ReadableStorage, key: &str) -> Result<bool, Problem> {
    match store.size_key(&self::key(key)?) {
        Ok(Some(size)) if size > MAX_METADATA_BYTES => Err(format!(
            "{key} is {size} bytes; metadata of more than {MAX_METADATA_BYTES} bytes is not read"
        )),
        Ok(size) => Ok(size.is_some()),
        Err(e) => Err(format!("cannot read {key}: {}", printable(&e.to_string()))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_round_trip_guesses_the_levels_that_fit_its_wave_of_requests() {
        let root = node_documents("");
        for (max_requests, levels) in [(0, 0), (4, 0), (8, 0), (9, 1), (18, 4), (30, 8), (1024, 8)]
        {
            let (asked, guesses) = first_documents(max_requests);
            assert_eq!(asked, root);
            assert_eq!(
                guesses.len(),
                3 * levels + 2,
                "{max_requests} requests in flight"
            );
            assert!(root.len() + guesses.len() <= max_requests.max(root.len() + 2));
        }
        let (_, guesses) = first_documents(32);
        assert_eq!(&guesses[..3], ["0/zarr.json", "0/.zarray", "0/.zattrs"]);
        assert_eq!(guesses[guesses.len() - 3], "7/.zattrs");
        assert_eq!(&guesses[guesses.len() - 2..], ["attributes.json", "info"]);
    }
}
