//! The command line's transfer functions and defaults: `--opacity-points`, `--preset`, `--tf`,
//! the transfer function a CT opens with, the renderer chosen when the octree does not fit,
//! and `probe`.

mod support;

use std::path::Path;
use std::process::{Command, Output};

use voxscope_octree::{Colormap, OpacityMode, TransferFunction};
use voxscope_render::RenderMode;
use voxscope_scene::SavedTransfer;
use voxscope_volume::{LoadOptions, ValueWindow};

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Renders `volume` with `extra` arguments into `out` (small, from the front) and reads it.
fn render(volume: &str, out: &Path, extra: &[&str]) -> image::RgbaImage {
    let mut args = vec![
        "render",
        volume,
        "-o",
        out.to_str().expect("a UTF-8 path"),
        "--size",
        "160x120",
        "--azimuth",
        "0",
        "--elevation",
        "0",
        "--distance",
        "2",
    ];
    args.extend_from_slice(extra);
    let output = voxscope(&args);
    assert!(output.status.success(), "{args:?}: {}", stderr(&output));
    image::open(out).expect("a PNG").to_rgba8()
}

fn lit(pixel: &image::Rgba<u8>) -> bool {
    pixel.0[..3].iter().any(|&c| c > 12)
}

#[test]
fn a_step_curve_draws_what_binary_draws_at_the_same_threshold() {
    let dir = tempfile::tempdir().unwrap();
    // u8 values: binary at t ≥ 0.5 of the window 0…255 keeps 128 and above, as the curve does.
    let binary = render(
        "synthetic:sphere:48",
        &dir.path().join("binary.png"),
        &[
            "--window",
            "0:255",
            "--opacity",
            "binary",
            "--threshold",
            "0.5",
        ],
    );
    let curve = render(
        "synthetic:sphere:48",
        &dir.path().join("curve.png"),
        &["--window", "0:255", "--opacity-points", "127:0,128:1"],
    );
    assert!(binary.pixels().filter(|p| lit(p)).count() > 1000);
    assert_eq!(binary, curve, "pixel for pixel");
}

#[test]
fn presets_and_saved_transfer_functions_draw_what_their_flags_draw() {
    let dir = tempfile::tempdir().unwrap();
    let bone = render(
        "synthetic:ct:96x96x48",
        &dir.path().join("bone.png"),
        &["--preset", "ct-bone"],
    );
    let soft = render(
        "synthetic:ct:96x96x48",
        &dir.path().join("soft.png"),
        &["--preset", "ct-soft-tissue"],
    );
    let lit_bone = bone.pixels().filter(|p| lit(p)).count();
    let lit_soft = soft.pixels().filter(|p| lit(p)).count();
    assert!(lit_bone > 200, "the skeleton shows ({lit_bone} pixels)");
    assert!(lit_soft > lit_bone, "soft tissue covers more than bone");

    let unknown = voxscope(&[
        "render",
        "synthetic:ct:8",
        "-o",
        "x.png",
        "--preset",
        "bone",
    ]);
    assert!(!unknown.status.success());
    assert!(stderr(&unknown).contains("ct-bone"), "{}", stderr(&unknown));

    // A file saved by the app: the same picture as the flags it stands for.
    let saved = SavedTransfer {
        transfer: TransferFunction {
            opacity: OpacityMode::Binary,
            window: ValueWindow {
                low: 40.0,
                high: 240.0,
            },
            threshold: 0.25,
            colormap: Colormap::Viridis,
        },
        density: 0.5,
        mode: RenderMode::Dvr,
    };
    let ron = dir.path().join("saved.ron");
    saved.write(&ron).expect("written");
    let from_file = render(
        "synthetic:sphere:48",
        &dir.path().join("file.png"),
        &["--tf", ron.to_str().unwrap()],
    );
    let from_flags = render(
        "synthetic:sphere:48",
        &dir.path().join("flags.png"),
        &[
            "--opacity",
            "binary",
            "--threshold",
            "0.25",
            "--window",
            "40:240",
            "--colormap",
            "viridis",
            "--density",
            "0.5",
        ],
    );
    assert_eq!(from_file, from_flags);

    let garbage = dir.path().join("garbage.ron");
    std::fs::write(&garbage, "(not: a transfer function").unwrap();
    let refused = voxscope(&["render", "-o", "x.png", "--tf", garbage.to_str().unwrap()]);
    assert!(!refused.status.success());
    let message = stderr(&refused);
    assert!(
        message.contains("garbage.ron") && message.trim().lines().count() == 1,
        "{message}"
    );
}

