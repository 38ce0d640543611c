//! The slow-frame harness: the app on Mesa's software Vulkan device, where a frame of a CT
//! takes seconds, must keep answering input while one is drawn (issue 28: the File menu opened
//! 2.5 s after the click, drags lost their end). Nothing goes to the device while it works on
//! the last batch, and a batch fits a UI frame's budget: a preview first, then the full image
//! band by band. Playing a time series shows the time point that is drawn. GPU tests fail when
//! no adapter is found.

mod support;

use std::time::{Duration, Instant};

use egui_kittest::kittest::Queryable;
use support::app_harness::{settle, software_device_harness};

/// A CT whose frame takes the software device seconds at the harness's size.
const SLOW: &str = "synthetic:ct:256x256x160";

#[test]
fn input_is_answered_while_a_slow_frame_is_drawn() {
    let mut harness = software_device_harness(SLOW);
    let started = Instant::now();
    while harness.state().volume().is_none() {
        assert!(started.elapsed() < Duration::from_secs(120), "never opened");
        harness.step();
        std::thread::sleep(Duration::from_millis(5));
    }
    // Orbit for thirty frames: every one a new view of a frame the device takes seconds for.
    let center = harness.state().pane_rects()[0].center();
    harness.hover_at(center);
    harness.step();
    harness.drag_at(center);
    let mut slowest = Duration::ZERO;
    let mut drawing = 0;
    for step in 0..30 {
        harness.hover_at(center + egui::vec2(4.0 * step as f32, 0.0));
        let begun = Instant::now();
        harness.step();
        slowest = slowest.max(begun.elapsed());
        drawing += usize::from(harness.state().is_drawing());
    }
    harness.drop_at(center + egui::vec2(120.0, 0.0));
    harness.step();
    assert!(
        drawing > 20,
        "the device was busy in only {drawing} of 30 frames"
    );
    // While the full image is drawn, a click on File opens the menu (egui shows a menu the
    // frame after the click's).
    assert!(harness.state().is_drawing(), "a frame is being drawn");
    harness.get_by_label("File").click();
    let begun = Instant::now();
    harness.step();
    harness.step();
    let menu_after = begun.elapsed();
    harness.get_by_label_contains("Open…");
    assert!(harness.state().is_drawing(), "and it still is");
    harness.key_press(egui::Key::Escape);
    harness.step();
    // The frame, once drawn, took the device far longer than any UI frame waited.
    settle(&mut harness);
    let (frame_ms, bands) = harness.state().frame_cost().expect("measured");
    eprintln!(
        "a frame: {frame_ms:.0} ms in {bands} bands; the slowest UI frame while orbiting {:.0} ms, the menu's {:.0} ms",
        slowest.as_secs_f64() * 1e3,
        menu_after.as_secs_f64() * 1e3
    );
    assert!(bands > 1, "drawn in bands ({frame_ms:.0} ms)");
    let frame = Duration::from_secs_f64(frame_ms * 1e-3);
    assert!(
        slowest * 4 < frame && menu_after * 4 < frame,
        "UI frames waited {slowest:?} (the menu {menu_after:?}) for a {frame:?} frame"
    );
}

#[test]
fn playback_on_a_slow_device_shows_every_time_point_it_names() {
    let store = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ome-zarr/tzyx-head-v04.ome.zarr");
    let mut harness = software_device_harness(&store.display().to_string());
    settle(&mut harness);
    let time = |harness: &egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>| {
        harness.state().frame().expect("a volume").time
    };
    // As fast as playback goes: each frame's drawing is what paces it.
    harness.state_mut().settings.frame_rate = 30.0;
    harness.get_by_label("Play").click();
    let started = Instant::now();
    let mut named = time(&harness);
    let mut advances = 0;
    let mut said_drawing = false;
    while advances < 4 {
        harness.step();
        std::thread::sleep(Duration::from_millis(5));
        let now = time(&harness);
        if now != named {
            // The next time point only once the last one was on screen whole.
            assert_eq!(
                harness.state().shown_time(),
                Some(named),
                "moved on to {now} before {named} was shown"
            );
            named = now;
            advances += 1;
        }
        // While a time point is drawn, the controls say which one the picture still is.
        if harness.state().shown_time() != Some(named) {
            said_drawing |= harness
                .query_by_label_contains(&format!("drawing {named}; showing"))
                .is_some();
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "playback stalled at {named}"
        );
    }
    assert!(
        said_drawing,
        "the time controls never said a frame was being drawn"
    );
    harness.get_by_label("Pause").click();
    settle(&mut harness);
}
