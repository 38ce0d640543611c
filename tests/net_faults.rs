//! Faults on the wire and in the store (issue 29), one test per fault, against the seeded
//! fault-injecting server (tests/support/fault_server.rs) on 127.0.0.1 and damaged copies of
//! stores (tests/support/damage.rs): a silent server costs one timeout and never a render's
//! `--max-wait`; a malformed URL is one line; no secret is shown and basic authentication is
//! sent; a dead chunk costs its bricks (drawn coarser, listed, exit code 3), not the render;
//! chunked and close-delimited bodies and a server that ignores `Range` are read; a store of
//! tiny chunks is refused up front; messages give the cause whole; dead objects are not asked
//! for again and again, one fetch per object at a time, `Retry-After` honoured.

mod support;

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use support::damage::{self, StoreKind};
use support::fault_server::{FaultPlan, FaultServer, Framing, base64_encode};
use voxscope_stream::{BrickId, BrickSource, ZarrSource};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};
use voxscope_volume::remote::{RemoteOptions, RemoteStore, Timing};

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr")
}

fn voxscope(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_voxscope"));
    command.args(args);
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Short time bounds, so that a test of retries and silence takes a second, not a minute.
fn fast() -> RemoteOptions {
    RemoteOptions {
        timing: Timing {
            connect: Duration::from_millis(500),
            request: Duration::from_millis(400),
            open_deadline: Duration::from_secs(2),
            read_deadline: Duration::from_secs(3),
            max_retries: 8,
            first_backoff: Duration::from_millis(2),
            max_backoff: Duration::from_millis(20),
            max_retry_after: Duration::from_secs(3),
            remember_failure: Duration::from_millis(500),
            max_remembered: Duration::from_secs(5),
            silence_cool_down: Duration::from_millis(500),
        },
        ..RemoteOptions::default()
    }
}

/// A port nothing listens on.
fn closed_port() -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    listener.local_addr().expect("address").port()
}

/// The one line of a failed command, checked for one line and against every `secret`.
fn one_line_error(out: &Output, secrets: &[&str]) -> String {
    assert!(!out.status.success(), "it should have failed");
    let text = stderr(out);
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "not one line: {text}");
    assert!(!text.contains("panicked"), "{text}");
    for secret in secrets {
        assert!(!text.contains(secret), "'{secret}' is shown: {text}");
    }
    lines[0].to_owned()
}

/// `convert synthetic:ct:200x160x120 --chunk 32` (OME-Zarr 0.4: levels 200, 100, 50 and 25
/// voxels along x, keys `L/z/y/x`) into `folder`.
fn ct_store(folder: &Path) -> PathBuf {
    let store = folder.join("ct.ome.zarr");
    let out = voxscope(
        &[
            "convert",
            "synthetic:ct:200x160x120",
            store.to_str().expect("UTF-8"),
            "--chunk",
            "32",
            "--format",
            "0.4",
        ],
        &[],
    );
    assert!(out.status.success(), "convert: {}", stderr(&out));
    store
}

/// A chunk (not a document) of the store's level 0.
fn level0_chunk(path: &str) -> bool {
    let Some((_, key)) = path.split_once(".ome.zarr/") else {
        return false;
    };
    key.starts_with("0/") && !damage::is_metadata(Path::new(key))
}

/// Any chunk (not a document).
fn any_chunk(path: &str) -> bool {
    !damage::is_metadata(Path::new(path))
}

