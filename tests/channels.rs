//! Channels and time points from every format: the frame asked for is read (sums and voxels
//! against what the reference writers wrote, tests/data/channels/expected.json), the file's
//! channels and time points are listed, a frame out of range is a one-line error, and a frame
//! rendered with `--channel`/`--time` equals the same frame written as a 3-D file of its own.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;
use voxscope_volume::{LoadOptions, Selection, Volume};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/channels")
        .join(name)
}

fn expected() -> Value {
    let text = std::fs::read_to_string(fixture("expected.json")).expect("expected.json");
    serde_json::from_str(&text).expect("expected.json parses")
}

fn load(path: &Path, channel: usize, time: usize) -> Result<Volume, String> {
    let options = LoadOptions {
        select: Selection { channel, time },
        ..LoadOptions::default()
    };
    voxscope_volume::load(&path.display().to_string(), &options).map_err(|e| e.to_string())
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Every frame of every fixture: its sum and three voxels as the writer's script computed them.
#[test]
fn every_frame_of_every_format_reads_the_writers_values() {
    let expected = expected();
    let files = [
        "hyperstack.tif",
        "two-channels.ome.tif",
        "rgb.tif",
        "series-4d.nii.gz",
        "vector.nrrd",
    ];
    let mut frames_checked = 0;
    for name in files {
        let facts = &expected[name];
        let channels = facts["channels"].as_u64().unwrap() as usize;
        let time_points = facts["time_points"].as_u64().unwrap() as usize;
        let dims: Vec<usize> = facts["dims"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| d.as_u64().unwrap() as usize)
            .collect();
        for channel in 0..channels {
            for time in 0..time_points {
                let volume = load(&fixture(name), channel, time).unwrap();
                assert_eq!(volume.dims.to_vec(), dims, "{name}");
                assert_eq!(volume.series.channel_count(), channels, "{name}");
                assert_eq!(volume.series.time_points, time_points, "{name}");
                assert_eq!(volume.series.selected, Selection { channel, time });
                let frame = &facts["frames"][format!("c{channel}t{time}")];
                let sum: f64 = (0..volume.voxel_count())
                    .map(|i| volume.data.get(i).unwrap())
                    .sum();
                assert_eq!(
                    sum,
                    frame["sum"].as_f64().unwrap(),
                    "{name} channel {channel} time {time}"
                );
                for voxel in frame["voxels"].as_array().unwrap() {
                    let v: Vec<u64> = voxel
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|n| n.as_u64().unwrap())
                        .collect();
                    let (x, y, z) = (v[0] as usize, v[1] as usize, v[2] as usize);
                    assert_eq!(
                        volume.value(x, y, z),
                        Some(v[3] as f64),
                        "{name} channel {channel} time {time} voxel ({x}, {y}, {z})"
                    );
                }
                frames_checked += 1;
            }
        }
    }
    // 4 + 2 + 3 + 3 + 3: a fixture that lost frames would show here.
    assert_eq!(frames_checked, 15);
}

#[test]
fn channel_names_and_spacing_come_from_the_files() {
    let ome = load(&fixture("two-channels.ome.tif"), 1, 0).unwrap();
    let names: Vec<Option<&str>> = ome
        .series
        .channels
        .iter()
        .map(|c| c.name.as_deref())
        .collect();
    assert_eq!(names, [Some("DAPI"), Some("GFP")]);
    assert_eq!(ome.spacing, [0.25, 0.25, 1.0]);

    // ImageJ: the LUTs' colors, and each channel's first page's label.
    let hyperstack = load(&fixture("hyperstack.tif"), 0, 1).unwrap();
    assert_eq!(hyperstack.spacing, [0.5, 0.5, 2.0]);
    let expected = expected();
    let facts = &expected["hyperstack.tif"];
    for (channel, info) in hyperstack.series.channels.iter().enumerate() {
        assert_eq!(
            info.name.as_deref(),
            facts["names"][channel].as_str(),
            "channel {channel}"
        );
        let [r, g, b] = info.color.expect("a LUT color");
        assert_eq!(
            format!("#{r:02x}{g:02x}{b:02x}"),
            facts["colors"][channel].as_str().unwrap()
        );
    }
    let nifti = load(&fixture("series-4d.nii.gz"), 0, 2).unwrap();
    assert_eq!(nifti.spacing, [1.5, 1.5, 2.0]);
    let nrrd = load(&fixture("vector.nrrd"), 2, 0).unwrap();
    assert_eq!(nrrd.spacing, [0.5, 0.5, 0.5]);
}

