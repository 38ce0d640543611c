//! Fetching ahead: the chunks of the bricks the loaders take next handed to the store before
//! their reads ([`BrickSource::fetch_ahead`]).

use super::*;

/// What [`BrickSource::fetch_ahead`] handed the store already.
#[derive(Default)]
pub(super) struct FetchedAhead {
    /// Chunks of unsharded levels.
    pub(super) chunks: std::collections::HashSet<ChunkKey>,
    /// Bricks whose chunks were all handed over (at a sharded level: whose inner chunks were
    /// all decoded when looked at): passed over at once when a later call's window holds them
    /// again.
    pub(super) bricks: std::collections::HashSet<BrickId>,
}

/// The most chunks a [`ZarrSource`] remembers having fetched ahead.
const MAX_FETCHED_AHEAD: usize = 1 << 16;

/// Most inner chunks of sharded levels one [`BrickSource::fetch_ahead`] call hands the store
/// in a batch (96 bricks' at 27 inner chunks of 32³ each; a batch past 4 096 inner chunks is
/// not fetched ahead at all).
const MAX_SHARDED_CHUNKS_AHEAD: usize = 96 * 27;

/// Most bytes of inner chunks (as stored voxels: what they hold decoded, more than they
/// weigh compressed) one [`BrickSource::fetch_ahead`] call hands the store in a sharded batch:
/// the batch lands in the fetch cache, not held (at most
/// [`voxscope_volume::remote::FETCH_CACHE_BYTES`], an eighth of the RAM cache), and one larger
/// than it is evicted before it is read and fetched again. 2 592 one-plane inner chunks of
/// 1024² were 5 GiB: a level-0 view of a 1024×1024×256 store of them over the link fetched
/// 1.25 GB for 0.36 GB of chunks (222 requests, 86 distinct), 61.8 s against the 64³ store's
/// 8.2 s (issue 54). 2 592 inner chunks of 32³ u16 are 162 MiB.
const MAX_SHARDED_BYTES_AHEAD: u64 = 64 << 20;

/// Most chunks one [`BrickSource::fetch_ahead`] call hands the store (which starts what its
/// limit has room for: twice `--max-requests`, 64 by default, within half its fetch cache
/// with what it fetched ahead and is not read yet; the rest on later calls).
const MAX_CHUNKS_AHEAD: usize = 256;

