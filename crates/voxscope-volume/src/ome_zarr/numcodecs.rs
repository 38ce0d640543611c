//! numcodecs' `lz4` and `lzma` compressors, which zarrs does not have, as zarrs codec plugins
//! (Zarr v2 ids `lz4` and `lzma`, Zarr v3 names `numcodecs.lz4` and `numcodecs.lzma`, the
//! names zarr-python 3 writes).
//!
//! They are registered at compile time with `inventory`, the way zarrs registers its own
//! codecs: zarrs converts a Zarr v2 array's metadata to its v3 form through those plugins only,
//! so a runtime plugin (as in [`super::guard`]) would never see a v2 array.
//!
//! Decoding is bounded by the size the codec chain expects, like [`super::guard`]'s: an LZ4
//! chunk's declared size is checked before its buffer exists, and an LZMA stream's LZMA2
//! chunks (each declares its decoded size) are summed before any is decoded. lzma-rs grows its
//! dictionary with the data it has decoded, never to the size a header declares.
//!
//! Encoding writes what numcodecs reads (voxscope's `convert` never chooses these, but a
//! codec that decodes should encode, and the tests round-trip through it).

use std::any::Any;
use std::borrow::Cow;
use std::io::{self, Write};
use std::sync::Arc;

use serde_json::{Map, Value};
use zarrs::array::codec::api::{CodecPluginV2, CodecPluginV3};
use zarrs::array::codec::api::{PartialDecoderCapability, PartialEncoderCapability};
use zarrs::array::{
    ArrayBytesRaw, BytesRepresentation, BytesToBytesCodecTraits, Codec, CodecError,
    CodecMetadataOptions, CodecOptions, CodecTraits, CodecTraitsV2, CodecTraitsV3,
    RecommendedConcurrency,
};
use zarrs::metadata::Configuration;
use zarrs::metadata::v2::MetadataV2;
use zarrs::metadata::v3::MetadataV3;
use zarrs::plugin::{PluginCreateError, ZarrVersion};

/// The plugin boilerplate of a numcodecs compressor `$codec` (a struct holding its JSON
/// `configuration`): its Zarr v3 and v2 names, its registration, its creation from either
/// version's metadata and the codec traits every such compressor shares (its configuration
/// written back as read; no partial decoding or encoding).
macro_rules! numcodecs_plugin {
    ($codec:ident, v3: $v3:literal, v2: $v2:literal) => {
        zarrs::plugin::impl_extension_aliases!($codec,
            v3: $v3, [],
            v2: $v2, []
        );

        inventory::submit! {
            CodecPluginV3::new::<$codec>()
        }

        inventory::submit! {
            CodecPluginV2::new::<$codec>()
        }

        impl CodecTraitsV3 for $codec {
            fn create(metadata: &MetadataV3) -> Result<Codec, PluginCreateError> {
                let configuration = metadata.configuration().cloned().unwrap_or_default().into();
                Ok(Codec::BytesToBytes(Arc::new(Self { configuration })))
            }
        }

        impl CodecTraitsV2 for $codec {
            fn create(metadata: &MetadataV2) -> Result<Codec, PluginCreateError> {
                let configuration = metadata.configuration().clone().into();
                Ok(Codec::BytesToBytes(Arc::new(Self { configuration })))
            }
        }

        impl CodecTraits for $codec {
            fn as_any(&self) -> &dyn Any {
                self
            }

            fn configuration(
                &self,
                _version: ZarrVersion,
                _options: &CodecMetadataOptions,
            ) -> Option<Configuration> {
                Some(self.configuration.clone().into())
            }

            fn partial_decoder_capability(&self) -> PartialDecoderCapability {
                PartialDecoderCapability {
                    partial_read: false,
                    partial_decode: false,
                }
            }

            fn partial_encoder_capability(&self) -> PartialEncoderCapability {
                PartialEncoderCapability {
                    partial_encode: false,
                }
            }
        }
    };
}

/// numcodecs' LZ4: the decoded size as a 4-byte little-endian integer, then one LZ4 block.
#[derive(Debug, Clone)]
pub struct Lz4Codec {
    configuration: Map<String, Value>,
}

