//! What the stores that show another format to zarrs as Zarr v3 ([`super::n5`],
//! [`super::precomputed`]) share: telling Zarr documents from data, and answering byte ranges
//! of what they make up.

use zarrs::storage::byte_range::{ByteRange, ByteRangeIterator};
use zarrs::storage::{Bytes, StorageError};

/// Byte ranges of a value, as zarrs's partial reads answer them.
pub(super) type Parts<'a> = Box<dyn Iterator<Item = Result<Bytes, StorageError>> + 'a>;

/// The traits every whole-chunk array-to-bytes codec of these stores shares: its
/// configuration (the `configuration` field, a JSON map) written back as read, no partial
/// decoding or encoding, one chunk decoded per thread.
macro_rules! whole_chunk_codec_traits {
    ($codec:ident) => {
        impl zarrs::array::CodecTraits for $codec {
            fn as_any(&self) -> &dyn std::any::Any {
                self
            }

            fn configuration(
                &self,
                _version: zarrs::plugin::ZarrVersion,
                _options: &zarrs::array::CodecMetadataOptions,
            ) -> Option<zarrs::metadata::Configuration> {
                Some(self.configuration.clone().into())
            }

            fn partial_decoder_capability(
                &self,
            ) -> zarrs::array::codec::api::PartialDecoderCapability {
                zarrs::array::codec::api::PartialDecoderCapability {
                    partial_read: false,
                    partial_decode: false,
                }
            }

            fn partial_encoder_capability(
                &self,
            ) -> zarrs::array::codec::api::PartialEncoderCapability {
                zarrs::array::codec::api::PartialEncoderCapability {
                    partial_encode: false,
                }
            }
        }

        impl zarrs::array::codec::api::ArrayCodecTraits for $codec {
            fn recommended_concurrency(
                &self,
                _shape: &[std::num::NonZeroU64],
                _data_type: &zarrs::array::DataType,
            ) -> Result<zarrs::array::RecommendedConcurrency, zarrs::array::CodecError> {
                Ok(zarrs::array::RecommendedConcurrency::new_maximum(1))
            }
        }
    };
}
pub(super) use whole_chunk_codec_traits;

/// The Zarr document a key names (`zarr.json`, `.zgroup`, …) and the node it describes
/// (`""`, `s0/`), if it names one.
pub(super) fn zarr_document(key: &str) -> Option<(&str, &str)> {
    let (node, name) = match key.rfind('/') {
        Some(slash) => key.split_at(slash + 1),
        None => ("", key),
    };
    crate::remote::NODE_DOCUMENTS
        .contains(&name)
        .then_some((node, name))
}

/// The byte ranges `byte_ranges` of `bytes` (ranges past its end are cut to it).
pub(super) fn slice_ranges<'a>(bytes: Bytes, byte_ranges: ByteRangeIterator<'a>) -> Parts<'a> {
    let size = bytes.len() as u64;
    let parts: Vec<Result<Bytes, StorageError>> = byte_ranges
        .map(|range| {
            // Computed here: zarrs's `start` of a suffix longer than the value underflows.
            let (start, end) = match range {
                ByteRange::FromStart(offset, length) => {
                    let start = offset.min(size);
                    let end = length.map_or(size, |n| start.saturating_add(n).min(size));
                    (start, end)
                }
                ByteRange::Suffix(length) => (size.saturating_sub(length), size),
            };
            Ok(bytes.slice(start as usize..end as usize))
        })
        .collect();
    Box::new(parts.into_iter())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zarr_documents_are_told_from_data() {
        assert_eq!(zarr_document("zarr.json"), Some(("", "zarr.json")));
        assert_eq!(zarr_document("s0/.zarray"), Some(("s0/", ".zarray")));
        assert_eq!(zarr_document("s0/1/2/3"), None);
        assert_eq!(zarr_document("4_4_40/0-64_0-64_0-64"), None);
    }

    #[test]
    fn ranges_past_the_value_are_cut_to_it() {
        let ranges = vec![
            ByteRange::FromStart(2, Some(2)),
            ByteRange::FromStart(4, Some(10)),
            ByteRange::FromStart(9, None),
            ByteRange::Suffix(3),
            ByteRange::Suffix(100),
        ];
        let parts: Vec<Bytes> =
            slice_ranges(Bytes::from_static(b"abcdef"), Box::new(ranges.into_iter()))
                .map(Result::unwrap)
                .collect();
        let parts: Vec<&[u8]> = parts.iter().map(|p| &p[..]).collect();
        assert_eq!(parts, [&b"cd"[..], b"ef", b"", b"def", b"abcdef"]);
    }
}
