//! Decoded bricks in RAM (`--ram-cache SIZE`): what was loaded stays until the least recently
//! used bricks make room, so a brick evicted from the GPU and wanted again is uploaded from here
//! without reading it again.

use std::collections::BTreeSet;

use super::key_hash::KeyMap;
use super::loader::LoadedBrick;

struct Cached {
    brick: LoadedBrick,
    /// When it was last put in or taken out (the cache's own clock).
    used: u64,
}

/// Loaded bricks by key, least recently used evicted first, within a byte capacity.
pub struct RamCache {
    bricks: KeyMap<Cached>,
    /// (last use, key), oldest first.
    order: BTreeSet<(u64, u32)>,
    bytes: u64,
    capacity: u64,
    clock: u64,
}

impl RamCache {
    /// An empty cache holding at most `capacity` bytes.
    pub fn new(capacity: u64) -> Self {
        Self {
            bricks: KeyMap::default(),
            order: BTreeSet::new(),
            bytes: 0,
            capacity,
            clock: 0,
        }
    }

    fn tick(&mut self) -> u64 {
        self.clock += 1;
        self.clock
    }

    /// Adds `brick` under `key` (the most recent), evicting the least recently used bricks
    /// until it fits. A brick larger than the whole cache is not kept.
    pub fn insert(&mut self, key: u32, brick: LoadedBrick) {
        self.remove(key);
        let size = brick.bytes();
        if size > self.capacity {
            return;
        }
        while self.bytes + size > self.capacity {
            let Some(&(used, oldest)) = self.order.first() else {
                break;
            };
            self.order.remove(&(used, oldest));
            if let Some(gone) = self.bricks.remove(&oldest) {
                self.bytes -= gone.brick.bytes();
            }
        }
        let used = self.tick();
        self.order.insert((used, key));
        self.bytes += size;
        self.bricks.insert(key, Cached { brick, used });
    }

    /// The brick of `key`, now the most recently used.
    pub fn get(&mut self, key: u32) -> Option<LoadedBrick> {
        let used = self.tick();
        let cached = self.bricks.get_mut(&key)?;
        self.order.remove(&(cached.used, key));
        cached.used = used;
        self.order.insert((used, key));
        Some(cached.brick.clone())
    }

    /// The cached brick of `key`, without counting as a use.
    pub fn peek(&self, key: u32) -> Option<&LoadedBrick> {
        self.bricks.get(&key).map(|cached| &cached.brick)
    }

    /// Whether `key` is cached (without counting as a use).
    pub fn contains(&self, key: u32) -> bool {
        self.bricks.contains_key(&key)
    }

    fn remove(&mut self, key: u32) {
        if let Some(gone) = self.bricks.remove(&key) {
            self.order.remove(&(gone.used, key));
            self.bytes -= gone.brick.bytes();
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Bytes it may hold.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// Bricks held.
    pub fn len(&self) -> usize {
        self.bricks.len()
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.bricks.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::ValueRange;

    fn brick(bytes: usize) -> LoadedBrick {
        LoadedBrick {
            range: ValueRange { min: 0, max: 1 },
            texels: Some(Arc::from(vec![0u8; bytes])),
        }
    }

    #[test]
    fn the_least_recently_used_goes_first() {
        // Each brick takes 100 + 32 bytes; room for three.
        let mut cache = RamCache::new(400);
        for key in 1..=3 {
            cache.insert(key, brick(100));
        }
        assert!(cache.get(1).is_some()); // 1 is now the most recent; 2 the oldest
        cache.insert(4, brick(100));
        assert!(!cache.contains(2));
        assert!(cache.contains(1) && cache.contains(3) && cache.contains(4));
        assert_eq!(cache.bytes(), 3 * 132);
        // Too big for the cache: not kept, nothing evicted for it.
        cache.insert(5, brick(1000));
        assert!(!cache.contains(5));
        assert_eq!(cache.len(), 3);
        // Replacing a key does not count it twice.
        cache.insert(3, brick(100));
        assert_eq!(cache.bytes(), 3 * 132);
    }
}
