//! What a new user of the app met in the first fifteen minutes (issue 28), driven through
//! egui_kittest on the software Vulkan device, each as a user meets it: with a fresh home
//! (no settings stored) and with settings stored by a session that looked at a CT first.
//! GPU tests fail when no adapter is found.

mod support;

use std::path::Path;

use egui_kittest::kittest::{NodeT, Queryable};
use support::app_harness::{
    SIZE, fresh_app, harness_with, lit_pixels, restarted_app, scratch, settle, stored_settings,
    view,
};
use voxscope::app::{Command, DialogKind, Layout};
use voxscope_octree::{DataKind, OpacityMode, TransferFunction};
use voxscope_render::RendererKind;
use voxscope_scene::{TransferRequest, VolumeSource, opening_transfer};

const CT: &str = "synthetic:ct:96x96x48";

fn mri() -> String {
    support::shared_data("mri-head-128x128x62.nii.gz")
        .display()
        .to_string()
}

fn open(harness: &mut egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>, spec: &str) {
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(spec.to_owned())), &ctx);
    settle(harness);
    assert_eq!(harness.state().error(), None, "{spec}");
    assert_eq!(harness.state().volume().map(|v| v.0), Some(spec));
}

/// What the volume on screen opens with when nothing is asked: its own default.
fn own_default(app: &voxscope::app::VoxscopeApp) -> TransferFunction {
    let data = app.volume_data().expect("a volume");
    opening_transfer(
        &data.quantized,
        data.kind,
        data.default_window,
        &TransferRequest::default(),
    )
}

#[test]
fn a_ct_then_an_mri_opens_the_mri_with_its_own_default_fresh_and_after_a_restart() {
    // A fresh home: the CT opens with its soft-tissue curve.
    let mut harness = fresh_app(CT);
    let ct = harness.state().transfer();
    assert_eq!(
        harness.state().volume_data().map(|d| d.kind),
        Some(DataKind::Ct)
    );
    assert!(matches!(ct.opacity, OpacityMode::Points(_)), "{ct:?}");
    // Touch nothing; open the MRI: its own default (alpha = gray over its robust window), not
    // the CT's curve in Hounsfield units (a solid cube).
    open(&mut harness, &mri());
    let app = harness.state();
    assert_eq!(app.transfer(), own_default(app));
    assert_eq!(app.transfer().opacity, OpacityMode::Gray);
    let after_ct = view(&harness);
    let direct = view(&fresh_app(&mri()));
    assert_eq!(
        support::app_harness::differing_pixels(&after_ct, &direct),
        0,
        "the MRI after the CT is the MRI opened first"
    );

    // A restart with the settings that session stored (the CT's curve among them): the sample
    // and the MRI open with their own defaults too.
    let mut harness = fresh_app(CT);
    let stored = stored_settings(&mut harness);
    let mut restarted = restarted_app(stored, None);
    assert_eq!(restarted.state().transfer(), own_default(restarted.state()));
    open(&mut restarted, &mri());
    assert_eq!(restarted.state().transfer(), own_default(restarted.state()));
}

#[test]
fn a_pinned_transfer_function_is_kept_for_the_next_volume_and_after_a_restart() {
    let mut harness = fresh_app(&mri());
    harness.get_by_label("Binary").click();
    settle(&mut harness);
    harness.get_by_label("Keep for the next volumes").click();
    settle(&mut harness);
    let pinned = harness.state().transfer();
    assert_eq!(pinned.opacity, OpacityMode::Binary);
    assert_eq!(harness.state().settings.pinned_transfer, Some(pinned));
    // The CT opens with the pinned function, window and all, instead of its preset.
    open(&mut harness, CT);
    assert_eq!(harness.state().transfer(), pinned);
    // Pinned survives a restart: the first volume opens with it.
    let stored = stored_settings(&mut harness);
    let restarted = restarted_app(stored, Some(VolumeSource::Spec(mri())));
    assert_eq!(restarted.state().transfer(), pinned);
    // Unpinned, the next volume is its own again.
    let mut harness = restarted;
    harness.get_by_label("Keep for the next volumes").click();
    settle(&mut harness);
    assert_eq!(harness.state().settings.pinned_transfer, None);
    open(&mut harness, CT);
    assert_eq!(harness.state().transfer(), own_default(harness.state()));
}