impl ZarrSource {
    /// Starts the fetches of the bricks' chunks that are neither decoded nor fetched ahead
    /// before, in the bricks' order: whole chunks ([`Pyramid::fetch_ahead_chunks`]), or a
    /// sharded level's inner chunks shard by shard, coalesced
    /// ([`Pyramid::fetch_ahead_regions`]). The chunks already handed to the store are
    /// remembered, and so are the bricks whose chunks all were (at a sharded level, whose
    /// inner chunks were all decoded), so that a call costs little once a view's chunks are
    /// on their way.
    pub(super) fn fetch_ahead_bricks(&self, ids: &[BrickId]) {
        if !self.pyramid.can_fetch_ahead() {
            return;
        }
        let mut sharded = Vec::new();
        let mut sharded_bytes = 0u64;
        let mut chunks: Vec<ChunkKey> = Vec::new();
        // Per brick with chunks to fetch: how many of `chunks` it needs handled.
        let mut bricks: Vec<(BrickId, usize)> = Vec::new();
        let mut looked_at = 0u64;
        // Whether the sharded batch has reached its bound, and the bricks of sharded levels
        // whose inner chunks were all decoded (or their faces kept) when looked at: passed
        // over by later calls, as bricks whose chunks were handed over are. Without that, each
        // call looked up every inner chunk of its window's bricks again (2 048 bricks of 33
        // one-plane chunks at level 0) under the decoded chunks' lock, before each brick a
        // loader took: the loaders of a level-0 view of a 1024×1024×256 store in one-plane
        // inner chunks over a link spent most of their time there or waiting for that lock,
        // 32 s against the 64³ store's 6.8 s, the link idle after 10 s (issue 54). Should
        // such a chunk leave the decoded cache, its brick's read fetches it.
        let mut sharded_full = false;
        let mut decoded_bricks: Vec<BrickId> = Vec::new();
        {
            // (Locked in the order of `region_parts`: decoded chunks, faces, then these.)
            let (Ok(decoded), Ok(kept_faces), Ok(mut asked)) = (
                self.chunks.lock(),
                self.faces.lock(),
                self.fetched_ahead.lock(),
            ) else {
                return;
            };
            let mut seen = std::collections::HashSet::new();
            for &id in ids {
                if asked.bricks.contains(&id) {
                    continue;
                }
                let (Some(level), Some(source)) = (
                    self.shape.levels.get(id.level as usize),
                    self.sources.get(id.level as usize),
                ) else {
                    continue;
                };
                let info = &self.pyramid.levels[source.stored];
                if info.shard.is_some() && sharded_full {
                    continue;
                }
                let first = id.brick.map(|c| c as usize * BRICK_SIZE);
                if (0..3).any(|a| first[a] >= level.dims[a]) {
                    continue;
                }
                let voxels = padded_voxels(first, level.dims);
                let (origin, size) = stored_region(&voxels, source.ratio, info.dims);
                let reached = chunks_reached(info.chunk, origin, size);
                // Whether the brick's read takes the chunk's part without decoding it: the
                // chunk is decoded, or the part lies in its faces, kept.
                let served = |index: [usize; 3], part: &ChunkPart| {
                    let key = (source.stored, index);
                    decoded.chunks.contains_key(&key)
                        || kept_faces.chunks.contains_key(&key) && part.face().is_some()
                };
                let part_of = |index| ChunkPart::of(info.chunk, info.dims, index, origin, size);
                if info.shard.is_some() {
                    // Each inner chunk to decode as a region of its own (the batch coalesces
                    // a shard's), their number bounded: a shard batch of too many inner
                    // chunks is not fetched ahead at all. The batch is what is not decoded
                    // yet, whatever earlier batches fetched (those the fetch cache still
                    // keeps are not fetched again), so it stays within the bound of what the
                    // loaders read next; a full batch ends the look at the sharded bricks.
                    let mut all_decoded = true;
                    for index in reached {
                        if sharded.len() >= MAX_SHARDED_CHUNKS_AHEAD
                            || sharded_bytes >= MAX_SHARDED_BYTES_AHEAD
                        {
                            sharded_full = true;
                            break;
                        }
                        looked_at += 1;
                        let part = part_of(index);
                        if served(index, &part) {
                            continue;
                        }
                        all_decoded = false;
                        if seen.insert((source.stored, index)) {
                            sharded.push((source.stored, part.start, part.extent));
                            sharded_bytes += part.extent.iter().product::<usize>() as u64
                                * self.pyramid.voxel_type.size() as u64;
                        }
                    }
                    if all_decoded && !sharded_full {
                        decoded_bricks.push(id);
                    }
                    continue;
                }
                if chunks.len() >= MAX_CHUNKS_AHEAD {
                    continue;
                }
                // Whether every chunk was handed to the store (by this call or one before): a
                // chunk only decoded, or whose faces only are kept, may leave its cache, and
                // the brick is then looked at again.
                let mut all_handed = true;
                for index in reached {
                    looked_at += 1;
                    let key = (source.stored, index);
                    if asked.chunks.contains(&key) || seen.contains(&key) {
                        continue;
                    }
                    if served(index, &part_of(index)) {
                        all_handed = false;
                    } else {
                        seen.insert(key);
                        chunks.push(key);
                    }
                }
                if all_handed {
                    // Handed over once the first `chunks.len()` are (at once for none).
                    bricks.push((id, chunks.len()));
                }
            }
            if asked.bricks.len() > MAX_FETCHED_AHEAD {
                asked.bricks.clear();
            }
            let now = bricks.iter().take_while(|&&(_, needs)| needs == 0);
            let now: Vec<BrickId> = now.map(|&(id, _)| id).collect();
            asked.bricks.extend(now);
            asked.bricks.extend(decoded_bricks);
        }
        self.looked_at_ahead
            .fetch_add(looked_at, std::sync::atomic::Ordering::Relaxed);
        if !sharded.is_empty() {
            self.pyramid.fetch_ahead_regions(&sharded);
        }
        if !chunks.is_empty() {
            let handled = self.pyramid.fetch_ahead_chunks(&chunks);
            if let Ok(mut asked) = self.fetched_ahead.lock() {
                if asked.chunks.len() + handled > MAX_FETCHED_AHEAD {
                    asked.chunks.clear();
                    asked.bricks.clear();
                }
                asked.chunks.extend(chunks[..handled].iter().copied());
                let done = bricks.iter().take_while(|&&(_, needs)| needs <= handled);
                asked.bricks.extend(done.map(|&(id, _)| id));
            }
        }
    }
}
