//! Label overlays in the app, driven through egui_kittest on the software Vulkan device: an
//! OME-Zarr image with a `labels/` group (tests/data/labels-overlay, written by ome-zarr-py)
//! lists its label images in the Labels section; ticking one draws it over the 3D view in its
//! `image-label` colors (a background job reads, uploads and draws it); unticking a label value
//! hides it, and the ray shows what lies behind.

mod support;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use support::app_harness::{choose_renderer, fresh_app, scratch, settle};
use voxscope::app::{Command, VoxscopeApp};
use voxscope_render::RendererKind;

const IMAGE: &str = "tests/data/labels-overlay/cells-v04.ome.zarr";

/// The 3D pane of `window` (a screenshot at one pixel a point), less its corners' gizmo.
fn pane(harness: &Harness<'_, VoxscopeApp>, window: &image::RgbaImage) -> image::RgbaImage {
    let rect = harness.state().pane_rects()[0].shrink(80.0);
    image::imageops::crop_imm(
        window,
        rect.left() as u32,
        rect.top() as u32,
        rect.width() as u32,
        rect.height() as u32,
    )
    .to_image()
}

/// Pixels whose channel `c` stands well above the other two: label 1's red (c = 0) or label
/// 2's green (c = 1) over the image.
fn dominant(image: &image::RgbaImage, c: usize) -> usize {
    image
        .pixels()
        .filter(|p| (0..3).all(|o| o == c || p.0[c] as i32 > p.0[o] as i32 + 80))
        .count()
}

fn green_pixels(image: &image::RgbaImage) -> usize {
    dominant(image, 1)
}

fn red_pixels(image: &image::RgbaImage) -> usize {
    dominant(image, 0)
}

#[test]
fn label_images_are_listed_ticked_drawn_over_the_view_and_hidden_one_by_one() {
    let mut harness = fresh_app(IMAGE);
    assert_eq!(harness.state().error(), None);
    let window = harness.render().expect("the window renders");
    let plain = pane(&harness, &window);
    window.save(scratch("labels-plain.png")).expect("saved");
    assert_eq!(green_pixels(&plain), 0, "no labels before one is ticked");

    // Both label images are listed; ticking `cells` draws it.
    assert!(
        harness.query_by_label("regions").is_some(),
        "regions is listed"
    );
    harness.get_by_label("cells").click();
    settle(&mut harness);
    let window = harness.render().expect("the window renders");
    let drawn = pane(&harness, &window);
    window.save(scratch("labels-cells.png")).expect("saved");
    let green = green_pixels(&drawn);
    assert!(
        green > 500,
        "label 2 (green) is drawn over the view: {green} pixels"
    );
    let red = red_pixels(&drawn);
    assert!(red > 50, "label 1 (red) is drawn: {red} pixels");

    // Label 2 hidden: its green is gone, and the red box behind the ball shows more.
    harness.get_by_label("label 2").click();
    settle(&mut harness);
    let window = harness.render().expect("the window renders");
    let hidden = pane(&harness, &window);
    window
        .save(scratch("labels-cells-without-2.png"))
        .expect("saved");
    assert!(
        green_pixels(&hidden) < 20,
        "label 2 is hidden: {}",
        green_pixels(&hidden)
    );
    assert!(red_pixels(&hidden) > red, "label 1 behind label 2 shows");

    // Unticked: the view as before.
    harness.get_by_label("cells").click();
    settle(&mut harness);
    let window = harness.render().expect("the window renders");
    let again = pane(&harness, &window);
    assert_eq!(green_pixels(&again), 0);
    assert_eq!(again, plain, "the view without labels");

    // File ▸ Open labels…: the cells as a NIfTI file, drawn at once in the labels palette.
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::OpenLabels("tests/data/labels-overlay/cells.nii".into()),
        &ctx,
    );
    settle(&mut harness);
    let window = harness.render().expect("the window renders");
    window
        .save(scratch("labels-cells-nifti.png"))
        .expect("saved");
    let file = pane(&harness, &window);
    let changed = file
        .pixels()
        .zip(plain.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        changed > 1000,
        "the label file is drawn: {changed} pixels changed"
    );
    assert_eq!(
        green_pixels(&file),
        0,
        "in the palette, not image-label's colors"
    );
    assert_eq!(harness.state().error(), None);
}

