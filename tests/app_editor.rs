//! The transfer-function editor, presets and the app's own file browser, driven through
//! egui_kittest on the software Vulkan device (snapshots in tests/snapshots, each looked at).

mod support;

use egui_kittest::kittest::Queryable;
use support::app_harness::{
    click_at, differing_pixels, drag, harness, lit_pixels, settle, snapshot, view,
};
use voxscope::app::{Command, DialogKind};
use voxscope_octree::OpacityMode;

/// The control points of the main transfer function (panics if it is not a curve).
fn points(harness: &egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>) -> Vec<(f64, f32)> {
    match &harness.state().settings.transfer.opacity {
        OpacityMode::Points(curve) => curve
            .points()
            .iter()
            .map(|p| (p.value, p.opacity))
            .collect(),
        other => panic!("the opacity is {other:?}, not a curve"),
    }
}

#[test]
fn the_points_editor_adds_moves_and_deletes_control_points_and_the_image_follows() {
    let mut harness = harness();
    let gray = view(&harness);
    harness.get_by_label("Points").click();
    settle(&mut harness);
    // Switching to Points turns the gray ramp over the window into a two-point curve: the
    // same picture.
    assert_eq!(points(&harness).len(), 2);
    assert_eq!(differing_pixels(&gray, &view(&harness)), 0);

    // A click on the empty histogram, above the middle of the ramp, adds a point there.
    let low = harness.get_by_label("window low: drag").rect();
    let high = harness.get_by_label("window high: drag").rect();
    let spot = egui::pos2(
        (low.center().x + high.center().x) / 2.0,
        low.top() + 0.15 * low.height(),
    );
    click_at(&harness, spot);
    settle(&mut harness);
    let added = points(&harness);
    assert_eq!(added.len(), 3, "{added:?}");
    assert!(added[1].1 > 0.7, "the new point is high: {added:?}");
    let raised = view(&harness);
    assert!(differing_pixels(&gray, &raised) > 1000);
    snapshot(&mut harness, "transfer_editor_points");

    // Dragging it down to the bottom makes the middle values transparent.
    let point = harness.get_by_label("point 2: drag").rect().center();
    drag(&mut harness, point, egui::pos2(point.x, low.bottom()));
    settle(&mut harness);
    let dragged = points(&harness);
    assert!(dragged[1].1 < 0.05, "{dragged:?}");
    assert!(lit_pixels(&view(&harness)) < lit_pixels(&raised));

    // A right-click deletes it.
    harness.get_by_label("point 2: drag").click_secondary();
    settle(&mut harness);
    assert_eq!(points(&harness).len(), 2);
}

#[test]
fn the_app_browser_opens_a_typed_path_and_a_listed_file() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::Open), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), Some(DialogKind::Open));
    let mni = support::shared_data("mni152-t1-197x233x189.nii.gz");
    let path = harness.get_by_label("Path");
    path.focus();
    path.type_text(&mni.display().to_string());
    harness.step();
    harness.key_press(egui::Key::Enter);
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), None);
    assert_eq!(harness.state().error(), None);
    assert_eq!(
        harness.state().volume().expect("open").0,
        mni.display().to_string()
    );

    // Typing a folder goes there; its volume files are listed and a click opens one.
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::Open), &ctx);
    settle(&mut harness);
    let folder = mni.parent().expect("a folder");
    let path = harness.get_by_label("Path");
    path.focus();
    path.type_text(&folder.display().to_string());
    harness.step();
    harness.key_press(egui::Key::Enter);
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), Some(DialogKind::Open));
    harness
        .get_by_label_contains("mri-head-128x128x62.nii.gz")
        .click();
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), None);
    let head = folder.join("mri-head-128x128x62.nii.gz");
    assert_eq!(
        harness.state().volume().expect("open").0,
        head.display().to_string()
    );
}

