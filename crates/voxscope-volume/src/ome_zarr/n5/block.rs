//! An N5 block as a Zarr v3 chunk: the `voxscope.n5_block` array-to-bytes codec and the
//! `voxscope.n5_keys` chunk key encoding, both registered with zarrs at compile time.
//!
//! An N5 block is a big-endian header (mode, dimension count, the block's extent along each
//! dimension, fastest first; in varlength mode also its element count) followed by the
//! block's values, big-endian, the first dimension fastest, compressed as the dataset's
//! `compression` says. A block at the dataset's far edge may hold fewer values than the
//! block size: it decodes into a whole chunk, the rest the fill value, as Zarr's edge chunks
//! are. The values' order is Zarr's C order of the reversed dimensions, so no transposition
//! is needed: the array [`super::attributes`] writes has N5's dimensions reversed.
//!
//! Compression is zarrs's codecs (through [`super::super::guard`]'s bounded decoders and
//! [`super::super::numcodecs`]' lzma): `raw`, `gzip` (gzip or, with `useZlib`, zlib), `bzip2`,
//! `xz`, `zstd` and `blosc`; and N5's `lz4`, the LZ4Block framing of lz4-java, here. Every
//! stage decodes into at most the block's bytes, and a header whose extent exceeds the block
//! size is refused before anything of its size exists.

use std::borrow::Cow;
use std::num::NonZeroU64;
use std::sync::Arc;

use serde_json::{Map, Value};
use zarrs::array::chunk_key_encoding::api::{ChunkKeyEncodingPlugin, ChunkKeyEncodingTraits};
use zarrs::array::codec::api::{ArrayToBytesCodecTraits, CodecPluginV3};
use zarrs::array::{
    ArrayBytes, ArrayBytesRaw, BytesRepresentation, BytesToBytesCodecTraits, ChunkKeyEncoding,
    Codec, CodecError, CodecOptions, CodecTraitsV3, DataType, DataTypeSize, FillValue,
};
use zarrs::metadata::Configuration;
use zarrs::metadata::v3::MetadataV3;
use zarrs::plugin::PluginCreateError;
use zarrs::storage::StoreKey;

/// The codec's name in the Zarr v3 metadata [`super::attributes`] writes.
pub(super) const BLOCK_CODEC: &str = "voxscope.n5_block";
/// The chunk key encoding's name there.
pub(super) const KEY_ENCODING: &str = "voxscope.n5_keys";

/// The most dimensions a block header may declare (N5 datasets are rarely above 5).
const MAX_DIMENSIONS: usize = 32;

/// How a dataset's blocks are compressed (its `compression` attribute).
#[derive(Debug, Clone)]
enum Compression {
    Raw,
    /// A zarrs codec with bounded decoding: gzip, zlib, bz2, lzma (xz), zstd, blosc.
    Codec(Arc<dyn BytesToBytesCodecTraits>),
    /// lz4-java's LZ4Block framing.
    Lz4Blocks,
}

