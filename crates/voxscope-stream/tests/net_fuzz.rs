//! The network fuzz: seeded cases, each a store served by the fault-injecting server
//! (tests/support/fault_server.rs) under a seeded mix of faults (500, 503 with Retry-After,
//! resets, cut bodies, wrong lengths, latency, silence, chunked and close-delimited bodies,
//! `Range` ignored, basic authentication), the store pristine or damaged in one seeded way
//! (tests/support/damage.rs), read level by level or brick by brick as the streaming renderer
//! reads it, through a URL carrying a planted user name, password and query token. The oracle:
//!
//! - no panic anywhere (a panic hook counts them, caught or not);
//! - no case runs past its deadline (the store's time bounds, shortened here, and a margin);
//! - what is read equals the folder's bit for bit, or the read fails with one line: never
//!   other values (a damaged chunk is an error, never data); and a mix of transient faults
//!   the retries can absorb is read equal, always;
//! - no planted secret in any message or name.
//!
//! CI runs [`CI_CASES`] cases (a minute or so on two cores). The full campaign of 10⁴ cases:
//! `VOXSCOPE_NET_FUZZ_CASES=10000 cargo test --release -p voxscope-stream --test net_fuzz -- --nocapture`
//! (`VOXSCOPE_NET_FUZZ_SEED` picks another campaign).

mod support;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use support::damage::{self, Damage, StoreKind};
use support::fault_server::{FaultPlan, FaultServer, Framing, Rng};
use voxscope_stream::{BrickId, BrickSource, ZarrSource};
use voxscope_volume::VoxelData;
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};
use voxscope_volume::remote::{RemoteOptions, Timing};

/// Cases in CI, and the campaign's seed there.
const CI_CASES: u64 = 2000;
const CI_SEED: u64 = 29;

/// Damaged copies made of each store (a case picks one).
const VARIANTS: usize = 12;

/// Cases run at once (each mostly waits on its server).
const THREADS: usize = 16;

/// The store's time bounds in the fuzz: a fortieth to a tenth of the real ones, so that a
/// silent server costs a case half a second (and a loaded two-core machine running sixteen
/// cases at once still answers every request in time).
fn timing() -> Timing {
    Timing {
        connect: Duration::from_millis(500),
        request: Duration::from_millis(500),
        open_deadline: Duration::from_millis(1500),
        read_deadline: Duration::from_millis(2500),
        max_retries: 8,
        first_backoff: Duration::from_millis(1),
        max_backoff: Duration::from_millis(10),
        max_retry_after: Duration::from_millis(500),
        remember_failure: Duration::from_millis(100),
        max_remembered: Duration::from_millis(500),
        silence_cool_down: Duration::from_millis(200),
    }
}

/// The most one case may take: opening (each of a few document batches within the open
/// deadline) and every level's read (each within the read deadline and a request) with room
/// for a loaded machine.
fn case_deadline() -> Duration {
    let t = timing();
    t.open_deadline * 4 + (t.read_deadline + t.request) * 6 + Duration::from_secs(4)
}

static PANICS: AtomicU64 = AtomicU64::new(0);

fn count_panics() {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICS.fetch_add(1, Ordering::SeqCst);
            default(info);
        }));
    });
}

/// The stores, their damaged copies and their reference voxels.
struct Stores {
    _dir: tempfile::TempDir,
    /// Per kind: the folder holding the pristine store.
    pristine: Vec<(StoreKind, PathBuf)>,
    /// Per kind: folders each holding a damaged copy (same name), and its damage.
    damaged: Vec<Vec<(PathBuf, Damage)>>,
    /// Per kind: every level read from the pristine folder.
    reference: Vec<Vec<VoxelData>>,
}

