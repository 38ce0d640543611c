//! Saved views in the app, driven through egui_kittest on the software Vulkan device: File ▸
//! Save view… writes what is shown; File ▸ Open view… in a fresh app opens its data and shows
//! the same state and the same picture; Ctrl+S saves again to the view file of the session;
//! `render --view` of a view the app saved draws the app's picture; a view whose data is
//! missing says so in one line; the composite's channels travel with the view.

mod support;

use std::path::Path;
use std::process::Command as Process;

use egui_kittest::Harness;
use support::app_harness::{differing_pixels, harness_with, lit_pixels, scratch, settle, view};
use voxscope::app::{Command, VoxscopeApp};
use voxscope_octree::{Colormap, OpacityMode};
use voxscope_render::Camera;
use voxscope_scene::{ChannelChoice, OpenOptions, SavedView, TransferChoice, VolumeSource};
use voxscope_volume::ValueWindow;

/// Small and asymmetric: a turn or a window changes the picture.
const VOLUME: &str = "synthetic:noise:24x20x16";

/// A small window (the panels hidden make the 3D view most of it), so that frames are cheap.
const WINDOW: egui::Vec2 = egui::vec2(480.0, 360.0);

/// An app showing `source`, its side panels hidden, settled.
fn app(source: &str) -> Harness<'static, VoxscopeApp> {
    let mut harness = harness_with(Some(VolumeSource::Spec(source.to_owned())), WINDOW);
    let ctx = harness.ctx.clone();
    for panel in [voxscope::app::Panel::Transfer, voxscope::app::Panel::Octree] {
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
    settle(harness);
}

fn text(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 path")
}

#[test]
fn a_saved_view_opens_in_a_fresh_app_as_it_was_and_render_draws_the_same_picture() {
    let path = scratch("round-trip-view.ron");
    let _ = std::fs::remove_file(&path);
    let mut first = app(VOLUME);
    let depth = first.state().volume().expect("a volume is shown").1;
    {
        let app = first.state_mut();
        app.settings.camera = Camera {
            azimuth_deg: 63.0,
            elevation_deg: -12.0,
            distance: 2.2,
            ..Camera::default()
        };
        app.settings.transfer = TransferChoice {
            opacity: OpacityMode::Binary,
            threshold: 0.45,
            colormap: Colormap::Viridis,
        };
        app.view.window = ValueWindow {
            low: 0.1,
            high: 0.8,
        };
        app.view.max_level = depth - 1;
        app.view.clipping.box_on = true;
        app.view.clipping.bounds = [[0.0, 0.8], [0.1, 1.0], [0.0, 1.0]];
        // A GPU budget other than the one a fresh app streams with.
        app.settings.stream_gpu_memory = 128 << 20;
    }
    settle(&mut first);
    run(&mut first, Command::SaveView(path.clone()));
    assert_eq!(first.state().error(), None);
    let notice = first.state().notice().expect("the status bar says so");
    assert!(notice.starts_with("view saved: "), "{notice}");
    let saved = SavedView::read(&path).expect("the app wrote a view file");
    assert_eq!(Some(&saved), first.state().saved_view().as_ref());
    assert_eq!(saved.open.source.as_deref(), Some(VOLUME));
    assert_eq!(saved.draw.camera.azimuth_deg, 63.0);
    assert_eq!(saved.draw.transfer.level, Some(depth - 1));
    assert_eq!(saved.draw.stream.gpu_memory, 128 << 20);
    let shown = view(&first);
    assert!(lit_pixels(&shown) > 500, "the view shows the volume");
    shown
        .save(scratch("round-trip-view-app.png"))
        .expect("write the app's picture");

    // A fresh app showing something else opens the view: the same state, the same picture.
    let mut second = app("synthetic:sphere:16");
    let second_budget = second.state().settings.stream_gpu_memory;
    run(&mut second, Command::OpenView(path.clone()));
    assert_eq!(second.state().error(), None);
    let reopened = second.state();
    assert_eq!(
        reopened.volume().map(|v| v.0),
        first.state().volume().map(|v| v.0)
    );
    assert_eq!(reopened.settings.camera, first.state().settings.camera);
    assert_eq!(reopened.transfer(), first.state().transfer());
    assert_eq!(reopened.view.max_level, depth - 1);
    assert_eq!(reopened.view.clipping, first.state().view.clipping);
    assert_ne!(second_budget, 128 << 20);
    assert_eq!(reopened.settings.stream_gpu_memory, 128 << 20);
    assert_eq!(reopened.saved_view(), Some(saved.clone()));
    let drawn = view(&second);
    assert_eq!(
        differing_pixels(&drawn, &shown),
        0,
        "the reopened view draws alike"
    );

    // Ctrl+S saves again to the file the view came from.
    second.state_mut().settings.camera.azimuth_deg = 140.0;
    second.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::S);
    settle(&mut second);
    assert_eq!(second.state().error(), None);
    let again = SavedView::read(&path).expect("Ctrl+S wrote the view file");
    assert_eq!(again.draw.camera.azimuth_deg, 140.0);
    assert_eq!(again.draw.transfer, saved.draw.transfer);
    assert_eq!(again.draw.clip, saved.draw.clip);

    // The command line draws the view the app saved (before Ctrl+S) as the app drew it.
    saved.write(&path).expect("rewrite the first view");
    let png = scratch("round-trip-view.png");
    let resaved = scratch("round-trip-view-resaved.ron");
    let output = Process::new(env!("CARGO_BIN_EXE_voxscope"))
        .args([
            "render",
            "--view",
            text(&path),
            "-o",
            text(&png),
            "--save-view",
            text(&resaved),
        ])
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let rendered = SavedView::read(&resaved).expect("render wrote its view");
    assert_eq!(rendered.draw.camera, saved.draw.camera);
    assert_eq!(rendered.draw.transfer, saved.draw.transfer);
    assert_eq!(rendered.draw.clip, saved.draw.clip);
    assert_eq!(rendered.draw.size, saved.draw.size);
    assert_eq!(rendered.draw.stream, saved.draw.stream);
    let still = image::open(&png).expect("render wrote a PNG").to_rgba8();
    assert_eq!(still.dimensions(), shown.dimensions());
    let differing = differing_pixels(&still, &shown);
    assert!(
        differing * 1000 <= lit_pixels(&shown),
        "{differing} pixels of the still differ from the app's view"
    );
}

