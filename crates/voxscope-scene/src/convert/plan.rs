//! A conversion's plan (`OUT/.voxscope/plan.json`): what the input is (its path or URL, how
//! it is read, a fingerprint of the files), what the output is (the image's layout) and which
//! part owns which columns. `convert plan` writes it with the arrays' metadata; every part and
//! `finalize` read it, so that they need nothing but the output's path.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use voxscope_volume::ome_zarr::{
    Columns, Compression, Downsampling, ImageLayout, SlabSource, WriteOptions, ZarrVersion,
};
use voxscope_volume::{Endian, RawLayout, VoxelType, format_dims};

use super::{ConvertOptions, failed};
use crate::SceneError;

/// Where the plan and the parts' markers live, inside the output.
pub const PLAN_FOLDER: &str = ".voxscope";
const PLAN_FILE: &str = "plan.json";
/// What the plan file says it is (and its version).
const PLAN_KIND: &str = "voxscope convert plan 1";

/// The most bytes one column's slab of level 0 holds when parts share the work, unless the
/// plan says (`convert plan --part-memory`): a part's memory stays near twice this, whatever
/// the input's size.
pub const PART_SLAB_BYTES: u64 = 512 << 20;

/// A conversion's plan, as `plan.json` holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub kind: String,
    /// Names this plan (a checksum of the rest): markers of another plan's parts carry
    /// another id.
    pub id: String,
    /// The input's path (absolute) or URL, and what is known of its files when planned.
    pub input: String,
    pub fingerprint: String,
    pub options: PlanOptions,
    /// The image: level 0's voxels, type, spacing, name and unit.
    pub dims: [usize; 3],
    pub voxel_type: String,
    pub spacing: [f64; 3],
    pub name: String,
    pub unit: Option<String>,
    /// The columns and the levels parts write of them (`0..column_levels`).
    pub column_side: [usize; 2],
    pub column_grid: [usize; 2],
    pub column_levels: usize,
    /// Part `i` owns columns `parts[i][0] .. parts[i][1]` (row by row, x fastest).
    pub parts: Vec<[usize; 2]>,
    /// The most bytes a column's slab holds, in the parts and in `finalize`'s rounds
    /// (`None`: one column of the whole plane, in one process).
    pub slab_bytes: Option<u64>,
}

/// The options a part reopens the input with, and the output's, in words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanOptions {
    pub raw: Option<String>,
    pub spacing: Option<[f64; 3]>,
    pub channel: usize,
    pub time: usize,
    pub max_requests: usize,
    pub format: String,
    pub chunk: usize,
    pub shard: usize,
    pub compression: String,
    pub labels: bool,
    pub unit: Option<String>,
    pub tile: Option<[usize; 3]>,
    pub upsample: Option<[usize; 3]>,
    pub noise: f64,
}

impl PlanOptions {
    fn of(options: &ConvertOptions) -> Self {
        Self {
            raw: options.raw.map(|raw| {
                format!(
                    "{}:{}:{}",
                    format_dims(raw.dims),
                    raw.voxel_type.name(),
                    match raw.endian {
                        Endian::Little => "le",
                        Endian::Big => "be",
                    }
                )
            }),
            spacing: options.spacing,
            channel: options.channel,
            time: options.time,
            max_requests: options.max_requests,
            format: version_name(options.version).to_owned(),
            chunk: options.chunk,
            shard: options.shard,
            compression: Compression::NAMES
                .iter()
                .find(|(_, c)| *c == options.compression)
                .map(|(name, _)| (*name).to_owned())
                .unwrap_or_default(),
            labels: options.labels,
            unit: options.unit.clone(),
            tile: options.tile,
            upsample: options.upsample,
            noise: options.noise,
        }
    }

