//! What one level is: which array dimension holds what ([`Layout`]), and the [`LevelInfo`]
//! of an opened array (dimensions, chunks, shards, codecs, fill value, place in space).

use serde_json::Value;
use zarrs::array::{Array, ArrayMetadata, ArrayShardedExt, DataType};
use zarrs::storage::ReadableStorageTraits;

use super::super::error::{Problem, printable, quoted};
use super::super::{VoxelType, format_dims};
use super::metadata::{self, Axis, AxisKind};
use super::{Layout, LevelInfo, MAX_CHUNK_BYTES, MAX_SHARD_CHUNKS, Stored};

/// Which dimension is time, channel, x, y, z: the last space axis is x (fastest), then y,
/// then z, as OME-Zarr orders them.
pub(super) fn layout_of(axes: &[Axis]) -> Result<Layout, Problem> {
    let mut layout = Layout {
        ndim: axes.len(),
        time: None,
        channel: None,
        space: [None; 3],
    };
    let space: Vec<usize> = axes
        .iter()
        .enumerate()
        .filter(|(_, a)| a.kind == AxisKind::Space)
        .map(|(i, _)| i)
        .collect();
    if !(2..=3).contains(&space.len()) {
        let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
        return Err(format!(
            "axes {} have {} space axes; a volume has 2 or 3",
            quoted(&names.join(", ")),
            space.len()
        ));
    }
    for (axis, dim) in space.iter().rev().enumerate() {
        layout.space[axis] = Some(*dim);
    }
    for (dim, axis) in axes.iter().enumerate() {
        let slot = match axis.kind {
            AxisKind::Time => &mut layout.time,
            AxisKind::Channel => &mut layout.channel,
            _ => continue,
        };
        if slot.replace(dim).is_some() {
            return Err(format!(
                "axis {} is a second {:?} axis",
                quoted(&axis.name),
                axis.kind
            )
            .to_lowercase());
        }
    }
    Ok(layout)
}

pub(super) fn level_info(
    path: &str,
    shown: &str,
    array: &Array<dyn ReadableStorageTraits>,
    layout: &Layout,
    stored: Stored,
    multiscale: Option<(&metadata::Multiscale, usize)>,
) -> Result<LevelInfo, Problem> {
    let shape = array.shape();
    let pick = |values: &[u64], axis: usize| layout.space[axis].map_or(1, |d| values[d]);
    let mut dims = [0usize; 3];
    for (axis, dim) in dims.iter_mut().enumerate() {
        let extent = pick(shape, axis);
        *dim = usize::try_from(extent)
            .ok()
            .filter(|&e| e > 0 && (e as u64) < (1 << 40))
            .ok_or_else(|| {
                format!(
                    "{shown} has extent {extent} along {}",
                    ["x", "y", "z"][axis]
                )
            })?;
    }
    if dims
        .iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
        .is_none_or(|count| count > 1 << 60)
    {
        return Err(format!(
            "{shown} has {} voxels, too many to address",
            format_dims(dims)
        ));
    }
    let element = stored_size(stored);
    let zeros = vec![0u64; shape.len()];
    let outer: Vec<u64> = array
        .chunk_shape(&zeros)
        .map_err(|e| format!("{shown}: {}", printable(&e.to_string())))?
        .iter()
        .map(|n| n.get())
        .collect();
    let inner: Vec<u64> = match array.subchunk_shape() {
        Some(inner) if array.is_sharded() => inner.iter().map(|n| n.get()).collect(),
        _ => outer.clone(),
    };
    let chunk_bytes = inner
        .iter()
        .try_fold(element, |acc, &n| acc.checked_mul(n))
        .unwrap_or(u64::MAX);
    if chunk_bytes > MAX_CHUNK_BYTES {
        return Err(format!(
            "{shown} has chunks of {} ({chunk_bytes} bytes decoded); at most {MAX_CHUNK_BYTES} are read",
            short_shape(&inner)
        ));
    }
    let sharded = array.is_sharded();
    if sharded {
        let per_shard = outer
            .iter()
            .zip(&inner)
            .try_fold(1u64, |acc, (o, i)| acc.checked_mul(o.div_ceil(*i)))
            .unwrap_or(u64::MAX);
        if per_shard > MAX_SHARD_CHUNKS {
            return Err(format!(
                "{shown} has shards of {} chunks; at most {MAX_SHARD_CHUNKS} are read",
                per_shard
            ));
        }
    }
    let to_usize = |values: &[u64], axis: usize| pick(values, axis).min(usize::MAX as u64) as usize;
    let chunk = std::array::from_fn(|axis| to_usize(&inner, axis));
    let shard = sharded.then(|| std::array::from_fn(|axis| to_usize(&outer, axis)));

    let (mut spacing, mut origin) = ([1.0; 3], [0.0; 3]);
    if let Some((multiscale, index)) = multiscale {
        let dataset = &multiscale.datasets[index];
        let ndim = layout.ndim;
        let check = |values: &Option<Vec<f64>>, what: &str| -> Result<(), Problem> {
            match values {
                Some(v) if v.len() != ndim => Err(format!(
                    "multiscales[0].datasets[{index}]: {what} has {} values for {ndim} axes",
                    v.len()
                )),
                _ => Ok(()),
            }
        };
        check(&dataset.scale, "scale")?;
        check(&dataset.translation, "translation")?;
        check(&multiscale.global_scale, "the multiscale's scale")?;
        check(
            &multiscale.global_translation,
            "the multiscale's translation",
        )?;
        for axis in 0..3 {
            let Some(dim) = layout.space[axis] else {
                continue;
            };
            let global_scale = multiscale.global_scale.as_ref().map_or(1.0, |s| s[dim]);
            let global_shift = multiscale
                .global_translation
                .as_ref()
                .map_or(0.0, |t| t[dim]);
            let scale = dataset.scale.as_ref().map_or(1.0, |s| s[dim]);
            let shift = dataset.translation.as_ref().map_or(0.0, |t| t[dim]);
            spacing[axis] = scale * global_scale;
            origin[axis] = shift * global_scale + global_shift;
        }
    }
    Ok(LevelInfo {
        path: path.to_owned(),
        dims,
        spacing,
        origin,
        chunk,
        shard,
        codec: describe_codecs(array.metadata()),
        fill_value: fill_value(array, stored),
    })
}

