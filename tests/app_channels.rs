//! Multi-channel volumes in the app, driven through egui_kittest on the software Vulkan
//! device: a multi-channel file opens as the composite of its channels with the file's colors
//! and windows; the channel list's edits (visibility, the channel being edited, its window)
//! stay live, with no load; the composite is shaded, and the level slider says why it has no
//! levels; one channel is a click away in the channel combo, and the composite comes back as
//! the user left it.

mod support;

use support::app_harness::{differing_pixels, harness, lit_pixels, settle, snapshot, view};

use egui_kittest::kittest::{NodeT, Queryable};
use voxscope::app::Command;
use voxscope_scene::{FrameKey, VolumeSource};
use voxscope_volume::{Selection, ValueWindow};

/// Relative (tests run in the package's folder), so the snapshot's status bar is the same in
/// every checkout: 2 channels (LUTs black to cyan and to orange) × 2 time points.
const HYPERSTACK: &str = "tests/data/channels/hyperstack.tif";

/// t = 2, c = 2 with `omero` labels, colors (green, magenta) and windows.
const OME_ZARR: &str = "tests/data/ome-zarr/tczyx-v04.ome.zarr";

fn open(harness: &mut egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>, spec: &str) {
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::Open(VolumeSource::Spec(spec.into())), &ctx);
    settle(harness);
    assert_eq!(harness.state().error(), None);
}

/// The largest value of color component `component` over the image.
fn max_component(image: &image::RgbaImage, component: usize) -> u8 {
    image.pixels().map(|p| p.0[component]).max().unwrap_or(0)
}

