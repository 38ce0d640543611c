//! What `render` draws by default for one channel and for a projection: `--channel N` in the
//! channel's color and window (from `--channel-colors` and `--channel-window`, as the
//! composite draws it), and `--mode mip` of any volume in grays unless a colormap or preset is
//! asked for (a CT's DVR keeps its soft-tissue preset).

mod support;

use std::path::Path;
use std::process::{Command, Output};

use image::RgbaImage;
use support::writers::{NiftiSpec, encode, nifti_bytes, nifti_datatype};
use voxscope_volume::{Endian, VoxelType};

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Renders `input` with `extra` options to `out` (64×48) and returns the image and stderr.
fn render(input: &str, out: &Path, extra: &[&str]) -> (RgbaImage, String) {
    let mut args = vec![
        "render",
        input,
        "-o",
        out.to_str().unwrap(),
        "--size",
        "64x48",
    ];
    args.extend_from_slice(extra);
    let output = voxscope(&args);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{extra:?}: {stderr}");
    (image::open(out).unwrap().to_rgba8(), stderr)
}

/// The fraction of pixels that are not black.
fn lit(image: &RgbaImage) -> f64 {
    let count = image
        .pixels()
        .filter(|p| p[0] > 8 || p[1] > 8 || p[2] > 8)
        .count();
    count as f64 / (image.width() * image.height()) as f64
}

/// The mean of every pixel's brightest component.
fn brightness(image: &RgbaImage) -> f64 {
    let sum: f64 = image
        .pixels()
        .map(|p| f64::from(p[0].max(p[1]).max(p[2])))
        .sum();
    sum / (image.width() * image.height()) as f64
}

fn is_gray(image: &RgbaImage) -> bool {
    image
        .pixels()
        .all(|p| p[0].abs_diff(p[1]) <= 1 && p[1].abs_diff(p[2]) <= 1)
}

#[test]
fn one_channel_renders_in_its_color_and_window() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("channel.png");
    let ome = format!(
        "{}/tests/data/channels/two-channels.ome.tif",
        env!("CARGO_MANIFEST_DIR")
    );
    let (wide, stderr) = render(
        &ome,
        &out,
        &[
            "--channel",
            "1",
            "--channel-colors",
            "green,magenta",
            "--channel-window",
            "1:0:65535",
            "--mode",
            "mip",
        ],
    );
    assert!(stderr.contains("in #ff00ff, dense renderer"), "{stderr}");
    // Magenta only: red and blue alike, no green.
    assert!(lit(&wide) > 0.05, "{}", lit(&wide));
    assert!(
        wide.pixels().all(|p| p[1] == 0 && p[0].abs_diff(p[2]) <= 1),
        "not magenta"
    );
    // The window is the one asked for: a narrower one around the data draws it brighter.
    let (narrow, _) = render(
        &ome,
        &out,
        &[
            "--channel",
            "1",
            "--channel-colors",
            "green,magenta",
            "--channel-window",
            "1:3800:5000",
            "--mode",
            "mip",
        ],
    );
    assert!(
        brightness(&narrow) > brightness(&wide) + 10.0,
        "{} against {}",
        brightness(&narrow),
        brightness(&wide)
    );

    // Another renderer draws the channel in grays (in its window) and says why.
    let (octree, stderr) = render(
        &ome,
        &out,
        &[
            "--channel",
            "1",
            "--channel-colors",
            "green,magenta",
            "--renderer",
            "octree",
            "--mode",
            "mip",
        ],
    );
    assert!(
        stderr.contains("its color needs the dense renderer"),
        "{stderr}"
    );
    assert!(is_gray(&octree) && lit(&octree) > 0.05);
}

