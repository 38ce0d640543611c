//! Decoded chunks kept for the bricks after the one that read them, within a byte budget.

use super::*;

/// Whether chunks of `chunk` voxels are thin: at most 4 voxels along an axis (one-plane
/// acquisition chunks, 1×1024×1024 or 4×512×512 in zarr's order), so that a brick reads a
/// sliver of each of the many chunks it reaches, and every brick of a layer the same ones. The
/// decoded chunks are then what is worth keeping (a brick is a copy from them): with a quarter
/// of a 1 GiB RAM cache (128 planes of 1024²), a view of a 1024×1024×256 store at level 0,
/// whose loaders take bricks of every layer in turn, decoded 9 915 planes in 60 s and did not
/// complete in 300 s (the 64³ store's: 1 029 chunks, 4.1 s).
pub(super) fn thin_chunk(chunk: [usize; 3]) -> bool {
    chunk
        .iter()
        .min()
        .is_some_and(|&side| side * 8 <= BRICK_SIZE)
}

/// The least recently used decoded chunks, each with the clock of its last use, within a
/// byte capacity (the last chunk used is kept even when it alone is larger).
pub(super) struct ChunkCache {
    pub(super) chunks: HashMap<ChunkKey, (Arc<Vec<u16>>, u64)>,
    pub(super) bytes: usize,
    pub(super) capacity: usize,
    pub(super) clock: u64,
}

impl Default for ChunkCache {
    fn default() -> Self {
        Self {
            chunks: HashMap::new(),
            bytes: 0,
            capacity: CHUNK_CACHE_BYTES,
            clock: 0,
        }
    }
}

impl ChunkCache {
    pub(super) fn with_capacity(capacity: usize) -> Self {
        Self {
            capacity,
            ..Self::default()
        }
    }

    pub(super) fn set_capacity(&mut self, capacity: usize) {
        self.capacity = capacity;
        self.shrink();
    }

    pub(super) fn shrink(&mut self) {
        while self.bytes > self.capacity && self.chunks.len() > 1 {
            // Evict the least recently used (a scan: the cache holds about a thousand chunks).
            let Some((&oldest, _)) = self.chunks.iter().min_by_key(|(_, (_, used))| *used) else {
                break;
            };
            if let Some((old, _)) = self.chunks.remove(&oldest) {
                self.bytes -= old.len() * 2;
            }
        }
    }

    pub(super) fn get(&mut self, key: ChunkKey) -> Option<Arc<Vec<u16>>> {
        self.clock += 1;
        let clock = self.clock;
        self.chunks.get_mut(&key).map(|(chunk, used)| {
            *used = clock;
            Arc::clone(chunk)
        })
    }

    pub(super) fn insert(&mut self, key: ChunkKey, chunk: Arc<Vec<u16>>) {
        self.clock += 1;
        self.bytes += chunk.len() * 2;
        if let Some((old, _)) = self.chunks.insert(key, (chunk, self.clock)) {
            self.bytes -= old.len() * 2;
        }
        self.shrink();
    }
}
