//! The requests a remote store makes, counted by the test's own HTTP server
//! (tests/support/http_server.rs): byte ranges of one object asked for together are coalesced
//! (adjacent ones one request, far-apart ones apart), a sharded region's inner chunks are
//! fetched shard by shard in one batch, and a streamer's next bricks are fetched ahead in its
//! order (coarse before fine), many in flight at once, without waiting (a sharded level's a
//! request per shard).

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use support::http_server::{Faults, FileServer, fixture_over_http};
use voxscope_stream::{BrickId, BrickSource, ZarrSource};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};
use voxscope_volume::remote::{COALESCE_GAP, RemoteOptions, RemoteStore};
use zarrs::storage::byte_range::ByteRange;
use zarrs::storage::{ReadableStorageTraits, StoreKey};

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr")
}

/// Waits (5 s at most) until no request is being answered: the server counts a body's
/// bytes once it has sent them, after the client may have read them.
fn answered(server: &FileServer) {
    let started = Instant::now();
    while server.counters.in_flight.load(Ordering::SeqCst) > 0
        && started.elapsed() < Duration::from_secs(5)
    {
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn requests(server: &FileServer) -> u64 {
    answered(server);
    server.counters.requests.load(Ordering::SeqCst)
}

fn bytes(server: &FileServer) -> u64 {
    answered(server);
    server.counters.bytes.load(Ordering::SeqCst)
}

/// `ranges` of the object `key`, through zarrs' store trait, as one call.
fn ranges_of(store: &RemoteStore, key: &str, ranges: &[(u64, u64)]) -> Vec<Vec<u8>> {
    let key = StoreKey::new(key).expect("a key");
    let asked: Vec<ByteRange> = ranges
        .iter()
        .map(|&(start, end)| ByteRange::FromStart(start, Some(end - start)))
        .collect();
    store
        .get_partial_many(&key, Box::new(asked.into_iter()))
        .unwrap_or_else(|e| panic!("{e}"))
        .expect("the object exists")
        .map(|part| part.unwrap_or_else(|e| panic!("{e}")).to_vec())
        .collect()
}

#[test]
fn adjacent_byte_ranges_of_one_object_are_one_request_far_apart_ones_are_not() {
    let folder = tempfile::tempdir().expect("a temporary folder");
    let blob: Vec<u8> = (0..1u32 << 20)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    std::fs::write(folder.path().join("blob"), &blob).expect("the blob");
    let server = FileServer::start(folder.path(), Faults::default());
    let store = RemoteStore::open(&server.url(""), RemoteOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let slice = |(start, end): (u64, u64)| blob[start as usize..end as usize].to_vec();

    // The first range alone: the store learns that the server honours `Range`.
    assert_eq!(ranges_of(&store, "blob", &[(0, 100)]), [slice((0, 100))]);
    assert_eq!(requests(&server), 1);

    // Four ranges side by side, or nearly (a gap of 100 bytes), asked in any order: one
    // request, for the run from the first start to the last end.
    let near = [
        (30_000, 40_000),
        (10_000, 20_000),
        (20_000, 30_000),
        (40_100, 50_000),
    ];
    let (requests_before, bytes_before) = (requests(&server), bytes(&server));
    let parts = ranges_of(&store, "blob", &near);
    assert_eq!(parts, near.map(slice), "the pieces, in the order asked");
    assert_eq!(
        requests(&server) - requests_before,
        1,
        "{:?}",
        server.counters.arrivals()
    );
    assert_eq!(bytes(&server) - bytes_before, 40_000);
    let (_, range) = server.counters.arrivals().pop().expect("a request");
    assert_eq!(range.as_deref(), Some("bytes=10000-49999"));

    // Far apart (more than the gap between them): a request each, only their bytes.
    let far = [(100_000, 101_000), (100_000 + 2 * COALESCE_GAP, 300_000)];
    let (requests_before, bytes_before) = (requests(&server), bytes(&server));
    assert_eq!(ranges_of(&store, "blob", &far), far.map(slice));
    assert_eq!(requests(&server) - requests_before, 2);
    assert_eq!(
        bytes(&server) - bytes_before,
        1_000 + 300_000 - (100_000 + 2 * COALESCE_GAP)
    );

    // Each coalesced piece is kept on its own: asked again, no request.
    let requests_before = requests(&server);
    assert_eq!(
        ranges_of(&store, "blob", &[(20_000, 30_000), (40_100, 50_000)]),
        [slice((20_000, 30_000)), slice((40_100, 50_000))]
    );
    assert_eq!(requests(&server), requests_before);
}

#[test]
fn a_sharded_regions_inner_chunks_come_in_one_request_per_shard() {
    let name = "head-v05-sharded-blosc-zstd.ome.zarr";
    let (server, pyramid) = fixture_over_http(name);
    let info = pyramid.levels[0].clone();
    let shard = info.shard.expect("level 0 is sharded");
    let inner: usize = (0..3)
        .map(|a| shard[a].min(info.dims[a]).div_ceil(info.chunk[a]))
        .product();
    assert!(inner >= 8, "{info:?}");
    // The first shard whole: its index, then its inner chunks in one request (they lie side
    // by side in the shard), where each inner chunk was a request of its own.
    let size: [usize; 3] = std::array::from_fn(|a| shard[a].min(info.dims[a]));
    let before = requests(&server);
    let _held = pyramid.prefetch_regions(&[(0, [0; 3], size)]);
    let arrivals = server.counters.arrivals();
    let key = pyramid.chunk_key(0, [0; 3]).expect("the shard's key");
    let asked: Vec<_> = arrivals[before as usize..]
        .iter()
        .filter(|(path, _)| path.ends_with(&key))
        .collect();
    assert_eq!(
        asked.len(),
        2,
        "the shard's index and one request for its {inner} inner chunks: {asked:?}"
    );
    // The region's read then asks for nothing more, and reads what the folder holds.
    let before = requests(&server);
    let region = pyramid
        .read_region(0, [0; 3], size)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        requests(&server),
        before,
        "{:?}",
        &server.counters.arrivals()[before as usize..]
    );
    let local = Pyramid::open(&fixtures().join(name), PyramidOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(region == local.read_region(0, [0; 3], size).unwrap());
}

#[test]
fn what_a_batch_fetched_is_read_without_a_second_request_even_where_no_fetched_byte_is_kept() {
    // No fetched byte is kept (a fetch cache of none): a region's chunks fetched together are
    // still what its read gets, held while the batch's answer lives, both for whole chunks
    // and for a shard's index and inner chunks. Without the hold the read fetched each chunk
    // again (three requests a chunk in all, measured). Once the answer is dropped, nothing
    // stays held.
    for name in [
        "head-v04-zstd.ome.zarr",
        "head-v05-sharded-blosc-zstd.ome.zarr",
    ] {
        let (server, pyramid) = fixture_over_http(name);
        pyramid.set_fetch_cache_bytes(0);
        let info = pyramid.levels[0].clone();
        let size: [usize; 3] = std::array::from_fn(|a| info.dims[a].min(48));
        let before = requests(&server);
        let held = pyramid.prefetch_regions(&[(0, [0; 3], size)]);
        let fetched = requests(&server) - before;
        assert!(fetched >= 2, "{name}: {fetched} requests");
        assert!(held.len() >= 2, "{name}: {} held", held.len());
        let region = pyramid
            .read_region(0, [0; 3], size)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            requests(&server) - before,
            fetched,
            "{name}: the read asked again: {:?}",
            &server.counters.arrivals()[before as usize..]
        );
        assert!(
            pyramid.fetch_cached_bytes() > 0,
            "{name}: what is held counts as fetched bytes in RAM"
        );
        let local = Pyramid::open(&fixtures().join(name), PyramidOptions::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            region == local.read_region(0, [0; 3], size).unwrap(),
            "{name}"
        );
        // Let go of, the bytes are fetched again by the next read.
        drop(held);
        assert_eq!(pyramid.fetch_cached_bytes(), 0, "{name}: nothing stays");
        let before = requests(&server);
        let again = pyramid
            .read_region(0, [0; 3], size)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(again == region, "{name}");
        assert!(
            requests(&server) > before,
            "{name}: nothing was fetched again"
        );
    }
}

/// A 240x200x120 CT phantom as OME-Zarr 0.4 in 64³ chunks: level 0 is 4x4x2 chunks.
fn converted_phantom(folder: &Path) -> String {
    let name = "phantom.ome.zarr";
    let out = Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args([
            "convert",
            "synthetic:ct:240x200x120",
            folder.join(name).to_str().expect("a UTF-8 path"),
            "--chunk",
            "64",
        ])
        .output()
        .expect("voxscope runs");
    assert!(
        out.status.success(),
        "convert: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    name.to_owned()
}

/// Waits until the server has answered `count` requests and none is in flight (10 s at most).
fn settle(server: &FileServer, count: u64) {
    let started = Instant::now();
    while (requests(server) < count || server.counters.in_flight.load(Ordering::SeqCst) > 0)
        && started.elapsed() < Duration::from_secs(10)
    {
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn bricks_fetched_ahead_go_out_in_their_order_many_at_once_without_waiting() {
    let folder = tempfile::tempdir().expect("a temporary folder");
    let name = converted_phantom(folder.path());
    let local = Pyramid::open(&folder.path().join(&name), PyramidOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let latency = Duration::from_millis(100);
    let open = |max_requests: usize| {
        let server = FileServer::start(
            folder.path(),
            Faults {
                latency,
                ..Faults::default()
            },
        );
        let pyramid = Pyramid::open_url(
            &server.url(&name),
            PyramidOptions::default(),
            RemoteOptions {
                max_requests,
                ..RemoteOptions::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let source = ZarrSource::new(Arc::new(pyramid)).unwrap_or_else(|e| panic!("{e}"));
        (server, source)
    };
    let brick = |level: u32, x: u32, y: u32, z: u32| BrickId {
        level,
        brick: [x, y, z],
        channel: 0,
    };

    // One request at a time: the chunks reach the server in the order of their bricks, a
    // coarse brick's (level 2: the store's third level, one chunk) before a fine one's or
    // after it, as asked. Each brick at a level's origin reads one chunk.
    let coarse = brick(2, 0, 0, 0);
    let fine = brick(0, 0, 0, 0);
    let local_source = ZarrSource::new(Arc::new(
        Pyramid::open(&folder.path().join(&name), PyramidOptions::default())
            .unwrap_or_else(|e| panic!("{e}")),
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let key_of = |id: BrickId| {
        let (stored, _) = local_source
            .stored_level(id.level as usize)
            .expect("a level");
        assert_eq!(stored, id.level as usize, "the store has the level");
        let key = local.chunk_key(stored, [0; 3]).expect("a chunk key");
        format!("{name}/{key}")
    };
    for order in [[coarse, fine], [fine, coarse]] {
        let (server, source) = open(1);
        let opened = requests(&server);
        let started = Instant::now();
        source.fetch_ahead(&order);
        assert!(
            started.elapsed() < latency,
            "fetch_ahead waited {:?} (latency {latency:?})",
            started.elapsed()
        );
        settle(&server, opened + 2);
        let arrivals: Vec<String> = server.counters.arrivals()[opened as usize..]
            .iter()
            .map(|(path, _)| path.clone())
            .collect();
        let wanted: Vec<String> = order.iter().map(|&id| key_of(id)).collect();
        assert_eq!(arrivals, wanted, "asked for {order:?}");
    }

    // Many bricks at once: their chunks all in flight together (one round trip, not one a
    // brick), each chunk once, and nothing asked again once kept.
    let (server, source) = open(32);
    let opened = requests(&server);
    let bricks: Vec<BrickId> = (0..4)
        .flat_map(|z| (0..7).flat_map(move |y| (0..8).map(move |x| brick(0, x, y, z))))
        .collect();
    let started = Instant::now();
    source.fetch_ahead(&bricks);
    assert!(started.elapsed() < latency, "{:?}", started.elapsed());
    // 8x7x4 bricks with their aprons cover level 0's 4x4x2 chunks.
    settle(&server, opened + 32);
    let fetched = requests(&server) - opened;
    let peak = server.counters.peak_in_flight.load(Ordering::SeqCst);
    assert_eq!(fetched, 32, "each chunk once");
    assert!(peak >= 16, "at most {peak} requests in flight at once");
    let trips = server.counters.sequential_round_trips();
    assert!(
        trips <= 3,
        "{trips} round trips one after another (opening's included)"
    );
    // Kept: fetched ahead again, or read, no request.
    source.fetch_ahead(&bricks);
    source
        .read_brick(brick(0, 1, 1, 1))
        .unwrap_or_else(|e| panic!("{e}"));
    std::thread::sleep(latency * 2);
    assert_eq!(requests(&server) - opened, 32);
    // A window whose first bricks were handed over before: passed over, and the coarser
    // brick behind them fetched (its level's chunk at the origin: one request).
    let mut window = bricks.clone();
    window.push(brick(2, 0, 0, 0));
    source.fetch_ahead(&window);
    settle(&server, opened + 33);
    std::thread::sleep(latency * 2);
    let arrivals = server.counters.arrivals();
    assert_eq!(
        requests(&server) - opened,
        33,
        "{:?}",
        &arrivals[opened as usize..]
    );
    assert_eq!(arrivals[arrivals.len() - 1].0, key_of(brick(2, 0, 0, 0)));
}

/// Sizes of the files under `folder` and its subfolders, metadata (dot files) left out.
fn file_sizes(folder: &Path) -> Vec<u64> {
    let mut sizes = Vec::new();
    for entry in std::fs::read_dir(folder).expect("a folder").flatten() {
        let path = entry.path();
        if path.is_dir() {
            sizes.extend(file_sizes(&path));
        } else if !entry.file_name().to_string_lossy().starts_with('.') {
            sizes.push(entry.metadata().expect("a file").len());
        }
    }
    sizes
}

#[test]
fn bricks_fetched_ahead_through_a_small_fetch_cache_cross_the_link_once() {
    // A fetch cache with room for six of the phantom's level-0 chunks, and a loader's way
    // through level 0: before each brick's read, the bricks from it on are handed to fetch
    // ahead. What is fetched ahead and not yet read stays within half the cache, so nothing
    // is dropped before its read: each chunk crosses the link once. Fetching the window's
    // 32 chunks at once, as before, dropped most of them before their reads, which fetched
    // them again.
    let folder = tempfile::tempdir().expect("a temporary folder");
    let name = converted_phantom(folder.path());
    let chunks = file_sizes(&folder.path().join(&name).join("0"));
    assert_eq!(chunks.len(), 32, "level 0 is 4x4x2 chunks");
    let largest = *chunks.iter().max().expect("chunks");
    let server = FileServer::start(
        folder.path(),
        Faults {
            latency: Duration::from_millis(20),
            ..Faults::default()
        },
    );
    let pyramid = Pyramid::open_url(
        &server.url(&name),
        PyramidOptions::default(),
        RemoteOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Every chunk is small enough to keep (a piece over a quarter of the cache is not).
    pyramid.set_fetch_cache_bytes(6 * largest);
    let source = ZarrSource::new(Arc::new(pyramid)).unwrap_or_else(|e| panic!("{e}"));
    let opened = requests(&server) as usize;
    let bricks: Vec<BrickId> = (0..4)
        .flat_map(|z| {
            (0..7).flat_map(move |y| {
                (0..8).map(move |x| BrickId {
                    level: 0,
                    brick: [x, y, z],
                    channel: 0,
                })
            })
        })
        .collect();
    // The first brick read (the chunks' size known), the rest fetched ahead: some go out
    // before their reads, as many as half the cache holds.
    source
        .read_brick(bricks[0])
        .unwrap_or_else(|e| panic!("{e}"));
    let (before, bytes_before) = (requests(&server), bytes(&server));
    source.fetch_ahead(&bricks[1..]);
    std::thread::sleep(Duration::from_millis(100));
    settle(&server, before + 1);
    let ahead = requests(&server) - before;
    let ahead_bytes = bytes(&server) - bytes_before;
    assert!(
        (1..=6).contains(&ahead) && ahead_bytes <= 3 * largest,
        "{ahead} chunks ({ahead_bytes} bytes) fetched ahead into a cache of six of {largest}"
    );
    for (i, &id) in bricks.iter().enumerate().skip(1) {
        source.fetch_ahead(&bricks[i..]);
        source.read_brick(id).unwrap_or_else(|e| panic!("{e}"));
    }
    answered(&server);
    let asked: Vec<String> = server.counters.arrivals()[opened..]
        .iter()
        .map(|(path, _)| path.clone())
        .collect();
    let distinct: std::collections::HashSet<&String> = asked.iter().collect();
    assert_eq!(distinct.len(), 32, "level 0's chunks: {asked:?}");
    assert_eq!(
        asked.len(),
        distinct.len(),
        "each chunk once: {} requests for {} chunks",
        asked.len(),
        distinct.len()
    );
}

#[test]
fn a_sharded_levels_bricks_fetched_ahead_come_in_one_request_per_shard() {
    // Level 0 of the fixture: 64x64x31 voxels, inner chunks of 16³ in shards of 32³ (2x2x1
    // shards), read as 2x2x1 bricks whose aprons reach into every shard. Fetched ahead, each
    // shard's index and then its inner chunks in one request; the bricks' reads then ask for
    // nothing more.
    let name = "head-v05-sharded-blosc-zstd.ome.zarr";
    let (server, pyramid) = fixture_over_http(name);
    let info = pyramid.levels[0].clone();
    assert_eq!(info.shard, Some([32, 32, 32]), "{info:?}");
    assert_eq!(info.chunk, [16, 16, 16], "{info:?}");
    let source = ZarrSource::new(Arc::new(pyramid)).unwrap_or_else(|e| panic!("{e}"));
    let grid = source.shape().levels[0].grid;
    assert_eq!(grid, [2, 2, 1]);
    let bricks: Vec<BrickId> = (0..2)
        .flat_map(|y| {
            (0..2).map(move |x| BrickId {
                level: 0,
                brick: [x, y, 0],
                channel: 0,
            })
        })
        .collect();
    let opened = requests(&server);
    source.fetch_ahead(&bricks);
    // Four shards: an index and a run of inner chunks each.
    settle(&server, opened + 8);
    std::thread::sleep(Duration::from_millis(200));
    let asked = &server.counters.arrivals()[opened as usize..];
    assert_eq!(asked.len(), 8, "{asked:?}");
    for shard in ["c/0/0/0", "c/0/0/1", "c/0/1/0", "c/0/1/1"] {
        let of_shard = asked.iter().filter(|(path, _)| path.ends_with(shard));
        assert_eq!(of_shard.count(), 2, "{shard}: {asked:?}");
    }
    let local = ZarrSource::new(Arc::new(
        Pyramid::open(&fixtures().join(name), PyramidOptions::default())
            .unwrap_or_else(|e| panic!("{e}")),
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    for &id in &bricks {
        let read = source.read_brick(id).unwrap_or_else(|e| panic!("{e}"));
        let expected = local.read_brick(id).unwrap_or_else(|e| panic!("{e}"));
        assert!(read.levels == expected.levels, "{id} differs");
    }
    assert_eq!(
        requests(&server) - opened,
        8,
        "{:?}",
        &server.counters.arrivals()[opened as usize..]
    );
}
