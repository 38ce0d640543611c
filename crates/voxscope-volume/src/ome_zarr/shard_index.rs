//! Where a shard keeps its inner chunks: the `sharding_indexed` codec's index read by voxscope
//! itself, so that a region's inner chunks can be fetched shard by shard in one batch of byte
//! ranges before zarrs reads them one by one (zarrs answers an inner chunk's range only
//! through a call that overflows on an empty inner chunk, `u64::MAX` twice in the index).

use zarrs::array::{Array, ArrayMetadata};
use zarrs::storage::ReadableStorageTraits;
use zarrs::storage::byte_range::ByteRange;

/// An index entry's offset and size for an inner chunk that was never written.
const EMPTY: u64 = u64::MAX;

/// How one level's shards keep their index, for arrays sharded and nothing else whose index
/// is plain little-endian `u64` pairs (with or without its CRC-32C): what `voxscope
/// convert` and most writers make. Anything else is left to zarrs alone.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct ShardIndexLayout {
    /// Inner chunks per shard along each of the array's dimensions.
    pub per_shard: Vec<u64>,
    /// The index's size in bytes (16 an inner chunk, and 4 for a CRC-32C).
    pub bytes: u64,
    /// Whether the index ends the shard (else it begins it).
    pub at_end: bool,
}

impl ShardIndexLayout {
    /// The layout of `array`'s shards, if voxscope reads their index itself.
    pub fn of(array: &Array<dyn ReadableStorageTraits>) -> Option<Self> {
        let ArrayMetadata::V3(metadata) = array.metadata() else {
            return None;
        };
        let [sharding] = &metadata.codecs[..] else {
            return None;
        };
        if sharding.name() != "sharding_indexed" {
            return None;
        }
        let config = sharding.configuration()?;
        let shape = |value: &serde_json::Value| -> Option<Vec<u64>> {
            value.as_array()?.iter().map(|v| v.as_u64()).collect()
        };
        let inner = shape(config.get("chunk_shape")?)?;
        let grid = metadata.chunk_grid.configuration()?;
        if metadata.chunk_grid.name() != "regular" {
            return None;
        }
        let shard = shape(grid.get("chunk_shape")?)?;
        if inner.len() != shard.len() {
            return None;
        }
        let per_shard: Vec<u64> = shard
            .iter()
            .zip(&inner)
            .map(|(&s, &i)| (i > 0 && s % i == 0).then(|| s / i))
            .collect::<Option<_>>()?;
        let mut crc = false;
        for (position, codec) in config.get("index_codecs")?.as_array()?.iter().enumerate() {
            let name = codec.get("name")?.as_str()?;
            let little = codec
                .get("configuration")
                .and_then(|c| c.get("endian"))
                .and_then(|e| e.as_str())
                .is_none_or(|e| e == "little");
            match (position, name) {
                (0, "bytes") if little => {}
                (1, "crc32c") => crc = true,
                _ => return None,
            }
        }
        let entries = per_shard
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul(n))?;
        let bytes = entries
            .checked_mul(16)?
            .checked_add(if crc { 4 } else { 0 })?;
        let at_end = match config.get("index_location").and_then(|l| l.as_str()) {
            None | Some("end") => true,
            Some("start") => false,
            Some(_) => return None,
        };
        Some(Self {
            per_shard,
            bytes,
            at_end,
        })
    }

    /// The byte range of the index in its shard, as zarrs asks for it (so that one fetch
    /// serves both).
    pub fn range(&self) -> ByteRange {
        if self.at_end {
            ByteRange::Suffix(self.bytes)
        } else {
            ByteRange::FromStart(0, Some(self.bytes))
        }
    }

    /// The entry of the inner chunk `inner` (the array's chunk indices of the inner grid)
    /// in its shard's index.
    pub fn entry(&self, inner: &[u64]) -> Option<u64> {
        if inner.len() != self.per_shard.len() {
            return None;
        }
        // C order: the last dimension fastest.
        Some(
            inner
                .iter()
                .zip(&self.per_shard)
                .fold(0, |acc, (&i, &n)| acc * n + i % n),
        )
    }

    /// The byte range of inner chunk `entry` from the encoded `index`; `None` if it was
    /// never written, or if the index is too short, damaged (a range that overflows) or
    /// places it beyond `max_bytes` (the largest a shard may be): zarrs then says what is
    /// wrong when it reads the chunk.
    pub fn inner_range(&self, index: &[u8], entry: u64, max_bytes: u64) -> Option<ByteRange> {
        let at = usize::try_from(entry.checked_mul(16)?).ok()?;
        let word = |from: usize| -> Option<u64> {
            Some(u64::from_le_bytes(
                index.get(from..from + 8)?.try_into().ok()?,
            ))
        };
        let (offset, size) = (word(at)?, word(at + 8)?);
        if offset == EMPTY && size == EMPTY {
            return None;
        }
        let end = offset.checked_add(size)?;
        (end <= max_bytes && size > 0).then_some(ByteRange::FromStart(offset, Some(size)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_entries_give_inner_ranges_and_empty_or_damaged_ones_none() {
        let layout = ShardIndexLayout {
            per_shard: vec![2, 2, 2],
            bytes: 8 * 16 + 4,
            at_end: true,
        };
        assert_eq!(layout.range(), ByteRange::Suffix(132));
        // Inner chunk (z, y, x) = (1, 0, 1) of the second shard along x: entry 5.
        assert_eq!(layout.entry(&[1, 0, 3]), Some(5));
        let mut index = Vec::new();
        for entry in 0..8u64 {
            let (offset, size) = match entry {
                2 => (EMPTY, EMPTY),
                6 => (u64::MAX - 1, 10),
                _ => (entry * 100, 100),
            };
            index.extend(offset.to_le_bytes());
            index.extend(size.to_le_bytes());
        }
        assert_eq!(
            layout.inner_range(&index, 5, 1 << 20),
            Some(ByteRange::FromStart(500, Some(100)))
        );
        assert_eq!(layout.inner_range(&index, 2, 1 << 20), None, "empty");
        assert_eq!(layout.inner_range(&index, 6, u64::MAX), None, "overflows");
        assert_eq!(layout.inner_range(&index, 5, 550), None, "beyond the shard");
        assert_eq!(layout.inner_range(&index[..40], 5, 1 << 20), None, "short");
    }
}
