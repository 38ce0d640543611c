//! The in-memory renderers' benchmark through the crate's own API (the command line's `bench`
//! is tested in the root's tests/cli.rs): what is refused before anything is read, and a tiny
//! run's rows, report and table. GPU work on lavapipe in CI.

use voxscope_bench::{BenchError, BenchOptions, BenchVolume, renderers};
use voxscope_render::RendererKind;
use voxscope_scene::{OpenOptions, Progress, SceneError};

fn options(source: &str) -> BenchOptions {
    BenchOptions {
        open: OpenOptions {
            source: Some(source.to_owned()),
            ..OpenOptions::default()
        },
        size: (16, 16),
        frames: 1,
        ..BenchOptions::default()
    }
}

#[test]
fn no_frames_and_missing_files_are_refused_before_any_gpu_work() {
    let none = BenchOptions {
        frames: 0,
        ..options("no-such-file.nii")
    };
    let progress = Progress::new();
    assert!(matches!(
        BenchVolume::open(&none, &progress),
        Err(BenchError::NoFrames)
    ));
    assert!(matches!(
        voxscope_bench::stream::run(&none),
        Err(BenchError::NoFrames)
    ));
    assert_eq!(
        BenchError::NoFrames.to_string(),
        "--frames must be at least 1"
    );
    // A file that does not open is the scene layer's error, for the front end to word.
    let missing = BenchVolume::open(&options("no-such-file.nii"), &progress);
    assert!(
        matches!(missing, Err(BenchError::Open(SceneError::Load(_)))),
        "{:?}",
        missing.err()
    );
}

#[test]
fn one_renderer_and_a_composite_give_a_row_per_case_and_camera() {
    let options = BenchOptions {
        renderer: Some(RendererKind::Dense),
        composite_channels: vec![2],
        ..options("synthetic:sphere:16")
    };
    let volume = BenchVolume::open(&options, &Progress::new()).expect("the sphere opens");
    let report = renderers::run(&options, &volume).expect("a report");
    // The dense renderer: 4 modes × 3 cameras; the 2-channel composite: DVR and MIP × 3.
    assert_eq!(report.results.len(), 12 + 6);
    let composite: Vec<&str> = report
        .results
        .iter()
        .filter(|row| row.renderer == "composite")
        .map(|row| row.mode)
        .collect();
    assert_eq!(composite, [["dvr-gray-2ch"; 3], ["mip-2ch"; 3]].concat());
    assert!(report.results.iter().all(|row| row.median_ms > 0.0));
    assert_eq!(report.json["results"].as_array().map(Vec::len), Some(18));
    for key in ["dense", "composite-2", "target"] {
        assert!(report.json["gpu_bytes"][key].is_object(), "{key}");
    }
    // The table: the device, the volume, the header, a line a row, the totals.
    let table = report.table();
    assert_eq!(table.lines().count(), 3 + 18 + 1, "{table}");
    assert!(table.ends_with('\n'));
}
