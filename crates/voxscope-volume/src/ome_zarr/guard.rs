//! Compressed chunks decode into no more bytes than their chunk holds.
//!
//! zarrs trusts what a compressed stream says about itself: its zstd codec reserves a frame's
//! declared content size (a 20-byte frame can declare petabytes, and the reservation aborts
//! the process), its gzip codec reads to the end of the stream however far that is, and blosc
//! reserves the header's size (up to 2 GiB) before checking it. Each decoder here wraps zarrs's
//! own codec and bounds the output by the size the codec chain expects at that stage (the
//! chunk's voxels times their size, for numeric data), so a hostile or damaged chunk costs no
//! more memory than a good one and fails with a message that says what it claimed.
//!
//! zarrs's zlib and bz2 codecs read to the end of the stream too. numcodecs' lz4 and lzma,
//! which zarrs lacks, are [`super::numcodecs`]'s, bounded the same way.
//!
//! The wrappers are registered once, as zarrs runtime codec plugins under the same names
//! (`blosc`, `zstd`, `gzip`, `zlib`, `bz2` for Zarr v2; the same and `numcodecs.zlib`,
//! `numcodecs.bz2` for Zarr v3); runtime plugins take precedence over the
//! built-in ones, so every array zarrs opens afterwards, inner chunks of shards included, gets
//! them. Encoding is zarrs's own, unchanged.

use std::any::Any;
use std::borrow::Cow;
use std::io::Read;
use std::sync::{Arc, Once};

use zarrs::array::codec::api::{
    CodecRuntimePluginV2, CodecRuntimePluginV3, PartialDecoderCapability, PartialEncoderCapability,
    register_codec_v2, register_codec_v3,
};
use zarrs::array::codec::{BloscCodec, Bz2Codec, GzipCodec, ZlibCodec, ZstdCodec};
use zarrs::array::{
    ArrayBytesRaw, BytesRepresentation, BytesToBytesCodecTraits, Codec, CodecError,
    CodecMetadataOptions, CodecOptions, CodecTraits, CodecTraitsV2, CodecTraitsV3,
    RecommendedConcurrency,
};
use zarrs::metadata::Configuration;
use zarrs::metadata::v2::MetadataV2;
use zarrs::metadata::v3::MetadataV3;
use zarrs::plugin::{ExtensionName, PluginCreateError, ZarrVersion};

/// The compressors whose decoding is bounded here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Compressor {
    Blosc,
    Zstd,
    Gzip,
    Zlib,
    Bz2,
}

impl Compressor {
    const ALL: [Self; 5] = [Self::Blosc, Self::Zstd, Self::Gzip, Self::Zlib, Self::Bz2];

    fn name(self) -> &'static str {
        match self {
            Self::Blosc => "blosc",
            Self::Zstd => "zstd",
            Self::Gzip => "gzip",
            Self::Zlib => "zlib",
            Self::Bz2 => "bz2",
        }
    }

    /// Whether `name` names this compressor in Zarr v3 metadata: zarrs's name, or numcodecs'
    /// (`numcodecs.zlib`, as zarr-python 3 writes it, and as zarrs names a v2 array's codecs).
    fn matches_v3(self, name: &str) -> bool {
        name == self.name() || name.strip_prefix("numcodecs.") == Some(self.name())
    }

    /// zarrs's own codec for Zarr v3 metadata. Under a `numcodecs.` name zarr-python 3 writes
    /// numcodecs' own settings, which for some codecs are not zarrs's v3 ones (`zstd` without
    /// `checksum`, `blosc` with a numeric `shuffle`): those are read as the codec's v2 settings.
    fn create_v3(self, metadata: &MetadataV3) -> Result<Codec, PluginCreateError> {
        let created = match self {
            Self::Blosc => <BloscCodec as CodecTraitsV3>::create(metadata),
            Self::Zstd => <ZstdCodec as CodecTraitsV3>::create(metadata),
            Self::Gzip => <GzipCodec as CodecTraitsV3>::create(metadata),
            Self::Zlib => <ZlibCodec as CodecTraitsV3>::create(metadata),
            Self::Bz2 => <Bz2Codec as CodecTraitsV3>::create(metadata),
        };
        match created {
            Err(error) if metadata.name().starts_with("numcodecs.") => {
                let mut settings = match metadata.configuration().map(serde_json::to_value) {
                    Some(Ok(serde_json::Value::Object(settings))) => settings,
                    _ => serde_json::Map::new(),
                };
                if self == Self::Blosc {
                    // zarrs makes v2's blosc only with the array's data type: as v3 settings
                    // instead, the shuffle named. A frame's header holds its type size, so the
                    // decoder needs none (1 stands in).
                    let shuffle = match settings.get("shuffle").and_then(serde_json::Value::as_u64)
                    {
                        Some(0) => "noshuffle",
                        Some(2) => "bitshuffle",
                        _ => "shuffle",
                    };
                    settings.insert("shuffle".to_owned(), shuffle.into());
                    settings.insert("typesize".to_owned(), 1.into());
                    settings.entry("blocksize").or_insert(0.into());
                    let v3 =
                        MetadataV3::new_with_configuration("blosc", Configuration::from(settings));
                    return <BloscCodec as CodecTraitsV3>::create(&v3).map_err(|_| error);
                }
                settings.insert("id".to_owned(), self.name().into());
                serde_json::from_value::<MetadataV2>(serde_json::Value::Object(settings))
                    .ok()
                    .and_then(|v2| self.create_v2(&v2).ok())
                    .ok_or(error)
            }
            created => created,
        }
    }

    /// zarrs's own codec for Zarr v2 metadata (numcodecs' `id`).
    fn create_v2(self, metadata: &MetadataV2) -> Result<Codec, PluginCreateError> {
        match self {
            Self::Blosc => <BloscCodec as CodecTraitsV2>::create(metadata),
            Self::Zstd => <ZstdCodec as CodecTraitsV2>::create(metadata),
            Self::Gzip => <GzipCodec as CodecTraitsV2>::create(metadata),
            Self::Zlib => <ZlibCodec as CodecTraitsV2>::create(metadata),
            Self::Bz2 => <Bz2Codec as CodecTraitsV2>::create(metadata),
        }
    }
}

