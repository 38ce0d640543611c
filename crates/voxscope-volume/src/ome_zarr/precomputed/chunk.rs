//! A precomputed chunk as a Zarr v3 chunk: the `voxscope.precomputed_keys` key encoding (a
//! chunk's file name, `x0-x1_y0-y1_z0-z1` in voxels, the scale's `voxel_offset` included) and
//! the `voxscope.precomputed_chunk` codec.
//!
//! A chunk at the volume's far edge holds only the voxels inside it, and its encodings do not
//! say how many: [`super::PrecomputedStore`] reads the extent from the chunk's name and puts
//! it before the bytes ([`with_extent`]), and the codec places the chunk's voxels in a whole
//! chunk of zeros. The values are x fastest, then y, z and channel: Zarr's C order of the
//! array [`super::info`] writes. A chunk may be gzip-compressed as a whole (the `gzip`
//! transfer encoding of files cloud-volume writes, or of a server that stores them so): it is
//! recognized by its magic bytes and inflated, bounded, first.

use std::io::Cursor;
use std::num::NonZeroU64;
use std::sync::Arc;

use serde_json::{Map, Value};
use zarrs::array::chunk_key_encoding::api::{ChunkKeyEncodingPlugin, ChunkKeyEncodingTraits};
use zarrs::array::codec::api::{ArrayToBytesCodecTraits, CodecPluginV3};
use zarrs::array::{
    ArrayBytes, ArrayBytesRaw, BytesRepresentation, ChunkKeyEncoding, Codec, CodecError,
    CodecOptions, CodecTraitsV3, DataType, DataTypeSize, FillValue,
};
use zarrs::metadata::Configuration;
use zarrs::metadata::v3::MetadataV3;
use zarrs::plugin::{PluginCreateError, ZarrVersion};
use zarrs::storage::StoreKey;

use super::segmentation;

/// The codec's name in the metadata [`super::info`] writes.
pub(super) const CHUNK_CODEC: &str = "voxscope.precomputed_chunk";
/// The chunk key encoding's name there.
pub(super) const KEY_ENCODING: &str = "voxscope.precomputed_keys";

/// What [`with_extent`] puts before a chunk's bytes.
const MAGIC: &[u8; 4] = b"VXPC";
const HEADER: usize = 16;

/// The chunk's bytes behind its extent (x, y, z), as the codec reads them.
pub(super) fn with_extent(extent: [u32; 3], bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + bytes.len());
    out.extend_from_slice(MAGIC);
    for e in extent {
        out.extend_from_slice(&e.to_le_bytes());
    }
    out.extend_from_slice(bytes);
    out
}

/// Where a chunk file's name `x0-x1_y0-y1_z0-z1` puts it: its first voxel and its extent
/// (x, y, z; bounds may be negative: `-64-0`), if it is one.
pub(super) fn chunk_of_name(name: &str) -> Option<([i64; 3], [u32; 3])> {
    fn bound(text: &str) -> Option<i64> {
        let digits = text.strip_prefix('-').unwrap_or(text);
        let valid =
            !digits.is_empty() && digits.len() <= 12 && digits.bytes().all(|b| b.is_ascii_digit());
        valid.then(|| text.parse().ok()).flatten()
    }
    let mut begin = [0; 3];
    let mut extent = [0; 3];
    let mut parts = name.split('_');
    for a in 0..3 {
        let part = parts.next()?;
        // The separator: the first '-' after the begin's first character.
        let at = part.get(1..)?.find('-')? + 1;
        let (first, end) = (bound(&part[..at])?, bound(&part[at + 1..])?);
        begin[a] = first;
        extent[a] = u32::try_from(end.checked_sub(first)?)
            .ok()
            .filter(|&e| e > 0)?;
    }
    parts.next().is_none().then_some((begin, extent))
}

/// How a scale's chunks are encoded (the codec's configuration).
#[derive(Debug, Clone)]
enum Encoding {
    Raw,
    Jpeg,
    Png,
    CompressedSegmentation([usize; 3]),
}

/// The `voxscope.precomputed_chunk` codec.
#[derive(Debug, Clone)]
pub struct PrecomputedChunkCodec {
    configuration: Map<String, Value>,
    encoding: Encoding,
    channels: usize,
}

zarrs::plugin::impl_extension_aliases!(PrecomputedChunkCodec, v3: "voxscope.precomputed_chunk", []);