#[test]
fn a_two_channel_file_opens_as_the_composite_and_its_edits_stay_live() {
    let mut harness = harness();
    open(&mut harness, HYPERSTACK);
    let state = harness.state();
    assert_eq!(
        state.frame(),
        Some(FrameKey {
            time: 0,
            channel: None
        })
    );
    let channels = state.composite_channels().expect("the composite is shown");
    assert_eq!(channels.len(), 2);
    // The ImageJ LUTs' end colors, and the pages' labels as names.
    assert_eq!(channels[0].color, [0, 255, 255]);
    assert_eq!(channels[1].color, [255, 127, 0]);
    assert_eq!(channels[0].name, "nuclei z0 t0");
    assert!(channels.iter().all(|c| c.visible));
    let both = view(&harness);
    assert!(lit_pixels(&both) > 1000, "the composite is drawn");
    assert!(max_component(&both, 0) > 100, "the orange channel adds red");
    both.save(support::app_harness::scratch("composite.png"))
        .expect("write the view");
    let channel_combo = harness
        .query_all_by_label("Channel")
        .filter_map(|node| node.accesskit_node().value())
        .collect::<Vec<_>>();
    assert_eq!(channel_combo, ["All (composite)"]);
    harness.get_by_label("0: nuclei z0 t0");
    harness.get_by_label("1: actin z0 t0");
    assert!(
        !harness
            .get_by_label("Lit (headlight)")
            .accesskit_node()
            .is_disabled(),
        "the composite is shaded (each channel by its own gradient)"
    );
    // Unlit, it is another picture, drawn without a load.
    harness.state_mut().settings.shading.enabled = false;
    settle(&mut harness);
    assert!(!harness.state().is_loading());
    let unlit = view(&harness);
    assert!(
        differing_pixels(&both, &unlit) > 500,
        "shading changes the composite's picture"
    );
    harness.state_mut().settings.shading.enabled = true;
    settle(&mut harness);
    assert!(
        harness
            .query_all_by_label("Max level")
            .any(|node| node.accesskit_node().is_disabled()),
        "the composite has no levels"
    );
    harness.get_by_label("Samples per ray");
    snapshot(&mut harness, "channels_composite");

    // Hiding the orange channel: live, no load; what is left is cyan (no red).
    harness.state_mut().view.channels[1].visible = false;
    settle(&mut harness);
    assert!(!harness.state().is_loading());
    let cyan = view(&harness);
    assert!(lit_pixels(&cyan) > 1000);
    assert!(
        max_component(&cyan, 0) <= 2,
        "a hidden channel adds no color (red up to {})",
        max_component(&cyan, 0)
    );
    harness.state_mut().view.channels[1].visible = true;

    // The heat map and the per-ray figures count the composite's samples: with every channel
    // hidden, every block is skipped and no ray samples anything.
    harness.state_mut().settings.heatmap = true;
    settle(&mut harness);
    let samples = harness.state().frame_report().expect("measured");
    let heat = view(&harness);
    heat.save(support::app_harness::scratch("composite-heat.png"))
        .expect("write the view");
    assert!(
        differing_pixels(&both, &heat) > 1000,
        "the heat map is drawn"
    );
    assert!(samples.nodes_per_ray_avg > 1.0, "{samples:?}");
    for channel in &mut harness.state_mut().view.channels {
        channel.visible = false;
    }
    settle(&mut harness);
    let none = harness.state().frame_report().expect("measured");
    assert_eq!(none.nodes_per_ray_max, 0, "every block skipped: {none:?}");
    for channel in &mut harness.state_mut().view.channels {
        channel.visible = true;
    }
    harness.state_mut().settings.heatmap = false;

    // Editing channel 1: the panel takes its transfer function; its window changes alone.
    let ctx = harness.ctx.clone();
    let before = harness.state().composite_channels().expect("composite");
    harness.get_by_label("1: actin z0 t0").click();
    harness.run_steps(2);
    assert_eq!(
        harness.state().view.active_channel,
        1,
        "a click on the row selects it"
    );
    assert_eq!(harness.state().transfer(), before[1].transfer);
    let narrow = ValueWindow {
        low: before[1].transfer.window.high * 0.9,
        high: before[1].transfer.window.high,
    };
    harness.state_mut().view.window = narrow;
    settle(&mut harness);
    assert!(!harness.state().is_loading(), "window edits need no load");
    let after = harness.state().composite_channels().expect("composite");
    assert_eq!(after[1].transfer.window, narrow);
    assert_eq!(
        after[0].transfer, before[0].transfer,
        "channel 0 is untouched"
    );
    let narrowed = view(&harness);
    assert!(
        differing_pixels(&both, &narrowed) > 100,
        "channel 1's window shows at once"
    );
    harness.get_by_label("Transfer function: channel 1");

    // The Slices layout: the composite in 3D beside channel 0's slices.
    harness
        .state_mut()
        .run_command(Command::SetLayout(voxscope::app::Layout::Slices), &ctx);
    settle(&mut harness);
    assert_eq!(harness.state().pane_sizes().len(), 4);
    let slices = view(&harness);
    slices
        .save(support::app_harness::scratch("composite-slices.png"))
        .expect("write the view");
    assert!(lit_pixels(&slices) > 4000);
    harness
        .state_mut()
        .run_command(Command::SetLayout(voxscope::app::Layout::Single), &ctx);
    settle(&mut harness);

    // One channel with any renderer, then back to the composite as it was left.
    harness.state_mut().run_command(
        Command::ShowFrame(Selection {
            channel: 0,
            time: 0,
        }),
        &ctx,
    );
    settle(&mut harness);
    assert_eq!(
        harness.state().frame(),
        Some(FrameKey {
            time: 0,
            channel: Some(0)
        })
    );
    assert!(harness.state().composite_channels().is_none());
    assert!(
        !harness
            .get_by_label("Lit (headlight)")
            .accesskit_node()
            .is_disabled()
    );
    harness
        .state_mut()
        .run_command(Command::ShowComposite, &ctx);
    settle(&mut harness);
    let back = harness
        .state()
        .composite_channels()
        .expect("composite again");
    assert_eq!(back[1].transfer.window, narrow, "the user's window stays");
    assert_eq!(back[1].color, [255, 127, 0]);
}

