//! File ▸ Save screenshot at 2× and 4×, driven through egui_kittest on the software Vulkan
//! device: the 3D view drawn again at that scale in the background equals `render --view` of
//! the same view at that size but for the axes gizmo in its corner; drawn in tiles it is the
//! same image; the rulers and the gizmo are drawn at the same scale (a ruler at 2× covers about
//! four times the pixels it covers at 1×).

mod support;

use std::process::Command as Process;

use egui_kittest::Harness;
use support::app_harness::{harness_with, lit_pixels, scratch, settle};
use voxscope::app::{Command, Panel, Ruler, VoxscopeApp};
use voxscope_scene::VolumeSource;

const VOLUME: &str = "synthetic:noise:24x20x16";

/// The rulers' color in a screenshot (the app's ruler color, opaque).
const RULER: image::Rgba<u8> = image::Rgba([80, 220, 255, 255]);

fn app() -> Harness<'static, VoxscopeApp> {
    app_of(VOLUME)
}

/// The app at 400×300 points showing `spec`, its side panels closed.
fn app_of(spec: &str) -> Harness<'static, VoxscopeApp> {
    let mut harness = harness_with(
        Some(VolumeSource::Spec(spec.to_owned())),
        egui::vec2(400.0, 300.0),
    );
    let ctx = harness.ctx.clone();
    for panel in [Panel::Transfer, Panel::Octree] {
        harness
            .state_mut()
            .run_command(Command::TogglePanel(panel), &ctx);
    }
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    harness
}

fn save(
    harness: &mut Harness<'static, VoxscopeApp>,
    command: Command,
    name: &str,
) -> image::RgbaImage {
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(command, &ctx);
    settle(harness);
    assert_eq!(harness.state().error(), None);
    let notice = harness.state().notice().expect("the status bar says so");
    assert!(notice.starts_with("screenshot saved: "), "{notice}");
    image::open(scratch(name))
        .expect("the screenshot was written")
        .to_rgba8()
}

/// `scaled`, a 2× screenshot of `harness`'s view, is `render --view` of that view at its size
/// but for the axes gizmo in its corner (`name` names the scratch files).
fn assert_is_render_of_the_view(
    harness: &Harness<'static, VoxscopeApp>,
    scaled: &image::RgbaImage,
    name: &str,
) {
    let (width, height) = scaled.dimensions();
    let view = scratch(&format!("{name}.ron"));
    let mut saved = harness.state().saved_view().expect("a view");
    saved.draw.size = (width, height);
    saved.write(&view).expect("write the view");
    let still_path = scratch(&format!("{name}-still.png"));
    let output = Process::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(["render", "--view"])
        .arg(&view)
        .arg("-o")
        .arg(&still_path)
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let still = image::open(&still_path).expect("a still").to_rgba8();
    // The gizmo at 2×: its backdrop's reach and labels lie within 2 × 110 points of the
    // bottom-left corner.
    let gizmo = |x: u32, y: u32| x < 220 && y + 220 > height;
    let mut in_gizmo = 0;
    for (x, y, pixel) in scaled.enumerate_pixels() {
        if pixel != still.get_pixel(x, y) {
            assert!(gizmo(x, y), "({x}, {y}) differs outside the gizmo");
            in_gizmo += 1;
        }
    }
    assert!(
        in_gizmo > 1000,
        "the gizmo is drawn at 2× ({in_gizmo} pixels)"
    );
}

fn ruler_pixels(image: &image::RgbaImage) -> usize {
    image.pixels().filter(|p| **p == RULER).count()
}

#[test]
fn a_screenshot_at_2x_is_the_view_drawn_at_twice_its_pixels_with_rulers_and_gizmo_to_scale() {
    let mut harness = app();
    let [width, height] = harness.state().pane_sizes()[0];
    let scaled = save(
        &mut harness,
        Command::SaveScaledScreenshot {
            path: scratch("shot-2x.png"),
            scale: 2,
        },
        "shot-2x.png",
    );
    assert_eq!(scaled.dimensions(), (2 * width, 2 * height));
    assert!(lit_pixels(&scaled) > 2000, "the volume is drawn");

    assert_is_render_of_the_view(&harness, &scaled, "shot-2x");

    // Drawn in tiles of 64 pixels: the same image.
    harness.state_mut().screenshot_tile = Some(64);
    let tiled = save(
        &mut harness,
        Command::SaveScaledScreenshot {
            path: scratch("shot-2x-tiled.png"),
            scale: 2,
        },
        "shot-2x-tiled.png",
    );
    assert!(tiled == scaled, "tiles make the image one target makes");
    harness.state_mut().screenshot_tile = None;

    // A ruler: at 2× twice as long and twice as wide as at 1×.
    harness.state_mut().view.rulers.push(Ruler {
        from: [2.0, 2.0, 8.0],
        to: [22.0, 18.0, 8.0],
    });
    settle(&mut harness);
    let one = save(
        &mut harness,
        Command::SaveScreenshot(scratch("shot-ruler-1x.png")),
        "shot-ruler-1x.png",
    );
    let two = save(
        &mut harness,
        Command::SaveScaledScreenshot {
            path: scratch("shot-ruler-2x.png"),
            scale: 2,
        },
        "shot-ruler-2x.png",
    );
    let (at_one, at_two) = (ruler_pixels(&one), ruler_pixels(&two));
    assert!(at_one > 50, "the ruler is drawn at 1× ({at_one} pixels)");
    let ratio = at_two as f64 / at_one as f64;
    assert!(
        (3.0..=5.5).contains(&ratio),
        "the ruler at 2× covers {ratio:.2} times its pixels at 1×"
    );
}

/// The composite of a file's channels, saved at 2× (drawn by the offscreen device's own
/// composite renderer, whole and in tiles), is what `render --view` draws of its view.
#[test]
fn a_composite_screenshot_at_2x_is_what_render_draws_of_its_view() {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/channels/two-channels.ome.tif"
    );
    let mut harness = app_of(file);
    let view = harness.state().saved_view().expect("a view");
    assert_eq!(
        view.draw.channels.colors.len(),
        2,
        "the composite of both channels"
    );
    let [width, height] = harness.state().pane_sizes()[0];
    let scaled = save(
        &mut harness,
        Command::SaveScaledScreenshot {
            path: scratch("composite-2x.png"),
            scale: 2,
        },
        "composite-2x.png",
    );
    assert_eq!(scaled.dimensions(), (2 * width, 2 * height));
    assert!(lit_pixels(&scaled) > 2000, "the channels are drawn");
    assert_is_render_of_the_view(&harness, &scaled, "composite-2x");
    harness.state_mut().screenshot_tile = Some(64);
    let tiled = save(
        &mut harness,
        Command::SaveScaledScreenshot {
            path: scratch("composite-2x-tiled.png"),
            scale: 2,
        },
        "composite-2x-tiled.png",
    );
    assert!(tiled == scaled, "tiles make the image one target makes");
}
