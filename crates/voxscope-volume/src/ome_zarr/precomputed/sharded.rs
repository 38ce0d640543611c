//! neuroglancer's sharded scales (`neuroglancer_uint64_sharded_v1`): where a chunk lies.
//!
//! A chunk's id is the compressed Morton code of its grid position; shifted right by
//! `preshift_bits` and hashed (`identity` or `murmurhash3_x86_128`), its low `minishard_bits`
//! pick the minishard and the next `shard_bits` the shard file (`KEY/HEX.shard`). A shard
//! file opens with its index: per minishard, the byte range of the minishard's index
//! (relative to the index's end), which lists the minishard's chunks (ids, offsets and sizes,
//! each list delta-coded, 8-byte little-endian) and may be gzip-compressed. A chunk is then one
//! range read. Minishard indexes are kept once read (a scale's, up to [`MAX_KEPT_BYTES`]).
//!
//! Every range and count is checked before it is read or allocated: a damaged index is an
//! error naming the shard, never a read of another chunk's bytes as this one's.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use serde_json::{Map, Value};
use zarrs::storage::byte_range::ByteRange;
use zarrs::storage::{Bytes, ReadableStorageTraits, StorageError, StoreKey};

use crate::error::escape;

/// The largest minishard index read (24 bytes a chunk: 2.8 million chunks).
const MAX_MINISHARD_INDEX: u64 = 64 << 20;
/// The most bytes of minishard indexes a scale keeps.
const MAX_KEPT_BYTES: usize = 256 << 20;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Hash {
    Identity,
    Murmur3,
}

/// A scale's `sharding`, checked.
#[derive(Debug, Clone)]
pub(super) struct Sharding {
    preshift_bits: u32,
    hash: Hash,
    minishard_bits: u32,
    shard_bits: u32,
    minishard_index_gzip: bool,
}

fn encoding_is_gzip(sharding: &Map<String, Value>, name: &str) -> Result<bool, String> {
    match sharding.get(name).and_then(Value::as_str).unwrap_or("raw") {
        "raw" => Ok(false),
        "gzip" => Ok(true),
        other => Err(format!(
            "sharding's {name} '{}' is neither raw nor gzip",
            escape(other)
        )),
    }
}

impl Sharding {
    pub(super) fn parse(sharding: &Map<String, Value>) -> Result<Self, String> {
        if sharding.get("@type").and_then(Value::as_str) != Some("neuroglancer_uint64_sharded_v1") {
            return Err("sharding's @type is not neuroglancer_uint64_sharded_v1".to_owned());
        }
        let bits = |name: &str, most: u64| {
            sharding
                .get(name)
                .and_then(Value::as_u64)
                .filter(|&b| b <= most)
                .map(|b| b as u32)
                .ok_or_else(|| format!("sharding's {name} is not a count of 0 to {most} bits"))
        };
        let hash = match sharding.get("hash").and_then(Value::as_str) {
            Some("identity") => Hash::Identity,
            Some("murmurhash3_x86_128") => Hash::Murmur3,
            other => {
                return Err(format!(
                    "sharding's hash '{}' is neither identity nor murmurhash3_x86_128",
                    escape(other.unwrap_or_default())
                ));
            }
        };
        let sharding_checked = Self {
            preshift_bits: bits("preshift_bits", 64)?,
            hash,
            // A shard's index holds 16 bytes a minishard, read whole per minishard entry.
            minishard_bits: bits("minishard_bits", 32)?,
            shard_bits: bits("shard_bits", 64)?,
            minishard_index_gzip: encoding_is_gzip(sharding, "minishard_index_encoding")?,
        };
        // Chunks are gzip-compressed as a whole: the chunk codec recognizes them.
        encoding_is_gzip(sharding, "data_encoding")?;
        if sharding_checked.minishard_bits + sharding_checked.shard_bits > 64 {
            return Err("sharding's minishard_bits and shard_bits exceed 64".to_owned());
        }
        Ok(sharding_checked)
    }

    /// The shard file (its name under the scale) and minishard of chunk `id`.
    fn place(&self, id: u64) -> (String, u64) {
        let shifted = id.checked_shr(self.preshift_bits).unwrap_or(0);
        let hashed = match self.hash {
            Hash::Identity => shifted,
            Hash::Murmur3 => murmur3_x86_128_low64(shifted),
        };
        let mask = |bits: u32| 1u64.checked_shl(bits).map_or(u64::MAX, |b| b - 1);
        let minishard = hashed & mask(self.minishard_bits);
        let shard = hashed.checked_shr(self.minishard_bits).unwrap_or(0) & mask(self.shard_bits);
        let digits = self.shard_bits.div_ceil(4) as usize;
        (format!("{shard:0digits$x}.shard"), minishard)
    }
}

