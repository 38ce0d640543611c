//! Frame prefetch of an in-memory time series in the app, driven through egui_kittest on the
//! software Vulkan device: the next frames in play direction are loaded ahead, a prefetched
//! frame shows without a load job (and faster than one loaded on demand: the test prints both
//! times), the window moves on and is bounded; a streamed OME-Zarr store prefetches the next
//! time point with the bricks of the view on screen, and shows it with the view kept.

mod support;

use std::time::{Duration, Instant};

use support::app_harness::{differing_pixels, harness, scratch, settle, view};
use support::http_server::{Faults, FileServer};
use support::writers::{NiftiSpec, encode, nifti_bytes, nifti_datatype};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use voxscope::app::{Command, VoxscopeApp};
use voxscope_render::RendererKind;
use voxscope_scene::{FrameKey, VolumeSource};
use voxscope_volume::{Endian, VoxelType};

/// Voxels along each side of the written series: large enough that loading a frame costs
/// more than showing one.
const SIDE: usize = 96;
const TIME_POINTS: usize = 4;

/// A 4-D NIfTI of `TIME_POINTS` frames of `SIDE`³ i16 voxels (a ball whose radius grows with
/// time), written under target/ (a relative path).
fn write_series() -> String {
    let path = scratch("prefetch-series.nii");
    let center = SIDE as f64 / 2.0;
    let mut values = Vec::with_capacity(SIDE * SIDE * SIDE * TIME_POINTS);
    for t in 0..TIME_POINTS {
        let radius = SIDE as f64 * (0.2 + 0.06 * t as f64);
        for z in 0..SIDE {
            for y in 0..SIDE {
                for x in 0..SIDE {
                    let d = ((x as f64 - center).powi(2)
                        + (y as f64 - center).powi(2)
                        + (z as f64 - center).powi(2))
                    .sqrt();
                    let inside = (radius - d).clamp(0.0, 8.0) / 8.0;
                    values.push((inside * 1000.0 + (x % 7) as f64 * 10.0) as i16);
                }
            }
        }
    }
    let spec = NiftiSpec {
        dims: [SIDE; 3],
        datatype: nifti_datatype(VoxelType::I16),
        spacing: [1.0; 3],
        slope: 0.0,
        intercept: 0.0,
        sform: None,
        endian: Endian::Little,
    };
    let mut bytes = nifti_bytes(&spec, &encode(&values, Endian::Little));
    // dim[0] = 4 and dim[4] = the time points (the writer makes 3-D headers).
    bytes[40..42].copy_from_slice(&4i16.to_le_bytes());
    bytes[48..50].copy_from_slice(&(TIME_POINTS as i16).to_le_bytes());
    std::fs::write(&path, bytes).expect("write the series");
    path.display().to_string()
}

fn at(time: usize) -> FrameKey {
    FrameKey {
        time,
        channel: Some(0),
    }
}

