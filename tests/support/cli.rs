//! The voxscope binary run as a user runs it, and the images its `render` writes.

use std::path::Path;
use std::process::{Command, Output};

use image::RgbaImage;

/// Runs `voxscope ARGS…` to its end.
pub fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// `voxscope render INPUT -o DIR/N.png ARGS…` of each input in turn (it must succeed), the
/// images read back.
pub fn renders(dir: &Path, inputs: &[&Path], args: &[&str]) -> Vec<RgbaImage> {
    inputs
        .iter()
        .enumerate()
        .map(|(i, input)| {
            let png = dir.join(format!("render-{i}.png"));
            let mut all = vec![
                "render",
                input.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
            ];
            all.extend_from_slice(args);
            let out = voxscope(&all);
            assert!(
                out.status.success(),
                "{}: {}",
                input.display(),
                String::from_utf8_lossy(&out.stderr)
            );
            image::open(&png).unwrap().to_rgba8()
        })
        .collect()
}

/// Pixels that differ between two images of one size.
pub fn differing_pixels(a: &RgbaImage, b: &RgbaImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}