#[test]
fn mip_defaults_to_grays_for_any_volume() {
    let dir = tempfile::tempdir().unwrap();
    // A CT in Hounsfield units: a ball of soft tissue and bone in air.
    let dims = [24usize, 24, 24];
    let values: Vec<i16> = (0..dims.iter().product::<usize>())
        .map(|i| {
            let (x, y, z) = (i % 24, (i / 24) % 24, i / 576);
            let r2 = [x, y, z]
                .iter()
                .map(|&c| (c as f64 - 11.5).powi(2))
                .sum::<f64>();
            if r2 < 16.0 {
                1500
            } else if r2 < 100.0 {
                40 + (i % 50) as i16
            } else {
                -1000
            }
        })
        .collect();
    let spec = NiftiSpec {
        dims,
        datatype: nifti_datatype(VoxelType::I16),
        spacing: [1.0; 3],
        slope: 1.0,
        intercept: 0.0,
        sform: None,
        endian: Endian::Little,
    };
    let ct = dir.path().join("ct.nii");
    std::fs::write(&ct, nifti_bytes(&spec, &encode(&values, Endian::Little))).unwrap();
    let ct = ct.to_str().unwrap();
    let out = dir.path().join("ct.png");

    // DVR keeps the CT preset's colors; MIP draws grays.
    let (dvr, _) = render(ct, &out, &[]);
    assert!(!is_gray(&dvr), "the soft-tissue preset draws in color");
    let (mip, _) = render(ct, &out, &["--mode", "mip"]);
    assert!(lit(&mip) > 0.05, "{}", lit(&mip));
    assert!(is_gray(&mip), "MIP of a CT is gray");
    // A colormap or preset asked for still applies.
    let (viridis, _) = render(ct, &out, &["--mode", "mip", "--colormap", "viridis"]);
    assert!(!is_gray(&viridis));
    let (preset, _) = render(ct, &out, &["--mode", "mip", "--preset", "ct-bone"]);
    assert!(!is_gray(&preset));
}

/// The PSNR of `a` against `b` (RGB), in dB.
fn psnr(a: &RgbaImage, b: &RgbaImage) -> f64 {
    support::reference::psnr(a, b)
}

#[test]
fn a_stores_channels_stream_together_as_the_in_memory_composite_draws_them() {
    let dir = tempfile::tempdir().unwrap();
    let store = "tests/data/ome-zarr/tczyx-v04.ome.zarr";
    let out = |name: &str| dir.path().join(name);
    let (in_memory, said) = render(store, &out("memory.png"), &[]);
    assert!(said.contains("composite of 2 channels"), "{said}");
    let (streamed, said) = render(store, &out("stream.png"), &["--renderer", "stream"]);
    assert!(
        said.contains("stream renderer")
            && said.contains("composite of 2 channels (#00ff00, #ff00ff)"),
        "{said}"
    );
    assert!(lit(&streamed) > 0.1);
    let db = psnr(&streamed, &in_memory);
    assert!(db > 40.0, "{db:.1} dB from the in-memory composite");

    // One channel chosen: drawn alone in its color; the other channel's bricks never read.
    let (head, said) = render(
        store,
        &out("head.png"),
        &["--renderer", "stream", "--channels", "1"],
    );
    assert!(said.contains("head in #ff00ff"), "{said}");
    assert!(lit(&head) > 0.1);
    assert!(
        head.pixels().all(|p| p[1] <= p[0].max(p[2]) / 4 + 2),
        "magenta only"
    );

    // A channel the store does not have, and --channels beside --channel.
    let bad = voxscope(&[
        "render",
        store,
        "-o",
        out("bad.png").to_str().unwrap(),
        "--renderer",
        "stream",
        "--channels",
        "4",
    ]);
    let said = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success());
    assert!(
        said.contains("--channels 4: there are 2 channels (0 to 1)"),
        "{said}"
    );
    let both = voxscope(&[
        "render",
        store,
        "-o",
        out("bad.png").to_str().unwrap(),
        "--channels",
        "1",
        "--channel",
        "0",
    ]);
    assert!(!both.status.success());
    assert!(String::from_utf8_lossy(&both.stderr).contains("--channel N draws one"));
    // In memory, --channels chooses too: channel 1 alone, in its color.
    let (memory, said) = render(store, &out("memory-head.png"), &["--channels", "1"]);
    assert!(said.contains("head in #ff00ff, dense renderer"), "{said}");
    assert!(lit(&memory) > 0.1);
}