#[test]
fn a_ct_opens_with_a_ct_preset_and_each_preset_draws_its_tissue() {
    let mut harness = support::app_harness::harness_with(
        Some(voxscope_scene::VolumeSource::Spec(
            "synthetic:ct:128x128x64".into(),
        )),
        egui::vec2(1100.0, 720.0),
    );
    // The CT default: a curve in Hounsfield units that leaves air and padding transparent.
    let curve = points(&harness);
    assert!(
        curve
            .first()
            .is_some_and(|(value, opacity)| *value > -300.0 && *opacity == 0.0)
    );
    let mut lit = Vec::new();
    for (label, name) in [
        ("Soft tissue", "ct_preset_soft_tissue"),
        ("Bone", "ct_preset_bone"),
        ("Vessels", "ct_preset_vessels"),
        ("Lung", "ct_preset_lung"),
        ("Skin", "ct_preset_skin"),
    ] {
        harness.get_by_label(label).click();
        settle(&mut harness);
        let image = view(&harness);
        lit.push((label, lit_pixels(&image)));
        snapshot(&mut harness, name);
    }
    // Bone shows less than soft tissue, skin (an opaque surface) the most.
    let count = |name: &str| lit.iter().find(|(l, _)| *l == name).expect("measured").1;
    assert!(count("Bone") < count("Soft tissue"), "{lit:?}");
    assert!(count("Skin") >= count("Soft tissue"), "{lit:?}");
    assert!(
        lit.iter().all(|(_, n)| *n > 500),
        "every preset draws something: {lit:?}"
    );
}

#[test]
fn shading_lights_the_surface_and_can_be_switched_off() {
    let mut harness = harness();
    assert!(harness.state().settings.shading.enabled, "on by default");
    let lit_view = view(&harness);
    harness.get_by_label("Lit (headlight)").click();
    settle(&mut harness);
    assert!(!harness.state().settings.shading.enabled);
    let flat = view(&harness);
    assert!(differing_pixels(&lit_view, &flat) > 5000);
    snapshot(&mut harness, "shading_off");
}

#[test]
fn a_cts_mip_has_its_own_window_and_dvr_gets_its_curve_back() {
    let mut harness = support::app_harness::harness_with(
        Some(voxscope_scene::VolumeSource::Spec(
            "synthetic:ct:128x128x64".into(),
        )),
        egui::vec2(1100.0, 720.0),
    );
    let dvr_transfer = harness.state().settings.transfer;
    let dvr_window = harness.state().view.window;
    harness.get_by_label("MIP").click();
    settle(&mut harness);
    let state = harness.state();
    assert_eq!(state.settings.mode, voxscope_render::RenderMode::Mip);
    // Grays over the CT's default window (as `render --mode mip` draws it), wider than the
    // soft-tissue curve's, which a projection through bone saturates.
    assert_eq!(
        state.settings.transfer.colormap,
        voxscope_octree::Colormap::Grays
    );
    assert_eq!(state.settings.transfer.opacity, OpacityMode::Gray);
    let width = |w: voxscope_volume::ValueWindow| w.high - w.low;
    assert!(
        width(state.view.window) > 2.0 * width(dvr_window),
        "MIP window {:?}, DVR's {dvr_window:?}",
        state.view.window
    );
    let image = view(&harness);
    let lit = lit_pixels(&image);
    let white = image
        .pixels()
        .filter(|p| p.0[..3].iter().all(|&c| c >= 250))
        .count();
    assert!(lit > 5000, "the MIP draws the body: {lit} lit pixels");
    assert!(
        white * 10 < lit,
        "the MIP saturates: {white} of {lit} lit pixels are white"
    );
    snapshot(&mut harness, "ct_mip");
    // Back to DVR: the curve and window it had.
    harness.get_by_label("DVR").click();
    settle(&mut harness);
    assert_eq!(harness.state().settings.transfer, dvr_transfer);
    assert_eq!(harness.state().view.window, dvr_window);
}