impl Compression {
    /// The compression an N5 `compression` attribute names (N5 1.x's `compressionType`, a
    /// bare name, is [`super::attributes`]'s to turn into this form).
    fn of(compression: &Map<String, Value>) -> Result<Self, String> {
        let kind = compression
            .get("type")
            .and_then(Value::as_str)
            .unwrap_or("raw");
        let int = |name: &str, default: i64| {
            compression
                .get(name)
                .and_then(Value::as_i64)
                .unwrap_or(default)
        };
        let metadata = match kind {
            "raw" => return Ok(Self::Raw),
            "lz4" => return Ok(Self::Lz4Blocks),
            "gzip" if compression.get("useZlib").and_then(Value::as_bool) == Some(true) => {
                MetadataV3::new_with_configuration(
                    "numcodecs.zlib",
                    configuration([("level", int("level", 6).clamp(0, 9).into())]),
                )
            }
            "gzip" => MetadataV3::new_with_configuration(
                "gzip",
                configuration([("level", int("level", 6).clamp(0, 9).into())]),
            ),
            "bzip2" => MetadataV3::new_with_configuration(
                "numcodecs.bz2",
                configuration([("level", int("blockSize", 9).clamp(1, 9).into())]),
            ),
            "xz" => MetadataV3::new_with_configuration(
                "numcodecs.lzma",
                configuration([("format", 1.into()), ("preset", int("preset", 6).into())]),
            ),
            "zstd" => MetadataV3::new_with_configuration(
                "zstd",
                configuration([
                    ("level", int("level", 3).clamp(-131_072, 22).into()),
                    ("checksum", false.into()),
                ]),
            ),
            "blosc" => {
                let shuffle = match int("shuffle", 1) {
                    0 => "noshuffle",
                    2 => "bitshuffle",
                    _ => "shuffle",
                };
                let cname = compression
                    .get("cname")
                    .and_then(Value::as_str)
                    .unwrap_or("lz4");
                MetadataV3::new_with_configuration(
                    "blosc",
                    configuration([
                        ("cname", cname.into()),
                        ("clevel", int("clevel", 5).clamp(0, 9).into()),
                        ("shuffle", shuffle.into()),
                        // A frame's header holds its type size and block size.
                        ("typesize", 1.into()),
                        ("blocksize", 0.into()),
                    ]),
                )
            }
            other => {
                return Err(format!(
                    "compression '{}' is not one N5 defines (raw, gzip, bzip2, xz, lz4, zstd, blosc)",
                    crate::error::escape(other)
                ));
            }
        };
        match Codec::from_metadata(&metadata) {
            Ok(Codec::BytesToBytes(codec)) => Ok(Self::Codec(codec)),
            Ok(_) => Err(format!("compression '{kind}' is not a compressor")),
            Err(e) => Err(format!("compression '{kind}': {e}")),
        }
    }

    /// Decodes `payload` into exactly `expected` bytes.
    fn decode(
        &self,
        payload: &[u8],
        expected: u64,
        options: &CodecOptions,
    ) -> Result<Vec<u8>, CodecError> {
        let decoded = match self {
            Self::Raw => payload.to_vec(),
            Self::Codec(codec) => codec
                .decode(
                    Cow::Borrowed(payload),
                    &BytesRepresentation::FixedSize(expected),
                    options,
                )?
                .into_owned(),
            Self::Lz4Blocks => decode_lz4_blocks(payload, expected)?,
        };
        if decoded.len() as u64 != expected {
            return Err(CodecError::Other(format!(
                "n5: the block's values decode to {} bytes, its header says {expected}",
                decoded.len()
            )));
        }
        Ok(decoded)
    }

    fn encode(&self, values: &[u8], options: &CodecOptions) -> Result<Vec<u8>, CodecError> {
        match self {
            Self::Raw => Ok(values.to_vec()),
            Self::Codec(codec) => Ok(codec.encode(Cow::Borrowed(values), options)?.into_owned()),
            Self::Lz4Blocks => Ok(encode_lz4_blocks(values)),
        }
    }
}

fn configuration<const N: usize>(entries: [(&str, Value); N]) -> Configuration {
    let map: Map<String, Value> = entries
        .into_iter()
        .map(|(name, value)| (name.to_owned(), value))
        .collect();
    Configuration::from(map)
}

/// The `voxscope.n5_block` codec: an N5 block's header, compression and byte order.
#[derive(Debug, Clone)]
pub struct N5BlockCodec {
    /// `{"compression": …}`: the dataset's `compression` attribute, written back as read.
    configuration: Map<String, Value>,
    compression: Compression,
}

zarrs::plugin::impl_extension_aliases!(N5BlockCodec, v3: "voxscope.n5_block", []);

inventory::submit! {
    CodecPluginV3::new::<N5BlockCodec>()
}

impl CodecTraitsV3 for N5BlockCodec {
    fn create(metadata: &MetadataV3) -> Result<Codec, PluginCreateError> {
        let compression_attribute = metadata
            .configuration()
            .and_then(|c| c.get("compression"))
            .and_then(Value::as_object)
            .cloned()
            .unwrap_or_default();
        let compression =
            Compression::of(&compression_attribute).map_err(PluginCreateError::Other)?;
        let configuration = Map::from_iter([(
            "compression".to_owned(),
            Value::Object(compression_attribute),
        )]);
        Ok(Codec::ArrayToBytes(Arc::new(Self {
            configuration,
            compression,
        })))
    }
}

super::super::adapted::whole_chunk_codec_traits!(N5BlockCodec);

