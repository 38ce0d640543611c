//! Label overlays (`render --labels NAME|FILE`, `probe`, `info`) on the labelled image that
//! ome-zarr-py wrote (tests/data/labels-overlay, see make_fixtures.py): each overlay equals the
//! expected one, computed independently of the overlay's own pass: the label image opened on
//! its own and drawn by the existing labels MIP (the first visible label along each ray, in the
//! labels palette) says which label each pixel's ray meets first; that label's color (the
//! `image-label` color, else the palette's) blended over the plain render at the opacity is
//! the expected pixel, and pixels whose ray meets no label equal the plain render bit for bit.
//! Runs on the software Vulkan device; GPU tests fail when no adapter is found.

mod support;

use std::path::Path;

use image::RgbaImage;
use serde_json::Value;
use support::labels::*;
use voxscope_octree::Colormap;

#[test]
fn cells_over_the_image_in_dvr_and_mip_in_the_image_label_colors() {
    let store = image_store();
    let alone_path = format!("{store}/labels/cells");
    for (mode, renderer) in [
        ("dvr", "octree"),
        ("mip", "octree"),
        ("dvr", "dense"),
        ("mip", "bricks"),
    ] {
        // The label image on its own, by the same renderer.
        let alone = render(
            &alone_path,
            &format!("cells-alone-{renderer}"),
            &[
                "--mode",
                "mip",
                "--colormap",
                "labels",
                "--renderer",
                renderer,
            ],
        );
        let labels = first_labels(&alone, &[1.0, 2.0, 3.0]);
        for label in [1.0, 2.0, 3.0] {
            assert!(labels.contains(&label), "label {label} is seen in the view");
        }
        let plain = render(
            &store,
            &format!("plain-{mode}-{renderer}"),
            &["--mode", mode, "--renderer", renderer],
        );
        let drawn = render(
            &store,
            &format!("cells-{mode}-{renderer}"),
            &["--mode", mode, "--renderer", renderer, "--labels", "cells"],
        );
        let expected = expected_overlay(&plain, &labels, |label| {
            if label == 0.0 {
                None
            } else {
                Some(image_label_color(label).expect("cells has colors for 1, 2, 3"))
            }
        });
        let labelled = assert_overlay(&drawn, &expected, &labels, &format!("{mode} {renderer}"));
        assert!(
            labelled > 200,
            "{mode} {renderer}: {labelled} labelled pixels"
        );
        assert_ne!(drawn, plain, "{mode} {renderer}: the labels show");
    }
}

