//! Thin-chunked stores (issue 54): one-plane chunks, as acquisitions write them, read brick by
//! brick. The fixtures (tests/data/thin-chunks, written by zarr-python and ome-zarr-py) hold
//! the same voxels in one-plane chunks (0.4), in one-plane inner chunks of 16-plane shards
//! (0.5) and in 64³ chunks (0.4).

mod support;

use std::path::PathBuf;
use std::sync::Arc;

use support::http_server::{Faults, FileServer};
use voxscope_stream::{BrickId, BrickSource, ZarrSource};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};
use voxscope_volume::remote::RemoteOptions;

const THIN: &str = "thin-v04.ome.zarr";
const THIN_SHARDED: &str = "thin-v05-sharded.ome.zarr";
const CUBIC: &str = "cubic64-v04.ome.zarr";

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/thin-chunks")
}

fn open(name: &str) -> ZarrSource {
    let pyramid = Pyramid::open(&fixtures().join(name), PyramidOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    ZarrSource::new(Arc::new(pyramid)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn open_url(server: &FileServer, name: &str) -> ZarrSource {
    let pyramid = Pyramid::open_url(
        &server.url(name),
        PyramidOptions::default(),
        RemoteOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    ZarrSource::new(Arc::new(pyramid)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Every brick of pyramid level `level`, x fastest.
fn bricks(source: &ZarrSource, level: u32) -> Vec<BrickId> {
    let grid = source.shape().levels[level as usize].grid;
    let mut ids = Vec::new();
    for z in 0..grid[2] as u32 {
        for y in 0..grid[1] as u32 {
            for x in 0..grid[0] as u32 {
                ids.push(BrickId {
                    level,
                    brick: [x, y, z],
                    channel: 0,
                });
            }
        }
    }
    ids
}

#[test]
fn the_thin_stores_bricks_equal_the_cubic_stores() {
    let cubic = open(CUBIC);
    for name in [THIN, THIN_SHARDED] {
        let thin = open(name);
        assert_eq!(
            thin.shape().levels.len(),
            cubic.shape().levels.len(),
            "{name}"
        );
        for level in 0..cubic.shape().levels.len() as u32 {
            for id in bricks(&cubic, level) {
                let expected = cubic.read_brick(id).unwrap();
                assert_eq!(thin.read_brick(id).unwrap(), expected, "{name}: {id}");
            }
        }
    }
}

#[test]
fn a_thin_stores_bricks_decode_each_chunk_once() {
    // Level 0 is 96 × 96 × 40 voxels in 40 one-plane chunks: its 3 × 3 × 2 bricks (aprons
    // included) reach every plane, nine bricks each, and the two layers share planes 31 and 32.
    for name in [THIN, THIN_SHARDED] {
        let thin = open(name);
        for id in bricks(&thin, 0) {
            thin.read_brick(id).unwrap();
        }
        assert_eq!(thin.chunks_decoded(), 40, "{name}");
    }
}

#[test]
fn a_thin_store_keeps_no_faces_of_its_planes() {
    // A one-plane chunk's faces are the plane twice over: what the source keeps of level 0
    // is its 40 decoded planes of 96 × 96 value levels, and nothing more.
    let thin = open(THIN);
    for id in bricks(&thin, 0) {
        thin.read_brick(id).unwrap();
    }
    let planes = 40 * 96 * 96 * 2;
    assert!(
        thin.cached_bytes() <= planes,
        "{} bytes kept for {planes} of planes",
        thin.cached_bytes()
    );
}

#[test]
fn a_sharded_thin_stores_brick_reads_its_inner_chunks_of_a_shard_in_few_requests() {
    // A level-0 brick of the first layer reaches planes 0..=32 (its apron clamped below):
    // 16 inner chunks of the first shard, 16 of the second and 1 of the third. Each shard's
    // inner chunks are adjacent: one request each (after the shard indexes), not one per
    // inner chunk (36 requests).
    let server = FileServer::start(&fixtures(), Faults::default());
    let thin = open_url(&server, THIN_SHARDED);
    let before = thin.remote_stats().unwrap().requests;
    let arrivals_before = server.counters.arrivals().len();
    thin.read_brick(BrickId {
        level: 0,
        brick: [1, 1, 0],
        channel: 0,
    })
    .unwrap();
    let requests = thin.remote_stats().unwrap().requests - before;
    let arrivals = server.counters.arrivals()[arrivals_before..].to_vec();
    // Three shard indexes and one range of each shard.
    assert!(
        requests <= 6,
        "{requests} requests for one brick's 33 inner chunks: {arrivals:?}"
    );
    assert_eq!(thin.chunks_decoded(), 33);
}

#[test]
fn a_thin_store_over_a_network_fetches_each_chunk_once_for_a_layer_of_bricks() {
    let server = FileServer::start(&fixtures(), Faults::default());
    let thin = open_url(&server, THIN);
    let before = thin.remote_stats().unwrap();
    let first_layer: Vec<BrickId> = bricks(&thin, 0)
        .into_iter()
        .filter(|id| id.brick[2] == 0)
        .collect();
    for id in first_layer {
        thin.read_brick(id).unwrap();
    }
    let after = thin.remote_stats().unwrap();
    // Planes 0..=32 (the layer and its apron above), one object each, fetched once for the
    // nine bricks.
    assert_eq!(after.requests - before.requests, 33);
    assert_eq!(thin.chunks_decoded(), 33);
}

#[test]
fn a_thin_store_gives_decoded_chunks_half_the_ram() {
    // Under a RAM budget, a thin store's decoded planes get half (every brick of a layer is a
    // copy from the same planes), a 64³ store's chunks a quarter; faces a sixteenth of both.
    let ram = 64 << 20;
    assert_eq!(open(THIN).reserve_caches(ram), ram / 2 + ram / 16);
    assert_eq!(open(THIN_SHARDED).reserve_caches(ram), ram / 2 + ram / 16);
    assert_eq!(open(CUBIC).reserve_caches(ram), ram / 4 + ram / 16);
}

#[test]
fn fetching_ahead_passes_over_a_sharded_thin_levels_bricks_once_their_planes_are_decoded() {
    // The loaders fetch ahead before each brick they take, over the queue's next bricks, and
    // every level-0 brick of a thin level reaches its layer's planes (here 33 or 9): looking
    // all of them up again at each call, under the decoded chunks' lock, was most of what the
    // loaders did during a level-0 view of a 1024×1024×256 store over a link (32 s against
    // the 64³ store's 6.8 s, the link idle after 10 s). A brick whose planes are all decoded
    // is looked at once.
    let server = FileServer::start(&fixtures(), Faults::default());
    let thin = open_url(&server, THIN_SHARDED);
    let level0 = bricks(&thin, 0);
    for &id in &level0 {
        thin.read_brick(id).unwrap();
    }
    let requests = thin.remote_stats().unwrap().requests;
    thin.fetch_ahead(&level0);
    let once = thin.chunks_looked_at_ahead();
    // Nine bricks of the first layer reach planes 0..=32, nine of the second 31..=39.
    assert_eq!(once, 9 * 33 + 9 * 9);
    for _ in 0..10 {
        thin.fetch_ahead(&level0);
    }
    assert_eq!(
        thin.chunks_looked_at_ahead(),
        once,
        "planes looked up again for bricks whose planes are all decoded"
    );
    // Nothing was fetched again: every plane is decoded.
    assert_eq!(thin.remote_stats().unwrap().requests, requests);
}