/// The size of one value of `data_type` (N5 has fixed-size numeric types only).
fn value_size(data_type: &DataType) -> Result<usize, CodecError> {
    match data_type.size() {
        DataTypeSize::Fixed(size) => Ok(size),
        DataTypeSize::Variable => Err(CodecError::Other(
            "n5: variable-size values are not numeric".into(),
        )),
    }
}

/// Swaps big-endian values of `size` bytes to the machine's order, in place (and back).
fn swap_big_endian(values: &mut [u8], size: usize) {
    if cfg!(target_endian = "little") && size > 1 {
        for value in values.chunks_exact_mut(size) {
            value.reverse();
        }
    }
}

/// What a block's header says: its extent in C order (slowest first) and where its values
/// begin.
#[derive(Debug, PartialEq, Eq)]
struct Header {
    extent: Vec<u64>,
    payload_at: usize,
}

fn read_u16(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes(bytes.get(at..at + 2)?.try_into().ok()?))
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_be_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

/// Reads a block header, checking it against the chunk's `shape` (C order): as many
/// dimensions, none empty or beyond the block size, and in varlength mode an element count
/// that is the extent's.
fn read_header(bytes: &[u8], shape: &[NonZeroU64]) -> Result<Header, CodecError> {
    let short = || {
        CodecError::Other(format!(
            "n5: {} bytes cannot hold the block header",
            bytes.len()
        ))
    };
    let mode = read_u16(bytes, 0).ok_or_else(short)?;
    if mode == 2 {
        return Err(CodecError::Other(
            "n5: an object-mode block holds no array values".into(),
        ));
    }
    if mode > 2 {
        return Err(CodecError::Other(format!("n5: unknown block mode {mode}")));
    }
    let ndim = usize::from(read_u16(bytes, 2).ok_or_else(short)?);
    if ndim != shape.len() || ndim > MAX_DIMENSIONS {
        return Err(CodecError::Other(format!(
            "n5: the block header has {ndim} dimensions, the dataset {}",
            shape.len()
        )));
    }
    let mut extent = Vec::with_capacity(ndim);
    for d in 0..ndim {
        extent.push(u64::from(read_u32(bytes, 4 + 4 * d).ok_or_else(short)?));
    }
    extent.reverse();
    if let Some((d, _)) = extent
        .iter()
        .zip(shape)
        .enumerate()
        .find(|(_, (e, s))| **e == 0 || **e > s.get())
    {
        let shown: Vec<String> = extent.iter().rev().map(u64::to_string).collect();
        let block: Vec<String> = shape.iter().rev().map(|s| s.to_string()).collect();
        return Err(CodecError::Other(format!(
            "n5: the block header's extent {} (dimension {}) does not fit the block size {}",
            shown.join("x"),
            ndim - 1 - d,
            block.join("x")
        )));
    }
    let mut payload_at = 4 + 4 * ndim;
    if mode == 1 {
        let count = u64::from(read_u32(bytes, payload_at).ok_or_else(short)?);
        let elements: u64 = extent.iter().product();
        if count != elements {
            return Err(CodecError::Other(format!(
                "n5: a varlength block of {count} values in an extent of {elements}"
            )));
        }
        payload_at += 4;
    }
    Ok(Header { extent, payload_at })
}

/// Copies a block of `extent` (C order) into a chunk of `shape` filled with `fill`.
fn place_in_chunk(block: &[u8], extent: &[u64], shape: &[NonZeroU64], fill: &[u8]) -> Vec<u8> {
    let size = fill.len();
    let elements: u64 = shape.iter().map(|s| s.get()).product();
    let mut chunk = fill.repeat(elements as usize);
    let row = extent[extent.len() - 1] as usize * size;
    let rows = block.len() / row.max(1);
    let ndim = shape.len();
    for r in 0..rows {
        // The row's index along every dimension but the last, then its place in the chunk.
        let mut rest = r as u64;
        let mut offset = 0u64;
        let mut stride = shape[ndim - 1].get();
        for d in (0..ndim - 1).rev() {
            let index = rest % extent[d];
            rest /= extent[d];
            offset += index * stride;
            stride *= shape[d].get();
        }
        let at = offset as usize * size;
        chunk[at..at + row].copy_from_slice(&block[r * row..(r + 1) * row]);
    }
    chunk
}