#[test]
fn cells_streamed_over_a_streamed_image_equal_the_expected_overlay() {
    // The streaming renderer marches its own sample positions: the reference for which label a
    // ray meets first is the dense renderer's (one-voxel steps) of the label image in memory,
    // which may differ at a label's edge; the colors must be exact.
    let store = image_store();
    let alone_path = format!("{store}/labels/cells");
    let alone = render(
        &alone_path,
        "cells-alone-dense-mip",
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
    // The label image on its own streams as labels too (its `image-label` says so): nearest
    // samples, never a blend of two labels that makes a third (a ring of label 1 between 0
    // and 2).
    let alone_streamed = render(
        &alone_path,
        "cells-alone-stream-mip",
        &[
            "--renderer",
            "stream",
            "--mode",
            "mip",
            "--colormap",
            "labels",
        ],
    );
    let streamed_labels = first_labels(&alone_streamed, &[1.0, 2.0, 3.0]);
    let labelled = labels.iter().filter(|&&l| l != 0.0).count();
    let disagree = labels
        .iter()
        .zip(&streamed_labels)
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        disagree * 20 <= labelled,
        "the label image streamed alone shows another label at {disagree} of {labelled} pixels"
    );
    for mode in ["dvr", "mip"] {
        let stream = ["--renderer", "stream", "--mode", mode];
        let plain = render(&store, &format!("plain-stream-{mode}"), &stream);
        let mut with_labels = stream.to_vec();
        with_labels.extend(["--labels", "cells", "--labels-hide", "3"]);
        let drawn = render(&store, &format!("cells-stream-{mode}"), &with_labels);
        let candidates: Vec<(f64, RgbaImage)> = [1.0, 2.0]
            .into_iter()
            .map(|label| {
                let everywhere = vec![label; labels.len()];
                let color = image_label_color(label).expect("colors");
                (
                    label,
                    expected_overlay(&plain, &everywhere, |_| Some(color)),
                )
            })
            .collect();
        let (mut labelled, mut disagree) = (0, 0);
        for (index, (d, p)) in drawn.pixels().zip(plain.pixels()).enumerate() {
            let (x, y) = (index as u32 % plain.width(), index as u32 / plain.width());
            // The label this pixel shows: none (the plain render's bits), or 1 or 2 exactly
            // blended (label 3 is hidden; nothing else may show).
            let shown = if d == p {
                0.0
            } else {
                candidates
                    .iter()
                    .find(|(_, blended)| {
                        let e = blended.get_pixel(x, y);
                        (0..3).all(|c| d.0[c].abs_diff(e.0[c]) <= 1)
                    })
                    .map(|(label, _)| *label)
                    .unwrap_or_else(|| {
                        panic!(
                            "{mode}: pixel {index} is {:?}: no label's color over the image",
                            d.0
                        )
                    })
            };
            labelled += usize::from(shown != 0.0);
            let reference = labels[index];
            if reference != 3.0 && shown != reference {
                disagree += 1;
            }
        }
        assert!(labelled > 200, "{mode}: {labelled} labelled pixels");
        assert!(
            disagree * 20 <= labelled,
            "{mode}: {disagree} of {labelled} pixels show another label than the dense march's"
        );
    }
    // A label file cannot stream: one line.
    let out = out_dir().join("never-stream.png").display().to_string();
    let file = data().join("cells.nii").display().to_string();
    let failed = voxscope(&[
        "render",
        &store,
        "-o",
        &out,
        "--renderer",
        "stream",
        "--labels",
        &file,
    ]);
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert_eq!(failed.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("a label file is drawn over the image in memory"),
        "{stderr}"
    );
}

#[test]
fn labels_without_colors_take_the_palette_and_a_label_file_works_as_a_name() {
    let store = image_store();
    let plain = render(&store, "plain", &[]);
    // `regions` gives no colors: the labels palette, opaque.
    let alone = render(
        &format!("{store}/labels/regions"),
        "regions-alone",
        &["--mode", "mip", "--colormap", "labels"],
    );
    let labels = first_labels(&alone, &[5.0, 9.0]);
    let palette = |label: f64| {
        (label != 0.0).then(|| {
            let [r, g, b] = Colormap::Labels.rgb_of(label, 0.0);
            [r, g, b, 255]
        })
    };
    let drawn = render(&store, "regions", &["--labels", "regions"]);
    let labelled = assert_overlay(
        &drawn,
        &expected_overlay(&plain, &labels, palette),
        &labels,
        "regions",
    );
    assert!(labelled > 200, "{labelled} labelled pixels");

    // The cells as a NIfTI file of the same grid: no image-label, so the palette.
    let alone = render(
        &format!("{store}/labels/cells"),
        "cells-alone-dvr-view",
        &["--mode", "mip", "--colormap", "labels"],
    );
    let labels = first_labels(&alone, &[1.0, 2.0, 3.0]);
    let file = data().join("cells.nii").display().to_string();
    let drawn = render(&store, "cells-nifti", &["--labels", &file]);
    assert_overlay(
        &drawn,
        &expected_overlay(&plain, &labels, palette),
        &labels,
        "cells.nii",
    );
}