inventory::submit! {
    CodecPluginV3::new::<PrecomputedChunkCodec>()
}

impl CodecTraitsV3 for PrecomputedChunkCodec {
    fn create(metadata: &MetadataV3) -> Result<Codec, PluginCreateError> {
        let configuration: Map<String, Value> = metadata
            .configuration()
            .map(|c| c.clone().into())
            .unwrap_or_default();
        let encoding = match configuration.get("encoding").and_then(Value::as_str) {
            Some("raw") => Encoding::Raw,
            Some("jpeg") => Encoding::Jpeg,
            Some("png") => Encoding::Png,
            Some("compressed_segmentation") => {
                let block: Vec<usize> = configuration
                    .get("block_size")
                    .and_then(Value::as_array)
                    .map(|b| {
                        b.iter()
                            .filter_map(Value::as_u64)
                            .map(|v| v as usize)
                            .collect()
                    })
                    .unwrap_or_default();
                let block: [usize; 3] = block.try_into().map_err(|_| {
                    PluginCreateError::Other("compressed_segmentation without a block size".into())
                })?;
                Encoding::CompressedSegmentation(block)
            }
            _ => {
                return Err(PluginCreateError::Other(
                    "a precomputed chunk codec without an encoding it reads".into(),
                ));
            }
        };
        let channels = configuration
            .get("channels")
            .and_then(Value::as_u64)
            .unwrap_or(1) as usize;
        Ok(Codec::ArrayToBytes(Arc::new(Self {
            configuration,
            encoding,
            channels,
        })))
    }
}

super::super::adapted::whole_chunk_codec_traits!(PrecomputedChunkCodec);

fn fail(what: impl std::fmt::Display) -> CodecError {
    CodecError::Other(format!("precomputed: {what}"))
}

/// Places a chunk of `extent` (x, y, z) and `channels` channels, x fastest, in a whole chunk
/// of `shape` (x, y, z) of zeros.
fn place_in_chunk(
    values: &[u8],
    extent: [usize; 3],
    shape: [usize; 3],
    channels: usize,
    size: usize,
) -> Vec<u8> {
    if extent == shape {
        return values.to_vec();
    }
    let mut chunk = vec![0u8; shape.iter().product::<usize>() * channels * size];
    let row = extent[0] * size;
    for c in 0..channels {
        for z in 0..extent[2] {
            for y in 0..extent[1] {
                let from = (((c * extent[2] + z) * extent[1]) + y) * row;
                let to = ((((c * shape[2] + z) * shape[1]) + y) * shape[0]) * size;
                chunk[to..to + row].copy_from_slice(&values[from..from + row]);
            }
        }
    }
    chunk
}

/// Decodes an 8-bit image of `width` x `height` pixels and `channels` samples each (JPEG or
/// PNG, checked against what the chunk holds before any pixel exists), to planes: all of
/// channel 0, then channel 1, …
fn decode_image(
    bytes: &[u8],
    format: image::ImageFormat,
    width: usize,
    height: usize,
    channels: usize,
) -> Result<Vec<u8>, CodecError> {
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(width as u32);
    limits.max_image_height = Some(height as u32);
    limits.max_alloc = Some((width * height * 8) as u64 + (1 << 20));
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| fail(format!("{format:?}: {e}")))?;
    if decoded.width() as usize != width || decoded.height() as usize != height {
        return Err(fail(format!(
            "the image is {}x{}, the chunk {width}x{height}",
            decoded.width(),
            decoded.height()
        )));
    }
    let interleaved = match channels {
        1 => decoded.into_luma8().into_raw(),
        3 => decoded.into_rgb8().into_raw(),
        n => {
            return Err(fail(format!(
                "an image chunk of {n} channels (1 or 3 are read)"
            )));
        }
    };
    let pixels = width * height;
    let mut planes = vec![0u8; pixels * channels];
    for (p, sample) in interleaved.chunks_exact(channels).enumerate() {
        for (c, &value) in sample.iter().enumerate() {
            planes[c * pixels + p] = value;
        }
    }
    Ok(planes)
}

