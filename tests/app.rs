//! The app, driven through egui_kittest on the software Vulkan device: snapshots of every
//! view the issue names (tests/snapshots, each looked at), and interactions that must change
//! the rendered image. GPU tests fail when no adapter is found; none is skipped.

mod support;

use support::app_harness::{
    MemoryStorage, SIZE, choose_renderer, differing_pixels, harness, harness_with, lit_pixels,
    scratch, settle, snapshot, view,
};

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use voxscope::app::{AppSettings, Command, Layout, STORAGE_KEY, VoxscopeApp, wgpu_setup};
use voxscope_octree::OpacityMode;
use voxscope_scene::VolumeSource;
use voxscope_volume::SAMPLE_NAME;

#[test]
fn main_window_opens_the_sample_and_draws_it() {
    let mut harness = harness();
    let app = harness.state();
    assert_eq!(app.error(), None);
    let (name, depth) = app.volume().expect("the sample is open");
    assert_eq!(name, SAMPLE_NAME);
    assert_eq!(depth, 7);
    let image = view(&harness);
    let lit = lit_pixels(&image);
    assert!(
        lit > image.len() / 4 / 20,
        "the head covers a good part of the view ({lit} lit pixels)"
    );
    let report = app.frame_report().expect("the first frame was measured");
    assert!(report.nodes_per_ray_avg > 1.0, "{report:?}");
    snapshot(&mut harness, "main_window");
}

#[test]
fn binary_mode_and_dragging_its_threshold_change_the_image() {
    let mut harness = harness();
    let gray = view(&harness);
    harness.get_by_label("Binary").click();
    settle(&mut harness);
    assert_eq!(
        harness.state().settings.transfer.opacity,
        OpacityMode::Binary
    );
    let binary = view(&harness);
    assert!(differing_pixels(&gray, &binary) > 1000);
    snapshot(&mut harness, "binary_opacity");

    // Drag the threshold handle on the histogram to the right.
    let before = harness.state().settings.transfer.threshold;
    let handle = harness
        .get_by_label("binary threshold: drag")
        .rect()
        .center();
    harness.hover_at(handle);
    harness.step();
    harness.drag_at(handle);
    harness.step();
    for dx in [10.0, 20.0, 30.0, 40.0] {
        harness.hover_at(handle + egui::vec2(dx, 0.0));
        harness.step();
    }
    harness.drop_at(handle + egui::vec2(40.0, 0.0));
    settle(&mut harness);
    let after = harness.state().settings.transfer.threshold;
    assert!(after > before + 0.05, "threshold {before} → {after}");
    let dragged = view(&harness);
    assert!(differing_pixels(&binary, &dragged) > 500);
}

#[test]
fn max_level_slider_changes_the_image() {
    let mut harness = harness();
    let full = view(&harness);
    harness
        .get_by_role_and_label(egui::accesskit::Role::Slider, "Max level")
        .set_value_accesskit(3.0);
    settle(&mut harness);
    assert_eq!(harness.state().view.max_level, 3);
    let coarse = view(&harness);
    assert!(
        differing_pixels(&full, &coarse) > 5000,
        "level 3 draws 16³ blocks, not voxels"
    );
    snapshot(&mut harness, "max_level_3");
}

#[test]
fn mip_snapshot() {
    let mut harness = harness();
    let dvr = view(&harness);
    harness.get_by_label("MIP").click();
    settle(&mut harness);
    assert!(differing_pixels(&dvr, &view(&harness)) > 1000);
    snapshot(&mut harness, "mip");
}

#[test]
fn level_grid_shows_one_pane_per_level() {
    let mut harness = harness();
    harness.get_by_label("Level grid").click();
    settle(&mut harness);
    assert_eq!(harness.state().settings.layout, Layout::LevelGrid);
    // Four panes by default: levels 4…7 of the sample's depth-7 octree.
    let levels: Vec<String> = harness
        .get_all_by_role_and_label(egui::accesskit::Role::SpinButton, "level")
        .map(|node| node.value().expect("a value"))
        .collect();
    assert_eq!(levels, ["4", "5", "6", "7"]);
    snapshot(&mut harness, "level_grid");
}