#[test]
fn ome_zarr_channels_take_their_omero_colors_and_windows() {
    let mut harness = harness();
    open(&mut harness, OME_ZARR);
    let channels = harness.state().composite_channels().expect("composite");
    let summary: Vec<(&str, [u8; 3], [f64; 2])> = channels
        .iter()
        .map(|c| {
            (
                c.name.as_str(),
                c.color,
                [c.transfer.window.low, c.transfer.window.high],
            )
        })
        .collect();
    assert_eq!(
        summary,
        [
            ("nuclei", [0, 255, 0], [2000.0, 30000.0]),
            ("head", [255, 0, 255], [10.0, 200.0]),
        ]
    );
    // Another time point keeps the channels' settings.
    let ctx = harness.ctx.clone();
    harness.state_mut().view.channels[0].color = [255, 255, 0];
    harness.state_mut().run_command(Command::ShowTime(1), &ctx);
    settle(&mut harness);
    assert_eq!(
        harness.state().frame(),
        Some(FrameKey {
            time: 1,
            channel: None
        })
    );
    let channels = harness.state().composite_channels().expect("composite");
    assert_eq!(channels[0].color, [255, 255, 0]);
    assert_eq!(channels[1].transfer.window.high, 200.0);
}

/// The value range of the volume on screen, in its units.
fn value_range(harness: &egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>) -> (f64, f64) {
    let data = harness.state().volume_data().expect("a volume is open");
    let [low, high] = data.quantized.value_range;
    (low, high)
}

/// Picks `item` from the combo box labelled `combo` (its popup opens on a click).
fn pick(
    harness: &mut egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>,
    combo: &str,
    item: &str,
) {
    harness.get_by_label(combo).click();
    harness.run();
    // The popup's entry, a button (a label elsewhere may read the same, e.g. a number).
    harness
        .query_all_by_label(item)
        .find(|node| node.accesskit_node().role() == egui::accesskit::Role::Button)
        .expect("the entry is in the popup")
        .click();
    settle(harness);
    assert_eq!(harness.state().error(), None);
}

#[test]
fn a_plate_opens_its_first_field_and_the_well_and_field_are_picked_in_the_panel() {
    // tests/data/plates: wells A/1 and B/3 of two fields each; a field's values are
    // 10 · well + 4 · field + (x + y + z) mod 4 (well 0 is A/1, 1 is B/3).
    let mut harness = harness();
    open(&mut harness, "tests/data/plates/plate-v04.ome.zarr");
    let (container, opened) = harness.state().container().expect("a plate");
    assert!(matches!(container, voxscope_volume::Container::Plate(_)));
    assert_eq!(opened, "A/1/0");
    assert_eq!(value_range(&harness), (0.0, 3.0));
    harness.get_by_label("Plate, channels and time");
    pick(&mut harness, "Field", "1");
    assert_eq!(
        harness.state().container().expect("still the plate").1,
        "A/1/1"
    );
    assert_eq!(value_range(&harness), (4.0, 7.0));
    // Another well opens its first field.
    pick(&mut harness, "Well", "B/3 (2 fields)");
    assert_eq!(
        harness.state().container().expect("still the plate").1,
        "B/3/0"
    );
    assert_eq!(value_range(&harness), (10.0, 13.0));
    let (name, _) = harness.state().volume().expect("open");
    assert!(name.ends_with("plate-v04.ome.zarr/B/3/0"), "{name}");
    // Another file: no plate.
    open(&mut harness, OME_ZARR);
    assert!(harness.state().container().is_none());
    assert!(harness.query_by_label("Well").is_none());
}