    /// The convert options these say; `None` where a word is not one convert knows.
    pub fn convert_options(&self) -> Option<ConvertOptions> {
        Some(ConvertOptions {
            raw: match &self.raw {
                Some(text) => Some(RawLayout::parse(text).ok()?),
                None => None,
            },
            spacing: self.spacing,
            channel: self.channel,
            time: self.time,
            max_requests: self.max_requests,
            version: match self.format.as_str() {
                "0.4" => ZarrVersion::V04,
                "0.5" => ZarrVersion::V05,
                _ => return None,
            },
            chunk: self.chunk,
            shard: self.shard,
            compression: Compression::parse(&self.compression).ok()?,
            labels: self.labels,
            unit: self.unit.clone(),
            tile: self.tile,
            upsample: self.upsample,
            noise: self.noise,
        })
    }
}

pub(super) fn version_name(version: ZarrVersion) -> &'static str {
    match version {
        ZarrVersion::V04 => "0.4",
        ZarrVersion::V05 => "0.5",
    }
}

/// What is known of the files at `spec` without reading them: a file's size and time of
/// change; a folder's entries' names, sizes and times (a folder of slices, a store's
/// metadata); for a URL, nothing.
pub(super) fn fingerprint(spec: &str) -> String {
    fn stamp(meta: &std::fs::Metadata) -> String {
        let changed = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        format!("{} bytes, changed {changed}", meta.len())
    }
    let path = Path::new(spec);
    let Ok(meta) = std::fs::metadata(path) else {
        return "not a local path".to_owned();
    };
    if !meta.is_dir() {
        return format!("file of {}", stamp(&meta));
    }
    let mut entries: Vec<String> = std::fs::read_dir(path)
        .into_iter()
        .flatten()
        .flatten()
        .map(|entry| {
            let meta = entry.metadata().map(|m| stamp(&m)).unwrap_or_default();
            format!("{}: {meta}", entry.file_name().to_string_lossy())
        })
        .collect();
    entries.sort();
    format!(
        "folder of {} entries, checksum {:08x}",
        entries.len(),
        crc32c::crc32c(entries.join("\n").as_bytes())
    )
}

/// The input's name as a part reopens it from anywhere: an existing path made absolute.
pub(super) fn absolute_spec(spec: &str) -> String {
    std::fs::canonicalize(spec)
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| spec.to_owned())
}

impl Plan {
    /// The plan for converting `source` (opened from `spec` with `options`, its `--tile` and
    /// `--upsample` applied) into `layout`, cut into `parts` parts whose slabs stay within
    /// `slab_bytes` (`None`: one column of the whole plane).
    pub(super) fn new(
        spec: &str,
        source: &SlabSource,
        options: &ConvertOptions,
        layout: &ImageLayout,
        parts: usize,
        slab_bytes: Option<u64>,
    ) -> Self {
        let columns = layout.columns(parts, slab_bytes);
        let count = columns.count();
        let owned = (0..parts)
            .map(|i| [i * count / parts, (i + 1) * count / parts])
            .collect();
        let mut plan = Self {
            kind: PLAN_KIND.to_owned(),
            id: String::new(),
            input: absolute_spec(spec),
            fingerprint: fingerprint(spec),
            options: PlanOptions::of(options),
            dims: source.dims,
            voxel_type: source.voxel_type.name().to_owned(),
            spacing: layout.spacing,
            name: layout.options.name.clone(),
            unit: layout.options.unit.clone(),
            column_side: columns.side,
            column_grid: columns.grid,
            column_levels: columns.levels,
            parts: owned,
            slab_bytes,
        };
        plan.id = plan.checksum();
        plan
    }

    pub(super) fn folder(output: &Path) -> PathBuf {
        output.join(PLAN_FOLDER)
    }

    /// Writes the plan into the output (whose arrays exist).
    pub(super) fn write(&self, output: &Path) -> Result<(), SceneError> {
        let text = serde_json::to_string_pretty(self).unwrap_or_default();
        write_atomically(&Self::folder(output).join(PLAN_FILE), &(text + "\n"))
            .map_err(|problem| failed(output, problem))
    }

