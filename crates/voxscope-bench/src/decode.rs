//! The loaders' read-and-decode rate on their own, from the page cache (the streaming
//! benchmark's `decode`): a block of finest-level bricks around the volume's center read by the
//! streamer's loaders (as many threads, the same queue and the same reads: the source's read
//! and decode, then the atlas's texel conversion), nearest the center first. The block is read
//! twice, each time by a fresh source (its decoded-chunk cache empty): the first read puts the
//! files in the page cache, the second is measured.

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::json;

use voxscope_stream::{
    AtlasTexels, BrickId, BrickSource, Loader, Priority, Request, RequestQueue, Tier,
};

use crate::error::BenchError;

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
                    channel: 0,
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

/// How long the block's read may take before the benchmark gives up on the bricks left.
const MAX_BLOCK_SECONDS: Duration = Duration::from_secs(120);

/// Reads `bricks` (nearest the center first) with `workers` loaders, as the streamer's
/// loaders read them.
fn read_block(
    source: &Arc<dyn BrickSource>,
    bricks: &[BrickId],
    workers: usize,
    texels: AtlasTexels,
) -> Result<BlockRead, BenchError> {
    let queue = Arc::new(RequestQueue::default());
    let requests = bricks
        .iter()
        .enumerate()
        .map(|(order, &id)| {
            let key = source.shape().key(id).ok_or_else(|| BenchError::NoBrick {
                volume: source.name().to_owned(),
                id,
            })?;
            Ok(Request {
                priority: Priority::new(Tier::Visible, 0, order as f32),
                id,
                key,
            })
        })
        .collect::<Result<Vec<_>, BenchError>>()?;
    let started = Instant::now();
    queue.replace(requests);
    let loader = Loader::start(Arc::clone(source), queue, texels, workers);
    let (mut bytes, mut busy_seconds, mut failed, mut received) = (0u64, 0.0f64, 0usize, 0usize);
    while received < bricks.len() {
        let left = MAX_BLOCK_SECONDS.saturating_sub(started.elapsed());
        let Some(result) = loader.next_received(left) else {
            return Err(BenchError::LoadersTooSlow {
                volume: source.name().to_owned(),
                received,
                total: bricks.len(),
                seconds: MAX_BLOCK_SECONDS.as_secs(),
            });
        };
        received += 1;
        bytes += result.bytes_read;
        busy_seconds += result.seconds;
        failed += usize::from(result.brick.is_err());
    }
    Ok(BlockRead {
        seconds: started.elapsed().as_secs_f64(),
        bytes,
        busy_seconds,
        failed,
    })
}

/// The read-and-decode rate of the sources `open` makes (each call a fresh one, its caches
/// sized for `ram_cache`), with `workers` threads, as JSON.
pub fn decode_rate(
    open: impl Fn() -> Result<Arc<dyn BrickSource>, BenchError>,
    ram_cache: u64,
    workers: usize,
) -> Result<serde_json::Value, BenchError> {
    let fresh = || -> Result<Arc<dyn BrickSource>, BenchError> {
        let source = open()?;
        source.reserve_caches(ram_cache);
        Ok(source)
    };
    let source = fresh()?;
    let bricks = center_block(&*source);
    let texels = AtlasTexels::Unorm16;
    // Into the page cache.
    let warm = read_block(&source, &bricks, workers, texels)?;
    drop(source);
    let measured = read_block(&fresh()?, &bricks, workers, texels)?;
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