/// Runs `command` and steps until frame `time` is on screen and drawn; the wall time.
fn switch_to(harness: &mut Harness<'_, VoxscopeApp>, time: usize) -> Duration {
    let ctx = harness.ctx.clone();
    let started = Instant::now();
    harness
        .state_mut()
        .run_command(Command::ShowTime(time), &ctx);
    loop {
        harness.step();
        if harness.state().frame() == Some(at(time)) && !harness.state().is_loading() {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "frame {time} never showed"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    // The step that took the frame in drew it.
    started.elapsed()
}

#[test]
fn prefetched_frames_show_without_a_load_and_the_window_moves_on() {
    let series = write_series();
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(series)), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().settings.prefetch_frames, 2);
    assert_eq!(harness.state().prefetched(), [at(1), at(2)]);
    let first = view(&harness);

    // A prefetched frame: on screen in the same call, no load job.
    harness.state_mut().run_command(Command::ShowTime(1), &ctx);
    assert!(
        !harness.state().is_loading(),
        "no load job for a prefetched frame"
    );
    assert_eq!(harness.state().frame(), Some(at(1)));
    settle(&mut harness);
    assert!(
        differing_pixels(&first, &view(&harness)) > 100,
        "frame 1 is drawn"
    );
    // The window moved on: 2 kept, 3 loaded; 1 is on screen and 0 was dropped.
    assert_eq!(harness.state().prefetched(), [at(2), at(3)]);

    let mut with = Vec::new();
    for time in [2, 3] {
        with.push(switch_to(&mut harness, time));
        settle(&mut harness);
    }
    // Wrapping: after the last frame, the first.
    assert_eq!(harness.state().prefetched(), [at(0), at(1)]);

    // Without prefetch every frame loads on demand.
    harness.state_mut().settings.prefetch_frames = 0;
    settle(&mut harness);
    assert!(
        harness.state().prefetched().is_empty(),
        "frames outside the window are dropped"
    );
    let mut without = Vec::new();
    for time in [0, 1] {
        without.push(switch_to(&mut harness, time));
        settle(&mut harness);
    }
    let ms = |d: &[Duration]| -> Vec<String> {
        d.iter()
            .map(|d| format!("{:.1} ms", d.as_secs_f64() * 1e3))
            .collect()
    };
    eprintln!(
        "frame switch of a {SIDE}³ i16 series: prefetched {:?}, loaded on demand {:?}",
        ms(&with),
        ms(&without)
    );
    let slowest_prefetched = with.iter().max().expect("two switches");
    let fastest_loaded = without.iter().min().expect("two switches");
    assert!(
        slowest_prefetched < fastest_loaded,
        "a prefetched frame shows faster ({slowest_prefetched:?}) than one loaded ({fastest_loaded:?})"
    );

    // Play at 2 frames a second switches from memory: no frame is loaded on demand.
    harness.state_mut().settings.prefetch_frames = 2;
    harness.state_mut().settings.frame_rate = 2.0;
    settle(&mut harness);
    harness.get_by_label("Play").click();
    let started = Instant::now();
    let mut shown = vec![harness.state().frame()];
    let mut loaded = false;
    while shown.len() < 4 {
        harness.step();
        loaded |= harness.state().is_loading();
        let frame = harness.state().frame();
        if shown.last() != Some(&frame) {
            shown.push(frame);
        }
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "playback stalled at {shown:?}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    harness.get_by_label("Pause").click();
    settle(&mut harness);
    assert_eq!(shown, [Some(at(1)), Some(at(2)), Some(at(3)), Some(at(0))]);
    assert!(!loaded, "every frame played came from the prefetch");
}

/// Opens the time series `spec` streamed and switches to time point 1 (prefetched) and 2 (the
/// prefetch switched off); the wall times to a complete view of each.
fn streamed_switches(spec: String) -> (Duration, Duration) {
    let mut harness = harness();
    harness.state_mut().settings.renderer = RendererKind::Stream;
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(spec)), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    // The head moving over three time points, streamed: the next time point alone is
    // prefetched, its own streaming renderer.
    assert_eq!(harness.state().frame(), Some(at(0)));
    harness.state_mut().settings.camera.azimuth_deg = 60.0;
    settle(&mut harness);
    assert_eq!(harness.state().prefetched(), [at(1)]);
    let (transfer, camera) = (harness.state().transfer(), harness.state().settings.camera);
    let first = view(&harness);
    // Its loaders read this view's bricks ahead (the warm runs once the view is complete).
    harness.run_steps(2);
    std::thread::sleep(Duration::from_millis(200));
    let started = Instant::now();
    harness.state_mut().run_command(Command::ShowTime(1), &ctx);
    assert!(
        !harness.state().is_loading(),
        "time point 1 came from the prefetch"
    );
    settle(&mut harness);
    let prefetched = started.elapsed();
    let state = harness.state();
    assert_eq!(state.error(), None);
    assert_eq!(state.frame(), Some(at(1)));
    assert_eq!(state.renderer_kind(), Some(RendererKind::Stream));
    assert_eq!(state.transfer(), transfer);
    assert_eq!(state.settings.camera, camera);
    let status = state.stream_status().expect("a streaming status");
    assert!(status.complete, "{status:?}");
    let counters = &status.counters;
    assert!(
        counters.prefetch_loads > 0 && counters.ram_hits > 0,
        "the rays found the view's bricks loaded ahead: {} prefetched, {} RAM hits",
        counters.prefetch_loads,
        counters.ram_hits
    );
    assert!(
        differing_pixels(&first, &view(&harness)) > 100,
        "time point 1 (shifted) is drawn"
    );
    // Without the prefetch, the same switch opens the store's frame and fetches its bricks.
    harness.state_mut().settings.prefetch_frames = 0;
    settle(&mut harness);
    let started = Instant::now();
    harness.state_mut().run_command(Command::ShowTime(2), &ctx);
    assert!(
        harness.state().is_loading(),
        "time point 2 is loaded on demand"
    );
    settle(&mut harness);
    let on_demand = started.elapsed();
    assert_eq!(harness.state().frame(), Some(at(2)));
    (prefetched, on_demand)
}

fn print_switches(what: &str, (prefetched, on_demand): (Duration, Duration)) {
    eprintln!(
        "streamed switch to a complete view ({what}): prefetched {:.1} ms, on demand {:.1} ms",
        prefetched.as_secs_f64() * 1e3,
        on_demand.as_secs_f64() * 1e3
    );
}

#[test]
fn a_streamed_store_prefetches_the_next_time_point_with_this_views_bricks() {
    let spec = "tests/data/ome-zarr/tzyx-head-v04.ome.zarr".to_owned();
    print_switches("folder", streamed_switches(spec));
}

#[test]
fn a_streamed_url_prefetches_the_next_time_point_over_a_slow_link() {
    // The fixtures on 127.0.0.1 with 50 ms a request.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr");
    let server = FileServer::start(
        &root,
        Faults {
            latency: Duration::from_millis(50),
            ..Faults::default()
        },
    );
    let url = server.url("tzyx-head-v04.ome.zarr");
    print_switches("50 ms a request", streamed_switches(url));
}