impl ArrayToBytesCodecTraits for N5BlockCodec {
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
        bytes: ArrayBytes<'a>,
        shape: &[NonZeroU64],
        data_type: &DataType,
        _fill_value: &FillValue,
        options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        let size = value_size(data_type)?;
        let mut values = bytes.into_fixed()?.into_owned();
        swap_big_endian(&mut values, size);
        let mut block = Vec::with_capacity(4 + 4 * shape.len() + values.len());
        block.extend_from_slice(&0u16.to_be_bytes());
        block.extend_from_slice(&(shape.len() as u16).to_be_bytes());
        for extent in shape.iter().rev() {
            let extent = u32::try_from(extent.get())
                .map_err(|_| CodecError::Other("n5: a block extent above 2^32".into()))?;
            block.extend_from_slice(&extent.to_be_bytes());
        }
        block.extend_from_slice(&self.compression.encode(&values, options)?);
        Ok(Cow::Owned(block))
    }

    fn decode<'a>(
        &self,
        bytes: ArrayBytesRaw<'a>,
        shape: &[NonZeroU64],
        data_type: &DataType,
        fill_value: &FillValue,
        options: &CodecOptions,
    ) -> Result<ArrayBytes<'a>, CodecError> {
        let size = value_size(data_type)?;
        let header = read_header(&bytes, shape)?;
        let elements: u64 = header.extent.iter().product();
        let mut values = self.compression.decode(
            &bytes[header.payload_at..],
            elements * size as u64,
            options,
        )?;
        swap_big_endian(&mut values, size);
        let whole = header.extent.iter().zip(shape).all(|(&e, s)| e == s.get());
        let values = if whole {
            values
        } else {
            place_in_chunk(&values, &header.extent, shape, fill_value.as_ne_bytes())
        };
        Ok(ArrayBytes::new_flen(values))
    }
}

/// lz4-java's LZ4Block framing: blocks of `LZ4Block`, a token (method in the high nibble:
/// 0x10 stored, 0x20 LZ4), compressed and decoded lengths and an xxhash32 checksum (all
/// little-endian 32-bit), then the block's bytes; an empty block ends the stream. The
/// checksum is not verified (a damaged block fails LZ4's own checks or the size checks).
fn decode_lz4_blocks(stream: &[u8], expected: u64) -> Result<Vec<u8>, CodecError> {
    const MAGIC: &[u8; 8] = b"LZ4Block";
    const HEADER: usize = 8 + 1 + 12;
    let fail = |what: String| CodecError::Other(format!("n5 lz4: {what}"));
    let mut decoded = Vec::new();
    let mut at = 0;
    loop {
        let header = stream.get(at..at + HEADER).ok_or_else(|| {
            fail(format!(
                "the stream ends inside a block header at byte {at}"
            ))
        })?;
        if &header[..8] != MAGIC {
            return Err(fail(format!("no LZ4Block magic at byte {at}")));
        }
        let method = header[8] & 0xF0;
        let word = |i: usize| {
            u32::from_le_bytes(header[9 + 4 * i..13 + 4 * i].try_into().unwrap_or_default())
        };
        let (compressed, length) = (word(0) as usize, word(1) as u64);
        at += HEADER;
        if length == 0 {
            break;
        }
        if decoded.len() as u64 + length > expected {
            return Err(fail(format!(
                "the blocks decode to more than the {expected} bytes the block holds"
            )));
        }
        let body = stream
            .get(at..at.saturating_add(compressed))
            .ok_or_else(|| fail(format!("a block of {compressed} bytes is cut short")))?;
        let start = decoded.len();
        decoded.resize(start + length as usize, 0);
        match method {
            0x10 if compressed as u64 == length => decoded[start..].copy_from_slice(body),
            0x20 => {
                let written = lz4_flex::block::decompress_into(body, &mut decoded[start..])
                    .map_err(|e| fail(e.to_string()))?;
                if written as u64 != length {
                    return Err(fail(format!(
                        "a block decodes to {written} bytes, its header says {length}"
                    )));
                }
            }
            _ => return Err(fail(format!("unknown block method {method:#x}"))),
        }
        at += compressed;
    }
    Ok(decoded)
}