/// Registers the bounded decoders (once per process; later calls do nothing).
pub(crate) fn register() {
    static REGISTERED: Once = Once::new();
    REGISTERED.call_once(|| {
        for compressor in Compressor::ALL {
            // The handles would unregister the plugins; they stay for the process's life.
            let _ = register_codec_v3(CodecRuntimePluginV3::new(
                move |name| compressor.matches_v3(name),
                move |metadata| wrap(compressor, compressor.create_v3(metadata)?),
            ));
            let _ = register_codec_v2(CodecRuntimePluginV2::new(
                move |name| name == compressor.name(),
                move |metadata| wrap(compressor, compressor.create_v2(metadata)?),
            ));
        }
    });
}

fn wrap(compressor: Compressor, codec: Codec) -> Result<Codec, PluginCreateError> {
    match codec {
        Codec::BytesToBytes(inner) => Ok(Codec::BytesToBytes(Arc::new(BoundedDecoder {
            compressor,
            inner,
        }))),
        _ => Err(PluginCreateError::Other(format!(
            "{} is not a bytes-to-bytes codec",
            compressor.name()
        ))),
    }
}

/// zarrs's codec for `compressor`, with decoding bounded by the expected size.
#[derive(Debug)]
struct BoundedDecoder {
    compressor: Compressor,
    inner: Arc<dyn BytesToBytesCodecTraits>,
}

impl ExtensionName for BoundedDecoder {
    fn name(&self, version: ZarrVersion) -> Option<Cow<'static, str>> {
        self.inner.name(version)
    }
}

impl CodecTraits for BoundedDecoder {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn configuration(
        &self,
        version: ZarrVersion,
        options: &CodecMetadataOptions,
    ) -> Option<Configuration> {
        self.inner.configuration(version, options)
    }

    fn partial_decoder_capability(&self) -> PartialDecoderCapability {
        // Partial reads go through this type's `decode` (the trait's default partial
        // decoder), so the bound holds there too.
        PartialDecoderCapability {
            partial_read: false,
            partial_decode: false,
        }
    }

    fn partial_encoder_capability(&self) -> PartialEncoderCapability {
        self.inner.partial_encoder_capability()
    }
}

impl BytesToBytesCodecTraits for BoundedDecoder {
    fn into_dyn(self: Arc<Self>) -> Arc<dyn BytesToBytesCodecTraits> {
        self
    }

    fn recommended_concurrency(
        &self,
        decoded_representation: &BytesRepresentation,
    ) -> Result<RecommendedConcurrency, CodecError> {
        self.inner.recommended_concurrency(decoded_representation)
    }

    fn encoded_representation(
        &self,
        decoded_representation: &BytesRepresentation,
    ) -> BytesRepresentation {
        self.inner.encoded_representation(decoded_representation)
    }