/// The plain `.nii` (read by seeking) and the gzipped one (decompressed up to the frame) give
/// the same frames.
#[test]
fn plain_and_gzipped_nifti_frames_agree() {
    for time in 0..3 {
        let plain = load(&fixture("series-4d.nii"), 0, time).unwrap();
        let gzipped = load(&fixture("series-4d.nii.gz"), 0, time).unwrap();
        assert_eq!(plain.data, gzipped.data, "time point {time}");
    }
}

#[test]
fn frames_out_of_range_are_one_line_errors_naming_file_axis_and_extent() {
    let cases = [
        (
            "hyperstack.tif",
            2,
            0,
            "channel 2 does not exist (the image has 2)",
        ),
        (
            "hyperstack.tif",
            0,
            2,
            "time point 2 does not exist (the image has 2)",
        ),
        (
            "two-channels.ome.tif",
            3,
            0,
            "channel 3 does not exist (the image has 2)",
        ),
        (
            "rgb.tif",
            3,
            0,
            "channel 3 does not exist (the image has 3)",
        ),
        (
            "series-4d.nii.gz",
            0,
            3,
            "time point 3 does not exist (the image has 3)",
        ),
        (
            "series-4d.nii",
            1,
            0,
            "channel 1 does not exist (the image has 1)",
        ),
        (
            "vector.nrrd",
            3,
            0,
            "channel 3 does not exist (the image has 3)",
        ),
        (
            "vector.nrrd",
            0,
            1,
            "time point 1 does not exist (the image has 1)",
        ),
        // A plain 3-D file has one of each.
        (
            "series-t1.nii.gz",
            0,
            1,
            "time point 1 does not exist (the image has 1)",
        ),
    ];
    for (name, channel, time, problem) in cases {
        let path = fixture(name);
        let error = load(&path, channel, time).unwrap_err();
        assert_eq!(error, format!("{}: {problem}", path.display()));
    }
    let synthetic = voxscope_volume::load(
        "synthetic:sphere:8",
        &LoadOptions {
            select: Selection {
                channel: 1,
                time: 0,
            },
            ..LoadOptions::default()
        },
    )
    .unwrap_err();
    assert_eq!(
        synthetic.to_string(),
        "synthetic:sphere:8: channel 1 does not exist (the image has 1)"
    );
}

/// A 4-D NIfTI cut inside its last frame: the frames before it still read, the last one is a
/// one-line error that says which frame; the file is not changed.
#[test]
fn a_truncated_series_fails_only_for_the_frames_it_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(fixture("series-4d.nii")).unwrap();
    let cut = dir.path().join("cut.nii");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    assert!(load(&cut, 0, 1).is_ok());
    let error = load(&cut, 0, 2).unwrap_err();
    assert!(
        error.contains("frame 2 of 3") && error.contains("truncated") && !error.contains('\n'),
        "{error}"
    );
    assert_eq!(std::fs::read(&cut).unwrap(), bytes[..bytes.len() - 100]);
}