#[test]
fn open_in_the_file_browser_opens_a_zarr_store_clicked_or_typed() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr");
    let store = fixtures.join("nuclei-v04-blosc-lz4.ome.zarr");
    let mut harness = fresh_app(&mri());
    let ctx = harness.ctx.clone();
    // Typed: Enter opens the store (before, it went into the folder).
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::Open), &ctx);
    settle(&mut harness);
    let path = harness.get_by_label("Path");
    path.focus();
    path.type_text(&store.display().to_string());
    harness.step();
    harness.key_press(egui::Key::Enter);
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), None);
    assert_eq!(harness.state().error(), None);
    assert_eq!(
        harness.state().volume().map(|v| v.0.to_owned()),
        Some(store.display().to_string())
    );

    // Listed: a store is an entry that opens on a click, the title names stores, and the Open
    // button does what Enter does.
    open(&mut harness, &mri());
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::Open), &ctx);
    settle(&mut harness);
    harness.get_by_label_contains(
        "a file, an OME-Zarr store, an N5 container or a precomputed volume",
    );
    let path = harness.get_by_label("Path");
    path.focus();
    path.type_text(&fixtures.display().to_string());
    harness.step();
    harness.get_by_label("Open").click();
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), Some(DialogKind::Open));
    harness
        .get_by_label_contains("head-v04-zstd.ome.zarr  ·  Zarr store")
        .click();
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), None);
    let head = fixtures.join("head-v04-zstd.ome.zarr");
    assert_eq!(
        harness.state().volume().map(|v| v.0.to_owned()),
        Some(head.display().to_string())
    );

    // Open folder…'s browser names stores in its title.
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::OpenFolder), &ctx);
    settle(&mut harness);
    harness.get_by_label_contains("an N5 container or a precomputed volume");
}

#[test]
fn a_renderer_the_data_called_for_is_not_the_users_and_zoom_starts_over() {
    let mut harness = fresh_app(&mri());
    harness.state_mut().settings.camera.distance = 0.6;
    // Longer than the octree's 1 024 voxels: streamed, for this volume alone. The notice says
    // why as it opens (it stays five seconds; the view refines longer on this device).
    let long = "synthetic:gradient:1040x40x36";
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(long.to_owned())), &ctx);
    while harness.state().volume().map(|v| v.0) != Some(long) {
        assert!(
            harness.state().is_busy(),
            "the open ended: {:?}",
            harness.state().error()
        );
        harness.step();
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let notice = harness.state().notice().expect("why it streams").to_owned();
    settle(&mut harness);
    assert_eq!(harness.state().renderer_kind(), Some(RendererKind::Stream));
    assert_eq!(harness.state().settings.renderer, RendererKind::Octree);
    assert!(
        notice.contains("longer than the octree's 1024 voxels a side") && notice.len() < 160,
        "{notice}"
    );
    assert_ne!(harness.state().settings.camera.distance, 0.6, "zoom reset");
    // The status bar gives the volume's own size, and the coarser level the panels read.
    let panels = harness.state().volume_data().expect("a volume").volume.dims;
    assert!(panels[0] < 1040, "the panels' level: {panels:?}");
    let [x, y, z] = panels;
    harness.get_by_label_contains("1040×40×36 ");
    harness.get_by_label_contains(&format!("streamed; panels at {x}×{y}×{z}"));
    // A small two-channel store opens as the composite of its channels, not streamed.
    let store =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr/tczyx-v04.ome.zarr");
    open(&mut harness, &store.display().to_string());
    let app = harness.state();
    assert!(app.composite_channels().is_some(), "the composite");
    assert_ne!(app.renderer_kind(), Some(RendererKind::Stream));
    // And after a restart the user's renderer is the octree still.
    let stored = stored_settings(&mut harness);
    let restarted = restarted_app(stored, Some(VolumeSource::Spec(mri())));
    assert_eq!(
        restarted.state().renderer_kind(),
        Some(RendererKind::Octree)
    );
}