#[test]
fn a_hidden_label_lets_the_ray_reach_the_next_and_opacity_scales_the_blend() {
    let store = image_store();
    let plain = render(&store, "plain-hide", &[]);
    let shown = render(&store, "cells-shown", &["--labels", "cells"]);
    let hidden = render(
        &store,
        "cells-without-2",
        &["--labels", "cells", "--labels-hide", "2"],
    );
    let alone = render(
        &format!("{store}/labels/cells"),
        "cells-alone-hide",
        &["--mode", "mip", "--colormap", "labels"],
    );
    let labels = first_labels(&alone, &[1.0, 2.0, 3.0]);
    let green = expected_overlay(&plain, &labels, |label| {
        (label == 2.0).then(|| image_label_color(2.0).expect("green"))
    });
    let mut changed = 0;
    for (index, &label) in labels.iter().enumerate() {
        let (x, y) = (index as u32 % plain.width(), index as u32 / plain.width());
        let (p, s, h) = (
            plain.get_pixel(x, y),
            shown.get_pixel(x, y),
            hidden.get_pixel(x, y),
        );
        if label == 2.0 {
            // Label 2 is gone: the image, or a label behind it (1 or 3), never its green.
            assert_ne!(
                h,
                green.get_pixel(x, y),
                "pixel {index} still shows label 2"
            );
            changed += usize::from(h != s);
            if h != p {
                assert!(
                    h.0[0] > p.0[0] || h.0[2] > p.0[2],
                    "pixel {index}: red or blue behind"
                );
            }
        } else {
            assert_eq!(
                h, s,
                "pixel {index}: labels 1 and 3 and the background stay"
            );
        }
    }
    assert!(changed > 50, "{changed} pixels of label 2 changed");

    // Opacity 0 draws the image alone; opacity 1 the labels' colors alone.
    let none = render(
        &store,
        "cells-opacity-0",
        &["--labels", "cells", "--labels-opacity", "0"],
    );
    assert_eq!(none, plain);
    let full = render(
        &store,
        "cells-opacity-1",
        &["--labels", "cells", "--labels-opacity", "1"],
    );
    for (pixel, &label) in full.pixels().zip(&labels) {
        if let Some(color) = (label != 0.0).then(|| image_label_color(label)).flatten() {
            assert_eq!(&pixel.0[..3], &color[..3]);
        }
    }
}

#[test]
fn wrong_grids_and_unknown_names_are_one_line_and_info_and_probe_read_the_labels() {
    let store = image_store();
    let out = out_dir().join("never.png").display().to_string();
    let wrong = data().join("wrong-grid.nii").display().to_string();
    let failed = voxscope(&["render", &store, "-o", &out, "--labels", &wrong]);
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert_eq!(failed.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("wrong-grid.nii")
            && stderr.contains("12x10x8")
            && stderr.contains("24x20x16"),
        "{stderr}"
    );
    assert!(!Path::new(&out).exists());

    let failed = voxscope(&["render", &store, "-o", &out, "--labels", "nuclei"]);
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert_eq!(failed.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("nuclei") && stderr.contains("cells, regions"),
        "{stderr}"
    );

    // info lists the label images with their image-label colors.
    let info = voxscope(&["info", &store, "--json"]);
    assert!(
        info.status.success(),
        "{}",
        String::from_utf8_lossy(&info.stderr)
    );
    let json: Value = serde_json::from_slice(&info.stdout).expect("JSON");
    let labels = json["pyramid"]["labels"].as_array().expect("labels listed");
    let names: Vec<&str> = labels.iter().filter_map(|l| l["name"].as_str()).collect();
    assert_eq!(names, ["cells", "regions"]);
    assert_eq!(labels[0]["path"], "labels/cells");
    assert_eq!(labels[0]["colors"][1]["value"], 2.0);
    assert_eq!(
        labels[0]["colors"][1]["rgba"],
        serde_json::json!([0, 255, 0, 255])
    );
    assert_eq!(labels[0]["version"], "0.4");
    assert_eq!(labels[1]["colors"].as_array().map(Vec::len), Some(0));

    // probe reads every label image's value beside the image's.
    for voxel in expected()["voxels"].as_array().expect("voxels") {
        let at: Vec<String> = voxel["at"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.to_string())
            .collect();
        let probe = voxscope(&["probe", &store, "--at", &at.join(","), "--json"]);
        assert!(
            probe.status.success(),
            "{}",
            String::from_utf8_lossy(&probe.stderr)
        );
        let json: Value = serde_json::from_slice(&probe.stdout).expect("JSON");
        assert_eq!(json["value"].as_f64(), voxel["image"].as_f64(), "{at:?}");
        assert_eq!(
            json["labels"]["cells"].as_f64(),
            voxel["cells"].as_f64(),
            "{at:?}"
        );
        assert_eq!(
            json["labels"]["regions"].as_f64(),
            voxel["regions"].as_f64(),
            "{at:?}"
        );
    }
    let file = data().join("cells.nii").display().to_string();
    let probe = voxscope(&["probe", &store, "--at", "16,12,9", "--labels", &file]);
    let stdout = String::from_utf8_lossy(&probe.stdout);
    assert!(
        stdout.contains("label      2 (") && stdout.contains("cells.nii)"),
        "{stdout}"
    );
}