/// A NRRD whose time axis is declared by `kinds`, channel axis outermost, ascii: the frame
/// is gathered from the values (written here by hand: value = 1000 c + 100 t + voxel index).
#[test]
fn nrrd_time_and_channel_axes_in_any_position_and_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny, nz, nt, nc) = (3usize, 2usize, 2usize, 2usize, 2usize);
    let mut values = Vec::new();
    // Axis order x, t, y, z, c: time sits between x and y.
    for c in 0..nc {
        for z in 0..nz {
            for y in 0..ny {
                for t in 0..nt {
                    for x in 0..nx {
                        values.push((1000 * c + 100 * t + x + nx * (y + ny * z)).to_string());
                    }
                }
            }
        }
    }
    let text = format!(
        "NRRD0004\ntype: int16\ndimension: 5\nsizes: {nx} {nt} {ny} {nz} {nc}\nkinds: domain time domain domain list\nencoding: ascii\n\n{}\n",
        values.join(" ")
    );
    let path = dir.path().join("xtyzc.nrrd");
    std::fs::write(&path, text).unwrap();
    for (c, t) in [(0, 0), (1, 1), (0, 1), (1, 0)] {
        let volume = load(&path, c, t).unwrap();
        assert_eq!(volume.dims, [nx, ny, nz]);
        assert_eq!(
            (volume.series.channel_count(), volume.series.time_points),
            (nc, nt)
        );
        for i in 0..volume.voxel_count() {
            assert_eq!(
                volume.data.get(i),
                Some((1000 * c + 100 * t + i) as f64),
                "c {c} t {t} voxel {i}"
            );
        }
    }
}

#[test]
fn info_lists_channels_and_time_points_for_every_format() {
    let ome = fixture("two-channels.ome.tif");
    let output = voxscope(&["info", ome.to_str().unwrap(), "--channel", "1"]);
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        text.contains("channels     2 (showing 1): 0 DAPI, 1 GFP\ntime points  1 (showing 0)\n"),
        "{text}"
    );

    let nifti = fixture("series-4d.nii.gz");
    let output = voxscope(&["info", nifti.to_str().unwrap(), "--time", "2", "--json"]);
    assert!(output.status.success());
    let json: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["volume"]["time_points"], 3);
    assert_eq!(json["volume"]["time"], 2);
    assert_eq!(json["volume"]["channels"].as_array().unwrap().len(), 1);

    let tiff = fixture("hyperstack.tif");
    let output = voxscope(&["info", tiff.to_str().unwrap(), "--json"]);
    let json: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["volume"]["channels"].as_array().unwrap().len(), 2);
    assert_eq!(json["volume"]["time_points"], 2);

    let output = voxscope(&["info", tiff.to_str().unwrap(), "--time", "7"]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(
        stderr.trim_end(),
        format!(
            "error: {}: time point 7 does not exist (the image has 2)",
            tiff.display()
        )
    );
}

/// `render FILE --channel C --time T` draws what rendering that frame's own 3-D file draws.
#[test]
fn a_chosen_frame_renders_as_the_same_frame_written_alone() {
    let dir = tempfile::tempdir().unwrap();
    let render = |file: &Path, frame: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut args = vec![
            "render",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--size",
            "96x72",
            "--azimuth",
            "30",
            "--elevation",
            "20",
        ];
        args.extend_from_slice(frame);
        let output = voxscope(&args);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        image::open(&out).unwrap().to_rgba8()
    };
    for (multi, frame, alone) in [
        // The octree renderer draws the chosen channel as a one-channel volume (the dense
        // renderer's default draws it in the file's channel color, as the composite does).
        (
            "hyperstack.tif",
            &["--channel", "1", "--time", "1", "--renderer", "octree"][..],
            "hyperstack-c1-t1.tif",
        ),
        ("series-4d.nii.gz", &["--time", "1"][..], "series-t1.nii.gz"),
    ] {
        let chosen = render(&fixture(multi), frame, "chosen.png");
        let single = render(&fixture(alone), &[], "alone.png");
        assert!(
            support::reference::coverage(&single) > 0.05,
            "{alone}: the volume is visible"
        );
        let psnr = support::reference::psnr(&chosen, &single);
        assert!(psnr >= 60.0, "{multi} {frame:?} against {alone}: {psnr} dB");
        // And another frame differs: the option was honoured.
        let other = render(&fixture(multi), &[], "other.png");
        assert!(
            support::reference::psnr(&other, &single) < 60.0,
            "{multi}: frame 0 differs"
        );
    }
}