#[test]
fn a_server_that_goes_silent_costs_one_timeout_and_never_a_renders_max_wait() {
    // Every chunk unanswered, the documents answered: one request timeout for all of a
    // level's chunks (then the server counts as silent and the rest fail at once).
    let dir = tempfile::tempdir().unwrap();
    let store = damage::write_store(dir.path(), StoreKind::Gzip);
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            silent: Some(any_chunk),
            ..FaultPlan::default()
        },
    );
    let options = fast();
    let url = server.url(StoreKind::Gzip.name());
    let pyramid = Pyramid::open_url(&url, PyramidOptions::default(), options)
        .unwrap_or_else(|e| panic!("{e}"));
    let started = Instant::now();
    for level in 0..pyramid.levels.len() {
        let error = pyramid.read_level(level).expect_err("nothing answers");
        assert!(error.problem.contains("no answer"), "{error}");
    }
    let seconds = started.elapsed().as_secs_f64();
    let timing = options.timing;
    // One request's time (400 ms) and the operations' retries around it, not one a chunk.
    let bound = (timing.request + timing.read_deadline).as_secs_f64();
    assert!(
        seconds < bound,
        "{seconds:.2} s for {} levels (bound {bound} s)",
        pyramid.levels.len()
    );
    drop(store);

    // The real binary: level 0 goes silent, the coarser levels answer. The image is written
    // when --max-wait runs out, and the process ends then (its loaders are not waited for).
    let ct = ct_store(dir.path());
    let server = FaultServer::start(
        ct.parent().unwrap(),
        FaultPlan {
            silent: Some(level0_chunk),
            ..FaultPlan::default()
        },
    );
    let png = dir.path().join("silent.png");
    let started = Instant::now();
    let out = voxscope(
        &[
            "render",
            &server.url("ct.ome.zarr"),
            "--renderer",
            "stream",
            "--lod-scale",
            "0",
            "--size",
            "160x120",
            "--max-wait",
            "3",
            "-o",
            png.to_str().unwrap(),
        ],
        &[],
    );
    let seconds = started.elapsed().as_secs_f64();
    let text = stderr(&out);
    // Written, and incomplete by its exit code.
    assert_eq!(out.status.code(), Some(3), "{text}");
    assert!(text.contains("still coarse after"), "{text}");
    assert!(png.exists());
    assert!(
        seconds < 3.0 + 10.0,
        "render took {seconds:.1} s with --max-wait 3: {text}"
    );
    assert!(support::reference::coverage(&image::open(&png).unwrap().to_rgba8()) > 0.02);
}

#[test]
fn info_on_a_server_whose_chunks_never_come_fails_in_one_line_within_its_bound() {
    let dir = tempfile::tempdir().unwrap();
    damage::write_store(dir.path(), StoreKind::Zstd);
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            silent: Some(any_chunk),
            ..FaultPlan::default()
        },
    );
    let started = Instant::now();
    let out = voxscope(&["info", &server.url(StoreKind::Zstd.name())], &[]);
    let seconds = started.elapsed().as_secs_f64();
    let line = one_line_error(&out, &[]);
    let timing = Timing::default();
    assert!(line.contains("no answer"), "{line}");
    // One request's time with its operation's retries: not one a chunk, not one a level.
    let bound = timing.read_deadline.as_secs_f64() + 5.0;
    assert!(
        seconds < bound,
        "info took {seconds:.1} s (bound {bound} s): {line}"
    );
}

#[test]
fn a_malformed_url_is_one_line_and_panics_nothing() {
    for url in [
        "http://u:hunter2secret@{bad}/z.ome.zarr",
        "http://u:hunter2secret@exa mple.org/z.ome.zarr",
        "s3://bucket{x}/z.ome.zarr",
        "http://[::zz]/z.ome.zarr?t=hunter2secret",
    ] {
        let out = voxscope(&["info", url], &[]);
        let line = one_line_error(&out, &["hunter2secret"]);
        assert_eq!(out.status.code(), Some(1), "{url}: {line}");
        assert!(
            line.contains("URL") || line.contains("bucket"),
            "{url}: {line}"
        );
    }
    let Err(problem) = RemoteStore::open("http://u:p@{bad}/z", RemoteOptions::default()) else {
        panic!("a host with braces opened");
    };
    let problem = problem.to_string();
    assert!(problem.contains("no host name"), "{problem}");
}