#[test]
fn transfer_pair_shows_gray_beside_binary() {
    let mut harness = harness();
    harness.get_by_label("Transfer pair").click();
    settle(&mut harness);
    let image = view(&harness);
    let half = image.width() / 2;
    let left = image::imageops::crop_imm(&image, 0, 0, half - 2, image.height()).to_image();
    let right = image::imageops::crop_imm(&image, half + 2, 0, half - 2, image.height()).to_image();
    assert!(
        differing_pixels(&left, &right) > 1000,
        "A (gray) and B (binary) differ"
    );
    snapshot(&mut harness, "transfer_pair");
}

#[test]
fn heat_map_shows_work_per_ray() {
    let mut harness = harness();
    harness.get_by_label("Nodes-visited heat map").click();
    settle(&mut harness);
    assert!(harness.state().settings.heatmap);
    let image = view(&harness);
    // Rays that miss the volume are black; hits are colored by their work.
    assert!(lit_pixels(&image) > 10_000);
    snapshot(&mut harness, "heat_map");
}

#[test]
fn statistics_panel_counts_under_the_live_transfer_function() {
    let mut harness = harness_with(None, egui::vec2(1280.0, 1100.0));
    snapshot(&mut harness, "statistics_panel");
    harness.get_by_label("Binary").click();
    settle(&mut harness);
    let app = harness.state();
    let data = voxscope_volume::sample().expect("sample");
    let quantized = voxscope_volume::QuantizedVolume::new(&data);
    let mut tree = voxscope_octree::build(&quantized, voxscope_octree::BuildOptions::default())
        .expect("build");
    voxscope_octree::recolor(&mut tree, &app.transfer());
    let expected = voxscope_octree::level_statistics(&tree);
    assert_eq!(app.statistics(), expected.as_slice());
}

#[test]
fn a_broken_file_shows_its_error_and_keeps_the_volume() {
    let mut harness = harness();
    let path = scratch("broken.nii");
    std::fs::write(&path, b"this is not a NIfTI file, only some text").expect("write");
    let spec = path.display().to_string();
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(spec.clone())), &ctx);
    settle(&mut harness);
    let app = harness.state();
    let error = app.error().expect("an error is shown");
    assert!(error.starts_with(&spec), "{error}");
    assert!(!error.contains('\n'));
    assert_eq!(
        app.volume().map(|v| v.0),
        Some(SAMPLE_NAME),
        "the sample stays on screen"
    );
    snapshot(&mut harness, "error_broken_file");
}

#[test]
fn opening_and_dropping_real_files_replace_the_volume() {
    let mut harness = harness();
    let mni = support::shared_data("mni152-t1-197x233x189.nii.gz");
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec(mni.display().to_string())),
        &ctx,
    );
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(
        harness.state().volume().expect("open").0,
        mni.display().to_string()
    );
    assert!(lit_pixels(&view(&harness)) > 10_000);

    // A drop goes through the same path.
    let head = support::shared_data("mri-head-128x128x62.nii.gz");
    harness
        .input_mut()
        .dropped_files
        .push(std::sync::Arc::new(DroppedPath(head.clone())));
    settle(&mut harness);
    assert_eq!(
        harness.state().volume().expect("open").0,
        head.display().to_string()
    );
    let recent = &harness.state().settings.recent;
    assert_eq!(
        recent[..2],
        [head.display().to_string(), mni.display().to_string()]
    );
}