/// A channel axis is listed channel by channel: one of more entries than an axis may have
/// voxels is refused before anything of that size exists.
#[test]
fn a_huge_nrrd_channel_axis_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("many.nrrd");
    let mut bytes =
        b"NRRD0004\ntype: uint8\ndimension: 4\nsizes: 70000 1 1 1\nkinds: list domain domain domain\nencoding: raw\n\n"
            .to_vec();
    bytes.extend(vec![7u8; 70000]);
    std::fs::write(&path, &bytes).unwrap();
    let error = load(&path, 0, 0).unwrap_err();
    assert_eq!(
        error,
        format!(
            "{}: NRRD channel axis 0 has 70000 entries, more than 65536",
            path.display()
        )
    );
}

/// A 4-D header/image pair (`.hdr` + `.img`, magic `ni1`): the frame is read from the `.img`.
#[test]
fn a_nifti_pair_reads_its_frames_from_the_image_file() {
    let dir = tempfile::tempdir().unwrap();
    let single = std::fs::read(fixture("series-4d.nii")).unwrap();
    let vox_offset = f32::from_le_bytes(single[108..112].try_into().unwrap()) as usize;
    let mut header = single[..348].to_vec();
    header[344..348].copy_from_slice(b"ni1\0");
    header[108..112].copy_from_slice(&0f32.to_le_bytes());
    std::fs::write(dir.path().join("pair.hdr"), &header).unwrap();
    std::fs::write(dir.path().join("pair.img"), &single[vox_offset..]).unwrap();
    for time in 0..3 {
        let pair = load(&dir.path().join("pair.hdr"), 0, time).unwrap();
        let gzipped = load(&fixture("series-4d.nii.gz"), 0, time).unwrap();
        assert_eq!(pair.data, gzipped.data, "time point {time}");
    }
    // The .img cut inside frame 2: that frame fails, naming the .img.
    let image = dir.path().join("pair.img");
    let cut = &single[vox_offset..single.len() - 10];
    std::fs::write(&image, cut).unwrap();
    let error = load(&dir.path().join("pair.hdr"), 0, 2).unwrap_err();
    assert!(
        error.contains("pair.img") && error.contains("frame 2 of 3"),
        "{error}"
    );
}

/// `convert` writes the frame asked for; a source read in slabs (raw NRRD) refuses a frame it
/// lacks instead of writing its only one.
#[test]
fn convert_writes_the_chosen_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t1.ome.zarr");
    let series = fixture("series-4d.nii.gz");
    let output = voxscope(&[
        "convert",
        series.to_str().unwrap(),
        out.to_str().unwrap(),
        "--time",
        "1",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let converted = load(&out, 0, 0).unwrap();
    let alone = load(&fixture("series-t1.nii.gz"), 0, 0).unwrap();
    assert_eq!(converted.dims, alone.dims);
    let values = |v: &Volume| -> Vec<f64> {
        (0..v.voxel_count())
            .map(|i| v.data.get(i).unwrap())
            .collect()
    };
    assert_eq!(values(&converted), values(&alone));

    let raw = dir.path().join("raw.nrrd");
    let mut bytes =
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n\n".to_vec();
    bytes.extend([1u8; 24]);
    std::fs::write(&raw, bytes).unwrap();
    let output = voxscope(&[
        "convert",
        raw.to_str().unwrap(),
        dir.path().join("raw.ome.zarr").to_str().unwrap(),
        "--channel",
        "1",
    ]);
    assert!(!output.status.success());
    assert!(
        String::from_utf8_lossy(&output.stderr)
            .contains("raw.nrrd: channel 1 does not exist (the image has 1)"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}
