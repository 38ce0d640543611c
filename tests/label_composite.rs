//! Labels over a composite of channels (`render --labels NAME` on a store of several channels,
//! in memory and streamed together) on the two-channel labelled image that ome-zarr-py wrote
//! (`tests/data/labels-overlay/cells-channels-v05.ome.zarr`, see make_fixtures.py): the cells
//! are drawn over the composite's picture as over one volume's, and `probe` reads every
//! channel and the cells at a voxel. Runs on the software Vulkan device; GPU tests fail when no
//! adapter is found.

mod support;

use image::RgbaImage;
use support::labels::*;

fn channels_store() -> String {
    data()
        .join("cells-channels-v05.ome.zarr")
        .display()
        .to_string()
}

/// The label each pixel's ray meets first: the cells label image (the same grid as the
/// two-channel image) drawn alone by the dense labels MIP.
fn cells_seen() -> Vec<f64> {
    let alone = render(
        &format!("{}/labels/cells", image_store()),
        "composite-cells-alone",
        &[
            "--renderer",
            "dense",
            "--mode",
            "mip",
            "--colormap",
            "labels",
        ],
    );
    let labels = first_labels(&alone, &[1.0, 2.0, 3.0]);
    for label in [1.0, 2.0, 3.0] {
        assert!(labels.contains(&label), "label {label} is seen in the view");
    }
    labels
}

fn cell_color(label: f64) -> Option<[u8; 4]> {
    (label != 0.0).then(|| image_label_color(label).expect("cells has colors for 1, 2, 3"))
}

#[test]
fn cells_over_the_composite_in_memory_equal_the_expected_overlay() {
    let store = channels_store();
    let labels = cells_seen();
    for mode in ["dvr", "mip"] {
        let plain = render(
            &store,
            &format!("composite-plain-{mode}"),
            &["--mode", mode],
        );
        let drawn = render(
            &store,
            &format!("composite-cells-{mode}"),
            &["--mode", mode, "--labels", "cells"],
        );
        let expected = expected_overlay(&plain, &labels, cell_color);
        let labelled = assert_overlay(&drawn, &expected, &labels, &format!("composite {mode}"));
        assert!(labelled > 200, "{mode}: {labelled} labelled pixels");
    }
    // One channel drawn alone in its color is the dense composite's too: the cells over it.
    let plain = render(&store, "channel1-plain", &["--channel", "1"]);
    let drawn = render(
        &store,
        "channel1-cells",
        &["--channel", "1", "--labels", "cells"],
    );
    let expected = expected_overlay(&plain, &labels, cell_color);
    assert_overlay(&drawn, &expected, &labels, "channel 1 alone");
}

/// Which of `candidates` (label, the plain image with that label's color blended everywhere)
/// pixel `index` of `drawn` shows: 0 where it is `plain`'s pixel, else the label whose blend
/// it is (within rounding); panics on any other color.
fn shown_label(
    drawn: &RgbaImage,
    plain: &RgbaImage,
    candidates: &[(f64, RgbaImage)],
    index: usize,
) -> f64 {
    let (x, y) = (index as u32 % plain.width(), index as u32 / plain.width());
    let pixel = drawn.get_pixel(x, y);
    if pixel == plain.get_pixel(x, y) {
        return 0.0;
    }
    candidates
        .iter()
        .find(|(_, blended)| {
            let expected = blended.get_pixel(x, y);
            (0..3).all(|c| pixel.0[c].abs_diff(expected.0[c]) <= 1)
        })
        .map(|(label, _)| *label)
        .unwrap_or_else(|| panic!("pixel {index} is {:?}: no cell's color", pixel.0))
}

#[test]
fn cells_streamed_over_the_streamed_composite_show_the_cells_the_rays_meet() {
    // The streaming renderer marches its own sample positions: which label a ray meets first
    // may differ from the dense march's at a label's edge; the colors must be exact.
    let store = channels_store();
    let labels = cells_seen();
    for mode in ["dvr", "mip"] {
        let stream = ["--renderer", "stream", "--mode", mode];
        let plain = render(&store, &format!("composite-stream-plain-{mode}"), &stream);
        let mut with_labels = stream.to_vec();
        with_labels.extend(["--labels", "cells"]);
        let drawn = render(
            &store,
            &format!("composite-stream-cells-{mode}"),
            &with_labels,
        );
        let candidates: Vec<(f64, RgbaImage)> = [1.0, 2.0, 3.0]
            .into_iter()
            .map(|label| {
                let everywhere = vec![label; labels.len()];
                (label, expected_overlay(&plain, &everywhere, cell_color))
            })
            .collect();
        let (mut labelled, mut disagree) = (0, 0);
        for (index, &reference) in labels.iter().enumerate() {
            let shown = shown_label(&drawn, &plain, &candidates, index);
            labelled += usize::from(shown != 0.0);
            disagree += usize::from(shown != reference);
        }
        assert!(labelled > 200, "{mode}: {labelled} labelled pixels");
        assert!(
            disagree * 20 <= labelled,
            "{mode}: {disagree} of {labelled} pixels show another cell than the dense march's"
        );
    }
}

#[test]
fn probe_reads_every_channel_and_the_cells_at_a_voxel() {
    // The fixture's channel 0 is the labelled image's blob (its values in expected.json),
    // channel 1 a ramp of 50 + 40·x (make_fixtures.py).
    let store = channels_store();
    for voxel in expected()["voxels"].as_array().expect("voxels") {
        let at: Vec<u64> = voxel["at"]
            .as_array()
            .expect("x, y, z")
            .iter()
            .map(|v| v.as_u64().expect("an index"))
            .collect();
        let text: Vec<String> = at.iter().map(u64::to_string).collect();
        let probe = voxscope(&["probe", &store, "--at", &text.join(","), "--json"]);
        assert!(
            probe.status.success(),
            "{}",
            String::from_utf8_lossy(&probe.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&probe.stdout).expect("JSON");
        let channels = json["channels"].as_array().expect("each channel's value");
        assert_eq!(channels.len(), 2, "{json}");
        assert_eq!(channels[0]["name"], "blob");
        assert_eq!(channels[0]["value"].as_f64(), voxel["image"].as_f64());
        assert_eq!(channels[1]["name"], "ramp");
        assert_eq!(
            channels[1]["value"].as_f64(),
            Some(50.0 + 40.0 * at[0] as f64)
        );
        assert_eq!(json["labels"]["cells"].as_f64(), voxel["cells"].as_f64());
    }
    // As lines; and one channel chosen reads that one alone.
    let lines = voxscope(&["probe", &store, "--at", "16,12,9"]);
    let stdout = String::from_utf8_lossy(&lines.stdout);
    assert!(
        stdout.contains("channel 0  ") && stdout.contains(" blob"),
        "{stdout}"
    );
    assert!(stdout.contains("channel 1  690 ramp"), "{stdout}");
    let one = voxscope(&["probe", &store, "--at", "16,12,9", "--channel", "1"]);
    let stdout = String::from_utf8_lossy(&one.stdout);
    assert!(stdout.contains("value      690"), "{stdout}");
    assert!(!stdout.contains("channel 0"), "{stdout}");
}