#[test]
fn screenshot_transfer_functions_and_settings_are_saved() {
    let mut harness = harness();
    harness.get_by_label("Binary").click();
    settle(&mut harness);

    let png = scratch("screenshot.png");
    harness
        .state()
        .save_screenshot(&png, 1.0)
        .expect("screenshot");
    let shot = image::open(&png).expect("a PNG").to_rgba8();
    // What is drawn, with the axes gizmo in the 3D view's bottom-left corner (as the window
    // shows it).
    let drawn = view(&harness);
    assert_eq!(shot.dimensions(), drawn.dimensions());
    let in_gizmo = |x: u32, y: u32| x < 110 && y + 110 > drawn.height();
    let mut gizmo_pixels = 0;
    for (x, y, pixel) in shot.enumerate_pixels() {
        if pixel != drawn.get_pixel(x, y) {
            assert!(in_gizmo(x, y), "({x}, {y}) differs outside the gizmo");
            gizmo_pixels += 1;
        }
    }
    assert!(
        gizmo_pixels > 200,
        "the gizmo is drawn ({gizmo_pixels} pixels)"
    );
    assert!(lit_pixels(&shot) > 10_000);

    let ron_path = scratch("binary.ron");
    harness
        .state()
        .save_transfer(&ron_path)
        .expect("save transfer");
    let saved = harness.state().transfer();
    harness.get_by_label("Gray").click();
    settle(&mut harness);
    assert_ne!(harness.state().transfer(), saved);
    harness
        .state_mut()
        .load_transfer(&ron_path)
        .expect("load transfer");
    assert_eq!(harness.state().transfer(), saved);

    let garbage = scratch("garbage.ron");
    std::fs::write(&garbage, "(this is: not a transfer function").expect("write");
    let error = harness
        .state_mut()
        .load_transfer(&garbage)
        .expect_err("garbage is refused")
        .to_string();
    assert!(
        error.starts_with(&garbage.display().to_string()) && !error.contains('\n'),
        "{error}"
    );

    // Persistence: what App::save stores comes back in a new window.
    let mut storage = MemoryStorage::default();
    harness.state_mut().settings.layout = Layout::TransferPair;
    eframe::App::save(harness.state_mut(), &mut storage);
    let stored: AppSettings = eframe::get_value(&storage, STORAGE_KEY).expect("stored");
    assert_eq!(stored, harness.state().settings);
    let storage: &'static MemoryStorage = Box::leak(Box::new(storage));
    let restored = Harness::builder()
        .with_size(SIZE)
        .wgpu_setup(wgpu_setup())
        .build_eframe(move |cc| {
            cc.storage = Some(storage);
            VoxscopeApp::new(cc, None)
        });
    assert_eq!(restored.state().settings.layout, Layout::TransferPair);
    assert_eq!(
        restored.state().settings.transfer.opacity,
        OpacityMode::Binary
    );
}

/// A file dropped on the window, as winit would hand it over.
#[derive(Debug)]
struct DroppedPath(PathBuf);

impl egui::DroppedFile for DroppedPath {
    fn path(&self) -> &Path {
        &self.0
    }
    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

#[test]
fn switching_the_renderer_uploads_in_the_background_and_draws_the_same_head() {
    let mut harness = harness();
    let octree_view = view(&harness);
    for (name, kind) in [
        ("bricks", voxscope_render::RendererKind::Bricks),
        ("dense", voxscope_render::RendererKind::Dense),
    ] {
        harness.get_by_label("Renderer").click();
        harness.run_steps(2);
        harness.get_by_label(name).click();
        settle(&mut harness);
        assert_eq!(harness.state().settings.renderer, kind);
        assert_eq!(harness.state().renderer_kind(), Some(kind));
        let image = view(&harness);
        // Trilinear sampling draws the same head, smoother than voxel cubes.
        let changed = differing_pixels(&octree_view, &image);
        assert!(
            changed > 1000,
            "{name} draws differently ({changed} pixels)"
        );
        assert!(
            lit_pixels(&image) > lit_pixels(&octree_view) / 2,
            "{name} draws the head"
        );
    }
}

#[test]
fn cancel_stops_a_load_and_keeps_the_current_volume() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec("synthetic:noise:320".into())),
        &ctx,
    );
    harness.step();
    // The status bar shows the job with its progress and a Cancel button.
    harness.get_by_label("Cancel").click();
    settle(&mut harness);
    let app = harness.state();
    assert_eq!(app.volume().map(|v| v.0), Some(SAMPLE_NAME));
    assert_eq!(app.error(), None);
}

#[test]
fn cancel_during_the_octree_build_is_a_notice_not_an_error() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec("synthetic:noise:320".into())),
        &ctx,
    );
    // Wait for the longest stage, the octree build, and cancel there.
    let started = Instant::now();
    while harness.state().opening_stage() != Some("building octree") {
        assert!(
            harness.state().opening_stage().is_some(),
            "the open ended before its build was seen"
        );
        assert!(started.elapsed() < Duration::from_secs(120));
        std::thread::sleep(Duration::from_millis(1));
    }
    harness.step();
    harness.get_by_label("Cancel").click();
    settle(&mut harness);
    let app = harness.state();
    assert_eq!(app.error(), None);
    assert_eq!(app.notice(), Some("opening cancelled"));
    assert_eq!(app.volume().map(|v| v.0), Some(SAMPLE_NAME));
}