#[test]
fn no_secret_is_shown_and_basic_authentication_is_sent() {
    // Refused: the cause, the URL without user, password or query.
    let port = closed_port();
    let out = voxscope(
        &[
            "info",
            &format!("http://alice:hunter2secret@127.0.0.1:{port}/z.ome.zarr?t=SECRETTOK"),
        ],
        &[],
    );
    let line = one_line_error(&out, &["hunter2secret", "SECRETTOK", "alice"]);
    assert!(line.contains("connection refused"), "{line}");
    assert!(
        line.starts_with(&format!("error: http://127.0.0.1:{port}/z.ome.zarr")),
        "{line}"
    );

    // A password in the S3 endpoint.
    let out = voxscope(
        &["info", "s3://bucket/z.ome.zarr"],
        &[
            (
                "AWS_ENDPOINT_URL",
                &format!("http://key:endpointSECRET@127.0.0.1:{port}"),
            ),
            ("AWS_ACCESS_KEY_ID", "AKIDTEST"),
            ("AWS_SECRET_ACCESS_KEY", "secretKEYvalue"),
            ("AWS_REGION", "us-east-1"),
            ("AWS_SHARED_CREDENTIALS_FILE", "/nonexistent"),
            ("AWS_CONFIG_FILE", "/nonexistent"),
        ],
    );
    one_line_error(&out, &["endpointSECRET", "secretKEYvalue"]);

    // Basic authentication: sent from the URL, and the server lets the store be read.
    let server = FaultServer::start(
        &fixtures(),
        FaultPlan {
            require_auth: Some(("alice".into(), "pa:ss word".into())),
            ..FaultPlan::default()
        },
    );
    let name = "head-v04-zstd.ome.zarr";
    let with_password = server
        .url(name)
        .replacen("http://", "http://alice:pa%3Ass%20word@", 1);
    let out = voxscope(&["info", &with_password], &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let printed = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
    assert!(
        !printed.contains("pa:ss") && !printed.contains("alice"),
        "{printed}"
    );
    let expected = format!("Basic {}", base64_encode(b"alice:pa:ss word"));
    let seen = server.counters.authorization.lock().unwrap().clone();
    assert!(
        !seen.is_empty() && seen.iter().all(|h| h.as_deref() == Some(expected.as_str())),
        "{seen:?}"
    );
    // Without it: refused in words.
    let line = one_line_error(&voxscope(&["info", &server.url(name)], &[]), &[]);
    assert!(line.contains("not authenticated (HTTP 401)"), "{line}");
    // Never over plain HTTP to another machine.
    let Err(problem) = RemoteStore::open(
        "http://alice:pw@example.org/x.zarr",
        RemoteOptions::default(),
    ) else {
        panic!("a password for plain HTTP elsewhere was accepted");
    };
    let problem = problem.to_string();
    assert!(
        problem.contains("only over https://") && !problem.contains("pw"),
        "{problem}"
    );
}

/// `render` of `url` through the stream renderer at max level `level` (no pixel LOD), into
/// `png`.
fn render_stream(url: &str, level: u32, png: &Path) -> Output {
    voxscope(
        &[
            "render",
            url,
            "--renderer",
            "stream",
            "--lod-scale",
            "0",
            "--level",
            &level.to_string(),
            "--size",
            "160x120",
            "--max-wait",
            "60",
            "-o",
            png.to_str().unwrap(),
        ],
        &[],
    )
}

#[test]
fn a_dead_chunk_costs_its_bricks_drawn_coarser_not_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let ct = ct_store(dir.path());
    let folder = dir.path().join("folder.png");
    // The folder's picture one level coarser: what the broken level is drawn from.
    let out = render_stream(ct.to_str().unwrap(), 7, &folder);
    assert!(out.status.success(), "{}", stderr(&out));

    // Every chunk of level 0 answers 500: the view's level-0 bricks are unreadable, drawn from
    // level 1; one summary line, the image written, exit code 3.
    let server = FaultServer::start(dir.path(), dead_level0());
    let png = dir.path().join("dead-level0.png");
    let out = render_stream(&server.url("ct.ome.zarr"), 8, &png);
    let text = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{text}");
    let lines: Vec<&str> = text.lines().collect();
    let unreadable = incomplete_count(&text);
    assert!(unreadable > 8, "{text}");
    let summaries: Vec<&&str> = lines
        .iter()
        .filter(|l| l.contains("bricks unreadable ("))
        .collect();
    assert_eq!(summaries.len(), 1, "one summary line for one cause: {text}");
    assert!(
        summaries[0].contains(&format!(
            "{unreadable} bricks unreadable (level 0: {unreadable})"
        )) && summaries[0].contains("): HTTP 500 Internal Server Error; the first: "),
        "{text}"
    );
    assert!(lines.len() <= 4, "no line per brick: {text}");
    let image = image::open(&png).unwrap().to_rgba8();
    let coarser = image::open(&folder).unwrap().to_rgba8();
    let db = support::reference::psnr(&image, &coarser);
    assert!(
        db >= 30.0,
        "drawn from level 1: {db:.1} dB against the folder's level 1"
    );

    // One dead chunk: its few bricks listed once each, the rest drawn as the folder's.
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            always_500: vec!["ct.ome.zarr/0/1/1/1".into()],
            ..FaultPlan::default()
        },
    );
    let png = dir.path().join("dead-chunk.png");
    let out = render_stream(&server.url("ct.ome.zarr"), 8, &png);
    let text = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{text}");
    let unreadable = incomplete_count(&text);
    assert!(unreadable >= 1, "{text}");
    if unreadable <= 8 {
        // Few: each brick once, with its chunk and cause.
        let listed: Vec<&str> = text
            .lines()
            .filter(|l| l.starts_with("unreadable: level 0 brick"))
            .collect();
        assert_eq!(listed.len(), unreadable, "{text}");
        assert!(
            listed
                .iter()
                .all(|l| l.contains("chunk '0/1/1/1'") && l.contains("HTTP 500")),
            "{text}"
        );
    } else {
        assert_eq!(
            text.lines()
                .filter(|l| l.contains("bricks unreadable ("))
                .count(),
            1,
            "{text}"
        );
    }
    // Requests to the dead chunk: one operation's tries (9) and, at most, one more operation
    // per brick retry; never one a brick and a frame.
    let requests = server.counters.path("/ct.ome.zarr/0/1/1/1").requests;
    assert!(
        (9..=18).contains(&requests),
        "{requests} requests to the dead chunk"
    );
}

