//! Looking inside in the app: the Slices layout and its shared cursor, the crop box and its
//! draggable edges, the ruler, and the 3D view's picked point (egui_kittest on lavapipe;
//! snapshots in tests/snapshots, each looked at).

mod support;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use support::app_harness::{
    click_at, differing_pixels, drag, harness, lit_pixels, scratch, settle, snapshot, view,
};
use voxscope::app::{Layout, VoxscopeApp};
use voxscope_render::{SliceConvention, SliceFrame, SliceView};

/// Opens the Slices layout on the sample.
fn slices() -> Harness<'static, VoxscopeApp> {
    let mut harness = harness();
    harness.get_by_label("Slices").click();
    settle(&mut harness);
    assert_eq!(harness.state().settings.layout, Layout::Slices);
    harness
}

/// The screen position of voxel-space `point` in the slice pane `pane` (1 axial, 2 coronal,
/// 3 sagittal) of the Slices layout, as the app lays that slice out.
fn on_slice(harness: &Harness<'_, VoxscopeApp>, pane: usize, point: [f64; 3]) -> egui::Pos2 {
    let app = harness.state();
    let axis = [2, 1, 0][pane - 1];
    let rect = app.pane_rects()[pane];
    let target = app.pane_sizes()[pane];
    let data = app.volume_data().expect("a volume");
    let volume = &data.volume;
    let slice_view = SliceView {
        index: app.view.cursor_voxel(volume.dims)[axis],
        ..app.view.slice_views[axis]
    };
    let frame = SliceFrame::axis_aligned(
        &slice_view,
        SliceConvention::of_volume(volume),
        volume.dims,
        volume.spacing,
        target,
    );
    let [x, y] = frame.pixel_of(point);
    egui::pos2(
        rect.left() + (x / target[0] as f64) as f32 * rect.width(),
        rect.top() + (y / target[1] as f64) as f32 * rect.height(),
    )
}

#[test]
fn slices_share_one_cursor_that_clicks_and_the_wheel_move() {
    let mut harness = slices();
    let app = harness.state();
    assert_eq!(app.pane_sizes().len(), 4, "3D, axial, coronal, sagittal");
    let dims = app.volume_data().expect("a volume").volume.dims;
    let start = app.view.cursor;
    // Each slice pane shows the sample's head: lit in its middle.
    let image = view(&harness);
    assert!(lit_pixels(&image) > 20_000);

    // A click in the axial view moves the cursor within the axial plane.
    let target = [start[0] + 20.0, start[1] - 10.0, start[2]];
    click_at(&harness, on_slice(&harness, 1, target));
    settle(&mut harness);
    let cursor = harness.state().view.cursor;
    assert!(
        (cursor[0] - target[0]).abs() < 1.0,
        "{cursor:?} vs {target:?}"
    );
    assert!(
        (cursor[1] - target[1]).abs() < 1.0,
        "{cursor:?} vs {target:?}"
    );
    assert_eq!(cursor[2], start[2], "the axial slice stays");

    // The wheel over the coronal view steps one voxel across y.
    let coronal = harness.state().pane_rects()[2].center();
    harness.hover_at(coronal);
    harness.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Line,
        delta: egui::vec2(0.0, 1.0),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Unknown,
        modifiers: egui::Modifiers::NONE,
    });
    settle(&mut harness);
    let stepped = harness.state().view.cursor;
    assert_eq!(
        harness.state().view.cursor_voxel(dims)[1],
        (cursor[1].floor() as usize + 1).min(dims[1] - 1),
        "{stepped:?}"
    );
    // The status bar reads the voxel under the pointer, with its value.
    harness.get_by_label_contains("voxel (");
    harness.get_by_label_contains("· value ");
    snapshot(&mut harness, "slices_layout");
}