/// Nine channels (OME-Zarr 0.5, sharded; omero marks 1, 3, 4 and 8 active), written by
/// ome-zarr-py (tests/data/ome-zarr/make_channels.py).
const NINE: &str = "tests/data/ome-zarr/channels9-v05-sharded.ome.zarr";

/// The bricks a streamed render says it read.
fn bricks_read(said: &str) -> u64 {
    let before = said.split(" bricks read").next().expect("a stream report");
    before
        .rsplit(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no brick count in {said}"))
}

#[test]
fn a_store_of_nine_channels_streams_its_active_ones_and_reads_no_other() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    // (Level 0 wherever the view is: at 64x48 the pixels' footprint would take level 1.)
    let stream = ["--renderer", "stream", "--lod-scale", "0"];
    let (four, said) = render(NINE, &out("four.png"), &stream);
    assert!(
        said.contains("composite of 4 channels (#ff00ff, #ffff00, #ff0000, #ff80ff)"),
        "omero's active channels, in their colors: {said}"
    );
    assert!(lit(&four) > 0.05);
    let (one, said_one) = render(
        NINE,
        &out("one.png"),
        &[&stream[..], &["--channels", "1"]].concat(),
    );
    assert!(said_one.contains("ch1 in #ff00ff"), "{said_one}");
    // Each channel's bricks alone: four channels read four times one channel's.
    assert_eq!(
        bricks_read(&said),
        4 * bricks_read(&said_one),
        "{said}\n{said_one}"
    );
    // The channel streamed alone draws what the in-memory renderer draws of it.
    let (in_memory, said) = render(NINE, &out("memory.png"), &["--channel", "1"]);
    assert!(said.contains("ch1 in #ff00ff, dense renderer"), "{said}");
    let db = psnr(&one, &in_memory);
    assert!(db > 40.0, "{db:.1} dB from the in-memory channel");

    // In memory as streamed, channels go by their number in the file: --channels chooses
    // them, and channel 8's window is channel 8's (not the fourth's place).
    let chosen = ["--channels", "1,8", "--channel-window", "8:0:9000"];
    let (streamed, _) = render(NINE, &out("s18.png"), &[&stream[..], &chosen].concat());
    let (memory, said) = render(NINE, &out("m18.png"), &chosen);
    assert!(said.contains("composite of 2 channels"), "{said}");
    let db = psnr(&memory, &streamed);
    assert!(
        db > 40.0,
        "{db:.1} dB between channels 1 and 8 in memory and streamed"
    );
    let (plain, _) = render(NINE, &out("m18-plain.png"), &["--channels", "1,8"]);
    assert!(psnr(&plain, &memory) < 30.0, "channel 8's window applies");
    // Chosen channels are checked before any is read: twice, beyond the file, more than 8.
    for (chosen, said) in [
        ("1,1", "channel 1 is chosen twice"),
        ("1,9", "there is no channel 9 (9 channels, 0 to 8)"),
        (
            "0,1,2,3,4,5,6,7,8",
            "9 channels chosen; at most 8 are drawn together",
        ),
    ] {
        let refused = voxscope(&[
            "render",
            NINE,
            "-o",
            out("refused.png").to_str().unwrap(),
            "--channels",
            chosen,
        ]);
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(
            !refused.status.success() && stderr.contains(said),
            "{stderr}"
        );
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
    let (four, _) = render(NINE, &out("m-four.png"), &["--channel-window", "8:0:9000"]);
    let (four_streamed, _) = render(
        NINE,
        &out("s-four.png"),
        &[&stream[..], &["--channel-window", "8:0:9000"]].concat(),
    );
    let db = psnr(&four, &four_streamed);
    assert!(
        db > 40.0,
        "{db:.1} dB: the active four with channel 8's window"
    );
}