impl Stores {
    fn new(seed: u64) -> Self {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let mut pristine = Vec::new();
        let mut damaged = Vec::new();
        let mut reference = Vec::new();
        for (k, kind) in StoreKind::ALL.into_iter().enumerate() {
            let folder = dir.path().join(format!("pristine-{k}"));
            std::fs::create_dir_all(&folder).unwrap();
            let store = damage::write_store(&folder, kind);
            let pyramid = Pyramid::open(&store, PyramidOptions::default()).unwrap();
            reference.push(
                (0..pyramid.levels.len())
                    .map(|l| pyramid.read_level(l).unwrap())
                    .collect(),
            );
            let mut copies = Vec::new();
            for v in 0..VARIANTS {
                let mut rng = Rng::new(seed ^ (k as u64) << 32 ^ v as u64);
                let copy = dir.path().join(format!("damaged-{k}-{v}"));
                damage::copy_store(&store, &copy.join(kind.name()));
                let what = Damage::pick(&copy.join(kind.name()), kind, &mut rng);
                what.apply(&copy.join(kind.name()), &mut rng);
                copies.push((copy, what));
            }
            pristine.push((kind, folder));
            damaged.push(copies);
        }
        Self {
            _dir: dir,
            pristine,
            damaged,
            reference,
        }
    }
}

/// How a case reads the store.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reading {
    /// Every level whole.
    Levels,
    /// Bricks of every pyramid level, as the streaming renderer's loaders read them.
    Bricks,
}

#[derive(Debug)]
struct Case {
    index: u64,
    kind: usize,
    /// The damaged copy, if any.
    variant: Option<usize>,
    plan: FaultPlan,
    reading: Reading,
    /// The fault mix is one the retries absorb: the read must succeed.
    recoverable: bool,
}

fn make_case(seed: u64, index: u64) -> Case {
    let mut rng = Rng::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index);
    let kind = rng.below(StoreKind::ALL.len() as u64) as usize;
    let variant = rng.chance(0.3).then(|| rng.below(VARIANTS as u64) as usize);
    let pick = |rng: &mut Rng, p: f64| if rng.chance(0.35) { p } else { 0.0 };
    let chances = [0.1, 0.3, 0.6, 1.0];
    let mut plan = FaultPlan {
        seed: rng.next(),
        ..FaultPlan::default()
    };
    let chance = |rng: &mut Rng| {
        let p = chances[rng.below(4) as usize];
        pick(rng, p)
    };
    plan.error_500 = chance(&mut rng);
    plan.error_503 = chance(&mut rng);
    plan.reset = chance(&mut rng);
    plan.truncate = chance(&mut rng);
    plan.wrong_length = if rng.chance(0.15) {
        chances[rng.below(4) as usize]
    } else {
        0.0
    };
    plan.silence = if rng.chance(0.05) { 0.3 } else { 0.0 };
    plan.faults_per_path = [1, 2, 4, u32::MAX][rng.below(4) as usize];
    plan.latency = Duration::from_micros(rng.below(3000));
    plan.framing = [
        Framing::Length,
        Framing::Chunked,
        Framing::Close,
        Framing::Mixed,
    ][rng.below(4) as usize];
    plan.ignore_range = rng.chance(0.3);
    plan.silence_for = Duration::from_secs(5);
    if rng.chance(0.05) {
        plan.dies_after = Some(rng.below(40));
    }
    if rng.chance(0.3) {
        plan.require_auth = Some(("fuzzuser".to_owned(), format!("PLANTEDpw{index}")));
    }
    let reading = if rng.chance(0.3) {
        Reading::Bricks
    } else {
        Reading::Levels
    };
    // Closing the connection is how a close-delimited body ends: a cut one looks whole (its
    // chunk then fails to decode, an error); and a wrong length or silence may outlast the
    // retries. Every other mix, with at most four faults an object, is read through.
    let close_framed = matches!(plan.framing, Framing::Close | Framing::Mixed);
    let recoverable = variant.is_none()
        && plan.wrong_length == 0.0
        && plan.silence == 0.0
        && plan.dies_after.is_none()
        && !(close_framed && plan.truncate > 0.0)
        && plan.faults_per_path <= 4;
    Case {
        index,
        kind,
        variant,
        plan,
        reading,
        recoverable,
    }
}