#[test]
fn the_crop_box_clips_every_view_and_its_edges_drag_in_a_slice() {
    let mut harness = slices();
    let before = view(&harness);
    let nodes_before: u64 = harness.state().statistics().iter().map(|s| s.nodes).sum();
    {
        let clipping = &mut harness.state_mut().view.clipping;
        clipping.box_on = true;
        // The patient's right, which faces the default camera, goes.
        clipping.bounds[0] = [0.0, 0.7];
    }
    settle(&mut harness);
    let clipped = view(&harness);
    let changed = differing_pixels(&before, &clipped);
    assert!(
        changed > 1000,
        "the 3D view is clipped ({changed} pixels differ)"
    );
    let nodes_after: u64 = harness.state().statistics().iter().map(|s| s.nodes).sum();
    assert!(
        nodes_after < nodes_before,
        "the statistics count only what is inside"
    );

    // Drag the box's high x edge in the axial view from 0.7 to 0.5 of the way.
    let app = harness.state();
    let dims = app.volume_data().expect("a volume").volume.dims;
    let cursor = app.view.cursor;
    let edge = |fraction: f64| [fraction * dims[0] as f64, cursor[1], cursor[2]];
    let from = on_slice(&harness, 1, edge(0.7));
    let to = on_slice(&harness, 1, edge(0.5));
    drag(&mut harness, from, to);
    settle(&mut harness);
    let high = harness.state().view.clipping.bounds[0][1];
    assert!(
        (high - 0.5).abs() < 0.03,
        "the high x limit follows the drag: {high}"
    );
    snapshot(&mut harness, "slices_crop_box");
}

#[test]
fn a_ruler_measures_in_a_slice_and_is_saved_with_the_screenshot() {
    let mut harness = slices();
    harness.get_by_label("Ruler").click();
    settle(&mut harness);
    let app = harness.state();
    let data = app.volume_data().expect("a volume");
    let spacing = data.volume.spacing;
    let cursor = app.view.cursor;
    // 30 voxels along x in the axial slice.
    let from = [cursor[0] - 15.0, cursor[1], cursor[2]];
    let to = [cursor[0] + 15.0, cursor[1], cursor[2]];
    let (a, b) = (on_slice(&harness, 1, from), on_slice(&harness, 1, to));
    drag(&mut harness, a, b);
    settle(&mut harness);
    let rulers = &harness.state().view.rulers;
    assert_eq!(rulers.len(), 1);
    let length = rulers[0].length(spacing);
    let expected = 30.0 * spacing[0];
    assert!(
        (length - expected).abs() < 0.05 * expected,
        "{length} mm against {expected} mm"
    );
    snapshot(&mut harness, "slices_ruler");

    // The screenshot has the ruler's color where the ruler lies.
    let png = scratch("ruler.png");
    harness.state().save_screenshot(&png, 1.0).expect("saved");
    let shot = image::open(&png).expect("a PNG").to_rgba8();
    let ruler_pixels = shot
        .pixels()
        .filter(|p| p.0[0] == 80 && p.0[1] == 220 && p.0[2] == 255)
        .count();
    assert!(ruler_pixels > 30, "{ruler_pixels} ruler pixels");
}

#[test]
fn a_click_in_the_3d_view_puts_the_cursor_on_the_surface_under_it() {
    let mut harness = slices();
    let start = harness.state().view.cursor;
    let center = harness.state().pane_rects()[0].center();
    click_at(&harness, center);
    settle(&mut harness);
    let cursor = harness.state().view.cursor;
    assert_ne!(cursor, start, "the cursor moved to the picked point");
    // The head's surface seen from the default camera is off the volume's center.
    let dims = harness.state().volume_data().expect("a volume").volume.dims;
    assert!(
        (0..3).all(|a| cursor[a] >= 0.0 && cursor[a] <= dims[a] as f64),
        "{cursor:?} inside {dims:?}"
    );
}

#[test]
fn one_wheel_notch_moves_one_slice_however_the_platform_reports_it() {
    let mut harness = slices();
    let dims = harness.state().volume_data().expect("a volume").volume.dims;
    let axial = harness.state().pane_rects()[1].center();
    harness.hover_at(axial);
    harness.step();
    let wheel = || egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Line,
        delta: egui::vec2(0.0, 1.0),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Unknown,
        modifiers: egui::Modifiers::NONE,
    };
    let slice = |harness: &Harness<'_, VoxscopeApp>| harness.state().view.cursor_voxel(dims)[2];
    let start = slice(&harness);
    // X11's button wheel as winit 0.30 reports it: the press and the release, one notch.
    harness.event(wheel());
    harness.event(wheel());
    settle(&mut harness);
    assert_eq!(
        slice(&harness),
        start + 1,
        "two events of one notch in a frame"
    );
    // The release may come a frame later, on a slow device long after.
    harness.event(wheel());
    harness.step();
    harness.event(wheel());
    settle(&mut harness);
    assert_eq!(
        slice(&harness),
        start + 2,
        "a notch whose release came a frame later"
    );
}