#[test]
fn a_view_whose_data_is_missing_says_so_in_one_line_and_the_volume_on_screen_stays() {
    let path = scratch("missing-data-view.ron");
    SavedView {
        open: OpenOptions {
            source: Some("target/app-test/no-such-volume.nii.gz".into()),
            ..Default::default()
        },
        ..SavedView::default()
    }
    .write(&path)
    .expect("write the view");
    let mut harness = app(VOLUME);
    run(&mut harness, Command::OpenView(path));
    let error = harness.state().error().expect("an error is shown");
    assert!(
        error.contains("missing-data-view.ron")
            && error.contains("no-such-volume.nii.gz does not exist"),
        "{error}"
    );
    assert_eq!(error.lines().count(), 1, "{error}");
    assert_eq!(harness.state().volume().map(|v| v.0), Some(VOLUME));
}

#[test]
fn the_composites_channels_travel_with_the_view() {
    let path = scratch("composite-view.ron");
    let mut first = app("tests/data/channels/hyperstack.tif");
    let channels = first.state().composite_channels().expect("the composite");
    assert_eq!(channels.len(), 2);
    {
        let app = first.state_mut();
        app.view.channels[1].color = [255, 200, 0];
        app.view.channels[1].transfer.window.high *= 0.5;
        app.view.channels[0].visible = false;
        app.settings.camera.azimuth_deg = -40.0;
    }
    settle(&mut first);
    run(&mut first, Command::SaveView(path.clone()));
    assert_eq!(first.state().error(), None);
    let saved = SavedView::read(&path).expect("a view file");
    assert_eq!(saved.open.channel, Some(ChannelChoice::All));
    assert_eq!(saved.draw.channels.colors.len(), 2);
    assert_eq!(saved.draw.channels.hidden, vec![0]);

    let mut second = app(VOLUME);
    run(&mut second, Command::OpenView(path));
    assert_eq!(second.state().error(), None);
    assert_eq!(
        second.state().composite_channels(),
        first.state().composite_channels()
    );
    assert_eq!(differing_pixels(&view(&second), &view(&first)), 0);
}