    /// Reads the plan of the conversion into `output`.
    pub fn read(output: &Path) -> Result<Self, SceneError> {
        let path = Self::folder(output).join(PLAN_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            failed(
                output,
                match e.kind() {
                    std::io::ErrorKind::NotFound => format!(
                        "no conversion plan ({PLAN_FOLDER}/{PLAN_FILE}); make one with `voxscope convert plan IN {} --parts N`",
                        output.display()
                    ),
                    _ => format!("cannot read {PLAN_FOLDER}/{PLAN_FILE}: {e}"),
                },
            )
        })?;
        let plan: Self = serde_json::from_str(&text).map_err(|e| {
            failed(
                output,
                format!("{PLAN_FOLDER}/{PLAN_FILE} is not a conversion plan: {e}"),
            )
        })?;
        if plan.kind != PLAN_KIND {
            return Err(failed(
                output,
                format!(
                    "{PLAN_FOLDER}/{PLAN_FILE} is a \"{}\", not a \"{PLAN_KIND}\"",
                    plan.kind
                ),
            ));
        }
        if let Some(problem) = plan.problem() {
            return Err(failed(
                output,
                format!("{PLAN_FOLDER}/{PLAN_FILE} is not a plan convert made ({problem})"),
            ));
        }
        Ok(plan)
    }

    /// The checksum [`Self::id`] holds: of the plan without it.
    fn checksum(&self) -> String {
        let text = serde_json::to_string(&Self {
            id: String::new(),
            ..self.clone()
        })
        .unwrap_or_default();
        format!("{:08x}", crc32c::crc32c(text.as_bytes()))
    }

    /// What makes this plan one that `plan` did not write (edited, or damaged), if anything:
    /// parts and `finalize` trust its geometry to write every object once.
    fn problem(&self) -> Option<String> {
        if self.id != self.checksum() {
            return Some("its checksum does not match its contents".to_owned());
        }
        let Some(layout) = self.layout() else {
            return Some("its options or image are not convert's".to_owned());
        };
        let levels = layout.levels().len();
        let [nx, ny, _] = self.dims;
        let side = self.column_side;
        let whole = side == [nx, ny] && self.column_grid == [1, 1];
        let aligned = side[0] == side[1]
            && side[0] > 0
            && self.column_levels >= 1
            && self.column_levels <= levels
            && layout.tile().checked_shl((self.column_levels - 1) as u32) == Some(side[0])
            && self.column_grid == [nx.div_ceil(side[0]), ny.div_ceil(side[0])];
        if !(whole && self.column_levels == levels || aligned) {
            return Some("its columns do not fit the image".to_owned());
        }
        let Some(count) = self.column_grid[0].checked_mul(self.column_grid[1]) else {
            return Some("its columns do not fit the image".to_owned());
        };
        let contiguous = self.parts.first().is_some_and(|p| p[0] == 0)
            && self.parts.last().is_some_and(|p| p[1] == count)
            && self.parts.windows(2).all(|w| w[0][1] == w[1][0])
            && self.parts.iter().all(|[a, b]| a <= b)
            && self.parts.len() <= super::MAX_PARTS;
        (!contiguous).then(|| "its parts do not share the columns out once each".to_owned())
    }

    pub fn columns(&self) -> Columns {
        Columns {
            side: self.column_side,
            grid: self.column_grid,
            levels: self.column_levels,
        }
    }

    /// The image's layout; `None` where the plan's words are not convert's.
    pub fn layout(&self) -> Option<ImageLayout> {
        let options = self.options.convert_options()?;
        let write = WriteOptions {
            version: options.version,
            chunk: options.chunk,
            shard_chunks: options.shard,
            compression: options.compression,
            downsampling: if options.labels {
                Downsampling::Max
            } else {
                Downsampling::Mean
            },
            name: self.name.clone(),
            unit: self.unit.clone(),
        };
        let voxel_type = VoxelType::from_name(&self.voxel_type)?;
        ImageLayout::new(self.dims, voxel_type, self.spacing, &write).ok()
    }
}

/// Writes `text` to `path` through a temporary file renamed over it: a reader never sees half
/// of it, and a process killed while writing leaves the old file or none.
pub(super) fn write_atomically(path: &Path, text: &str) -> Result<(), String> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
    }
    let temporary = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&temporary, text)
        .and_then(|()| std::fs::rename(&temporary, path))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}
