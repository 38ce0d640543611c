//! Hash maps and sets of brick keys with a multiply-and-fold hash: the streamer looks up
//! thousands of keys a frame (requests, their ancestors, the RAM cache), and the standard
//! library's SipHash, made for keys an attacker chooses, costs several times more for 32-bit
//! keys that come from the GPU's own requests.

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// Fibonacci hashing of one key: the product's high half, which every input bit reaches, folded
/// into the low half that hash tables index with.
#[derive(Debug, Default, Clone, Copy)]
pub struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 32)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            self.0 = (self.0 ^ byte as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }

    fn write_u32(&mut self, key: u32) {
        self.0 = (self.0 ^ key as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// A map from brick keys.
pub type KeyMap<V> = HashMap<u32, V, BuildHasherDefault<KeyHasher>>;

/// A set of brick keys.
pub type KeySet = HashSet<u32, BuildHasherDefault<KeyHasher>>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_differing_in_any_bits_spread_over_the_low_bits() {
        let hash = |key: u32| {
            let mut h = KeyHasher::default();
            h.write_u32(key);
            h.finish() & 0xfff
        };
        // Keys of different levels (the top bits) and neighbouring bricks (the low bits).
        let keys: Vec<u32> = (0..16u32)
            .flat_map(|level| (0..256u32).map(move |i| level << 28 | i))
            .collect();
        let buckets: KeySet = keys.iter().map(|&k| hash(k) as u32).collect();
        assert!(
            buckets.len() > 4096 / 2,
            "{} of 4096 buckets used",
            buckets.len()
        );
    }
}