/// N of the last line's `; incomplete: N bricks unreadable` (`render`'s line ends so).
fn incomplete_count(text: &str) -> usize {
    let last = text.lines().last().unwrap_or_default();
    assert!(last.starts_with("wrote "), "{text}");
    let Some((_, count)) = last.rsplit_once("; incomplete: ") else {
        panic!("the line does not end with 'incomplete: N bricks unreadable': {last}");
    };
    count
        .trim_end_matches(" bricks unreadable")
        .trim_end_matches(" brick unreadable")
        .parse()
        .unwrap_or_else(|_| panic!("{last}"))
}

/// Every chunk of level 0 answers 500.
fn dead_level0() -> FaultPlan {
    FaultPlan {
        error_500: 0.0,
        always_500: (0..4)
            .flat_map(|z| {
                (0..5).flat_map(move |y| (0..7).map(move |x| format!("ct.ome.zarr/0/{z}/{y}/{x}")))
            })
            .collect(),
        ..FaultPlan::default()
    }
}

/// Every level of `name` read over `server` equals the folder's.
fn assert_reads_equal(server: &FaultServer, root: &Path, name: &str, options: RemoteOptions) {
    let local = Pyramid::open(&root.join(name), PyramidOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let remote = Pyramid::open_url(&server.url(name), PyramidOptions::default(), options)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    for level in 0..local.levels.len() {
        let a = local.read_level(level).unwrap_or_else(|e| panic!("{e}"));
        let b = remote
            .read_level(level)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(a == b, "{name}: level {level} differs");
    }
}

#[test]
fn chunked_and_close_delimited_bodies_and_ignored_ranges_are_read() {
    let names = [
        "head-v04-zstd.ome.zarr",
        "head-v05-sharded-blosc-zstd.ome.zarr",
        "plain-v2-gzip.zarr",
        "plain-v3-none.zarr",
    ];
    for (framing, ignore_range) in [
        (Framing::Chunked, false),
        (Framing::Close, false),
        (Framing::Mixed, true),
    ] {
        let server = FaultServer::start(
            &fixtures(),
            FaultPlan {
                framing,
                ignore_range,
                seed: 7,
                ..FaultPlan::default()
            },
        );
        for name in names {
            assert_reads_equal(&server, &fixtures(), name, fast());
        }
    }
}

#[test]
fn a_server_that_ignores_range_streams_a_sharded_store_to_completion() {
    // Issue 28, item 3: Python's http.server answers a ranged GET with the whole file.
    let name = "head-v05-sharded-blosc-zstd.ome.zarr";
    let server = FaultServer::start(
        &fixtures(),
        FaultPlan {
            ignore_range: true,
            ..FaultPlan::default()
        },
    );
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("folder.png"), dir.path().join("url.png"));
    let out = voxscope(
        &[
            "render",
            fixtures().join(name).to_str().unwrap(),
            "--renderer",
            "stream",
            "--size",
            "160x120",
            "-o",
            a.to_str().unwrap(),
        ],
        &[],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = voxscope(
        &[
            "render",
            &server.url(name),
            "--renderer",
            "stream",
            "--size",
            "160x120",
            "-o",
            b.to_str().unwrap(),
        ],
        &[],
    );
    let text = stderr(&out);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("complete after") && !text.contains("unreadable"),
        "{text}"
    );
    let db = support::reference::psnr(
        &image::open(&a).unwrap().to_rgba8(),
        &image::open(&b).unwrap().to_rgba8(),
    );
    assert!(db >= 40.0, "{db:.1} dB against the folder: {text}");
    // Each shard was sent whole once or so, not once per inner chunk and index.
    let shards: Vec<(String, u64)> = server
        .counters
        .paths
        .lock()
        .unwrap()
        .iter()
        .filter(|(p, _)| p.contains("/c/"))
        .map(|(p, s)| (p.clone(), s.requests))
        .collect();
    assert!(!shards.is_empty());
    assert!(shards.iter().all(|(_, n)| *n <= 2), "{shards:?}");
}