    fn encode<'a>(
        &self,
        decoded_value: ArrayBytesRaw<'a>,
        options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        self.inner.encode(decoded_value, options)
    }

    fn decode<'a>(
        &self,
        encoded_value: ArrayBytesRaw<'a>,
        decoded_representation: &BytesRepresentation,
        options: &CodecOptions,
    ) -> Result<ArrayBytesRaw<'a>, CodecError> {
        let expected = match decoded_representation {
            BytesRepresentation::FixedSize(size) | BytesRepresentation::BoundedSize(size) => *size,
            // Variable-length data (strings) has no bound to check; voxscope reads none.
            BytesRepresentation::UnboundedSize => {
                return self
                    .inner
                    .decode(encoded_value, decoded_representation, options);
            }
        };
        match self.compressor {
            Compressor::Blosc => {
                check_blosc_header(&encoded_value, expected)?;
                self.inner
                    .decode(encoded_value, decoded_representation, options)
            }
            Compressor::Zstd => decompress_zstd(&encoded_value, expected).map(Cow::Owned),
            Compressor::Gzip => {
                let decoder = flate2::read::GzDecoder::new(&encoded_value[..]);
                read_bounded(decoder, expected, "gzip").map(Cow::Owned)
            }
            Compressor::Zlib => {
                let decoder = flate2::read::ZlibDecoder::new(&encoded_value[..]);
                read_bounded(decoder, expected, "zlib").map(Cow::Owned)
            }
            Compressor::Bz2 => {
                let decoder = bzip2::read::BzDecoder::new(&encoded_value[..]);
                read_bounded(decoder, expected, "bz2").map(Cow::Owned)
            }
        }
    }
}

/// A blosc header (16 bytes: version, format version, flags, type size, then the decoded,
/// block and compressed sizes as little-endian u32) must declare at most `expected` bytes.
fn check_blosc_header(encoded: &[u8], expected: u64) -> Result<(), CodecError> {
    if encoded.len() < 16 {
        return Err(CodecError::Other(format!(
            "blosc: {} bytes cannot hold the 16-byte header",
            encoded.len()
        )));
    }
    let declared = u32::from_le_bytes([encoded[4], encoded[5], encoded[6], encoded[7]]) as u64;
    if declared > expected {
        return Err(CodecError::Other(format!(
            "blosc: the header declares {declared} decoded bytes, the chunk holds {expected}"
        )));
    }
    Ok(())
}

/// Decompresses zstd frames (one or several, one after the other) into at most `expected`
/// bytes, in one call with the thread's own decompression context: no stream's buffers
/// copied through, no buffer zeroed first, no context made per chunk.
fn decompress_zstd(encoded: &[u8], expected: u64) -> Result<Vec<u8>, CodecError> {
    use zstd::zstd_safe;
    thread_local! {
        static CONTEXT: std::cell::RefCell<Option<zstd_safe::DCtx<'static>>> =
            const { std::cell::RefCell::new(None) };
    }
    let too_large = || {
        CodecError::Other(format!(
            "zstd: the stream holds more than the chunk's {expected} bytes"
        ))
    };
    // A frame that declares more is refused before anything is reserved.
    if let Ok(Some(declared)) = zstd_safe::get_frame_content_size(encoded)
        && declared > expected
    {
        return Err(too_large());
    }
    let expected_bytes = usize::try_from(expected)
        .map_err(|_| CodecError::Other(format!("zstd: {expected} bytes do not fit in memory")))?;
    // Reserved for the chunk's size (already checked against the limits), never grown.
    let mut decoded = Vec::with_capacity(expected_bytes);
    CONTEXT.with(|context| {
        let mut context = context.borrow_mut();
        let context = match &mut *context {
            Some(context) => context,
            None => context.insert(
                zstd_safe::DCtx::try_create()
                    .ok_or_else(|| CodecError::Other("zstd: no decompression context".into()))?,
            ),
        };
        context.decompress(&mut decoded, encoded).map_err(|code| {
            use zstd_safe::zstd_sys::{ZSTD_ErrorCode, ZSTD_getErrorCode};
            // SAFETY: ZSTD_getErrorCode only reads the number it is given.
            let kind = unsafe { ZSTD_getErrorCode(code) };
            // One that would write past `expected` bytes stops there.
            if kind == ZSTD_ErrorCode::ZSTD_error_dstSize_tooSmall {
                too_large()
            } else {
                CodecError::Other(format!("zstd: {}", zstd_safe::get_error_name(code)))
            }
        })
    })?;
    Ok(decoded)
}