/// The compressed Morton code of chunk `position` (x, y, z) in a grid of `grid` chunks: the
/// bits of x, y and z interleaved, each axis giving only as many bits as its grid needs.
pub(super) fn compressed_morton_code(position: [u64; 3], grid: [u64; 3]) -> u64 {
    let bits = grid.map(|g| 64 - g.saturating_sub(1).leading_zeros());
    let mut code = 0u64;
    let mut out = 0;
    for bit in 0..bits.iter().copied().max().unwrap_or(0) {
        for axis in 0..3 {
            if bit < bits[axis] && out < 64 {
                code |= ((position[axis] >> bit) & 1) << out;
                out += 1;
            }
        }
    }
    code
}

/// The low 64 bits of MurmurHash3_x86_128 (seed 0) of `key`'s 8 little-endian bytes, as
/// neuroglancer hashes chunk ids.
fn murmur3_x86_128_low64(key: u64) -> u64 {
    const C1: u32 = 0x239b_961b;
    const C2: u32 = 0xab0e_9789;
    const C3: u32 = 0x38b3_4ae5;
    fn fmix(mut h: u32) -> u32 {
        h ^= h >> 16;
        h = h.wrapping_mul(0x85eb_ca6b);
        h ^= h >> 13;
        h = h.wrapping_mul(0xc2b2_ae35);
        h ^ (h >> 16)
    }
    let (mut h1, mut h2, mut h3, mut h4) = (0u32, 0u32, 0u32, 0u32);
    // No whole 16-byte block; the 8-byte tail fills k1 (bytes 0–3) and k2 (bytes 4–7).
    let k2 = ((key >> 32) as u32)
        .wrapping_mul(C2)
        .rotate_left(16)
        .wrapping_mul(C3);
    h2 ^= k2;
    let k1 = (key as u32)
        .wrapping_mul(C1)
        .rotate_left(15)
        .wrapping_mul(C2);
    h1 ^= k1;
    for h in [&mut h1, &mut h2, &mut h3, &mut h4] {
        *h ^= 8;
    }
    h1 = h1.wrapping_add(h2).wrapping_add(h3).wrapping_add(h4);
    h2 = h2.wrapping_add(h1);
    h3 = h3.wrapping_add(h1);
    h4 = h4.wrapping_add(h1);
    h1 = fmix(h1);
    h2 = fmix(h2);
    h3 = fmix(h3);
    h4 = fmix(h4);
    h1 = h1.wrapping_add(h2).wrapping_add(h3).wrapping_add(h4);
    h2 = h2.wrapping_add(h1);
    u64::from(h1) | (u64::from(h2) << 32)
}

/// A chunk's entry in its minishard's index: its id, and where its bytes are (relative to the
/// end of the shard's index).
type Entry = (u64, u64, u64);

/// The minishard indexes read so far, by shard file and minishard, and their bytes.
#[derive(Default)]
struct Kept {
    indexes: HashMap<(String, u64), Arc<Vec<Entry>>>,
    bytes: usize,
}

/// One sharded scale, with the minishard indexes read so far.
pub(super) struct ShardedScale {
    key: String,
    sharding: Sharding,
    /// Chunks along x, y, z.
    grid: [u64; 3],
    /// The most bytes a chunk's range may have (its voxels' bytes, with room for encodings
    /// that can be larger).
    max_chunk_bytes: u64,
    minishards: Mutex<Kept>,
}

fn storage_error(what: String) -> StorageError {
    StorageError::Other(what)
}

impl ShardedScale {
    pub(super) fn new(
        key: String,
        sharding: Sharding,
        grid: [u64; 3],
        max_chunk_bytes: u64,
    ) -> Self {
        Self {
            key,
            sharding,
            grid,
            max_chunk_bytes,
            minishards: Mutex::default(),
        }
    }

    /// The bytes of the chunk at grid `position`, `None` where the volume has none there.
    pub(super) fn chunk(
        &self,
        store: &dyn ReadableStorageTraits,
        position: [u64; 3],
    ) -> Result<Option<Bytes>, StorageError> {
        let id = compressed_morton_code(position, self.grid);
        let (file, minishard) = self.sharding.place(id);
        let Some(entries) = self.minishard(store, &file, minishard)? else {
            return Ok(None);
        };
        let Some(&(_, offset, size)) = entries.iter().find(|(chunk, _, _)| *chunk == id) else {
            return Ok(None);
        };
        if size > self.max_chunk_bytes {
            return Err(storage_error(format!(
                "{}/{file}: chunk {id} is {size} bytes; a chunk of this scale holds at most {}",
                self.key, self.max_chunk_bytes
            )));
        }
        let start = self
            .index_bytes()
            .checked_add(offset)
            .ok_or_else(|| storage_error(format!("{file}: chunk {id} lies past 2^64")))?;
        let key = self.file_key(&file)?;
        store.get_partial(&key, ByteRange::FromStart(start, Some(size)))
    }

    /// Bytes of a shard's index: 16 a minishard.
    fn index_bytes(&self) -> u64 {
        16u64 << self.sharding.minishard_bits
    }

    fn file_key(&self, file: &str) -> Result<StoreKey, StorageError> {
        StoreKey::new(format!("{}/{file}", self.key)).map_err(|e| storage_error(e.to_string()))
    }