#[test]
fn stores_of_tiny_chunks_are_refused_up_front() {
    // A 64³ array in 1-voxel chunks (262 144 objects; none needs to exist: each would read as
    // the fill value).
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("tiny.zarr");
    std::fs::create_dir(&store).unwrap();
    std::fs::write(
        store.join("zarr.json"),
        r#"{"zarr_format": 3, "node_type": "array", "shape": [64, 64, 64], "data_type": "uint8",
            "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": [1, 1, 1]}},
            "chunk_key_encoding": {"name": "default"}, "fill_value": 0,
            "codecs": [{"name": "bytes"}]}"#,
    )
    .unwrap();
    let server = FaultServer::start(dir.path(), FaultPlan::default());
    let url = server.url("tiny.zarr");
    let started = Instant::now();
    let line = one_line_error(&voxscope(&["info", &url], &[]), &[]);
    assert!(
        line.contains("262144 requests") && line.contains("voxscope convert"),
        "{line}"
    );
    let png = dir.path().join("tiny.png");
    let out = voxscope(
        &[
            "render",
            &url,
            "--renderer",
            "stream",
            "-o",
            png.to_str().unwrap(),
        ],
        &[],
    );
    let line = one_line_error(&out, &[]);
    assert!(
        line.contains("chunks of 1x1x1 voxels") && line.contains("voxscope convert"),
        "{line}"
    );
    assert!(started.elapsed() < Duration::from_secs(20));
    // Metadata only (each open's first round trip guesses the documents of levels 0 to 7
    // beside the root's), never a chunk.
    let paths: Vec<String> = server
        .counters
        .paths
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .keys()
        .cloned()
        .collect();
    assert!(
        paths.iter().all(|path| !path.contains("/c/")),
        "a chunk was read before refusing: {paths:?}"
    );
    let requests = server.counters.requests.load(Ordering::SeqCst);
    assert!(requests < 100, "{requests} requests before refusing");
}

#[test]
fn messages_give_the_cause_first_and_whole() {
    // A 500 after its retries, a refused connection: the status or the cause, never cut.
    let dir = tempfile::tempdir().unwrap();
    let store = damage::write_store(dir.path(), StoreKind::Zstd);
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            always_500: vec!["/c/0/1/1".into()],
            ..FaultPlan::default()
        },
    );
    let url = server.url(StoreKind::Zstd.name());
    let pyramid = Pyramid::open_url(&url, PyramidOptions::default(), fast()).unwrap();
    let error = pyramid.read_level(0).expect_err("a dead chunk");
    assert!(
        error
            .problem
            .ends_with("chunk '0/c/0/1/1': HTTP 500 Internal Server Error (after 9 tries)"),
        "{error}"
    );
    assert_eq!(
        error.cause.as_deref(),
        Some("HTTP 500 Internal Server Error")
    );
    let port = closed_port();
    let refused = Pyramid::open_url(
        &format!("http://127.0.0.1:{port}/x.zarr"),
        PyramidOptions::default(),
        fast(),
    )
    .expect_err("nothing listens");
    assert!(refused.problem.contains("connection refused"), "{refused}");

    // A local chunk cut short says so, with its size.
    let copy = dir.path().join("short.ome.zarr");
    let raw = damage::write_store(dir.path(), StoreKind::Raw);
    damage::copy_store(&raw, &copy);
    std::fs::write(copy.join("0/0/0/0"), [1u8, 2, 3]).unwrap();
    let error = Pyramid::open(&copy, PyramidOptions::default())
        .unwrap()
        .read_level(0)
        .expect_err("a short chunk");
    assert!(
        error
            .problem
            .contains("chunk '0/0/0/0': the size of a decoded chunk is 3, expected 1024"),
        "{error}"
    );
    assert_eq!(error.kind, voxscope_volume::LoadErrorKind::Decode);
    // Zarr v3 without compression: zarrs reads the chunk's bytes by their offsets.
    let plain = dir.path().join("plain-v3-none.zarr");
    damage::copy_store(&fixtures().join("plain-v3-none.zarr"), &plain);
    std::fs::write(plain.join("c/0/1/0"), [1u8, 2, 3]).unwrap();
    let error = Pyramid::open(&plain, PyramidOptions::default())
        .unwrap()
        .read_level(0)
        .expect_err("a short chunk");
    assert!(
        error
            .problem
            .contains("chunk 'c/0/1/0': the chunk is shorter than its data (3 bytes)"),
        "{error}"
    );
    assert_eq!(error.kind, voxscope_volume::LoadErrorKind::Decode);

    // A store that convert is still writing: its levels are there, its root document not.
    let unfinished = dir.path().join("unfinished.ome.zarr");
    damage::copy_store(&store, &unfinished);
    std::fs::remove_file(unfinished.join("zarr.json")).unwrap();
    let out = voxscope(&["info", unfinished.to_str().unwrap()], &[]);
    let line = one_line_error(&out, &[]);
    assert!(line.contains("a Zarr store still being written"), "{line}");
}

