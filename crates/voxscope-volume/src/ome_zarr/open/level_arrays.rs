//! The arrays of an image's levels: opened (their metadata documents bounded first), their
//! axes found, the time point and channel asked for checked, and each level checked against
//! level 0 and described ([`LevelInfo`]).

use super::super::{Layout, LevelInfo};
use super::*;

/// A level's array, with its path in the store and how messages name it.
pub(super) struct LevelArray {
    pub path: String,
    /// `the root array`, or `array '0/1'`.
    pub shown: String,
    pub array: Array<dyn ReadableStorageTraits>,
}

/// Opens the array of each of `paths` under the image of `opening`, every level's documents
/// fetched at once first.
pub(super) fn open_arrays(
    store: &ReadableStorage,
    opening: &Opening,
    paths: &[String],
) -> Result<Vec<LevelArray>, Problem> {
    let prefix = opening.prefix;
    // Every level's documents at once: each level's array is then opened from them.
    let documents: Vec<String> = paths
        .iter()
        .flat_map(|path| array_documents(&format!("{prefix}{path}"), opening.zarr_format))
        .collect();
    (opening.warm)(&documents);
    let mut arrays = Vec::with_capacity(paths.len());
    for path in paths {
        let full = format!("{prefix}{path}");
        let shown = if full.is_empty() {
            "the root array".to_owned()
        } else {
            format!("array {}", quoted(&full))
        };
        // The documents zarrs reads whole are bounded first: zarr.json, else (Zarr v2)
        // .zarray and .zattrs.
        if !read_size_checked(store, &document_key(&full, "zarr.json"))? {
            for name in [".zarray", ".zattrs"] {
                read_size_checked(store, &document_key(&full, name))?;
            }
        }
        let array = Array::open(store.clone(), &format!("/{full}"))
            .map_err(|e| format!("{shown}: {}", printable(&e.to_string())))?;
        let array = through_codec_plugins(array, store, &full);
        arrays.push(LevelArray {
            path: full,
            shown,
            array,
        });
    }
    Ok(arrays)
}

/// The axes of the image: the multiscale's, else level 0's dimension names, else the
/// default axes of its dimensionality; one per dimension of level 0 (`first`).
pub(super) fn axes_of(
    multiscale: Option<&metadata::Multiscale>,
    first: &LevelArray,
) -> Result<Vec<Axis>, Problem> {
    let ndim = first.array.dimensionality();
    let axes = match multiscale.and_then(|m| m.axes.clone()) {
        Some(axes) => axes,
        None => match first.array.dimension_names() {
            Some(names) if names.iter().all(Option::is_some) && names.len() == ndim => names
                .iter()
                .flatten()
                .map(|name| Axis {
                    name: printable(name),
                    kind: metadata::kind_by_name(name),
                    unit: None,
                })
                .collect(),
            _ => {
                if !(2..=5).contains(&ndim) {
                    return Err(format!(
                        "{} has {ndim} dimensions; a volume has 2 to 5 (t, c, z, y, x)",
                        first.shown
                    ));
                }
                metadata::default_axes(ndim)
            }
        },
    };
    if axes.len() != ndim {
        return Err(format!(
            "the metadata names {} axes but {} has {ndim} dimensions",
            axes.len(),
            first.shown
        ));
    }
    Ok(axes)
}

/// The extent of `array` along its dimension `dim` (time or channel), 1 without one.
pub(super) fn leading_extent(array: &Array<dyn ReadableStorageTraits>, dim: Option<usize>) -> u64 {
    dim.map_or(1, |d| array.shape()[d])
}

/// Checks that level 0 (`first`) has no other axis of more than one voxel, and holds the
/// time point and channel `options` asks for (of `time_points` and `channels`).
pub(super) fn check_selection(
    axes: &[Axis],
    first: &Array<dyn ReadableStorageTraits>,
    options: PyramidOptions,
    time_points: u64,
    channels: u64,
) -> Result<(), Problem> {
    for (dim, axis) in axes.iter().enumerate() {
        if let AxisKind::Other(kind) = &axis.kind
            && first.shape()[dim] != 1
        {
            return Err(format!(
                "axis {} (type {}) has extent {}; voxscope reads space, time and channel axes",
                quoted(&axis.name),
                quoted(kind),
                first.shape()[dim]
            ));
        }
    }
    if options.time as u64 >= time_points {
        return Err(format!(
            "time point {} does not exist (the image has {time_points})",
            options.time
        ));
    }
    if options.channel as u64 >= channels {
        return Err(format!(
            "channel {} does not exist (the image has {channels})",
            options.channel
        ));
    }
    Ok(())
}

/// Each level of `arrays` described, once checked to agree with level 0 (dimensions, stored
/// type, time and channel extents); levels without a scale spaced by their size relative to
/// level 0.
pub(super) fn level_infos(
    arrays: &[LevelArray],
    layout: &Layout,
    stored: Stored,
    multiscale: Option<&metadata::Multiscale>,
) -> Result<Vec<LevelInfo>, Problem> {
    let first = &arrays[0].array;
    let ndim = first.dimensionality();
    let stored_type = type_name(first.data_type());
    let time_points = leading_extent(first, layout.time);
    let channels = leading_extent(first, layout.channel);
    let mut levels = Vec::with_capacity(arrays.len());
    for (index, level) in arrays.iter().enumerate() {
        let (shown, array) = (&level.shown, &level.array);
        if array.dimensionality() != ndim {
            return Err(format!(
                "{shown} has {} dimensions but level 0 has {ndim}",
                array.dimensionality()
            ));
        }
        if Stored::of(array.data_type()) != Some(stored) {
            return Err(format!(
                "{shown} holds {} but level 0 holds {stored_type}",
                printable(&type_name(array.data_type()))
            ));
        }
        if leading_extent(array, layout.time) != time_points
            || leading_extent(array, layout.channel) != channels
        {
            return Err(format!(
                "{shown} has other channel or time extents than level 0"
            ));
        }
        levels.push(level_info(
            &level.path,
            shown,
            array,
            layout,
            stored,
            multiscale.map(|m| (m, index)),
        )?);
    }
    // Levels without a scale are spaced by their size relative to level 0.
    if multiscale.is_none_or(|m| m.datasets.iter().all(|d| d.scale.is_none())) {
        let finest = levels[0].dims;
        for level in &mut levels {
            level.spacing = std::array::from_fn(|a| finest[a] as f64 / level.dims[a] as f64);
        }
    }
    Ok(levels)
}