/// Reads `decoder` to its end, refusing more than `expected` bytes. The buffer is reserved
/// for `expected` bytes (the chunk's size, already checked against the limits) and never grows.
pub(super) fn read_bounded(
    decoder: impl Read,
    expected: u64,
    name: &str,
) -> Result<Vec<u8>, CodecError> {
    let expected_bytes = usize::try_from(expected)
        .map_err(|_| CodecError::Other(format!("{name}: {expected} bytes do not fit in memory")))?;
    let mut decoded = Vec::with_capacity(expected_bytes);
    let read = decoder
        .take(expected + 1)
        .read_to_end(&mut decoded)
        .map_err(|e| CodecError::Other(format!("{name}: {e}")))?;
    if read as u64 > expected {
        return Err(CodecError::Other(format!(
            "{name}: the stream holds more than the chunk's {expected} bytes"
        )));
    }
    Ok(decoded)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_reads_refuse_more_than_expected() {
        let data = vec![7u8; 1000];
        let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut encoder, &data).unwrap();
        let gz = encoder.finish().unwrap();
        let ok = read_bounded(flate2::read::GzDecoder::new(&gz[..]), 1000, "gzip").unwrap();
        assert_eq!(ok, data);
        let error = read_bounded(flate2::read::GzDecoder::new(&gz[..]), 999, "gzip").unwrap_err();
        assert!(
            error
                .to_string()
                .contains("more than the chunk's 999 bytes"),
            "{error}"
        );

        let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut encoder, &data).unwrap();
        let zlib = encoder.finish().unwrap();
        let ok = read_bounded(flate2::read::ZlibDecoder::new(&zlib[..]), 1000, "zlib").unwrap();
        assert_eq!(ok, data);
        assert!(read_bounded(flate2::read::ZlibDecoder::new(&zlib[..]), 999, "zlib").is_err());

        let mut encoder = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::fast());
        std::io::Write::write_all(&mut encoder, &data).unwrap();
        let bz2 = encoder.finish().unwrap();
        let ok = read_bounded(bzip2::read::BzDecoder::new(&bz2[..]), 1000, "bz2").unwrap();
        assert_eq!(ok, data);
        assert!(read_bounded(bzip2::read::BzDecoder::new(&bz2[..]), 999, "bz2").is_err());

        let refused = |encoded: &[u8], expected: u64| {
            let error = decompress_zstd(encoded, expected).unwrap_err().to_string();
            let said = format!("more than the chunk's {expected} bytes");
            assert!(error.contains(&said), "{error}");
        };
        let zst = zstd::encode_all(&data[..], 3).unwrap();
        assert_eq!(decompress_zstd(&zst, 1000).unwrap(), data);
        refused(&zst, 999);
        // Frames that declare no size, one after the other: bounded as they are written.
        let mut unsized_frames = Vec::new();
        for _ in 0..2 {
            let mut encoder = zstd::stream::write::Encoder::new(Vec::new(), 3).unwrap();
            encoder.include_contentsize(false).unwrap();
            std::io::Write::write_all(&mut encoder, &data[..600]).unwrap();
            unsized_frames.extend(encoder.finish().unwrap());
        }
        assert_eq!(decompress_zstd(&unsized_frames, 1200).unwrap().len(), 1200);
        refused(&unsized_frames, 1000);
        assert!(decompress_zstd(&zst[..zst.len() / 2], 1000).is_err());
        assert!(decompress_zstd(b"not zstd", 1000).is_err());

        // A frame with a content checksum (convert writes them) is verified: a changed byte
        // of its content is an error, never other values.
        let varied: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let mut encoder = zstd::stream::write::Encoder::new(Vec::new(), 3).unwrap();
        encoder.include_checksum(true).unwrap();
        std::io::Write::write_all(&mut encoder, &varied).unwrap();
        let framed = encoder.finish().unwrap();
        assert_eq!(decompress_zstd(&framed, 1000).unwrap(), varied);
        let mut damaged = 0;
        for at in 6..framed.len() {
            let mut flipped = framed.clone();
            flipped[at] ^= 0x10;
            match decompress_zstd(&flipped, 1000) {
                Ok(values) => assert_eq!(values, varied, "byte {at} changed the values"),
                Err(_) => damaged += 1,
            }
        }
        assert!(
            damaged > framed.len() / 2,
            "{damaged} of {} flips caught",
            framed.len()
        );

        let mut blosc = vec![2u8, 1, 0, 1];
        blosc.extend_from_slice(&5000u32.to_le_bytes());
        blosc.extend_from_slice(&[0; 8]);
        assert!(check_blosc_header(&blosc, 5000).is_ok());
        let error = check_blosc_header(&blosc, 4999).unwrap_err();
        assert!(error.to_string().contains("declares 5000"), "{error}");
        assert!(check_blosc_header(&blosc[..10], 5000).is_err());
    }
}