/// 300 labels of distinct `image-label` colors (more than one pass's 255 slots), one voxel
/// each in one slice seen from above: every labelled pixel has one of the given colors, and
/// more than 255 distinct ones show (the second pass's high part is decoded).
#[test]
fn more_than_255_colors_take_a_second_pass_and_keep_their_colors() {
    use voxscope_render::{RenderSettings, RenderTarget, RendererKind};
    use voxscope_scene::LabelOverlay;
    use voxscope_volume::ome_zarr::LabelColor;
    use voxscope_volume::{Volume, VoxelData};

    let values: Vec<u16> = (1..=300).collect();
    let volume = Volume::new(
        "many",
        "test",
        [20, 15, 1],
        [1.0; 3],
        VoxelData::U16(values),
    )
    .expect("a volume");
    let given: Vec<LabelColor> = (1..=300u32)
        .map(|v| LabelColor {
            value: v as f64,
            rgba: [(v % 256) as u8, (v / 256 * 100 + 20) as u8, 77, 255],
        })
        .collect();
    let colors: std::collections::HashSet<[u8; 3]> = given
        .iter()
        .map(|c| [c.rgba[0], c.rgba[1], c.rgba[2]])
        .collect();
    let overlay = LabelOverlay::new("many", &volume, [20, 15, 1], given).expect("labels");
    assert_eq!(overlay.labels.len(), 300);
    let layer = overlay.layer(&[], 1.0, [1.0; 3]).expect("a layer");
    assert_eq!(layer.passes.len(), 2, "300 colors take two passes");
    let depth = layer.passes[0].octree.depth;
    let context = support::gpu();
    let mut uploaded = layer
        .upload(&context, RendererKind::Dense.into(), depth)
        .expect("upload");
    let (width, height) = (240, 180);
    let target = RenderTarget::new(&context, width, height);
    let camera = voxscope_render::Camera {
        azimuth_deg: 0.0,
        elevation_deg: 80.0,
        distance: 1.3,
        ..Default::default()
    };
    let settings = RenderSettings::full_detail(depth);
    let slots = uploaded
        .draw_slots(&context, &target, &camera, &settings)
        .expect("drawn");
    let mut rgba = vec![0u8; (width * height * 4) as usize];
    uploaded.blend(&mut rgba, &slots);
    let mut seen = std::collections::HashSet::new();
    for (pixel, &slot) in rgba.chunks_exact(4).zip(&slots) {
        if slot > 0 {
            let rgb = [pixel[0], pixel[1], pixel[2]];
            assert!(colors.contains(&rgb), "{rgb:?} is no label's color");
            seen.insert(rgb);
        }
    }
    assert!(
        seen.len() > 255,
        "{} distinct label colors drawn",
        seen.len()
    );
}

/// OME-Zarr 0.5 (Zarr v3, `attributes.ome`): the same label images listed and drawn as 0.4's.
#[test]
fn a_0_5_store_lists_and_draws_its_labels_as_0_4_does() {
    let v05 = data().join("cells-v05.ome.zarr").display().to_string();
    let info = voxscope(&["info", &v05, "--json"]);
    assert!(
        info.status.success(),
        "{}",
        String::from_utf8_lossy(&info.stderr)
    );
    let json: Value = serde_json::from_slice(&info.stdout).expect("JSON");
    let labels = json["pyramid"]["labels"].as_array().expect("labels listed");
    let names: Vec<&str> = labels.iter().filter_map(|l| l["name"].as_str()).collect();
    assert_eq!(names, ["cells", "regions"]);
    assert_eq!(labels[0]["version"], "0.5");
    assert_eq!(
        labels[0]["colors"][2]["rgba"],
        serde_json::json!([0, 0, 255, 255])
    );
    let both = ["--labels", "cells,regions", "--mode", "mip"];
    let drawn = render(&v05, "v05-cells-regions", &both);
    let v04 = render(&image_store(), "v04-cells-regions", &both);
    assert_eq!(drawn, v04, "the same voxels and labels draw the same image");
    assert_ne!(drawn, render(&v05, "v05-plain", &["--mode", "mip"]));
}