#[test]
fn a_bioformats2raw_root_of_two_series_offers_the_other_in_the_panel() {
    let mut harness = harness();
    open(&mut harness, "tests/data/series/two-series.zarr");
    let (container, opened) = harness.state().container().expect("a container");
    assert!(matches!(container, voxscope_volume::Container::Series(_)));
    assert_eq!(opened, "0");
    let before = harness.state().volume_data().expect("open").volume.dims;
    harness.get_by_label("Series").click();
    harness.run();
    let entry = harness
        .query_all_by_label_contains("(5×4×3)")
        .filter_map(|node| node.accesskit_node().label())
        .next()
        .expect("series 1 is listed with its shape");
    assert!(entry.starts_with("1"), "{entry}");
    harness.get_by_label(&entry).click();
    settle(&mut harness);
    assert_eq!(harness.state().error(), None);
    assert_eq!(harness.state().container().expect("still the root").1, "1");
    assert_eq!(
        harness.state().volume_data().expect("open").volume.dims,
        [5, 4, 3]
    );
    assert_ne!(before, [5, 4, 3]);
}

#[test]
fn a_stores_channels_stream_together_in_the_channel_list_and_hiding_one_reads_nothing() {
    let mut harness = harness();
    harness.state_mut().settings.renderer = voxscope_render::RendererKind::Stream;
    open(&mut harness, OME_ZARR);
    let channels = harness
        .state()
        .composite_channels()
        .expect("the streamed composite is shown");
    assert_eq!(channels.len(), 2);
    assert_eq!(channels[0].color, [0, 255, 0], "omero's colors");
    assert_eq!(channels[1].color, [255, 0, 255]);
    harness.get_by_label("0: nuclei");
    harness.get_by_label("1: head");
    let status = harness.state().stream_status().expect("streamed").clone();
    assert!(status.complete, "{status:?}");
    let both = view(&harness);
    assert!(lit_pixels(&both) > 1000, "the composite is drawn");
    assert!(max_component(&both, 0) > 100, "magenta adds red");
    assert!(max_component(&both, 1) > 100, "green");

    // Hiding the magenta channel: the next frames draw green alone, and nothing is read.
    let loads = status.counters.loads;
    harness.state_mut().view.channels[1].visible = false;
    settle(&mut harness);
    let green = view(&harness);
    assert!(lit_pixels(&green) > 1000);
    assert!(
        max_component(&green, 0) <= 2,
        "a hidden channel adds no color (red up to {})",
        max_component(&green, 0)
    );
    let after = harness.state().stream_status().expect("streamed");
    assert_eq!(after.counters.loads, loads, "nothing loaded");

    // The next time point streams its channels together too, with the settings kept.
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(Command::ShowTime(1), &ctx);
    settle(&mut harness);
    assert_eq!(
        harness.state().frame(),
        Some(FrameKey {
            time: 1,
            channel: None
        })
    );
    let channels = harness.state().composite_channels().expect("composite");
    assert_eq!(channels.len(), 2);
    assert!(!channels[1].visible, "the hidden channel stays hidden");
    assert!(harness.state().stream_status().is_some(), "streamed");
    let later = view(&harness);
    assert!(lit_pixels(&later) > 1000);
    assert!(max_component(&later, 0) <= 2, "green alone at time 1 too");

    // Another GPU budget: the channels are streamed together again, not the first alone.
    // (Before, the renderer of the first channel drew it untinted under the composite's name.)
    harness.state_mut().settings.stream_gpu_memory = 96 << 20;
    settle(&mut harness);
    let channels = harness
        .state()
        .composite_channels()
        .expect("still the composite");
    assert_eq!(channels.len(), 2);
    assert!(!channels[1].visible);
    let again = view(&harness);
    assert!(lit_pixels(&again) > 1000);
    assert!(
        max_component(&again, 1) > 100 && max_component(&again, 0) <= 2,
        "green"
    );
}

