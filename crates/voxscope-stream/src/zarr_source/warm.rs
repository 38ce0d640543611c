//! The first image's chunks fetched and decoded before it is drawn: the preview's level and
//! the pinned levels, each stored level as one region.

use super::*;

impl ZarrSource {
    /// Reads, before the first image, what it needs from the store: the stored voxels of the
    /// level [`preview`](super::preview()) reads with `preview_bricks` and of the levels the
    /// streamer pins (every level of a single brick), each stored level as one region whose
    /// chunks are all fetched together ([`Pyramid::prefetch_regions`]), split into the chunk
    /// cache. Those bricks then read no chunk one by one: over a network, a few round trips in
    /// all instead of one a chunk. A region of more than [`WARM_VOXELS`] is left to its bricks;
    /// a read that fails is too (they report it, naming the chunk).
    pub fn warm_first_image(&self, preview_bricks: u64) {
        let mut levels = vec![preview_level(&self.shape, preview_bricks)];
        levels.extend(pinned_levels(&self.shape).into_iter().map(|l| l as usize));
        // Per stored level, the end (exclusive, whole chunks) of what the levels' bricks read.
        let mut ends: HashMap<usize, [usize; 3]> = HashMap::new();
        for level in levels {
            let (Some(shape), Some(source)) =
                (self.shape.levels.get(level), self.sources.get(level))
            else {
                continue;
            };
            let info = &self.pyramid.levels[source.stored];
            let end: [usize; 3] = std::array::from_fn(|a| {
                let last = covered(0, shape.dims[a] - 1, source.ratio[a], info.dims[a]).1;
                (last + 1).next_multiple_of(info.chunk[a]).min(info.dims[a])
            });
            let merged = ends.entry(source.stored).or_insert([0; 3]);
            *merged = std::array::from_fn(|a| merged[a].max(end[a]));
        }
        let regions: Vec<(usize, [usize; 3], [usize; 3])> = ends
            .into_iter()
            .filter(|(_, end)| end.iter().map(|&e| e as u64).product::<u64>() <= WARM_VOXELS)
            .map(|(stored, end)| (stored, [0; 3], end))
            .collect();
        let _held = self.pyramid.prefetch_regions(&regions);
        regions.par_iter().for_each(|&(stored, _, end)| {
            if let Ok(data) = self.pyramid.read_region(stored, [0; 3], end) {
                self.cache_chunks(stored, end, &to_levels(data, self.quantization));
            }
        });
    }

    /// Runs `alongside` on this thread while [`Self::warm_first_image`] fetches the first
    /// image's chunks on another (a renderer's making overlaps the open's last round trip);
    /// returns its result once both are done.
    pub fn warm_first_image_while<R>(
        &self,
        preview_bricks: u64,
        alongside: impl FnOnce() -> R,
    ) -> R {
        std::thread::scope(|scope| {
            let warming = std::thread::Builder::new()
                .name("voxscope-first-image".into())
                .spawn_scoped(scope, || self.warm_first_image(preview_bricks));
            if warming.is_err() {
                self.warm_first_image(preview_bricks);
            }
            alongside()
        })
    }

    /// Puts the stored level's region `[0, end)` (whole chunks, x fastest, as value levels)
    /// into the chunk cache, chunk by chunk as [`Self::read_levels`] would have read them.
    fn cache_chunks(&self, stored: usize, end: [usize; 3], levels: &[u16]) {
        let info = &self.pyramid.levels[stored];
        let chunk = info.chunk;
        let grid: [usize; 3] = std::array::from_fn(|a| end[a].div_ceil(chunk[a]));
        for cz in 0..grid[2] {
            for cy in 0..grid[1] {
                for cx in 0..grid[0] {
                    let index = [cx, cy, cz];
                    let start: [usize; 3] = std::array::from_fn(|a| index[a] * chunk[a]);
                    let extent: [usize; 3] =
                        std::array::from_fn(|a| chunk[a].min(info.dims[a] - start[a]));
                    let mut out = Vec::with_capacity(extent.iter().product());
                    for z in 0..extent[2] {
                        for y in 0..extent[1] {
                            let from =
                                start[0] + end[0] * ((start[1] + y) + end[1] * (start[2] + z));
                            out.extend_from_slice(&levels[from..from + extent[0]]);
                        }
                    }
                    if let Ok(mut cache) = self.chunks.lock() {
                        cache.insert((stored, index), Arc::new(out));
                    }
                }
            }
        }
    }
}
