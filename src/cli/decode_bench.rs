//! The loaders' read-and-decode rate on their own, from the page cache (`bench --stream`'s
//! `decode`): a block of finest-level bricks around the volume's center read by as many threads
//! as the streamer's loaders, in the order its queue hands them out (nearest the center first),
//! each brick read as a loader reads it (the source's read and decode, then the atlas's texel
//! conversion). The block is read twice, each time by a fresh source (its decoded-chunk cache
//! empty): the first read puts the files in the page cache, the second is measured.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use serde_json::json;

use voxscope_stream::{AtlasTexels, BrickId, BrickSource, load_brick};

/// Finest-level bricks read at most (a block of 32 × 32 × 8 around the center: 8 192 bricks,
/// 644 MB of padded 16-bit voxels).
const BLOCK: [usize; 3] = [32, 32, 8];

/// The bricks of [`BLOCK`] (clamped to the level) around the finest level's center, nearest
/// the center first.
fn center_block(source: &dyn BrickSource) -> Vec<BrickId> {
    let grid = source.shape().levels[0].grid;
    let size: [usize; 3] = std::array::from_fn(|a| BLOCK[a].min(grid[a]));
    let first: [usize; 3] = std::array::from_fn(|a| (grid[a] - size[a]) / 2);
    let center: [f64; 3] = std::array::from_fn(|a| grid[a] as f64 / 2.0);
    let mut bricks = Vec::with_capacity(size.iter().product());
    for z in 0..size[2] {
        for y in 0..size[1] {
            for x in 0..size[0] {
                bricks.push(BrickId {
                    level: 0,
                    brick: [
                        (first[0] + x) as u32,
                        (first[1] + y) as u32,
                        (first[2] + z) as u32,
                    ],
                });
            }
        }
    }
    let distance = |id: &BrickId| -> f64 {
        (0..3)
            .map(|a| (id.brick[a] as f64 + 0.5 - center[a]).powi(2))
            .sum()
    };
    bricks.sort_by(|a, b| distance(a).total_cmp(&distance(b)));
    bricks
}

/// What one read of the block took.
struct BlockRead {
    seconds: f64,
    /// Padded voxels of the bricks read, as the atlas's texels.
    bytes: u64,
    /// Seconds the threads spent in reads (their sum).
    busy_seconds: f64,
    failed: usize,
}

/// Reads `bricks` with `workers` threads, each taking the next brick of the list.
fn read_block(
    source: &Arc<dyn BrickSource>,
    bricks: &[BrickId],
    workers: usize,
    texels: AtlasTexels,
) -> BlockRead {
    let next = AtomicUsize::new(0);
    let started = Instant::now();
    let per_thread: Vec<(u64, f64, usize)> = std::thread::scope(|scope| {
        let threads: Vec<_> = (0..workers.max(1))
            .map(|_| {
                scope.spawn(|| {
                    let (mut bytes, mut busy, mut failed) = (0u64, 0.0f64, 0usize);
                    while let Some(&id) = bricks.get(next.fetch_add(1, Ordering::Relaxed)) {
                        let reading = Instant::now();
                        let (brick, read) = load_brick(&**source, id, texels);
                        busy += reading.elapsed().as_secs_f64();
                        bytes += read;
                        failed += usize::from(brick.is_err());
                    }
                    (bytes, busy, failed)
                })
            })
            .collect();
        threads
            .into_iter()
            .map(|t| t.join().unwrap_or((0, 0.0, 1)))
            .collect()
    });
    BlockRead {
        seconds: started.elapsed().as_secs_f64(),
        bytes: per_thread.iter().map(|t| t.0).sum(),
        busy_seconds: per_thread.iter().map(|t| t.1).sum(),
        failed: per_thread.iter().map(|t| t.2).sum(),
    }
}

/// The read-and-decode rate of the sources `open` makes (each call a fresh one, its caches
/// sized for `ram_cache`), with `workers` threads, as JSON.
pub fn decode_rate(
    open: impl Fn() -> Result<Arc<dyn BrickSource>, String>,
    ram_cache: u64,
    workers: usize,
) -> Result<serde_json::Value, String> {
    let fresh = || -> Result<Arc<dyn BrickSource>, String> {
        let source = open()?;
        source.reserve_caches(ram_cache);
        Ok(source)
    };
    let source = fresh()?;
    let bricks = center_block(&*source);
    let texels = AtlasTexels::Unorm16;
    // Into the page cache.
    let warm = read_block(&source, &bricks, workers, texels);
    drop(source);
    let measured = read_block(&fresh()?, &bricks, workers, texels);
    let rate = |bytes: u64, seconds: f64| (seconds > 0.0).then(|| bytes as f64 / seconds);
    Ok(json!({
        "bricks": bricks.len(),
        "level": 0,
        "workers": workers,
        "bytes": measured.bytes,
        "seconds": measured.seconds,
        "bytes_per_s": rate(measured.bytes, measured.seconds),
        "bytes_per_s_per_thread": rate(measured.bytes, measured.busy_seconds),
        "failed": measured.failed,
        "first_read_seconds": warm.seconds,
        "first_read_bytes_per_s": rate(warm.bytes, warm.seconds),
    }))
}
