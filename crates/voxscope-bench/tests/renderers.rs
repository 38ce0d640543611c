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
    assert!(
        report
            .results
            .iter()
            .all(|row| row.median_ms > 0.0 && row.wall_ms_per_frame > 0.0)
    );
    assert_eq!(report.json["results"].as_array().map(Vec::len), Some(18));
    for key in ["dense", "composite-2", "target"] {
        assert!(report.json["gpu_bytes"][key].is_object(), "{key}");
    }
    // The table: the device, the volume, the header, a line a row, the totals.
    let table = report.table();
    assert_eq!(table.lines().count(), 3 + 18 + 1, "{table}");
    assert!(table.ends_with('\n'));
}

#[test]
fn the_azimuth_turns_every_cases_cameras() {
    // The box's silhouette: face on from 0° (and each quarter turn from it, where the rays'
    // work is sampled), two faces from 45°, which more rays enter from the medium and far
    // cameras (the near one, at 1.5 radii, sees the box fill the image face on).
    let rows = |azimuth: f64| {
        let options = BenchOptions {
            renderer: Some(RendererKind::Dense),
            size: (32, 24),
            azimuth,
            ..options("synthetic:sphere:16")
        };
        let volume = BenchVolume::open(&options, &Progress::new()).expect("the sphere opens");
        let report = renderers::run(&options, &volume).expect("a report");
        assert_eq!(report.json["azimuth"], azimuth);
        assert!(report.table().contains(&format!("from azimuth {azimuth}")));
        report.results
    };
    let (face_on, diagonal) = (rows(0.0), rows(45.0));
    for (face_on, diagonal) in face_on.iter().zip(&diagonal) {
        assert_eq!(
            (face_on.mode, face_on.camera),
            (diagonal.mode, diagonal.camera)
        );
        let (from_0, from_45) = (face_on.rays_in_volume, diagonal.rays_in_volume);
        let turned = match face_on.camera {
            "near" => from_45 != from_0,
            _ => from_45 > from_0,
        };
        assert!(
            turned,
            "{} {}: {from_45} rays from 45°, {from_0} from 0°",
            face_on.mode, face_on.camera
        );
    }
}