impl PrecomputedChunkCodec {
    /// The chunk's values (x fastest, then y, z, channel) for its `extent`.
    fn values(
        &self,
        encoded: &[u8],
        extent: [usize; 3],
        size: usize,
        data_type: &DataType,
    ) -> Result<Vec<u8>, CodecError> {
        let voxels = extent.iter().product::<usize>();
        let expected = (voxels * self.channels * size) as u64;
        // The gzip transfer encoding, whatever the encoding under it (a raw chunk of its
        // exact size is raw, whatever its first bytes; the others cannot begin so).
        let raw_size = matches!(self.encoding, Encoding::Raw) && encoded.len() as u64 == expected;
        let inflated;
        let encoded = if encoded.starts_with(&[0x1f, 0x8b]) && !raw_size {
            let bound = expected.saturating_mul(4) + (1 << 16);
            let decoder = flate2::read::GzDecoder::new(encoded);
            inflated = super::super::guard::read_bounded(decoder, bound, "precomputed gzip")?;
            &inflated[..]
        } else {
            encoded
        };
        let values = match &self.encoding {
            Encoding::Raw => {
                if encoded.len() as u64 != expected {
                    return Err(fail(format!(
                        "a raw chunk of {} bytes; {}x{}x{} voxels of {} channel(s) take {expected}",
                        encoded.len(),
                        extent[0],
                        extent[1],
                        extent[2],
                        self.channels
                    )));
                }
                encoded.to_vec()
            }
            Encoding::Jpeg => decode_image(
                encoded,
                image::ImageFormat::Jpeg,
                extent[0],
                extent[1] * extent[2],
                self.channels,
            )?,
            Encoding::Png => {
                if size != 1 {
                    return Err(fail("png chunks of more than 8 bits are not read"));
                }
                decode_image(
                    encoded,
                    image::ImageFormat::Png,
                    extent[0],
                    extent[1] * extent[2],
                    self.channels,
                )?
            }
            Encoding::CompressedSegmentation(block) => {
                let wide = match size {
                    4 => false,
                    8 => true,
                    _ => {
                        return Err(fail(format!(
                            "compressed_segmentation of {} values",
                            data_type.name(ZarrVersion::V3).unwrap_or_default()
                        )));
                    }
                };
                segmentation::decode(encoded, extent, *block, self.channels, wide).map_err(fail)?
            }
        };
        Ok(values)
    }
}

impl ArrayToBytesCodecTraits for PrecomputedChunkCodec {
    fn into_dyn(self: Arc<Self>) -> Arc<dyn ArrayToBytesCodecTraits> {
        self
    }

    fn encoded_representation(
        &self,
        _shape: &[NonZeroU64],
        _data_type: &DataType,
        _fill_value: &FillValue,
    ) -> Result<BytesRepresentation, CodecError> {
        Ok(BytesRepresentation::UnboundedSize)
    }

    fn encode<'a>(
        &self,
        _bytes: ArrayBytes<'a>,
        _shape: &[NonZeroU64],
        _data_type: &DataType,
        _fill_value: &FillValue,
        _options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        // voxscope reads precomputed volumes; `convert` writes OME-Zarr.
        Err(fail("voxscope does not write precomputed chunks"))
    }

    fn decode<'a>(
        &self,
        bytes: ArrayBytesRaw<'a>,
        shape: &[NonZeroU64],
        data_type: &DataType,
        _fill_value: &FillValue,
        _options: &CodecOptions,
    ) -> Result<ArrayBytes<'a>, CodecError> {
        let size = match data_type.size() {
            DataTypeSize::Fixed(size) => size,
            DataTypeSize::Variable => return Err(fail("variable-size values")),
        };
        if bytes.len() < HEADER || &bytes[..4] != MAGIC {
            return Err(fail(
                "a chunk read without its extent (not through the precomputed store)",
            ));
        }
        let word = |i: usize| {
            u32::from_le_bytes(bytes[4 + 4 * i..8 + 4 * i].try_into().unwrap_or_default()) as usize
        };
        let extent = [word(0), word(1), word(2)];
        let dims: Vec<usize> = shape.iter().map(|s| s.get() as usize).collect();
        let whole = [
            dims[dims.len() - 1],
            dims[dims.len() - 2],
            dims[dims.len() - 3],
        ];
        if (0..3).any(|a| extent[a] == 0 || extent[a] > whole[a]) {
            return Err(fail(format!(
                "a chunk of {}x{}x{} voxels in chunks of {}x{}x{}",
                extent[0], extent[1], extent[2], whole[0], whole[1], whole[2]
            )));
        }
        let mut values = self.values(&bytes[HEADER..], extent, size, data_type)?;
        if cfg!(target_endian = "big") && size > 1 {
            for value in values.chunks_exact_mut(size) {
                value.reverse();
            }
        }
        let chunk = place_in_chunk(&values, extent, whole, self.channels, size);
        Ok(ArrayBytes::new_flen(chunk))
    }
}

