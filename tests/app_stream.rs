//! The streaming renderer in the app, driven through egui_kittest on the software Vulkan
//! device: chosen in the Octree panel it refines the view without blocking (the app keeps
//! stepping while bricks load), ends equal to the in-memory bricks renderer, reports its state
//! in the panel and the status bar; an OME-Zarr store streams from the file; a budget-limited
//! view offers the budget that holds it, and takes it on a click.

mod support;

use support::app_harness::{choose_renderer, harness, settle, view};
use support::http_server::{Faults, FileServer};
use support::reference::psnr;

use egui_kittest::kittest::Queryable;
use voxscope::app::Command;
use voxscope_render::RendererKind;
use voxscope_scene::VolumeSource;
use voxscope_stream::FullDetailBudget;

#[test]
fn the_streaming_renderer_refines_the_head_to_the_bricks_picture() {
    let mut harness = harness();
    choose_renderer(&mut harness, "bricks");
    let bricks = view(&harness);
    choose_renderer(&mut harness, "stream");
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    let status = harness.state().stream_status().expect("a streaming status");
    assert!(status.complete, "settled means refined: {status:?}");
    assert_eq!(status.missing, 0);
    assert!(
        status.counters.levels[0].resident > 0,
        "level 0 was streamed"
    );
    let streamed = view(&harness);
    let db = psnr(&streamed, &bricks);
    assert!(db >= 35.0, "streamed against bricks: {db:.1} dB");
    // The panel says what the renderer holds; the GPU budget is offered.
    harness.get_by_label("Streaming");
    harness.get_by_label("GPU budget");
    harness.get_by_label("complete: nothing visible is missing");
    // Without the pixel LOD every ray wants the finest level: loaded whole, then walked.
    harness.get_by_label("walking level 7 whole");
    // Measured times and what the loads raced to (prefetches, slots, upload rate) vary: masked.
    let right = harness.ctx.content_rect().right();
    let values = harness.get_by_label("RAM cache").rect().right() + 4.0;
    let top = harness.get_by_label("Atlas").rect().top();
    let bottom = harness.get_by_label("Uploaded").rect().bottom();
    harness.mask(egui::Rect::from_min_max(
        egui::pos2(values, top),
        egui::pos2(right, bottom),
    ));
    let resident = harness.get_by_label("resident").rect();
    harness.mask(egui::Rect::from_min_max(
        egui::pos2(resident.left(), resident.bottom()),
        egui::pos2(right, harness.ctx.content_rect().bottom()),
    ));
    support::app_harness::snapshot(&mut harness, "stream_panel");
}

#[test]
fn an_ome_zarr_store_streams_from_the_file() {
    let mut harness = harness();
    choose_renderer(&mut harness, "stream");
    let store = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ome-zarr/nuclei-v04-blosc-lz4.ome.zarr");
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec(store.display().to_string())),
        &ctx,
    );
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    let status = harness.state().stream_status().expect("a streaming status");
    assert!(status.complete && status.errors.is_empty(), "{status:?}");
    // The store's level 0 (48×48×20) is what streams: 2×2×1 bricks.
    assert_eq!(status.counters.levels[0].total, 4);
    assert!(support::app_harness::lit_pixels(&view(&harness)) > 1000);
}

#[test]
fn a_volume_longer_than_the_octree_streams_from_memory_at_full_resolution() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    // 1 040 voxels along x: beyond the voxel octree's 1 024.
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec("synthetic:gradient:1040x40x36".into())),
        &ctx,
    );
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    let status = harness.state().stream_status().expect("a streaming status");
    assert!(status.complete && status.errors.is_empty(), "{status:?}");
    // The full resolution streams: level 0 is 33×2×2 bricks of 32³, and the max level is the
    // pyramid's depth (11), past the octree's 10.
    assert_eq!(status.counters.levels[0].total, 33 * 2 * 2);
    assert!(status.counters.levels[0].resident > 0);
    assert_eq!(harness.state().view.max_level, 11);
    let image = view(&harness);
    image
        .save(support::image_dir().join("app-stream-1040.png"))
        .expect("write the view");
    assert!(support::app_harness::lit_pixels(&image) > 1000);
}

#[test]
fn a_url_streams_over_a_slow_server_and_the_panel_shows_the_network() {
    // The fixtures served on 127.0.0.1 with 30 ms a request; the store is opened from a URL
    // typed with a user name and password, which must never be saved.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr");
    let server = FileServer::start(
        &root,
        Faults {
            latency: std::time::Duration::from_millis(30),
            ..Faults::default()
        },
    );
    let mut harness = harness();
    choose_renderer(&mut harness, "stream");
    let url = server.url("head-v05-sharded-blosc-zstd.ome.zarr");
    let with_secret = url.replacen("http://", "http://user:secret@", 1);
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(with_secret)), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    let status = harness.state().stream_status().expect("a streaming status");
    assert!(status.complete && status.errors.is_empty(), "{status:?}");
    assert!(support::app_harness::lit_pixels(&view(&harness)) > 1000);
    harness.get_by_label("Network");
    assert!(
        server
            .counters
            .requests
            .load(std::sync::atomic::Ordering::SeqCst)
            > 0
    );
    let recent = &harness.state().settings.recent;
    assert_eq!(
        recent[0], url,
        "remembered without the user name and password"
    );
    assert!(recent.iter().all(|spec| !spec.contains("secret")));
}

#[test]
fn a_budget_limited_view_offers_the_budget_that_holds_it_and_takes_it_on_a_click() {
    let mut harness = harness();
    let ctx = harness.ctx.clone();
    // Under 4 MiB the CT's view needs about twenty times the slots the atlas has for it.
    harness.state_mut().settings.stream_gpu_memory = 4 << 20;
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec("synthetic:ct:256".into())),
        &ctx,
    );
    settle(&mut harness);
    choose_renderer(&mut harness, "stream");
    let status = harness.state().stream_status().expect("a streaming status");
    let limit = status.budget.expect("the budget limits the near view");
    assert!(status.complete, "complete at the budget: {status:?}");
    let FullDetailBudget::Bytes(holding) = limit.full_detail else {
        panic!("no budget named: {}", limit.describe());
    };
    assert!(holding > 4 << 20);
    // The status bar and the panel's state say so.
    assert_eq!(
        harness
            .query_all_by_label_contains(&limit.describe())
            .count(),
        2
    );
    let coarse = view(&harness);
    // The button next to the budget takes the one named: the view refines to full detail.
    // The button and the status name the budget alike ("Use 96 MiB", "a GPU budget of 96 MiB").
    let named = voxscope_stream::format_budget(holding);
    assert!(
        limit
            .describe()
            .contains(&format!("a GPU budget of {named} holds it all")),
        "{}",
        limit.describe()
    );
    let label = format!("Use {named}");
    harness.get_by_label(&label).click();
    settle(&mut harness);
    assert_eq!(harness.state().settings.stream_gpu_memory, holding);
    let status = harness.state().stream_status().expect("a streaming status");
    assert!(status.complete && status.budget.is_none(), "{status:?}");
    assert!(
        harness.query_by_label(&label).is_none(),
        "nothing left to offer"
    );
    let full = view(&harness);
    full.save(support::image_dir().join("app-stream-budget-held.png"))
        .expect("write the view");
    coarse
        .save(support::image_dir().join("app-stream-budget-limited.png"))
        .expect("write the view");
    assert!(support::app_harness::differing_pixels(&coarse, &full) > 100);
}