numcodecs_plugin!(Lz4Codec, v3: "numcodecs.lz4", v2: "lz4");

impl BytesToBytesCodecTraits for Lz4Codec {
    fn into_dyn(self: Arc<Self>) -> Arc<dyn BytesToBytesCodecTraits> {
        self
    }

    fn recommended_concurrency(
        &self,
        _decoded_representation: &BytesRepresentation,
    ) -> Result<RecommendedConcurrency, CodecError> {
        Ok(RecommendedConcurrency::new_maximum(1))
    }

    fn encoded_representation(
        &self,
        decoded_representation: &BytesRepresentation,
    ) -> BytesRepresentation {
        decoded_representation
            .size()
            .map_or(BytesRepresentation::UnboundedSize, |size| {
                // LZ4's worst case (size + size / 255 + 16) and the 4-byte size.
                BytesRepresentation::BoundedSize(size + size / 255 + 20)
            })
    }

    fn encode<'a>(
        &self,
        decoded_value: ArrayBytesRaw<'a>,
        _options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        let size = u32::try_from(decoded_value.len()).map_err(|_| {
            CodecError::Other(format!(
                "lz4: {} bytes do not fit numcodecs' 4-byte size",
                decoded_value.len()
            ))
        })?;
        let mut encoded = size.to_le_bytes().to_vec();
        encoded.extend_from_slice(&lz4_flex::block::compress(&decoded_value));
        Ok(Cow::Owned(encoded))
    }

    fn decode<'a>(
        &self,
        encoded_value: ArrayBytesRaw<'a>,
        decoded_representation: &BytesRepresentation,
        _options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        decode_lz4(&encoded_value, decoded_representation.size()).map(Cow::Owned)
    }
}

/// Decodes numcodecs' LZ4 framing, refusing a declared size above `expected` before the
/// output buffer exists.
fn decode_lz4(encoded: &[u8], expected: Option<u64>) -> Result<Vec<u8>, CodecError> {
    let Some((size, block)) = encoded.split_first_chunk::<4>() else {
        return Err(CodecError::Other(format!(
            "lz4: {} bytes cannot hold the 4-byte size",
            encoded.len()
        )));
    };
    let declared = u64::from(u32::from_le_bytes(*size));
    // Variable-length data (which voxscope never reads) has no expected size to check the
    // declared one against: refused rather than trusted.
    let expected = expected.ok_or_else(|| {
        CodecError::Other("lz4: variable-length data has no size to bound the chunk".into())
    })?;
    if declared > expected {
        return Err(CodecError::Other(format!(
            "lz4: the chunk declares {declared} decoded bytes, it holds {expected}"
        )));
    }
    let mut decoded = vec![0; declared as usize];
    let written = lz4_flex::block::decompress_into(block, &mut decoded)
        .map_err(|e| CodecError::Other(format!("lz4: {e}")))?;
    if written != decoded.len() {
        return Err(CodecError::Other(format!(
            "lz4: the block decodes to {written} bytes, its header says {declared}"
        )));
    }
    Ok(decoded)
}

/// numcodecs' LZMA, as Python's `lzma` module writes it: format 1 (xz, the default), 2 (the
/// legacy `.lzma` "alone" format), or 3 (raw, with the filter chain in the configuration;
/// only a chain of one LZMA2 filter is read). Format 0 (auto) reads xz or alone.
#[derive(Debug, Clone)]
pub struct LzmaCodec {
    configuration: Map<String, Value>,
}

numcodecs_plugin!(LzmaCodec, v3: "numcodecs.lzma", v2: "lzma");

/// Python's `lzma.FORMAT_RAW`.
const FORMAT_RAW: i64 = 3;
/// Python's `lzma.FILTER_LZMA2`.
const FILTER_LZMA2: i64 = 0x21;
/// The magic bytes that open an xz stream.
const XZ_MAGIC: [u8; 6] = [0xFD, b'7', b'z', b'X', b'Z', 0];

impl LzmaCodec {
    fn format(&self) -> i64 {
        self.configuration
            .get("format")
            .and_then(Value::as_i64)
            .unwrap_or(1)
    }

