//! The metadata documents `convert` writes: an array's `.zarray` (0.4) or `zarr.json` (0.5),
//! with the chunk ranges' extra axis.

use std::fs;
use std::path::Path;

use serde_json::{Value, json};

use super::super::super::VoxelType;
use super::super::super::error::Problem;
use super::super::super::io::io_reason;
use super::{Compression, ZarrVersion};

pub(super) fn zarr_types(voxel_type: VoxelType) -> (&'static str, &'static str) {
    match voxel_type {
        VoxelType::U8 => ("|u1", "uint8"),
        VoxelType::I8 => ("|i1", "int8"),
        VoxelType::U16 => ("<u2", "uint16"),
        VoxelType::I16 => ("<i2", "int16"),
        VoxelType::U32 => ("<u4", "uint32"),
        VoxelType::I32 => ("<i4", "int32"),
        VoxelType::F32 => ("<f4", "float32"),
        VoxelType::F64 => ("<f8", "float64"),
    }
}

pub(super) fn write_json(path: &Path, value: &Value) -> Result<(), Problem> {
    if let Some(parent) = path.parent() {
        fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create {}: {}", parent.display(), io_reason(&e)))?;
    }
    let text = serde_json::to_string_pretty(value).unwrap_or_default();
    fs::write(path, text + "\n")
        .map_err(|e| format!("cannot write {}: {}", path.display(), io_reason(&e)))
}

/// What an array metadata document says: shape, chunk and shard (z, y, x), the type's names
/// (v2, v3) and size, compression, fill value, dimension names.
pub(super) struct ArraySpec<'a> {
    pub(super) shape: [usize; 3],
    pub(super) chunk: [usize; 3],
    pub(super) shard: Option<[usize; 3]>,
    pub(super) type_names: (&'a str, &'a str),
    pub(super) type_size: usize,
    pub(super) compression: Compression,
    pub(super) fill_value: Value,
}

/// The metadata document of an array (`.zarray` for 0.4, `zarr.json` for 0.5).
pub(super) fn array_document(version: ZarrVersion, spec: ArraySpec) -> Value {
    let ArraySpec {
        shape,
        chunk,
        shard,
        type_names,
        type_size,
        compression,
        fill_value,
    } = spec;
    match version {
        ZarrVersion::V04 => json!({
            "zarr_format": 2,
            "shape": shape,
            "chunks": shard.unwrap_or(chunk),
            "dtype": type_names.0,
            "compressor": compression.v2(),
            "fill_value": fill_value,
            "order": "C",
            "filters": null,
            "dimension_separator": "/"
        }),
        ZarrVersion::V05 => {
            let mut codecs = vec![json!({"name": "bytes", "configuration": {"endian": "little"}})];
            codecs.extend(compression.v3(type_size));
            let (grid, codecs) = match shard {
                Some(shard) => (
                    shard,
                    vec![json!({
                        "name": "sharding_indexed",
                        "configuration": {
                            "chunk_shape": chunk,
                            "codecs": codecs,
                            "index_codecs": [
                                {"name": "bytes", "configuration": {"endian": "little"}},
                                {"name": "crc32c"}
                            ],
                            "index_location": "end"
                        }
                    })],
                ),
                None => (chunk, codecs),
            };
            json!({
                "zarr_format": 3,
                "node_type": "array",
                "shape": shape,
                "data_type": type_names.1,
                "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": grid}},
                "chunk_key_encoding": {"name": "default", "configuration": {"separator": "/"}},
                "fill_value": fill_value,
                "codecs": codecs,
                "attributes": {},
                "dimension_names": ["z", "y", "x"]
            })
        }
    }
}

pub(super) fn metadata_name(version: ZarrVersion) -> &'static str {
    match version {
        ZarrVersion::V04 => ".zarray",
        ZarrVersion::V05 => "zarr.json",
    }
}

/// Adds the `[min, max]` axis to a ranges array's document.
pub(super) fn with_min_max_axis(mut document: Value) -> Value {
    let push = |value: &mut Value, n: u64| {
        if let Some(list) = value.as_array_mut() {
            list.push(json!(n));
        }
    };
    push(&mut document["shape"], 2);
    if document.get("chunks").is_some() {
        push(&mut document["chunks"], 2);
    }
    if let Some(grid) = document.pointer_mut("/chunk_grid/configuration/chunk_shape") {
        push(grid, 2);
    }
    if let Some(names) = document
        .get_mut("dimension_names")
        .and_then(Value::as_array_mut)
    {
        names.push(json!("range"));
    }
    document
}