#[test]
fn a_volume_too_large_for_the_octree_buffers_opens_with_bricks() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    // 320³ needs 286 MiB of octree nodes; lavapipe allows 128 MiB per storage buffer.
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec("synthetic:noise:320".into())),
        &ctx,
    );
    settle(&mut harness);
    let app = harness.state();
    assert_eq!(app.error(), None);
    assert_eq!(
        app.volume().map(|v| v.0),
        Some("synthetic:noise:320x320x320")
    );
    assert_eq!(
        app.renderer_kind(),
        Some(voxscope_render::RendererKind::Bricks)
    );
    assert!(lit_pixels(&view(&harness)) > 10_000);
    // Bricks were this volume's need, not the user's choice: the next opens with the octree.
    assert_eq!(app.settings.renderer, voxscope_render::RendererKind::Octree);
    assert!(
        app.notice()
            .is_some_and(|n| n.contains("drawn with bricks")),
        "{:?}",
        app.notice()
    );
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Sample), &ctx);
    settle(&mut harness);
    assert_eq!(
        harness.state().renderer_kind(),
        Some(voxscope_render::RendererKind::Octree)
    );
}

#[test]
fn dragging_orbits_with_a_smaller_preview_on_a_slow_gpu_then_draws_full() {
    let mut harness = harness();
    let full = harness.state().pane_sizes()[0];
    let azimuth = harness.state().settings.camera.azimuth_deg;
    // The middle of the central panel.
    let center = egui::pos2(640.0, 420.0);
    harness.hover_at(center);
    harness.step();
    harness.drag_at(center);
    harness.step();
    for dx in [10.0, 30.0, 50.0, 70.0] {
        harness.hover_at(center + egui::vec2(dx, 0.0));
        harness.step();
    }
    let moving = harness.state().pane_sizes()[0];
    // lavapipe takes far more than the 40 ms a UI frame gives the GPU: a preview while moving.
    assert!(
        moving[0] <= full[0] / 2 && moving[1] <= full[1] / 2,
        "a preview of at most half the size while moving: {moving:?} of {full:?}"
    );
    assert!(
        harness.state().settings.camera.azimuth_deg != azimuth,
        "the drag orbits"
    );
    harness.drop_at(center + egui::vec2(70.0, 0.0));
    settle(&mut harness);
    assert_eq!(harness.state().pane_sizes()[0], full);
}

#[test]
fn a_long_error_wraps_inside_the_view() {
    let mut harness = harness();
    // A deep path makes a message longer than the view is wide.
    let folder = scratch("long").join("a-folder-with-a-rather-long-name/".repeat(8));
    std::fs::create_dir_all(&folder).expect("create the folders");
    let path = folder.join("not-a-volume.nii");
    std::fs::write(&path, b"not a volume").expect("write");
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec(path.display().to_string())),
        &ctx,
    );
    settle(&mut harness);
    assert!(harness.state().error().is_some_and(|e| e.len() > 250));
    let view = harness.state().pane_rects()[0];
    let dismiss = harness.get_by_label("Dismiss").rect();
    assert!(
        dismiss.right() <= view.right() && dismiss.left() >= view.left(),
        "{dismiss:?} inside {view:?}"
    );
    snapshot(&mut harness, "error_long_message");
    harness.get_by_label("Dismiss").click();
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
}

#[test]
fn a_renderer_switch_draws_the_transfer_function_on_screen() {
    // The octree's CPU colors follow the transfer function the volume opened with; the new
    // renderer is recolored to the one on screen before it is drawn, as after an edit. The
    // full value range shows values the opening window hid: without the recolor the octree
    // renderer drew its uniform regions in the opening window's colors (27.6 dB).
    let mut harness = harness();
    choose_renderer(&mut harness, "bricks");
    harness.get_by_label("Full range").click();
    settle(&mut harness);
    choose_renderer(&mut harness, "octree");
    assert_eq!(
        harness.state().renderer_kind(),
        Some(voxscope_render::RendererKind::Octree)
    );
    let switched = view(&harness);
    harness.get_by_label("Binary").click();
    settle(&mut harness);
    harness.get_by_label("Gray").click();
    settle(&mut harness);
    let recolored = view(&harness);
    let db = support::reference::psnr(&switched, &recolored);
    assert!(db >= 60.0, "the switch against a recolor: {db:.1} dB");
}