    /// Whether a raw stream's filter chain is the one LZMA2 filter that lzma-rs reads.
    fn raw_is_lzma2(&self) -> bool {
        match self.configuration.get("filters").and_then(Value::as_array) {
            Some(filters) => {
                filters.len() == 1
                    && filters[0].get("id").and_then(Value::as_i64) == Some(FILTER_LZMA2)
            }
            None => false,
        }
    }
}

impl BytesToBytesCodecTraits for LzmaCodec {
    fn into_dyn(self: Arc<Self>) -> Arc<dyn BytesToBytesCodecTraits> {
        self
    }

    fn recommended_concurrency(
        &self,
        _decoded_representation: &BytesRepresentation,
    ) -> Result<RecommendedConcurrency, CodecError> {
        Ok(RecommendedConcurrency::new_maximum(1))
    }

    fn encoded_representation(
        &self,
        _decoded_representation: &BytesRepresentation,
    ) -> BytesRepresentation {
        BytesRepresentation::UnboundedSize
    }

    fn encode<'a>(
        &self,
        decoded_value: ArrayBytesRaw<'a>,
        _options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        let mut encoded = Vec::new();
        let mut input = &decoded_value[..];
        match self.format() {
            0 | 1 => lzma_rs::xz_compress(&mut input, &mut encoded)?,
            2 => lzma_rs::lzma_compress(&mut input, &mut encoded)?,
            _ if self.raw_is_lzma2() => lzma_rs::lzma2_compress(&mut input, &mut encoded)?,
            format => {
                return Err(CodecError::Other(format!(
                    "lzma: format {format} with these filters is not written"
                )));
            }
        }
        Ok(Cow::Owned(encoded))
    }

    fn decode<'a>(
        &self,
        encoded_value: ArrayBytesRaw<'a>,
        decoded_representation: &BytesRepresentation,
        _options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        let expected = decoded_representation.size().ok_or_else(|| {
            CodecError::Other("lzma: variable-length data has no size to bound the chunk".into())
        })?;
        let encoded = &encoded_value[..];
        let decoded = if encoded.starts_with(&XZ_MAGIC) {
            check_xz(encoded, expected)?;
            decode_with(encoded, expected, |input, output| {
                lzma_rs::xz_decompress(input, output)
            })?
        } else if self.format() == FORMAT_RAW {
            if !self.raw_is_lzma2() {
                return Err(CodecError::Other(format!(
                    "lzma: a raw stream with filters other than one LZMA2 filter is not \
                     supported (filters {})",
                    self.configuration.get("filters").unwrap_or(&Value::Null)
                )));
            }
            let declared = lzma2_decoded_size(encoded, 0)?.0;
            check_declared(declared, expected)?;
            decode_with(encoded, expected, |input, output| {
                lzma_rs::lzma2_decompress(input, output)
            })?
        } else {
            // The alone format: 13 header bytes, the last 8 the decoded size (or all ones
            // when the stream ends with a marker instead).
            let Some(size) = encoded.get(5..13) else {
                return Err(CodecError::Other(format!(
                    "lzma: {} bytes cannot hold the 13-byte header",
                    encoded.len()
                )));
            };
            let declared = u64::from_le_bytes(size.try_into().expect("8 bytes"));
            if declared != u64::MAX {
                check_declared(declared, expected)?;
            }
            let options = lzma_rs::decompress::Options {
                // The dictionary never needs to be larger than what the chunk decodes to.
                memlimit: Some(usize::try_from(expected).unwrap_or(usize::MAX)),
                ..Default::default()
            };
            decode_with(encoded, expected, |input, output| {
                lzma_rs::lzma_decompress_with_options(input, output, &options)
            })?
        };
        Ok(Cow::Owned(decoded))
    }
}

fn check_declared(declared: u64, expected: u64) -> Result<(), CodecError> {
    if declared > expected {
        return Err(CodecError::Other(format!(
            "lzma: the stream declares {declared} decoded bytes, the chunk holds {expected}"
        )));
    }
    Ok(())
}