/// A data type's Zarr v3 name (`uint16`), whatever version the array is.
pub(super) fn type_name(data_type: &DataType) -> String {
    use zarrs::plugin::ExtensionName;
    data_type
        .name_v3()
        .map(|name| name.into_owned())
        .unwrap_or_else(|| data_type.to_string())
}

fn stored_size(stored: Stored) -> u64 {
    match stored {
        Stored::Native(voxel_type) => voxel_type.size() as u64,
        Stored::U64 | Stored::I64 => 8,
    }
}

fn short_shape(shape: &[u64]) -> String {
    shape
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join("x")
}

/// The fill value as a number (0 when it cannot be read as one).
fn fill_value(array: &Array<dyn ReadableStorageTraits>, stored: Stored) -> f64 {
    let bytes = array.fill_value().as_ne_bytes();
    let take = |n: usize| -> Option<[u8; 8]> {
        let mut out = [0u8; 8];
        out[..n].copy_from_slice(bytes.get(..n)?);
        Some(out)
    };
    let value = match stored {
        Stored::Native(VoxelType::U8) => bytes.first().map(|&b| b as f64),
        Stored::Native(VoxelType::I8) => bytes.first().map(|&b| b as i8 as f64),
        Stored::Native(VoxelType::U16) => take(2).map(|b| u16::from_ne_bytes([b[0], b[1]]) as f64),
        Stored::Native(VoxelType::I16) => take(2).map(|b| i16::from_ne_bytes([b[0], b[1]]) as f64),
        Stored::Native(VoxelType::U32) => {
            take(4).map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64)
        }
        Stored::Native(VoxelType::I32) => {
            take(4).map(|b| i32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64)
        }
        Stored::Native(VoxelType::F32) => {
            take(4).map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64)
        }
        Stored::Native(VoxelType::F64) => take(8).map(f64::from_ne_bytes),
        Stored::U64 => take(8).map(|b| u64::from_ne_bytes(b) as f64),
        Stored::I64 => take(8).map(|b| i64::from_ne_bytes(b) as f64),
    };
    value.unwrap_or(0.0)
}

/// The codecs as a short text: `blosc lz4`, `zstd`, `gzip`, `none`, `sharding(blosc zstd)`.
fn describe_codecs(metadata: &ArrayMetadata) -> String {
    fn codec_name(codec: &Value) -> Option<String> {
        let name = codec
            .get("name")
            .or_else(|| codec.get("id"))
            .and_then(Value::as_str)?;
        let config = codec.get("configuration").unwrap_or(codec);
        Some(match name {
            "bytes" | "crc32c" => return None,
            "blosc" | "numcodecs.blosc" => format!(
                "blosc {}",
                config.get("cname").and_then(Value::as_str).unwrap_or("?")
            ),
            "sharding_indexed" => {
                let inner = config
                    .get("codecs")
                    .and_then(Value::as_array)
                    .map(|codecs| list(codecs))
                    .unwrap_or_else(|| "none".to_owned());
                format!("sharding({inner})")
            }
            // An N5 block: its `compression` (`n5 gzip`, `n5 blosc lz4`, `n5 raw`).
            "voxscope.n5_block" => {
                let compression = config.get("compression");
                let kind = compression
                    .and_then(|c| c.get("type"))
                    .and_then(Value::as_str)
                    .unwrap_or("raw");
                let cname = compression
                    .and_then(|c| c.get("cname"))
                    .and_then(Value::as_str)
                    .filter(|_| kind == "blosc")
                    .map(|cname| format!(" {}", printable(cname)))
                    .unwrap_or_default();
                format!("n5 {}{cname}", printable(kind))
            }
            // A precomputed chunk: its encoding (`precomputed raw`, `precomputed jpeg`).
            "voxscope.precomputed_chunk" => format!(
                "precomputed {}",
                printable(
                    config
                        .get("encoding")
                        .and_then(Value::as_str)
                        .unwrap_or("?")
                )
            ),
            // numcodecs' compressors in Zarr v3 (and zarrs's v3 form of a v2 array's).
            other => printable(other.strip_prefix("numcodecs.").unwrap_or(other)),
        })
    }
    fn list(codecs: &[Value]) -> String {
        let names: Vec<String> = codecs.iter().filter_map(codec_name).collect();
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        }
    }
    let json = serde_json::to_value(metadata).unwrap_or(Value::Null);
    match metadata {
        ArrayMetadata::V3(_) => json
            .get("codecs")
            .and_then(Value::as_array)
            .map(|codecs| list(codecs))
            .unwrap_or_else(|| "none".to_owned()),
        ArrayMetadata::V2(_) => {
            let mut codecs: Vec<Value> = json
                .get("filters")
                .and_then(Value::as_array)
                .cloned()
                .unwrap_or_default();
            if let Some(compressor) = json.get("compressor").filter(|c| !c.is_null()) {
                codecs.push(compressor.clone());
            }
            list(&codecs)
        }
    }
}