#[test]
fn dead_objects_are_not_asked_again_and_again_and_retry_after_is_honoured() {
    let dir = tempfile::tempdir().unwrap();
    damage::write_store(dir.path(), StoreKind::Gzip);
    let name = StoreKind::Gzip.name();
    let dead = "/gzip.ome.zarr/0/0/0/1";
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            always_500: vec![dead.into()],
            latency: Duration::from_millis(20),
            ..FaultPlan::default()
        },
    );
    let pyramid =
        Arc::new(Pyramid::open_url(&server.url(name), PyramidOptions::default(), fast()).unwrap());
    // Every brick of level 0 read by 8 threads at once, three times over: the dead chunk is
    // fetched by one operation (its tries one at a time), then answered from what the store
    // remembers; every other chunk is fetched once, never twice at once.
    let source = Arc::new(ZarrSource::new(pyramid.clone()).unwrap());
    for _ in 0..3 {
        let threads: Vec<_> = (0..8)
            .map(|_| {
                let source = source.clone();
                std::thread::spawn(move || {
                    let grid = source.shape().levels[0].grid;
                    (0..grid[0] as u32)
                        .map(|x| {
                            source
                                .read_brick(BrickId {
                                    level: 0,
                                    brick: [x, 0, 0],
                                    channel: 0,
                                })
                                .is_ok()
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for thread in threads {
            thread.join().unwrap();
        }
    }
    let dead_requests = server.counters.path(dead).requests;
    assert_eq!(dead_requests, 9, "the dead chunk: one operation of 9 tries");
    assert_eq!(server.counters.path(dead).peak_in_flight, 1);
    assert_eq!(
        server.counters.peak_per_path(),
        1,
        "one fetch per object at a time"
    );
    let chunk = "/gzip.ome.zarr/0/0/0/0";
    assert_eq!(
        server.counters.path(chunk).requests,
        1,
        "a good chunk fetched once"
    );

    // 503 with Retry-After: 1 on each object's first two requests: waited for, then read.
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            error_503: 1.0,
            retry_after_s: 1,
            faults_per_path: 2,
            ..FaultPlan::default()
        },
    );
    let started = Instant::now();
    let pyramid = Pyramid::open_url(
        &server.url(name),
        PyramidOptions::default(),
        RemoteOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let level = pyramid.read_level(2).unwrap_or_else(|e| panic!("{e}"));
    let local = Pyramid::open(&dir.path().join(name), PyramidOptions::default()).unwrap();
    assert!(level == local.read_level(2).unwrap());
    let arrivals = server.counters.path("/gzip.ome.zarr/2/0/0/0").arrivals;
    assert_eq!(arrivals.len(), 3, "two 503s, then the answer");
    for pair in arrivals.windows(2) {
        let gap = pair[1] - pair[0];
        assert!(
            gap >= Duration::from_millis(950),
            "asked again after {gap:?}, not Retry-After's 1 s"
        );
    }
    assert!(started.elapsed() < Duration::from_secs(15));
}
