//! The last step of a conversion (`convert finalize OUT`): every part's marker checked (there,
//! of this plan, its objects on disk at the sizes it wrote), the coarsest levels that no part
//! owns whole built from the last level the parts wrote, the parts' value ranges merged into
//! the `omero` window, and the group's metadata written last.

use std::path::Path;

use voxscope_volume::ome_zarr::{Window, WindowWriter, display_window, read_level, write_group};

use super::part::PartMarker;
use super::plan::{PART_SLAB_BYTES, PLAN_FOLDER, Plan};
use super::{failed, widened, write_column};
use crate::SceneError;

/// Finishes the conversion into `output`; returns the levels' dimensions.
pub fn finalize(
    output: &Path,
    mut report: impl FnMut(&str),
) -> Result<Vec<[usize; 3]>, SceneError> {
    let plan = Plan::read(output)?;
    let layout = plan
        .layout()
        .ok_or_else(|| failed(output, "the plan's image is not one convert writes"))?;
    let count = plan.parts.len();
    let mut missing = Vec::new();
    let mut range: Option<[f64; 2]> = None;
    for part in 0..count {
        let Some(marker) = PartMarker::read(output, part)? else {
            missing.push(part);
            continue;
        };
        if marker.plan != plan.id || marker.part != part || marker.parts != count {
            return Err(failed(
                output,
                format!(
                    "{PLAN_FOLDER}/parts/{part}.json belongs to another plan ({}, this is {}); nothing was written",
                    marker.plan, plan.id
                ),
            ));
        }
        for (key, (bytes, _)) in &marker.objects {
            let on_disk = std::fs::metadata(output.join(key)).map(|m| m.len());
            if on_disk.as_ref().ok() != Some(bytes) {
                let now = match on_disk {
                    Ok(len) => format!("{len} bytes"),
                    Err(_) => "missing".to_owned(),
                };
                return Err(failed(
                    output,
                    format!(
                        "part {part} wrote {key} as {bytes} bytes but it is {now}: delete {PLAN_FOLDER}/parts/{part}.json and run the part again"
                    ),
                ));
            }
        }
        if let Some(other) = marker.range {
            widened(&mut range, other);
        }
    }
    if let Some(&first) = missing.first() {
        let listed: Vec<String> = missing.iter().map(usize::to_string).collect();
        return Err(failed(
            output,
            format!(
                "part{} {} of {count} not finished: run `voxscope convert run {} --part {first}/{count}`{}; nothing was written",
                if missing.len() > 1 { "s" } else { "" },
                listed.join(", "),
                output.display(),
                if missing.len() > 1 {
                    " and the others"
                } else {
                    ""
                }
            ),
        ));
    }
    let levels = layout.levels();
    // The coarsest levels, in rounds: each reads the last level built column by column (a
    // column's slab within the parts' budget) and builds the levels its columns hold whole.
    let slab_bytes = plan.slab_bytes.unwrap_or(PART_SLAB_BYTES);
    let mut from = plan.column_levels - 1;
    while from + 1 < levels.len() {
        let columns = layout.columns_at(from, 1, Some(slab_bytes), 2);
        let to = from + columns.levels - 1;
        let [nx, ny, nz] = levels[from];
        report(&format!(
            "building levels {} to {to} from level {from} ({nx}x{ny}x{nz}) in {} column{}\n",
            from + 1,
            columns.count(),
            if columns.count() == 1 { "" } else { "s" }
        ));
        for column in 0..columns.count() {
            let window = columns.window(column, levels[from]);
            // The column in level 0's voxels, as the writer takes windows.
            let scale = 1usize << from;
            let origin = window.origin.map(|o| o * scale);
            let whole = Window {
                origin,
                size: std::array::from_fn(|a| {
                    (window.size[a] * scale).min(layout.dims[a] - origin[a])
                }),
            };
            let writer = WindowWriter::open(output, &layout, whole, from, to, false)
                .map_err(|p| failed(output, p))?;
            let [x0, y0] = window.origin;
            let [w, h] = window.size;
            let read = |z, n| {
                read_level(output, &layout, from, [x0, y0, z], [w, h, n])
                    .map_err(|p| failed(output, p))
            };
            write_column(output, writer, nz, read, |_| {})?;
        }
        from = to;
    }
    let display = display_window(output, &layout, range).map_err(|p| failed(output, p))?;
    write_group(output, &layout, display).map_err(|p| failed(output, p))?;
    Ok(levels)
}