/// What one case found wrong (empty: nothing).
fn run_case(stores: &Stores, case: &Case) -> Vec<String> {
    let (kind, pristine) = &stores.pristine[case.kind];
    let root: &Path = match case.variant {
        Some(v) => &stores.damaged[case.kind][v].0,
        None => pristine,
    };
    let secrets = [
        format!("PLANTEDpw{}", case.index),
        format!("PLANTEDtok{}", case.index),
        "fuzzuser".to_owned(),
    ];
    let server = FaultServer::start(root, case.plan.clone());
    let url = format!(
        "http://fuzzuser:PLANTEDpw{}@127.0.0.1:{}/{}?token=PLANTEDtok{}",
        case.index,
        server.port(),
        kind.name(),
        case.index
    );
    let options = RemoteOptions {
        timing: timing(),
        ..RemoteOptions::default()
    };
    let started = Instant::now();
    let mut messages = Vec::new();
    let result = read(
        &url,
        options,
        case.reading,
        &stores.reference[case.kind],
        pristine,
        kind,
        &mut messages,
    );
    let elapsed = started.elapsed();
    drop(server);
    judge(&result, &messages, &secrets, elapsed, case.recoverable)
}

/// The oracle: what is wrong with a case that ended with `result` after `elapsed`, having met
/// `messages`, where `secrets` must never show and, if `recoverable`, the read must succeed.
fn judge(
    result: &Result<Equal, String>,
    messages: &[String],
    secrets: &[String],
    elapsed: Duration,
    recoverable: bool,
) -> Vec<String> {
    let mut problems = Vec::new();
    if elapsed > case_deadline() {
        problems.push(format!(
            "ran {elapsed:.1?}, past its deadline of {:.1?}",
            case_deadline()
        ));
    }
    for message in messages {
        if message.contains('\n') {
            problems.push(format!("a message of more than one line: {message}"));
        }
        if let Some(secret) = secrets.iter().find(|s| message.contains(s.as_str())) {
            problems.push(format!("the secret '{secret}' shown: {message}"));
        }
    }
    match result {
        Ok(Equal::Yes) => {}
        Ok(Equal::No(what)) => problems.push(format!(
            "read other values than the folder's without a message: {what}"
        )),
        Err(message) if recoverable => problems.push(format!(
            "transient faults the retries absorb ended in an error: {message}"
        )),
        Err(_) => {}
    }
    problems
}

enum Equal {
    Yes,
    No(String),
}

/// Reads the store at `url` as `reading` says and compares it with the folder's. `Err`: the
/// read failed (its message); every message met goes to `messages`.
fn read(
    url: &str,
    options: RemoteOptions,
    reading: Reading,
    reference: &[VoxelData],
    pristine: &Path,
    kind: &StoreKind,
    messages: &mut Vec<String>,
) -> Result<Equal, String> {
    let pyramid = Pyramid::open_url(url, PyramidOptions::default(), options).map_err(|e| {
        messages.push(e.to_string());
        e.to_string()
    })?;
    messages.push(pyramid.source.clone());
    messages.extend(pyramid.levels.iter().map(|l| format!("{l:?}")));
    match reading {
        Reading::Levels => {
            if pyramid.levels.len() != reference.len() {
                return Ok(Equal::No(format!(
                    "{} levels, not {}",
                    pyramid.levels.len(),
                    reference.len()
                )));
            }
            for (level, expected) in reference.iter().enumerate() {
                let data = pyramid.read_level(level).map_err(|e| {
                    messages.push(e.to_string());
                    e.to_string()
                })?;
                if data != *expected {
                    return Ok(Equal::No(format!("level {level}")));
                }
            }
        }
        Reading::Bricks => {
            let remote = ZarrSource::new(Arc::new(pyramid)).map_err(|e| {
                let line = e.to_string();
                messages.push(line.clone());
                line
            })?;
            let local = ZarrSource::new(Arc::new(
                Pyramid::open(&pristine.join(kind.name()), PyramidOptions::default()).unwrap(),
            ))
            .unwrap();
            for level in 0..local.shape().levels.len() as u32 {
                let grid = local.shape().levels[level as usize].grid;
                for x in 0..grid[0] as u32 {
                    let id = BrickId {
                        level,
                        brick: [x, 0, grid[2] as u32 - 1],
                        channel: 0,
                    };
                    let brick = remote.read_brick(id).map_err(|e| {
                        messages.push(e.to_string());
                        e.to_string()
                    })?;
                    if brick != local.read_brick(id).unwrap() {
                        return Ok(Equal::No(format!("{id}")));
                    }
                }
            }
        }
    }
    Ok(Equal::Yes)
}

