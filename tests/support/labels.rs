//! The labelled image that ome-zarr-py wrote (tests/data/labels-overlay, see
//! make_fixtures.py) and how an overlay is expected to look: the label image opened on its own
//! and drawn by the labels MIP says which label each pixel's ray meets first; that label's
//! color blended over the plain render at the opacity is the expected pixel.

use std::path::PathBuf;
use std::process::{Command, Output};

use image::RgbaImage;
use serde_json::Value;
use voxscope_octree::Colormap;

pub const SIZE: &str = "64x48";
pub const OPACITY: f64 = 0.7;

pub fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/labels-overlay")
}

pub fn image_store() -> String {
    data().join("cells-v04.ome.zarr").display().to_string()
}

pub fn expected() -> Value {
    let text = std::fs::read_to_string(data().join("expected.json")).expect("expected.json");
    serde_json::from_str(&text).expect("valid JSON")
}

pub fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

pub fn out_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-images/label-overlays");
    std::fs::create_dir_all(&dir).expect("create the image folder");
    dir
}

/// Renders `volume` with `extra` options to `name`.png (a close view, 64x48) and reads it.
pub fn render(volume: &str, name: &str, extra: &[&str]) -> RgbaImage {
    let output_path = out_dir().join(format!("{name}.png"));
    let output_text = output_path.display().to_string();
    let mut args = vec![
        "render",
        volume,
        "-o",
        &output_text,
        "--size",
        SIZE,
        "--distance",
        "1.7",
        "--azimuth",
        "35",
    ];
    args.extend_from_slice(extra);
    let output = voxscope(&args);
    assert!(
        output.status.success(),
        "render {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    image::open(&output_path).expect("a PNG").to_rgba8()
}

/// The label values `values` in the labels palette: what the label image opened on its own
/// draws each of them in.
pub fn palette_of(values: &[f64]) -> Vec<([u8; 3], f64)> {
    values
        .iter()
        .map(|&v| (Colormap::Labels.rgb_of(v, 0.0), v))
        .collect()
}

/// The label each pixel's ray meets first (0: none), read from the label image drawn on its
/// own (`alone`) in the palette of `values`.
pub fn first_labels(alone: &RgbaImage, values: &[f64]) -> Vec<f64> {
    let palette = palette_of(values);
    alone
        .pixels()
        .map(|p| {
            let rgb = [p.0[0], p.0[1], p.0[2]];
            if rgb == [0, 0, 0] {
                return 0.0;
            }
            palette
                .iter()
                .find(|(color, _)| *color == rgb)
                .map(|(_, v)| *v)
                .unwrap_or_else(|| panic!("{rgb:?} is no label's palette color"))
        })
        .collect()
}

/// `plain` with each pixel's first label (`labels`) in `color_of`'s color blended over it at
/// `OPACITY` × the color's alpha.
pub fn expected_overlay(
    plain: &RgbaImage,
    labels: &[f64],
    color_of: impl Fn(f64) -> Option<[u8; 4]>,
) -> RgbaImage {
    let mut image = plain.clone();
    for (pixel, &label) in image.pixels_mut().zip(labels) {
        let Some(color) = color_of(label) else {
            continue;
        };
        let alpha = OPACITY * color[3] as f64 / 255.0;
        for (channel, &value) in pixel.0.iter_mut().zip(&color).take(3) {
            *channel = (*channel as f64 * (1.0 - alpha) + value as f64 * alpha).round() as u8;
        }
    }
    image
}

/// Asserts `drawn` equals `expected`: bit for bit where `labels` is 0, within 1 (rounding)
/// elsewhere; returns how many pixels are labelled.
pub fn assert_overlay(
    drawn: &RgbaImage,
    expected: &RgbaImage,
    labels: &[f64],
    what: &str,
) -> usize {
    let mut labelled = 0;
    for (index, ((d, e), &label)) in drawn
        .pixels()
        .zip(expected.pixels())
        .zip(labels)
        .enumerate()
    {
        if label == 0.0 {
            assert_eq!(
                d, e,
                "{what}: pixel {index} without a label must be the plain render's"
            );
        } else {
            labelled += 1;
            let off = (0..4).map(|c| d.0[c].abs_diff(e.0[c])).max().unwrap_or(0);
            assert!(
                off <= 1,
                "{what}: pixel {index} (label {label}) is {:?}, expected {:?}",
                d.0,
                e.0
            );
        }
    }
    labelled
}

pub fn image_label_color(label: f64) -> Option<[u8; 4]> {
    let colors = &expected()["colors"];
    let rgba = colors.get(format!("{label}"))?.as_array()?;
    Some(std::array::from_fn(|c| rgba[c].as_u64().unwrap_or(0) as u8))
}
