//! The group's metadata, written last (an interrupted conversion leaves no image that claims
//! to be complete): OME `multiscales` (each level's scale and the half-voxel shift of its
//! first voxel's centre), `omero` (the channel's display window) and voxscope's chunk ranges.

use std::path::Path;

use serde_json::{Value, json};

use super::super::super::error::Problem;
use super::documents::write_json;
use super::{Downsampling, ImageLayout, ZarrVersion};

/// The display window `omero` states: the data's smallest and largest value (`min`, `max`)
/// and the window it opens with (`start`, `end`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplayWindow {
    pub range: [f64; 2],
    pub window: [f64; 2],
}

/// Writes the group metadata of the image `layout` describes at `root`; `omero` with
/// `display`, where given (not for labels: their values are categories).
pub fn write_group(
    root: &Path,
    layout: &ImageLayout,
    display: Option<DisplayWindow>,
) -> Result<(), Problem> {
    let options = &layout.options;
    let [sx, sy, sz] = layout.spacing;
    let levels = layout.levels().len();
    let axis = |name: &str| match &options.unit {
        Some(unit) => json!({"name": name, "type": "space", "unit": unit}),
        None => json!({"name": name, "type": "space"}),
    };
    let datasets: Vec<Value> = (0..levels)
        .map(|index| {
            let factor = (1u64 << index) as f64;
            let scale = [sz * factor, sy * factor, sx * factor];
            let shift = [sz, sy, sx].map(|s| s * (factor - 1.0) / 2.0);
            json!({
                "path": index.to_string(),
                "coordinateTransformations": [
                    {"type": "scale", "scale": scale},
                    {"type": "translation", "translation": shift}
                ]
            })
        })
        .collect();
    let method = match options.downsampling {
        Downsampling::Mean => "mean",
        Downsampling::Max => "max",
    };
    let mut multiscale = json!({
        "name": options.name,
        "axes": [axis("z"), axis("y"), axis("x")],
        "datasets": datasets,
        "type": method,
        "metadata": {
            "description": format!("2x2x2 {method} of the level before; odd extents repeat their last voxel"),
            "method": "voxscope convert",
            "version": env!("CARGO_PKG_VERSION")
        }
    });
    let ranges = json!({
        "chunk_ranges": {
            "paths": (0..levels).map(|i| format!("ranges/{i}")).collect::<Vec<_>>(),
            "layout": "float64 [chunk z, chunk y, chunk x, 2]: the chunk's smallest and largest finite value, NaN where it holds none",
            "chunk": options.chunk
        }
    });
    let omero = display
        .filter(|_| options.downsampling == Downsampling::Mean)
        .map(|display| {
            json!({
                "channels": [{
                    "label": options.name,
                    "color": "FFFFFF",
                    "active": true,
                    "window": {
                        "min": display.range[0],
                        "max": display.range[1],
                        "start": display.window[0],
                        "end": display.window[1]
                    }
                }],
                "rdefs": {"model": "greyscale"}
            })
        });
    match options.version {
        ZarrVersion::V04 => {
            multiscale["version"] = json!("0.4");
            write_json(&root.join(".zgroup"), &json!({"zarr_format": 2}))?;
            let mut attributes = json!({"multiscales": [multiscale], "voxscope": ranges});
            if let Some(omero) = omero {
                attributes["omero"] = omero;
            }
            write_json(&root.join(".zattrs"), &attributes)
        }
        ZarrVersion::V05 => {
            let mut ome = json!({"version": "0.5", "multiscales": [multiscale]});
            if let Some(omero) = omero {
                ome["omero"] = omero;
            }
            write_json(
                &root.join("zarr.json"),
                &json!({
                    "zarr_format": 3,
                    "node_type": "group",
                    "attributes": {"ome": ome, "voxscope": ranges}
                }),
            )
        }
    }
}
