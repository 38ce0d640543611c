//! The Movie panel, driven through egui_kittest on the software Vulkan device: keyframes are
//! added from the view on screen, reordered and deleted; Export writes the movie on a job
//! thread with its own renderer, and its first and last frames are the stills `render --view`
//! draws of the first and last keyframes; Preview plays the path in the view and returns to the
//! view before; Cancel stops an export.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command as Process;
use std::time::{Duration, Instant};

use egui_kittest::Harness;
use support::app_harness::{differing_pixels, harness_with, lit_pixels, scratch, settle};
use voxscope::app::{Command, Panel, VoxscopeApp};
use voxscope_render::Camera;
use voxscope_scene::{SavedView, VolumeSource};
use voxscope_volume::ValueWindow;

const VOLUME: &str = "synthetic:noise:24x20x16";

fn app() -> Harness<'static, VoxscopeApp> {
    let mut harness = harness_with(
        Some(VolumeSource::Spec(VOLUME.to_owned())),
        egui::vec2(480.0, 360.0),
    );
    let ctx = harness.ctx.clone();
    for panel in [Panel::Transfer, Panel::Octree, Panel::Movie] {
        harness
            .state_mut()
            .run_command(Command::TogglePanel(panel), &ctx);
    }
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    harness
}

fn run(harness: &mut Harness<'static, VoxscopeApp>, command: Command) {
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(command, &ctx);
    harness.step();
}

/// Two keyframes: the camera turned and moved in, the window narrowed.
fn two_keyframes(harness: &mut Harness<'static, VoxscopeApp>) {
    harness.state_mut().settings.camera = Camera {
        azimuth_deg: 20.0,
        elevation_deg: 10.0,
        ..Camera::default()
    };
    run(harness, Command::AddKeyframe);
    {
        let app = harness.state_mut();
        app.settings.camera = Camera {
            azimuth_deg: 110.0,
            elevation_deg: 35.0,
            distance: 2.4,
            ..Camera::default()
        };
        app.view.window = ValueWindow {
            low: 0.2,
            high: 0.9,
        };
    }
    run(harness, Command::AddKeyframe);
    settle(harness);
}

fn png(path: &Path) -> image::RgbaImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgba8()
}

/// The still `render --view` draws of `view` at 32x24.
fn still(view: &SavedView, name: &str) -> image::RgbaImage {
    let path = scratch(&format!("{name}.ron"));
    let mut keyframe = view.clone();
    keyframe.draw.size = (32, 24);
    keyframe.write(&path).expect("write the keyframe");
    let out = scratch(&format!("{name}.png"));
    let output = Process::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(["render", "--view"])
        .arg(&path)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    png(&out)
}

/// Waits (at most a minute) until `folder` holds `count` frames or more.
fn wait_for_frames(folder: &Path, count: usize) {
    let started = Instant::now();
    while frames_in(folder).len() < count {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no frame written"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn frames_in(folder: &Path) -> Vec<PathBuf> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(folder)
        .map(|entries| entries.map(|e| e.expect("an entry").path()).collect())
        .unwrap_or_default();
    names.sort();
    names
}

#[test]
fn an_exported_movie_starts_and_ends_at_its_keyframes_stills() {
    let mut harness = app();
    two_keyframes(&mut harness);
    // A third keyframe, moved first and deleted: the list is as it was.
    harness.state_mut().settings.camera.azimuth_deg = 250.0;
    run(&mut harness, Command::AddKeyframe);
    run(&mut harness, Command::MoveKeyframe { from: 2, to: 0 });
    let azimuths = |h: &Harness<'static, VoxscopeApp>| -> Vec<f64> {
        h.state()
            .movie
            .keyframes
            .iter()
            .map(|k| k.draw.camera.azimuth_deg)
            .collect()
    };
    assert_eq!(azimuths(&harness), [250.0, 20.0, 110.0]);
    run(&mut harness, Command::DeleteKeyframe(0));
    assert_eq!(azimuths(&harness), [20.0, 110.0]);

    let folder = scratch("movie-frames");
    let _ = std::fs::remove_dir_all(&folder);
    {
        let plan = &mut harness.state_mut().movie;
        plan.frames_per_segment = 2;
        plan.fps = 10.0;
        plan.size = [32, 24];
        plan.output = folder.display().to_string();
    }
    run(&mut harness, Command::ExportMovie);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    let notice = harness.state().notice().expect("the status bar says so");
    assert!(notice.starts_with("movie written: "), "{notice}");
    let files = frames_in(&folder);
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    );
    let frames: Vec<image::RgbaImage> = files.iter().map(|p| png(p)).collect();
    let keys = harness.state().movie.keyframes.clone();
    let first = still(&keys[0], "movie-key-first");
    let last = still(&keys[1], "movie-key-last");
    assert!(lit_pixels(&first) > 50 && lit_pixels(&last) > 50);
    assert_eq!(
        differing_pixels(&frames[0], &first),
        0,
        "starts at the first"
    );
    assert_eq!(differing_pixels(&frames[2], &last), 0, "ends at the last");
    assert!(differing_pixels(&frames[1], &first) > 0 && differing_pixels(&frames[1], &last) > 0);
}

#[test]
fn preview_plays_the_path_and_returns_and_cancel_stops_an_export() {
    let mut harness = app();
    two_keyframes(&mut harness);
    let before = harness.state().settings.camera;
    {
        let plan = &mut harness.state_mut().movie;
        plan.frames_per_segment = 3;
        plan.fps = 20.0;
    }
    run(&mut harness, Command::PreviewMovie);
    harness.step();
    assert!(harness.state().previewing());
    let first = harness.state().movie.keyframes[0].draw.camera;
    assert_eq!(
        harness.state().settings.camera,
        first,
        "plays from the first"
    );
    let started = Instant::now();
    while harness.state().previewing() {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the preview ends"
        );
        std::thread::sleep(Duration::from_millis(20));
        harness.step();
    }
    assert_eq!(harness.state().settings.camera, before, "back to the view");

    let folder = scratch("movie-cancelled");
    let _ = std::fs::remove_dir_all(&folder);
    {
        let plan = &mut harness.state_mut().movie;
        plan.frames_per_segment = 5000;
        plan.size = [16, 12];
        plan.output = folder.display().to_string();
    }
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(Command::ExportMovie, &ctx);
    // Cancelled once frames are written: they go, and the folder the export made with them.
    wait_for_frames(&folder, 3);
    harness.state_mut().run_command(Command::CancelExport, &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(
        harness.state().notice(),
        Some("writing the movie cancelled")
    );
    assert_eq!(
        frames_in(&folder),
        Vec::<PathBuf>::new(),
        "a cancelled export left frames"
    );
    assert!(!folder.exists(), "the folder the export made is left");
    // A folder that was there keeps what it held before.
    std::fs::create_dir_all(&folder).expect("folder");
    let kept = folder.join("notes.txt");
    std::fs::write(&kept, "mine").expect("write");
    harness.state_mut().run_command(Command::ExportMovie, &ctx);
    wait_for_frames(&folder, 3);
    harness.state_mut().run_command(Command::CancelExport, &ctx);
    settle(&mut harness);
    assert_eq!(frames_in(&folder), vec![kept]);
}
