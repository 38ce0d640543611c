//! The app meeting bricks that cannot be read (issue 29, item 4 in the app; issue 28, item 3):
//! a store whose finest level is damaged streams with those bricks drawn from the coarser
//! level, shown as missing (never "complete"), named once in the status bar, listed in the
//! Octree panel, not asked for again (damage does not heal), and the untouched window goes
//! idle: no frame is asked for once nothing can change.

mod support;

use std::path::Path;
use std::process::Command as Process;

use egui_kittest::kittest::Queryable;
use support::app_harness::{choose_renderer, harness, settle};
use voxscope::app::Command;
use voxscope_render::RendererKind;
use voxscope_scene::VolumeSource;

/// `convert synthetic:ct:200x160x120 --chunk 32 --format 0.4` into `folder`, then every chunk
/// of level 0 replaced by garbage (each fails to decode).
fn damaged_ct(folder: &Path) -> std::path::PathBuf {
    let store = folder.join("ct.ome.zarr");
    let out = Process::new(env!("CARGO_BIN_EXE_voxscope"))
        .args([
            "convert",
            "synthetic:ct:200x160x120",
            store.to_str().expect("UTF-8"),
            "--chunk",
            "32",
            "--format",
            "0.4",
        ])
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut damaged = 0;
    for relative in support::damage::files(&store) {
        if relative.starts_with("0") && !support::damage::is_metadata(&relative) {
            std::fs::write(store.join(&relative), vec![0xA5u8; 700]).expect("writable");
            damaged += 1;
        }
    }
    assert_eq!(damaged, 7 * 5 * 4);
    store
}

#[test]
fn unreadable_bricks_are_shown_missing_named_once_and_the_app_goes_idle() {
    let dir = tempfile::tempdir().unwrap();
    let store = damaged_ct(dir.path());
    let mut harness = harness();
    choose_renderer(&mut harness, "stream");
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec(store.display().to_string())),
        &ctx,
    );
    settle(&mut harness);
    // It opened (the panels read level 1, since level 0 cannot be read) and streams.
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    let status = harness
        .state()
        .stream_status()
        .expect("a streaming status")
        .clone();
    assert!(status.unreadable > 0, "{status:?}");
    assert_eq!(status.missing, 0, "{status:?}");
    // Damage does not heal: nothing is asked for again.
    assert_eq!(status.next_retry_s, None, "{status:?}");
    let notice = harness.state().notice().unwrap_or_default().to_owned();
    assert!(
        notice.contains("could not be read") && notice.contains("Octree panel"),
        "the status bar names them: {notice}"
    );
    // The status bar and the panel say incomplete, never complete.
    let plural = if status.unreadable == 1 { "" } else { "s" };
    harness.get_by_label(&format!(
        "incomplete: {} brick{plural} unreadable",
        status.unreadable
    ));
    assert!(
        harness
            .query_by_label("complete: nothing visible is missing")
            .is_none()
    );
    // The Octree panel: the state line and the row that counts them (listed below it).
    harness.get_by_label_contains("the view needs could not be read (drawn from coarser levels)");
    harness.get_by_label_contains("could not be read (drawn from coarser levels; listed below)");
    let header = harness.get_by_label_contains("Unreadable bricks (");
    header.click();
    harness.run_steps(2);
    harness.get_by_label_contains("bricks unreadable (level 0:");
    let image = harness.render().expect("the window renders");
    image
        .save(support::image_dir().join("app-unreadable-bricks.png"))
        .expect("write the window");
    // Untouched, it asks for no frame: it does not spin.
    assert!(!harness.state().is_busy());
    for _ in 0..3 {
        harness.step();
    }
    assert!(
        !harness.ctx.requested_repaint_last_pass(),
        "the idle window asked for another frame at once"
    );
    assert!(!harness.state().is_busy());
}