/// Writes `values` in lz4-java's LZ4Block framing (one LZ4 block of at most 64 KiB each,
/// checksum 0: lz4-java's reader checks it, and a reader of voxscope's fixtures is voxscope).
fn encode_lz4_blocks(values: &[u8]) -> Vec<u8> {
    let mut stream = Vec::new();
    let header = |stream: &mut Vec<u8>, method: u8, compressed: usize, length: usize| {
        stream.extend_from_slice(b"LZ4Block");
        stream.push(method);
        stream.extend_from_slice(&(compressed as u32).to_le_bytes());
        stream.extend_from_slice(&(length as u32).to_le_bytes());
        stream.extend_from_slice(&0u32.to_le_bytes());
    };
    for piece in values.chunks(1 << 16) {
        let compressed = lz4_flex::block::compress(piece);
        header(&mut stream, 0x20, compressed.len(), piece.len());
        stream.extend_from_slice(&compressed);
    }
    header(&mut stream, 0x10, 0, 0);
    stream
}

/// The `voxscope.n5_keys` chunk key encoding: N5's block paths, the fastest dimension first
/// (`x/y/z`), of a Zarr array whose dimensions are N5's reversed.
#[derive(Debug, Clone)]
pub struct N5KeyEncoding;

zarrs::plugin::impl_extension_aliases!(N5KeyEncoding, v3: "voxscope.n5_keys");

inventory::submit! {
    ChunkKeyEncodingPlugin::new::<N5KeyEncoding>()
}

impl ChunkKeyEncodingTraits for N5KeyEncoding {
    fn create(_metadata: &MetadataV3) -> Result<ChunkKeyEncoding, PluginCreateError> {
        Ok(N5KeyEncoding.into())
    }

    fn configuration(&self) -> Configuration {
        Configuration::default()
    }

    fn encode(&self, chunk_grid_indices: &[u64]) -> StoreKey {
        let path: Vec<String> = chunk_grid_indices
            .iter()
            .rev()
            .map(u64::to_string)
            .collect();
        // Decimal numbers joined by '/' are always a valid key.
        StoreKey::new(path.join("/")).unwrap_or_else(|_| StoreKey::new("0").expect("valid key"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape(dims: &[u64]) -> Vec<NonZeroU64> {
        dims.iter().map(|&d| NonZeroU64::new(d).unwrap()).collect()
    }

    #[test]
    fn an_edge_block_is_placed_in_a_chunk_of_fill_values() {
        // A 2x3 block (C order: 2 rows of 3) in a 3x4 chunk of fill 9.
        let block = [1u8, 2, 3, 4, 5, 6];
        let chunk = place_in_chunk(&block, &[2, 3], &shape(&[3, 4]), &[9]);
        assert_eq!(chunk, [1, 2, 3, 9, 4, 5, 6, 9, 9, 9, 9, 9]);
    }

    #[test]
    fn headers_beyond_the_block_size_or_short_are_refused() {
        let mut bytes = vec![0, 0, 0, 2];
        bytes.extend_from_slice(&5u32.to_be_bytes());
        bytes.extend_from_slice(&3u32.to_be_bytes());
        let header = read_header(&bytes, &shape(&[4, 8])).unwrap();
        assert_eq!(header.extent, [3, 5]);
        assert_eq!(header.payload_at, 12);
        let error = read_header(&bytes, &shape(&[2, 8]))
            .unwrap_err()
            .to_string();
        assert!(error.contains("does not fit the block size 8x2"), "{error}");
        assert!(read_header(&bytes[..6], &shape(&[4, 8])).is_err());
        let error = read_header(&bytes, &shape(&[4, 8, 1]))
            .unwrap_err()
            .to_string();
        assert!(error.contains("2 dimensions"), "{error}");
    }

    #[test]
    fn lz4_blocks_round_trip_and_are_bounded() {
        let values: Vec<u8> = (0..200_000u32).map(|i| (i % 251) as u8).collect();
        let stream = encode_lz4_blocks(&values);
        assert_eq!(
            decode_lz4_blocks(&stream, values.len() as u64).unwrap(),
            values
        );
        let error = decode_lz4_blocks(&stream, 1000).unwrap_err().to_string();
        assert!(error.contains("more than the 1000 bytes"), "{error}");
        assert!(decode_lz4_blocks(&stream[..30], values.len() as u64).is_err());
    }

    #[test]
    fn keys_are_n5_block_paths() {
        let key = N5KeyEncoding.encode(&[4, 5, 6]);
        assert_eq!(key.as_str(), "6/5/4");
    }
}