#[test]
fn save_dialogs_save_with_a_button_confirm_and_start_in_the_last_save_folder() {
    let mut harness = fresh_app(&mri());
    let ctx = harness.ctx.clone();
    let folder = std::path::absolute(scratch("saves")).expect("absolute");
    std::fs::create_dir_all(&folder).expect("create");
    let shot = folder.join("head.png");
    let _ = std::fs::remove_file(&shot);
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::SaveScreenshot), &ctx);
    settle(&mut harness);
    // The field holds `voxscope.png`: select it and type the whole path over it.
    harness.get_by_label("Path").focus();
    harness.step();
    harness.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::A);
    harness.step();
    harness
        .get_by_label("Path")
        .type_text(&shot.display().to_string());
    harness.step();
    harness.get_by_label("Save").click();
    settle(&mut harness);
    assert_eq!(harness.state().browsing(), None);
    assert!(shot.exists(), "{} was saved", shot.display());
    // Confirmed in the status bar, with where it went.
    let notice = harness.state().notice().expect("a confirmation").to_owned();
    assert!(
        notice.starts_with("screenshot saved: ") && notice.contains("saves"),
        "{notice}"
    );
    harness.get_by_label_contains("screenshot saved: ");
    assert_eq!(
        harness.state().settings.last_save_folder.as_deref(),
        Some(folder.as_path())
    );
    // The next save starts there, not in the data's folder.
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::SaveTransfer), &ctx);
    settle(&mut harness);
    harness.get_by_label(&folder.display().to_string());
}

/// File ▸ Save screenshot at 2×… says 2× in its dialog's title and file name (it said
/// "Save screenshot" whatever the scale).
#[test]
fn a_scaled_screenshots_dialog_names_its_scale() {
    let mut harness = fresh_app(&mri());
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::SetScreenshotScale(2), &ctx);
    harness
        .state_mut()
        .run_command(Command::Browse(DialogKind::SaveScreenshot), &ctx);
    settle(&mut harness);
    harness.get_by_label("Save screenshot at 2× (PNG)");
    assert_eq!(
        harness.get_by_label("Path").value().as_deref(),
        Some("voxscope-2x.png")
    );
}

#[test]
fn the_url_window_sits_below_the_menus_and_enter_opens() {
    let mut harness = fresh_app(&mri());
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(Command::AskUrl, &ctx);
    settle(&mut harness);
    let menu = harness.get_by_label("File").rect();
    let field = harness.get_by_role(egui::accesskit::Role::TextInput).rect();
    assert!(
        field.top() > menu.bottom() + 20.0,
        "{field:?} under {menu:?}"
    );
    // A closed port: the open fails, which shows that Enter opened it.
    harness
        .get_by_role(egui::accesskit::Role::TextInput)
        .type_text("http://127.0.0.1:9/none.ome.zarr");
    harness.step();
    harness.key_press(egui::Key::Enter);
    settle(&mut harness);
    assert!(
        harness.query_by_label("Open URL").is_none(),
        "the window closed"
    );
    let error = harness
        .state()
        .error()
        .expect("a closed port fails")
        .to_owned();
    assert!(error.contains("127.0.0.1:9"), "{error}");
}

#[test]
fn the_binary_threshold_is_in_data_units_and_messages_name_no_flags() {
    let mut harness = fresh_app(&mri());
    harness.get_by_label("Binary").click();
    settle(&mut harness);
    let app = harness.state();
    let window = app.view.window;
    let threshold = app.settings.transfer.threshold as f64;
    let in_units = window.low + threshold * (window.high - window.low);
    let slider = harness.get_by_role_and_label(egui::accesskit::Role::Slider, "Threshold");
    let shown = slider
        .accesskit_node()
        .numeric_value()
        .expect("the slider's value");
    assert!(
        (shown - in_units).abs() < 0.01 * (window.high - window.low),
        "the slider says {shown}, the threshold is {in_units} in data units"
    );
    assert!(
        window.high > 1.0,
        "the data's units are not 0–1: {window:?}"
    );

    // A file no format recognizes: the app's message names no command-line flag.
    let path = scratch("mystery.bin");
    std::fs::write(&path, b"neither a header nor magic bytes").expect("write");
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        Command::Open(VolumeSource::Spec(path.display().to_string())),
        &ctx,
    );
    settle(&mut harness);
    let error = harness.state().error().expect("refused").to_owned();
    assert!(error.contains("unrecognized format"), "{error}");
    assert!(!error.contains("--"), "{error}");
}

#[test]
fn the_level_grid_says_which_pane_its_numbers_are_of() {
    let mut harness = harness_with(Some(VolumeSource::Spec(mri())), SIZE);
    harness.get_by_label("Level grid").click();
    settle(&mut harness);
    assert_eq!(harness.state().settings.layout, Layout::LevelGrid);
    harness.get_by_label("Measured");
    // `pane N (level L)`: whichever pane's full image was measured last.
    assert!(
        (1..=4).any(|pane| harness
            .query_by_label_contains(&format!("pane {pane} (level "))
            .is_some()),
        "the pane the numbers are of"
    );
    assert!(lit_pixels(&view(&harness)) > 1000);
}