#[test]
fn seeded_fault_mixes_and_damaged_stores_never_panic_stall_lie_or_leak() {
    count_panics();
    let cases: u64 = std::env::var("VOXSCOPE_NET_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(CI_CASES);
    let seed: u64 = std::env::var("VOXSCOPE_NET_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(CI_SEED);
    let stores = Stores::new(seed);
    let started = Instant::now();
    let next = AtomicU64::new(0);
    let report: Mutex<Vec<String>> = Mutex::default();
    let tally: Mutex<[u64; 4]> = Mutex::default();
    std::thread::scope(|scope| {
        for _ in 0..THREADS {
            scope.spawn(|| {
                loop {
                    let index = next.fetch_add(1, Ordering::SeqCst);
                    if index >= cases {
                        break;
                    }
                    let case = make_case(seed, index);
                    let problems = run_case(&stores, &case);
                    {
                        let mut tally = tally.lock().unwrap();
                        tally[case.variant.is_some() as usize] += 1;
                        tally[2] += case.recoverable as u64;
                        tally[3] += problems.is_empty() as u64;
                    }
                    if !problems.is_empty() {
                        let damage = case.variant.map(|v| format!("{:?}", stores.damaged[case.kind][v].1));
                        report.lock().unwrap().push(format!(
                            "case {index} ({:?}, {:?}, damage {damage:?}, recoverable {}): {}\n    plan: {:?}",
                            StoreKind::ALL[case.kind],
                            case.reading,
                            case.recoverable,
                            problems.join("; "),
                            case.plan
                        ));
                    }
                }
            });
        }
    });
    let report = report.into_inner().unwrap();
    let [pristine, damaged, recoverable, clean] = tally.into_inner().unwrap();
    let panics = PANICS.load(Ordering::SeqCst);
    eprintln!(
        "net fuzz, seed {seed}: {cases} cases ({pristine} pristine, {damaged} damaged, {recoverable} recoverable) in {:.1} s; {clean} clean, {} with problems, {panics} panics",
        started.elapsed().as_secs_f64(),
        report.len()
    );
    assert_eq!(panics, 0, "panics");
    assert!(
        report.is_empty(),
        "{} cases failed:\n{}",
        report.len(),
        report
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn the_oracle_catches_other_values_leaks_and_slow_cases() {
    count_panics();
    // A server that sends a store's valid chunks where the folder holds other values: read
    // without an error, and the oracle reports it.
    let dir = tempfile::tempdir().unwrap();
    let kind = StoreKind::Zstd;
    let store = damage::write_store(dir.path(), kind);
    let pyramid = Pyramid::open(&store, PyramidOptions::default()).unwrap();
    let reference: Vec<VoxelData> = (0..pyramid.levels.len())
        .map(|level| match pyramid.read_level(level).unwrap() {
            VoxelData::U16(values) => VoxelData::U16(values.iter().map(|v| v ^ 1).collect()),
            other => other,
        })
        .collect();
    let server = FaultServer::start(dir.path(), FaultPlan::default());
    let options = RemoteOptions {
        timing: timing(),
        ..RemoteOptions::default()
    };
    let mut messages = Vec::new();
    let result = read(
        &server.url(kind.name()),
        options,
        Reading::Levels,
        &reference,
        dir.path(),
        &kind,
        &mut messages,
    );
    let problems = judge(&result, &messages, &[], Duration::ZERO, false);
    assert!(
        problems.iter().any(|p| p.contains("other values")),
        "{problems:?}"
    );
    // A leaked secret, a message of two lines, a slow case, a recoverable case that failed.
    let secrets = ["PLANTEDpw7".to_owned()];
    let problems = judge(
        &Err("x".into()),
        &[
            "http://u:PLANTEDpw7@h/x: refused".into(),
            "two\nlines".into(),
        ],
        &secrets,
        case_deadline() + Duration::from_secs(1),
        true,
    );
    assert_eq!(problems.len(), 4, "{problems:?}");
}