    /// The entries of minishard `minishard` of shard file `file` (read once), `None` where
    /// the shard or minishard does not exist.
    fn minishard(
        &self,
        store: &dyn ReadableStorageTraits,
        file: &str,
        minishard: u64,
    ) -> Result<Option<Arc<Vec<Entry>>>, StorageError> {
        let wanted = (file.to_owned(), minishard);
        if let Ok(kept) = self.minishards.lock()
            && let Some(entries) = kept.indexes.get(&wanted)
        {
            return Ok(Some(Arc::clone(entries)));
        }
        let key = self.file_key(file)?;
        let Some(range) =
            store.get_partial(&key, ByteRange::FromStart(minishard * 16, Some(16)))?
        else {
            return Ok(None);
        };
        let name = format!("{}/{file}", self.key);
        let word = |bytes: &[u8], i: usize| {
            u64::from_le_bytes(bytes[8 * i..8 * i + 8].try_into().unwrap_or_default())
        };
        if range.len() != 16 {
            return Err(storage_error(format!(
                "{name}: the shard's index is cut short"
            )));
        }
        let (start, end) = (word(&range, 0), word(&range, 1));
        if start == end {
            // An empty minishard: kept, so that its chunks ask nothing again.
            let entries = Arc::new(Vec::new());
            if let Ok(mut kept) = self.minishards.lock() {
                kept.indexes.insert(wanted, Arc::clone(&entries));
            }
            return Ok(Some(entries));
        }
        if end < start || end - start > MAX_MINISHARD_INDEX {
            return Err(storage_error(format!(
                "{name}: minishard {minishard}'s index spans bytes {start} to {end}"
            )));
        }
        let at = self.index_bytes().checked_add(start).ok_or_else(|| {
            storage_error(format!(
                "{name}: minishard {minishard}'s index begins past 2^64"
            ))
        })?;
        let Some(mut index) =
            store.get_partial(&key, ByteRange::FromStart(at, Some(end - start)))?
        else {
            return Ok(None);
        };
        if self.sharding.minishard_index_gzip {
            let decoder = flate2::read::GzDecoder::new(&index[..]);
            let inflated =
                super::super::guard::read_bounded(decoder, MAX_MINISHARD_INDEX, "minishard index")
                    .map_err(|e| storage_error(format!("{name}: {e}")))?;
            index = Bytes::from(inflated);
        }
        if index.len() % 24 != 0 {
            return Err(storage_error(format!(
                "{name}: minishard {minishard}'s index of {} bytes is not whole entries",
                index.len()
            )));
        }
        let n = index.len() / 24;
        let mut entries = Vec::with_capacity(n);
        let (mut id, mut end_of_last) = (0u64, 0u64);
        for i in 0..n {
            id = id.wrapping_add(word(&index, i));
            let offset = end_of_last.wrapping_add(word(&index, n + i));
            let size = word(&index, 2 * n + i);
            end_of_last = offset.wrapping_add(size);
            entries.push((id, offset, size));
        }
        let entries = Arc::new(entries);
        if let Ok(mut kept) = self.minishards.lock() {
            let bytes = n * 24;
            if kept.bytes + bytes > MAX_KEPT_BYTES {
                kept.indexes.clear();
                kept.bytes = 0;
            }
            kept.bytes += bytes;
            kept.indexes.insert(wanted, Arc::clone(&entries));
        }
        Ok(Some(entries))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_interleave_only_the_bits_each_axis_needs() {
        // x needs 2 bits (grid 4), y 1 (grid 2), z none (grid 1): x0 y0 x1.
        assert_eq!(compressed_morton_code([3, 1, 0], [4, 2, 1]), 0b111);
        assert_eq!(compressed_morton_code([2, 0, 0], [4, 2, 1]), 0b100);
        assert_eq!(compressed_morton_code([0, 1, 0], [4, 2, 1]), 0b010);
        assert_eq!(compressed_morton_code([1, 1, 1], [2, 2, 2]), 0b111);
    }

    #[test]
    fn murmur3_matches_the_reference() {
        // The first 8 bytes of MurmurHash3_x86_128 (seed 0) of the ids' 8 little-endian
        // bytes, read little-endian, as Python's mmh3 5.2 computes them.
        assert_eq!(murmur3_x86_128_low64(0), 0x4772_b084_e028_ae41);
        assert_eq!(
            murmur3_x86_128_low64(0x0123_4567_89ab_cdef),
            0x7080_3626_4c10_9d93
        );
    }

    #[test]
    fn shards_are_named_in_hex_of_their_bits() {
        let sharding = Sharding {
            preshift_bits: 0,
            hash: Hash::Identity,
            minishard_bits: 2,
            shard_bits: 5,
            minishard_index_gzip: false,
        };
        // id 0b1_0111_01: minishard 0b01, shard 0b10111.
        assert_eq!(sharding.place(0b1011101), ("17.shard".to_owned(), 1));
    }
}
