//! One part of a conversion (`convert run OUT --part I/N`): its columns of level 0, read from
//! the input box by box, and every level it builds from them; then its marker
//! (`OUT/.voxscope/parts/I.json`) with each object it wrote (size and CRC-32C) and its
//! figures. A part whose marker is there returns at once; one killed half way writes the same
//! objects again when run again.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use voxscope_volume::ome_zarr::{SlabSource, WindowWriter};

use super::plan::{Plan, fingerprint, write_atomically};
use super::{ConvertOptions, failed, prepared, widened, write_column};
use crate::SceneError;

/// What a finished part leaves: the plan it belongs to, the objects it wrote and its figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartMarker {
    pub plan: String,
    pub part: usize,
    pub parts: usize,
    /// Each object written: its key, then its size in bytes and its CRC-32C.
    pub objects: BTreeMap<String, (u64, u32)>,
    /// The smallest and largest finite value of its voxels.
    pub range: Option<[f64; 2]>,
    pub bytes_in: u64,
    pub bytes_out: u64,
    pub seconds: f64,
    /// The process's peak resident memory, where the system says (Linux).
    pub peak_memory_bytes: Option<u64>,
}

impl PartMarker {
    pub(super) fn path(output: &Path, part: usize) -> PathBuf {
        Plan::folder(output)
            .join("parts")
            .join(format!("{part}.json"))
    }

    /// Part `part`'s marker, if it has finished (`Ok(None)`: no marker).
    pub(super) fn read(output: &Path, part: usize) -> Result<Option<Self>, SceneError> {
        let path = Self::path(output, part);
        let text = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => {
                return Err(failed(
                    output,
                    format!("cannot read {}: {e}", path.display()),
                ));
            }
        };
        serde_json::from_str(&text).map(Some).map_err(|e| {
            failed(
                output,
                format!("{} is not a part's marker: {e}", path.display()),
            )
        })
    }
}

/// The process's peak resident memory (Linux's `VmHWM`).
fn peak_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// How a part ended.
#[derive(Debug, Clone, PartialEq)]
pub enum PartOutcome {
    /// It ran and left this marker.
    Written(PartMarker),
    /// Its marker was there: nothing was done.
    AlreadyDone(PartMarker),
}

/// The input of `plan`, reopened as planned; refused where it changed since.
fn reopen(plan: &Plan, options: &ConvertOptions, output: &Path) -> Result<SlabSource, SceneError> {
    let source = SlabSource::open(&plan.input, &options.load_options())?;
    let source = prepared(source, options)?;
    let now = fingerprint(&plan.input);
    if now != plan.fingerprint
        || source.dims != plan.dims
        || source.voxel_type.name() != plan.voxel_type
    {
        return Err(failed(
            output,
            format!(
                "the input {} changed since the plan ({}, now {}); plan the conversion again into a new folder",
                plan.input, plan.fingerprint, now
            ),
        ));
    }
    Ok(source)
}

/// Runs part `part` of the conversion into `output` (of `parts` parts, where the caller
/// says how many it expects); `source`: the input already open (the one-process convert),
/// else reopened from the plan.
pub fn run_part(
    output: &Path,
    part: usize,
    parts: Option<usize>,
    source: Option<SlabSource>,
    mut report: impl FnMut(&str),
) -> Result<PartOutcome, SceneError> {
    let started = Instant::now();
    let plan = Plan::read(output)?;
    let count = plan.parts.len();
    if let Some(parts) = parts
        && parts != count
    {
        return Err(failed(
            output,
            format!("the plan has {count} parts, not {parts}"),
        ));
    }
    if part >= count {
        return Err(failed(
            output,
            format!(
                "part {part}: the plan has {count} parts (0 to {})",
                count - 1
            ),
        ));
    }
    if let Some(marker) = PartMarker::read(output, part)? {
        if marker.plan != plan.id || marker.part != part || marker.parts != count {
            return Err(failed(
                output,
                format!(
                    "part {part}'s marker belongs to another plan ({}, this is {}); nothing was written",
                    marker.plan, plan.id
                ),
            ));
        }
        return Ok(PartOutcome::AlreadyDone(marker));
    }
    let options = plan
        .options
        .convert_options()
        .ok_or_else(|| failed(output, "the plan's options are not convert's"))?;
    let layout = plan
        .layout()
        .ok_or_else(|| failed(output, "the plan's image is not one convert writes"))?;
    let mut source = match source {
        Some(source) => source,
        None => reopen(&plan, &options, output)?,
    };
    let columns = plan.columns();
    let [first, end] = plan.parts[part];
    let mut objects = BTreeMap::new();
    let mut range: Option<[f64; 2]> = None;
    let mut bytes_in = 0u64;
    let depth = source.dims[2];
    let total = (end - first).max(1) * depth;
    for (done, column) in (first..end).enumerate() {
        let window = columns.window(column, source.dims);
        let writer = WindowWriter::open(output, &layout, window, 0, columns.levels - 1, true)
            .map_err(|p| failed(output, p))?;
        let [x0, y0] = window.origin;
        let [w, h] = window.size;
        let stored_size = source.stored_type.size();
        let written = write_column(
            output,
            writer,
            depth,
            |z, n| {
                let data = source.read_box([x0, y0, z], [w, h, n])?;
                bytes_in += (data.len() * stored_size) as u64;
                Ok(data)
            },
            |z| {
                report(&format!(
                    "\rpart {part}/{count}: {:3.0} %",
                    100.0 * (done * depth + z) as f64 / total as f64
                ))
            },
        )?;
        if let Some(other) = written.range {
            widened(&mut range, other);
        }
        for (key, object) in written.written {
            objects.insert(key, (object.bytes, object.crc32c));
        }
    }
    let marker = PartMarker {
        plan: plan.id.clone(),
        part,
        parts: count,
        bytes_out: objects.values().map(|(bytes, _)| bytes).sum(),
        objects,
        range,
        bytes_in,
        seconds: started.elapsed().as_secs_f64(),
        peak_memory_bytes: peak_memory(),
    };
    let text = serde_json::to_string_pretty(&marker).unwrap_or_default();
    write_atomically(&PartMarker::path(output, part), &(text + "\n"))
        .map_err(|p| failed(output, p))?;
    Ok(PartOutcome::Written(marker))
}