/// The `voxscope.precomputed_keys` chunk key encoding: a chunk's file name from its grid
/// indices ((channel,) z, y, x) and the scale's chunk size, voxel offset and size (x, y, z).
#[derive(Debug, Clone)]
pub struct PrecomputedKeyEncoding {
    chunk: [i64; 3],
    offset: [i64; 3],
    size: [i64; 3],
}

zarrs::plugin::impl_extension_aliases!(PrecomputedKeyEncoding, v3: "voxscope.precomputed_keys");

inventory::submit! {
    ChunkKeyEncodingPlugin::new::<PrecomputedKeyEncoding>()
}

impl ChunkKeyEncodingTraits for PrecomputedKeyEncoding {
    fn create(metadata: &MetadataV3) -> Result<ChunkKeyEncoding, PluginCreateError> {
        let configuration: Map<String, Value> = metadata
            .configuration()
            .map(|c| c.clone().into())
            .unwrap_or_default();
        let triple = |name: &str| -> Result<[i64; 3], PluginCreateError> {
            let list: Vec<i64> = configuration
                .get(name)
                .and_then(Value::as_array)
                .map(|l| l.iter().filter_map(Value::as_i64).collect())
                .unwrap_or_default();
            list.try_into()
                .map_err(|_| PluginCreateError::Other(format!("precomputed keys without '{name}'")))
        };
        Ok(Self {
            chunk: triple("chunk")?,
            offset: triple("offset")?,
            size: triple("size")?,
        }
        .into())
    }

    fn configuration(&self) -> Configuration {
        let map: Map<String, Value> = [
            ("chunk", self.chunk),
            ("offset", self.offset),
            ("size", self.size),
        ]
        .into_iter()
        .map(|(name, value)| (name.to_owned(), Value::from(value.to_vec())))
        .collect();
        map.into()
    }

    fn encode(&self, chunk_grid_indices: &[u64]) -> StoreKey {
        let n = chunk_grid_indices.len();
        let range = |a: usize| {
            // x, y, z are the last three indices, reversed.
            let index = chunk_grid_indices
                .get(n.wrapping_sub(1 + a))
                .copied()
                .unwrap_or(0) as i64;
            let begin = self.offset[a] + index * self.chunk[a];
            let end = (begin + self.chunk[a]).min(self.offset[a] + self.size[a]);
            format!("{begin}-{end}")
        };
        let name = format!("{}_{}_{}", range(0), range(1), range(2));
        StoreKey::new(name).unwrap_or_else(|_| StoreKey::new("0").expect("valid key"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunk_names_carry_their_extent() {
        let extent_of = |name| chunk_of_name(name).map(|(_, extent)| extent);
        assert_eq!(chunk_of_name("3-9_2-7_1-5"), Some(([3, 2, 1], [6, 5, 4])));
        assert_eq!(
            chunk_of_name("-4-2_0-1_-3--1"),
            Some(([-4, 0, -3], [6, 1, 2]))
        );
        assert_eq!(extent_of("3-9_2-7"), None);
        assert_eq!(extent_of("3-9_2-7_1-5_0-1"), None);
        assert_eq!(extent_of("9-3_2-7_1-5"), None);
        assert_eq!(extent_of("info"), None);
    }

    #[test]
    fn keys_name_the_chunk_cut_at_the_volume_edge() {
        let keys = PrecomputedKeyEncoding {
            chunk: [6, 5, 4],
            offset: [3, 2, 1],
            size: [10, 9, 7],
        };
        assert_eq!(keys.encode(&[0, 0, 0]).as_str(), "3-9_2-7_1-5");
        assert_eq!(keys.encode(&[1, 1, 1]).as_str(), "9-13_7-11_5-8");
        assert_eq!(keys.encode(&[0, 1, 0, 1]).as_str(), "9-13_2-7_5-8");
    }

    #[test]
    fn an_edge_chunk_is_placed_in_zeros() {
        // 2x1x1 voxels, 2 channels, in a 3x2x1 chunk.
        let chunk = place_in_chunk(&[1, 2, 3, 4], [2, 1, 1], [3, 2, 1], 2, 1);
        assert_eq!(chunk, [1, 2, 0, 0, 0, 0, 3, 4, 0, 0, 0, 0]);
    }
}
