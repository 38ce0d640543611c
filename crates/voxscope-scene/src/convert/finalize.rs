//! The last step of a conversion (`convert finalize OUT`): every part's marker checked (there,
//! of this plan, its objects on disk at the sizes it wrote), the coarsest levels that no part
//! owns whole built from the last level the parts wrote, the parts' value ranges merged into
//! the `omero` window, and the group's metadata written last.

use std::path::Path;

use voxscope_volume::ome_zarr::{Window, WindowWriter, display_window, read_level, write_group};

use super::part::PartMarker;
use super::plan::{PLAN_FOLDER, Plan};
use crate::SceneError;

fn failed(output: &Path, problem: impl std::fmt::Display) -> SceneError {
    SceneError::Failed(format!("{}: {problem}", output.display()))
}

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
        if let Some([low, high]) = marker.range {
            let merged = range.get_or_insert([low, high]);
            merged[0] = merged[0].min(low);
            merged[1] = merged[1].max(high);
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
    let built = plan.column_levels;
    if built < levels.len() {
        // The coarsest levels, from the last level the parts wrote, read back whole-plane
        // slab by slab.
        let from = built - 1;
        let [nx, ny, nz] = levels[from];
        report(&format!(
            "building levels {built} to {} from level {from} ({nx}x{ny}x{nz})\n",
            levels.len() - 1
        ));
        let whole = Window {
            origin: [0, 0],
            size: [layout.dims[0], layout.dims[1]],
        };
        let mut writer = WindowWriter::open(output, &layout, whole, from, levels.len() - 1, false)
            .map_err(|p| failed(output, p))?;
        let slab = writer.slab_depth();
        let mut z = 0;
        while z < nz {
            let n = slab.min(nz - z);
            let data = read_level(output, &layout, from, z, n).map_err(|p| failed(output, p))?;
            writer.push(&data).map_err(|p| failed(output, p))?;
            z += n;
        }
        writer.finish().map_err(|p| failed(output, p))?;
    }
    let display = display_window(output, &layout, range).map_err(|p| failed(output, p))?;
    write_group(output, &layout, display).map_err(|p| failed(output, p))?;
    Ok(levels)
}