#[test]
fn a_ct_opens_showing_the_body_not_the_scanners_cylinder() {
    let dir = tempfile::tempdir().unwrap();
    let ct = "synthetic:ct:128x128x64";
    let default = render(ct, &dir.path().join("default.png"), &[]);
    let gray = render(ct, &dir.path().join("gray.png"), &["--opacity", "gray"]);
    // Along the middle row, from the front: the lit run's width.
    let lit_width = |image: &image::RgbaImage| {
        let row = image.height() / 2;
        let lit: Vec<u32> = (0..image.width())
            .filter(|&x| lit(image.get_pixel(x, row)))
            .collect();
        lit.last().map_or(0, |last| last - lit[0] + 1)
    };
    let center = |image: &image::RgbaImage| *image.get_pixel(image.width() / 2, image.height() / 2);
    let (body, cylinder) = (lit_width(&default), lit_width(&gray));
    assert!(lit(&center(&default)), "the body is drawn");
    // The body is 0.72 of the field of view's 0.96 across: the air around it is transparent.
    assert!(
        (body as f64) < 0.85 * cylinder as f64 && body > cylinder / 2,
        "body {body} px against the field of view's {cylinder} px"
    );
}

#[test]
fn render_uses_bricks_when_the_octree_does_not_fit_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("noise.png");
    // 320³ needs 286 MiB of octree nodes; lavapipe allows 128 MiB per storage buffer.
    let args = [
        "render",
        "synthetic:noise:320",
        "-o",
        out.to_str().unwrap(),
        "--size",
        "64x48",
    ];
    let output = voxscope(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(message.contains("rendering with bricks"), "{message}");
    assert!(message.contains("bricks renderer"), "{message}");
    assert!(out.exists());

    let mut explicit = args.to_vec();
    explicit.extend(["--renderer", "octree"]);
    let refused = voxscope(&explicit);
    assert!(
        !refused.status.success(),
        "an explicit octree fails clearly"
    );
    assert!(
        stderr(&refused).contains("it fits through max level"),
        "{}",
        stderr(&refused)
    );
}

#[test]
fn probe_prints_the_loaders_value_at_displayed_indices() {
    let path = support::shared_data("mri-head-128x128x62.nii.gz");
    let spec = path.to_str().unwrap();
    let volume = voxscope_volume::load(spec, &LoadOptions::default()).expect("loads");
    let [nx, ny, nz] = volume.dims;
    // A few voxels spread through the volume (deterministic).
    for (n, i) in [(0usize, 0usize), (1, 37), (2, 91), (3, 127)] {
        let index = [i % nx, (i * 7 + n) % ny, (i * 3 + 5 * n) % nz];
        let at = format!("{},{},{}", index[0], index[1], index[2]);
        let output = voxscope(&["probe", spec, "--at", &at, "--json"]);
        assert!(output.status.success(), "{}", stderr(&output));
        let json: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
        let expected = volume.value(index[0], index[1], index[2]).expect("inside");
        assert_eq!(json["value"].as_f64(), Some(expected), "at {at}");
        assert_eq!(json["index"], serde_json::json!(index));
        let position: Vec<f64> = (0..3)
            .map(|a| index[a] as f64 * volume.spacing[a])
            .collect();
        assert_eq!(json["position"], serde_json::json!(position));
        // The stored order of a reoriented file is another voxel of the same stored dims.
        let stored = json["stored_index"].as_array().expect("stored index");
        assert_eq!(stored.len(), 3);
    }
    let beyond = format!("0,0,{nz}");
    let outside = voxscope(&["probe", spec, "--at", &beyond]);
    assert!(!outside.status.success());
    let dims = voxscope_volume::format_dims(volume.dims);
    assert!(
        stderr(&outside).contains(&format!("outside its {dims} voxels")),
        "{}",
        stderr(&outside)
    );
}