#[test]
fn a_file_of_nine_channels_opens_as_the_composite_of_its_active_ones() {
    let mut harness = harness();
    open(
        &mut harness,
        "tests/data/ome-zarr/channels9-v05-sharded.ome.zarr",
    );
    let channels = harness
        .state()
        .composite_channels()
        .expect("the composite is shown");
    let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        ["ch1", "ch3", "ch4", "ch8"],
        "omero's active channels"
    );
    assert_eq!(channels[0].color, [255, 0, 255]);
    assert!(lit_pixels(&view(&harness)) > 500, "the composite is drawn");
}

#[test]
fn a_streamed_composite_of_chosen_channels_keeps_its_colors_through_a_view_file() {
    let mut harness = harness();
    harness.state_mut().settings.renderer = voxscope_render::RendererKind::Stream;
    open(
        &mut harness,
        "tests/data/ome-zarr/channels9-v05-sharded.ome.zarr",
    );
    assert_eq!(
        harness.state().composite_channels().map(|c| c.len()),
        Some(4)
    );
    // ch3 (file channel 3) in cyan, ch8 hidden.
    harness.state_mut().view.channels[1].color = [0, 255, 255];
    harness.state_mut().view.channels[3].visible = false;
    settle(&mut harness);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nine.ron");
    let ctx = harness.ctx.clone();
    harness
        .state_mut()
        .run_command(Command::SaveView(path.clone()), &ctx);
    settle(&mut harness);
    let saved = std::fs::read_to_string(&path).expect("the view is written");
    assert!(saved.contains("chosen: [\n                1,"), "{saved}");

    let mut again = support::app_harness::harness();
    let ctx = again.ctx.clone();
    again.state_mut().run_command(Command::OpenView(path), &ctx);
    settle(&mut again);
    assert_eq!(again.state().error(), None);
    let channels = again
        .state()
        .composite_channels()
        .expect("the composite again");
    let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["ch1", "ch3", "ch4", "ch8"]);
    assert_eq!(
        channels[1].color,
        [0, 255, 255],
        "ch3's color, by its file number"
    );
    assert!(!channels[3].visible && channels[0].visible);
}

/// The status bar's text that holds `part`, if any.
fn status_text(
    harness: &egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>,
    part: &str,
) -> Option<String> {
    harness
        .query_all_by_label_contains(part)
        .next()
        .and_then(|node| {
            let node = node.accesskit_node();
            node.label().or_else(|| node.value())
        })
}

#[test]
fn the_pointer_over_a_composite_reads_each_shown_channels_value_there() {
    for (renderer, spec) in [
        (voxscope_render::RendererKind::Octree, HYPERSTACK),
        (voxscope_render::RendererKind::Stream, OME_ZARR),
    ] {
        let mut harness = harness();
        harness.state_mut().settings.renderer = renderer;
        open(&mut harness, spec);
        let names: Vec<String> = harness
            .state()
            .composite_channels()
            .expect("the composite is shown")
            .iter()
            .map(|c| c.name.clone())
            .collect();
        // The pointer moves over the middle of the 3D view: the probe finds the point there.
        let center = harness.state().pane_rects()[0].center();
        let hover = |harness: &mut egui_kittest::Harness<'_, _>, dx: f32| {
            harness.hover_at(center + egui::vec2(dx, 0.0));
            harness.step();
            harness.hover_at(center + egui::vec2(dx + 2.0, 0.0));
            settle(harness);
        };
        hover(&mut harness, 0.0);
        let text = status_text(&harness, "voxel (")
            .unwrap_or_else(|| panic!("{spec}: the status bar reads the voxel under the pointer"));
        for name in &names {
            assert!(
                text.contains(&format!("· {name} ")),
                "{spec}: {name}'s value in {text:?}"
            );
        }
        // A hidden channel is not read.
        harness.state_mut().view.channels[1].visible = false;
        settle(&mut harness);
        hover(&mut harness, 4.0);
        let text = status_text(&harness, "voxel (").expect("the voxel under the pointer");
        assert!(text.contains(&format!("· {} ", names[0])), "{text:?}");
        assert!(!text.contains(&format!("· {} ", names[1])), "{text:?}");
    }
}