#[test]
fn over_the_streaming_renderer_a_label_image_streams_too() {
    let mut harness = fresh_app(IMAGE);
    choose_renderer(&mut harness, "stream");
    settle(&mut harness);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    harness.get_by_label("cells").click();
    settle(&mut harness);
    let window = harness.render().expect("the window renders");
    window
        .save(scratch("labels-cells-streamed.png"))
        .expect("saved");
    let drawn = pane(&harness, &window);
    assert!(
        green_pixels(&drawn) > 500,
        "label 2 streams over the view: {}",
        green_pixels(&drawn)
    );
    assert!(red_pixels(&drawn) > 50, "label 1 too");
    assert_eq!(harness.state().error(), None);
}

/// A label volume opens drawn as labels; the panel says so and offers its values instead (the
/// "Show labels" button did nothing there), and back.
#[test]
fn a_label_volume_toggles_between_labels_and_values() {
    let mut harness = fresh_app("synthetic:labels:48x40x36");
    let colormap = |h: &Harness<'_, VoxscopeApp>| h.state().settings.transfer.colormap;
    assert_eq!(colormap(&harness), voxscope_octree::Colormap::Labels);
    harness.get_by_label("Drawn as labels.");
    assert!(harness.query_by_label("Show labels").is_none());
    harness.get_by_label("Show values").click();
    settle(&mut harness);
    assert_eq!(colormap(&harness), voxscope_octree::Colormap::Grays);
    assert_eq!(
        harness.state().settings.transfer.opacity,
        voxscope_octree::OpacityMode::Gray
    );
    assert!(harness.query_by_label("Drawn as labels.").is_none());
    harness.get_by_label("Show labels").click();
    settle(&mut harness);
    assert_eq!(colormap(&harness), voxscope_octree::Colormap::Labels);
    harness.get_by_label("Drawn as labels.");
}

/// A label volume opened while MIP is on keeps its label colors (its MIP draws the first label
/// shown along each ray): the MIP rule of grays over the window is for intensities.
#[test]
fn a_label_volume_opened_in_mip_keeps_its_colors() {
    let mut harness = fresh_app("synthetic:sphere:32");
    harness.get_by_label("MIP").click();
    settle(&mut harness);
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(voxscope_scene::VolumeSource::Spec(
            "synthetic:labels:48x40x36".into(),
        )),
        &ctx,
    );
    settle(&mut harness);
    assert_eq!(
        harness.state().settings.mode,
        voxscope_render::RenderMode::Mip
    );
    assert_eq!(
        harness.state().settings.transfer.colormap,
        voxscope_octree::Colormap::Labels
    );
}

#[test]
fn a_view_file_keeps_the_label_layers_drawn_and_opens_them_again() {
    let mut harness = fresh_app(IMAGE);
    harness.get_by_label("cells").click();
    settle(&mut harness);
    harness.get_by_label("label 2").click();
    settle(&mut harness);
    let window = harness.render().expect("the window renders");
    let drawn = pane(&harness, &window);
    let saved = harness.state().saved_view().expect("a view");
    assert_eq!(
        saved.draw.labels,
        voxscope_scene::LabelOptions {
            names: vec!["cells".into()],
            opacity: voxscope_scene::DEFAULT_LABEL_OPACITY,
            hide: vec![2.0],
        }
    );
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("cells.ron");
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::SaveView(path.clone()), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);

    // A fresh app showing something else opens the view: the cells drawn again, label 2 hidden.
    let mut second = fresh_app("synthetic:sphere:16");
    let ctx = second.ctx.clone();
    second
        .state_mut()
        .run_command(Command::OpenView(path), &ctx);
    settle(&mut second);
    assert_eq!(second.state().error(), None);
    assert_eq!(
        second.state().saved_view().map(|v| v.draw.labels),
        Some(saved.draw.labels)
    );
    let window = second.render().expect("the window renders");
    window.save(scratch("labels-from-view.png")).expect("saved");
    let reopened = pane(&second, &window);
    assert!(red_pixels(&reopened) > 50, "label 1 is drawn");
    assert!(green_pixels(&reopened) < 20, "label 2 stays hidden");
    assert_eq!(reopened, drawn, "the same picture");
}