/// Runs an lzma-rs decoder on `encoded` into a buffer that refuses more than `expected` bytes.
fn decode_with(
    encoded: &[u8],
    expected: u64,
    decode: impl FnOnce(&mut &[u8], &mut BoundedWriter) -> Result<(), lzma_rs::error::Error>,
) -> Result<Vec<u8>, CodecError> {
    let mut output = BoundedWriter {
        data: Vec::new(),
        limit: expected,
    };
    let mut input = encoded;
    decode(&mut input, &mut output).map_err(|e| CodecError::Other(format!("lzma: {e}")))?;
    Ok(output.data)
}

/// A `Vec` that refuses to grow past `limit` bytes.
struct BoundedWriter {
    data: Vec<u8>,
    limit: u64,
}

impl Write for BoundedWriter {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        if (self.data.len() + bytes.len()) as u64 > self.limit {
            return Err(io::Error::other(format!(
                "the stream holds more than the chunk's {} bytes",
                self.limit
            )));
        }
        self.data.extend_from_slice(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// The decoded size of the LZMA2 chunks starting at `at`, and where they end (after the end
/// marker). Each chunk declares its decoded size in its header: 0x00 ends the stream; 0x01
/// and 0x02 are stored chunks (a 2-byte size minus one, then the bytes); 0x80 and above are
/// LZMA chunks (the decoded size's high 5 bits in the control byte, 2 more bytes of it, a
/// 2-byte compressed size, each minus one, and a properties byte from 0xC0 on).
fn lzma2_decoded_size(stream: &[u8], mut at: usize) -> Result<(u64, usize), CodecError> {
    let damaged = || CodecError::Other("lzma: the LZMA2 chunks end before their end marker".into());
    let byte = |at: usize| stream.get(at).copied().ok_or_else(damaged);
    let mut decoded = 0u64;
    loop {
        let control = byte(at)?;
        let (unpacked, packed, header) = match control {
            0x00 => return Ok((decoded, at + 1)),
            0x01 | 0x02 => {
                let size = u64::from(u16::from_be_bytes([byte(at + 1)?, byte(at + 2)?])) + 1;
                (size, size, 3)
            }
            0x80..=0xFF => {
                let unpacked = (u64::from(control & 0x1F) << 16)
                    + u64::from(u16::from_be_bytes([byte(at + 1)?, byte(at + 2)?]))
                    + 1;
                let packed = u64::from(u16::from_be_bytes([byte(at + 3)?, byte(at + 4)?])) + 1;
                (unpacked, packed, if control >= 0xC0 { 6 } else { 5 })
            }
            other => {
                return Err(CodecError::Other(format!(
                    "lzma: LZMA2 control byte {other:#04x} is not valid"
                )));
            }
        };
        decoded += unpacked;
        at = at
            .checked_add(header + packed as usize)
            .filter(|end| *end <= stream.len())
            .ok_or_else(damaged)?;
    }
}

/// Checks an xz stream's blocks (each a header, LZMA2 chunks, padding and a check) before any
/// is decoded: their filters must be one LZMA2 filter (what lzma-rs reads) and their chunks
/// must declare at most `expected` decoded bytes in all.
fn check_xz(stream: &[u8], expected: u64) -> Result<(), CodecError> {
    let damaged =
        |what: &str| CodecError::Other(format!("lzma: the xz stream's {what} is damaged"));
    let flags = stream.get(7).copied().ok_or_else(|| damaged("header"))?;
    // The check's size by its type (xz's file format, 2.1.1.2): none, CRC32, CRC64, SHA-256
    // and the reserved types in between.
    let check_size = match flags & 0x0F {
        0 => 0,
        kind => 4usize << ((kind - 1) / 3),
    };
    let mut at = 12;
    let mut decoded = 0u64;
    loop {
        let size_byte = stream
            .get(at)
            .copied()
            .ok_or_else(|| damaged("block list"))?;
        if size_byte == 0 {
            // The index: every block has been seen.
            return check_declared(decoded, expected);
        }
        let header_size = (usize::from(size_byte) + 1) * 4;
        let header = stream
            .get(at..at + header_size)
            .ok_or_else(|| damaged("block header"))?;
        let block_flags = header[1];
        if block_flags & 0x03 != 0 {
            return Err(CodecError::Other(
                "lzma: an xz block with filters other than one LZMA2 filter is not supported"
                    .into(),
            ));
        }
        let (chunks, end) = lzma2_decoded_size(stream, at + header_size)?;
        decoded += chunks;
        check_declared(decoded, expected)?;
        // Padding to a multiple of four, then the check.
        let padded = end.div_ceil(4) * 4;
        at = padded + check_size;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lzma(format: i64, filters: Value) -> LzmaCodec {
        let mut configuration = Map::new();
        configuration.insert("format".into(), format.into());
        configuration.insert("filters".into(), filters);
        LzmaCodec { configuration }
    }

    fn varied(len: usize) -> Vec<u8> {
        (0..len as u32).map(|i| (i * 7 % 251) as u8).collect()
    }

    #[test]
    fn lz4_round_trips_and_refuses_a_size_above_the_chunk() {
        let codec = Lz4Codec {
            configuration: Map::new(),
        };
        let data = varied(1000);
        let options = CodecOptions::default();
        let encoded = codec.encode(Cow::Borrowed(&data), &options).unwrap();
        let fixed = BytesRepresentation::FixedSize(1000);
        let decoded = codec.decode(encoded.clone(), &fixed, &options).unwrap();
        assert_eq!(decoded.as_ref(), &data[..]);

        // A header that claims 4 GiB is refused before anything of that size exists.
        let mut claims = encoded.to_vec();
        claims[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        let error = codec
            .decode(Cow::Owned(claims), &fixed, &options)
            .unwrap_err();
        assert!(error.to_string().contains("declares 4294967295"), "{error}");
        // A header that claims less than the block holds is an error, never a short chunk.
        let mut short = encoded.to_vec();
        short[..4].copy_from_slice(&999u32.to_le_bytes());
        assert!(codec.decode(Cow::Owned(short), &fixed, &options).is_err());
        assert!(
            codec
                .decode(Cow::Owned(vec![1, 2]), &fixed, &options)
                .is_err()
        );
    }

    #[test]
    fn lzma_formats_round_trip_and_refuse_more_than_the_chunk() {
        let data = varied(5000);
        let options = CodecOptions::default();
        let lzma2 = serde_json::json!([{"id": FILTER_LZMA2}]);
        for codec in [
            lzma(1, Value::Null),
            lzma(2, Value::Null),
            lzma(FORMAT_RAW, lzma2),
        ] {
            let encoded = codec.encode(Cow::Borrowed(&data), &options).unwrap();
            let fixed = BytesRepresentation::FixedSize(5000);
            let decoded = codec.decode(encoded.clone(), &fixed, &options).unwrap();
            assert_eq!(decoded.as_ref(), &data[..], "format {}", codec.format());
            let smaller = BytesRepresentation::FixedSize(4999);
            let error = codec.decode(encoded, &smaller, &options).unwrap_err();
            assert!(
                error.to_string().contains("4999"),
                "format {}: {error}",
                codec.format()
            );
        }
        let delta = lzma(
            FORMAT_RAW,
            serde_json::json!([{"id": 3}, {"id": FILTER_LZMA2}]),
        );
        let error = delta
            .decode(
                Cow::Owned(vec![0]),
                &BytesRepresentation::FixedSize(10),
                &options,
            )
            .unwrap_err();
        assert!(
            error.to_string().contains("other than one LZMA2"),
            "{error}"
        );
    }

    #[test]
    fn damaged_lzma_streams_are_errors_never_panics() {
        let data = varied(3000);
        let options = CodecOptions::default();
        let fixed = BytesRepresentation::FixedSize(3000);
        for codec in [lzma(1, Value::Null), lzma(2, Value::Null)] {
            let encoded = codec.encode(Cow::Borrowed(&data), &options).unwrap();
            for cut in [0, 5, 12, 13, encoded.len() / 2, encoded.len() - 1] {
                let cut = encoded[..cut].to_vec();
                let _ = codec.decode(Cow::Owned(cut), &fixed, &options);
            }
            for at in 0..encoded.len() {
                let mut flipped = encoded.to_vec();
                flipped[at] ^= 0x41;
                if let Ok(decoded) = codec.decode(Cow::Owned(flipped), &fixed, &options) {
                    assert!(decoded.len() <= 3000);
                }
            }
        }
    }
}
