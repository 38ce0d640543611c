//! What `convert` writes: the OME-Zarr version, the chunks' compression, how coarser levels
//! are computed, and the image's name and unit.

use serde_json::{Value, json};

use crate::OptionError;

/// The OME-Zarr version written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZarrVersion {
    /// OME-Zarr 0.4 on Zarr v2: one file per chunk, `/` separated keys.
    V04,
    /// OME-Zarr 0.5 on Zarr v3, sharded: one file per shard of chunks.
    V05,
}

/// How chunks are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Blosc with LZ4 and byte shuffle: the fastest to decode (the default).
    BloscLz4,
    /// Blosc with Zstandard and byte shuffle: smaller, slower to decode.
    BloscZstd,
    /// Zstandard, level 3.
    Zstd,
    /// gzip, level 5.
    Gzip,
    /// Uncompressed.
    None,
}

impl Compression {
    /// The names `convert --compression` takes.
    pub const NAMES: [(&'static str, Self); 5] = [
        ("blosc-lz4", Self::BloscLz4),
        ("blosc-zstd", Self::BloscZstd),
        ("zstd", Self::Zstd),
        ("gzip", Self::Gzip),
        ("none", Self::None),
    ];

    /// Parses a name of [`Self::NAMES`].
    pub fn parse(text: &str) -> Result<Self, OptionError> {
        Self::NAMES
            .iter()
            .find(|(name, _)| *name == text)
            .map(|(_, c)| *c)
            .ok_or_else(|| OptionError::UnknownCompression {
                name: text.to_owned(),
                known: Self::names(),
            })
    }

    /// The names of [`Self::NAMES`], comma-separated: what a message lists.
    pub(crate) fn names() -> String {
        let names: Vec<&str> = Self::NAMES.iter().map(|(n, _)| *n).collect();
        names.join(", ")
    }

    pub(super) fn v2(self) -> Value {
        match self {
            Self::BloscLz4 | Self::BloscZstd => json!({
                "id": "blosc",
                "cname": if self == Self::BloscLz4 { "lz4" } else { "zstd" },
                "clevel": 5,
                "shuffle": 1,
                "blocksize": 0
            }),
            Self::Zstd => json!({"id": "zstd", "level": 3}),
            Self::Gzip => json!({"id": "gzip", "level": 5}),
            Self::None => Value::Null,
        }
    }

    pub(super) fn v3(self, type_size: usize) -> Option<Value> {
        match self {
            Self::BloscLz4 | Self::BloscZstd => Some(json!({
                "name": "blosc",
                "configuration": {
                    "cname": if self == Self::BloscLz4 { "lz4" } else { "zstd" },
                    "clevel": 5,
                    "shuffle": if type_size > 1 { "shuffle" } else { "noshuffle" },
                    "typesize": type_size,
                    "blocksize": 0
                }
            })),
            // With the frame's content checksum: a damaged chunk fails to decode rather than
            // decoding to other values.
            Self::Zstd => {
                Some(json!({"name": "zstd", "configuration": {"level": 3, "checksum": true}}))
            }
            Self::Gzip => Some(json!({"name": "gzip", "configuration": {"level": 5}})),
            Self::None => None,
        }
    }
}

/// How a coarser voxel is made from the 2×2×2 finer ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Downsampling {
    /// Their mean (integers rounded half up): intensities.
    Mean,
    /// Their maximum: labels, where a mean would invent labels that do not exist.
    Max,
}

/// What `convert` writes.
#[derive(Debug, Clone, PartialEq)]
pub struct WriteOptions {
    pub version: ZarrVersion,
    /// Chunk side in voxels (a power of two from 8 to 512).
    pub chunk: usize,
    /// Chunks per shard side (0.5 only): a shard holds `shard_chunks³` chunks.
    pub shard_chunks: usize,
    pub compression: Compression,
    pub downsampling: Downsampling,
    /// The image's name in the metadata.
    pub name: String,
    /// The unit of the spacing (`millimeter`, `micrometer`), if known.
    pub unit: Option<String>,
}
