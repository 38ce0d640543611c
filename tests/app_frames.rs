//! Channels and time points in the app, driven through egui_kittest on the software Vulkan
//! device: a hyperstack's channel and time controls load another frame in the background and
//! show it with the view as it was (camera, transfer function, level); play steps through the
//! time points and wraps.

mod support;

use std::time::{Duration, Instant};

use support::app_harness::{differing_pixels, harness, settle, view};

use egui_kittest::kittest::Queryable;
use voxscope::app::Command;
use voxscope_scene::VolumeSource;
use voxscope_volume::{Selection, ValueWindow};

/// Relative (tests run in the package's folder), so the snapshot's status bar is the same in
/// every checkout.
fn hyperstack() -> String {
    "tests/data/channels/hyperstack.tif".to_owned()
}

#[test]
fn another_frame_keeps_the_view_and_play_steps_through_time() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(hyperstack())), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    let series = harness
        .state()
        .volume_data()
        .expect("open")
        .volume
        .series
        .clone();
    assert_eq!((series.channels.len(), series.time_points), (2, 2));
    assert_eq!(series.selected, Selection::default());
    // The user's own window and camera, which another frame must keep.
    harness.state_mut().view.window = ValueWindow {
        low: 100.0,
        high: 3000.0,
    };
    harness.state_mut().settings.camera.azimuth_deg = 75.0;
    settle(&mut harness);
    let (transfer, camera) = (harness.state().transfer(), harness.state().settings.camera);
    let first = view(&harness);
    assert!(harness.query_all_by_label("Channel").count() > 0);
    assert!(harness.query_all_by_label("Time").count() > 0);
    support::app_harness::snapshot(&mut harness, "frame_controls");

    let frame = Selection {
        channel: 1,
        time: 1,
    };
    harness
        .state_mut()
        .run_command(Command::ShowFrame(frame), &ctx);
    settle(&mut harness);
    let state = harness.state();
    assert_eq!(state.error(), None);
    assert_eq!(
        state.volume_data().expect("open").volume.series.selected,
        frame
    );
    assert_eq!(state.transfer(), transfer, "the transfer function stays");
    assert_eq!(state.settings.camera, camera, "the camera stays");
    let other = view(&harness);
    assert!(
        differing_pixels(&first, &other) > 100,
        "channel 1, time point 1 looks different"
    );

    // Play: time point 1 → 0 (wrapping) → 1, at the frame rate set.
    harness.state_mut().settings.frame_rate = 20.0;
    harness.get_by_label("Play").click();
    let started = Instant::now();
    let mut seen = Vec::new();
    while seen.len() < 2 {
        harness.step();
        std::thread::sleep(Duration::from_millis(10));
        let time = harness
            .state()
            .volume_data()
            .expect("open")
            .volume
            .series
            .selected
            .time;
        if seen.last().copied().unwrap_or(1) != time {
            seen.push(time);
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "playback stalled at {seen:?}"
        );
    }
    assert_eq!(seen, [0, 1]);
    harness.get_by_label("Pause").click();
    settle(&mut harness);
    assert_eq!(harness.state().transfer(), transfer);
}
