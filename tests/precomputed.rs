//! neuroglancer precomputed volumes (tests/data/precomputed, written by tensorstore; see
//! make_fixtures.py): raw, gzip-compressed `.gz` files, png, jpeg, three channels and
//! compressed_segmentation of uint32 and uint64, and two sharded layouts, read equal to the voxels they were written
//! from, scales placed by their resolution and voxel offset; a segmentation is a label image;
//! a volume reads the same over HTTP (by `precomputed://` too) as from its folder and
//! converts to OME-Zarr; damaged chunks and `info` documents are one-line errors.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use support::http_server::{Faults, FileServer};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions, is_zarr_folder};
use voxscope_volume::remote::RemoteOptions;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/precomputed")
}

/// Little-endian values of `size` bytes (1, 2, 4 or 8), as f64.
fn values(name: &str, size: usize) -> Vec<f64> {
    let path = fixtures().join(name);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    bytes
        .chunks_exact(size)
        .map(|b| {
            let mut wide = [0u8; 8];
            wide[..size].copy_from_slice(b);
            u64::from_le_bytes(wide) as f64
        })
        .collect()
}

fn voxels() -> Vec<f64> {
    values("../codecs/voxels.u16le", 2)
}

fn open_with(path: &Path, channel: usize) -> Result<Pyramid, String> {
    let options = PyramidOptions {
        channel,
        ..PyramidOptions::default()
    };
    Pyramid::open(path, options).map_err(|e| e.to_string())
}

fn open(name: &str) -> Result<Pyramid, String> {
    open_with(&fixtures().join(name), 0)
}

fn level(pyramid: &Pyramid, level: usize) -> Result<Vec<f64>, String> {
    let data = pyramid.read_level(level).map_err(|e| e.to_string())?;
    Ok((0..data.len()).map(|i| data.get(i).unwrap()).collect())
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn every_encoding_reads_equal_to_the_voxels_it_was_written_from() {
    for (name, codec, want) in [
        ("raw-u16", "precomputed raw", voxels()),
        ("raw-u16-gzip", "precomputed raw", voxels()),
        ("png-u8", "precomputed png", values("voxels.u8", 1)),
        (
            "cseg-u32",
            "precomputed compressed_segmentation",
            values("labels.u32le", 4),
        ),
        (
            "cseg-u64",
            "precomputed compressed_segmentation",
            values("labels.u64le", 8),
        ),
        ("sharded-u16", "precomputed raw", voxels()),
        (
            "sharded-cseg-u64",
            "precomputed compressed_segmentation",
            values("labels.u64le", 8),
        ),
    ] {
        assert!(is_zarr_folder(&fixtures().join(name)), "{name}");
        let pyramid = open(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(pyramid.format, "precomputed", "{name}");
        assert_eq!(pyramid.levels[0].dims, [10, 9, 7], "{name}");
        assert_eq!(pyramid.levels[0].chunk, [6, 5, 4], "{name}");
        assert_eq!(pyramid.levels[0].codec, codec, "{name}");
        assert_eq!(pyramid.label_image, name.contains("cseg"), "{name}");
        let got = level(&pyramid, 0).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(got == want, "{name}: the voxels differ");
    }
    // JPEG is lossy: within a few levels of what libjpeg-turbo decodes.
    let jpeg = level(&open("jpeg-u8").unwrap(), 0).unwrap();
    let libjpeg = values("jpeg-u8.expected.u8", 1);
    let worst = jpeg
        .iter()
        .zip(&libjpeg)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 2.0,
        "JPEG differs from libjpeg-turbo's by up to {worst}"
    );
    // Three channels, each its own volume.
    let rgb = values("rgb.u8", 1);
    let path = fixtures().join("rgb-u8");
    assert_eq!(open_with(&path, 0).unwrap().channels, 3);
    for c in 0..3 {
        let got = level(&open_with(&path, c).unwrap(), 0).unwrap();
        assert!(
            got[..] == rgb[c * 630..(c + 1) * 630],
            "channel {c} differs"
        );
    }
}

#[test]
fn scales_are_placed_by_their_resolution_and_offset() {
    let pyramid = open("raw-u16").unwrap();
    assert_eq!(pyramid.levels.len(), 2);
    let [fine, coarse] = [&pyramid.levels[0], &pyramid.levels[1]];
    assert_eq!(
        (fine.path.as_str(), coarse.path.as_str()),
        ("4_4_40", "8_8_80")
    );
    assert_eq!(fine.spacing, [4.0, 4.0, 40.0]);
    // Voxel offset (4, 2, 2) of 4 x 4 x 40 nm.
    assert_eq!(fine.origin, [16.0, 8.0, 80.0]);
    // Offset (2, 1, 1) of 8 x 8 x 80 nm, its centers half a finer voxel further.
    assert_eq!(coarse.origin, [18.0, 10.0, 100.0]);
    assert_eq!(pyramid.units[0].as_deref(), Some("nanometer"));
    assert!(level(&pyramid, 1).unwrap() == values("s1.u16le", 2));
}

#[test]
fn a_volume_reads_the_same_over_http_as_from_its_folder() {
    let server = FileServer::start(&fixtures(), Faults::default());
    for name in [
        "raw-u16",
        "raw-u16-gzip",
        "cseg-u64",
        "jpeg-u8",
        "sharded-u16",
        "sharded-cseg-u64",
    ] {
        let folder = open(name).unwrap();
        for url in [
            server.url(name),
            format!("precomputed://{}", server.url(name)),
        ] {
            let remote =
                Pyramid::open_url(&url, PyramidOptions::default(), RemoteOptions::default())
                    .unwrap_or_else(|e| panic!("{url}: {e}"));
            assert_eq!(remote.format, "precomputed", "{url}");
            assert_eq!(remote.levels, folder.levels, "{url}");
            for l in 0..folder.levels.len() {
                assert!(
                    level(&remote, l).unwrap() == level(&folder, l).unwrap(),
                    "{url}: level {l} differs"
                );
            }
        }
    }
}

#[test]
fn a_volume_converts_to_ome_zarr_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    let source = fixtures().join("raw-u16");
    let converted = dir.path().join("converted.ome.zarr");
    let out = voxscope(&[
        "convert",
        source.to_str().unwrap(),
        converted.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read_back = Pyramid::open(&converted, PyramidOptions::default()).unwrap();
    assert!(level(&read_back, 0).unwrap() == voxels());
    assert_eq!(read_back.levels[0].spacing, [4.0, 4.0, 40.0]);
    let info = voxscope(&["info", source.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains("precomputed") && text.contains("precomputed raw"),
        "{text}"
    );
    // Segmentations draw in the labels' colors, a uint64 one (ids above 2^32, read as f64)
    // as well as a uint32 one.
    for name in ["cseg-u32", "cseg-u64"] {
        let png = dir.path().join(format!("{name}.png"));
        let labels = fixtures().join(name);
        let out = voxscope(&[
            "render",
            labels.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--size",
            "96x72",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let image = image::open(&png).unwrap().to_rgba8();
        assert!(
            support::reference::coverage(&image) > 0.05,
            "{name}: nothing drawn"
        );
        let colored = image
            .pixels()
            .filter(|p| p[0].abs_diff(p[1]) > 40 || p[1].abs_diff(p[2]) > 40);
        assert!(
            colored.count() > 50,
            "{name}: drawn in grays, not the labels' colors"
        );
    }
}

/// Copies fixture `name` into a temporary folder to damage it there.
fn copy_fixture(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    support::damage::copy_store(&fixtures().join(name), &path);
    (dir, path)
}

/// The one-line error of opening `path` or reading its finest level.
fn read_error(path: &Path) -> String {
    let error = match open_with(path, 0) {
        Err(e) => e,
        Ok(pyramid) => level(&pyramid, 0).unwrap_err(),
    };
    assert!(!error.contains('\n'), "{error}");
    error
}

#[test]
fn damaged_chunks_and_info_documents_are_one_line_errors() {
    let chunk = "4_4_40/10-14_7-11_6-9";
    for (name, damage, expected) in [
        ("raw-u16", &[1u8, 2, 3][..], "a raw chunk of 3 bytes"),
        (
            "cseg-u32",
            &[0, 0, 0, 0, 255, 255, 255, 0][..],
            "past the chunk",
        ),
        ("png-u8", &[0x89, b'P', b'N', b'G'][..], "Png"),
        ("jpeg-u8", &[0xFF, 0xD8, 0xFF][..], "Jpeg"),
        ("raw-u16-gzip", &[0x1f, 0x8b, 8, 0][..], "gzip"),
    ] {
        let (_dir, path) = copy_fixture(name);
        let file = if name.ends_with("gzip") {
            format!("{chunk}.gz")
        } else {
            chunk.to_owned()
        };
        std::fs::write(path.join(&file), damage).unwrap();
        let error = read_error(&path);
        assert!(error.contains(expected), "{name}: {error}");
        assert!(error.contains("10-14_7-11_6-9"), "{name}: {error}");
        // The damaged file is as it was left: reading changes nothing.
        assert_eq!(std::fs::read(path.join(&file)).unwrap(), damage, "{name}");
    }
    // A raw chunk whose first voxel's bytes are gzip's magic is raw data, not gzip.
    let (_dir, path) = copy_fixture("raw-u16");
    let file = path.join("4_4_40/4-10_2-7_2-6");
    let mut bytes = std::fs::read(&file).unwrap();
    bytes[..2].copy_from_slice(&[0x1f, 0x8b]);
    std::fs::write(&file, bytes).unwrap();
    let read = level(&open_with(&path, 0).unwrap(), 0).unwrap();
    assert_eq!(read[0], f64::from(u16::from_le_bytes([0x1f, 0x8b])));
    assert!(read[1..] == voxels()[1..]);
    // A minishard index that gives its chunks petabytes: refused before any read of that size.
    let (_dir, path) = copy_fixture("sharded-cseg-u64");
    for shard in ["0", "1", "2", "3"] {
        let file = path.join(format!("4_4_40/{shard}.shard"));
        let mut bytes = std::fs::read(&file).unwrap();
        let word = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
        // Two minishards: a 32-byte shard index, then each minishard's ids, offsets, sizes.
        for minishard in 0..2 {
            let (start, end) = (
                word(&bytes, 16 * minishard),
                word(&bytes, 16 * minishard + 8),
            );
            let entries = ((end - start) / 24) as usize;
            for i in 0..entries {
                let at = 32 + start as usize + 8 * (2 * entries + i);
                bytes[at..at + 8].copy_from_slice(&(1u64 << 62).to_le_bytes());
            }
        }
        std::fs::write(&file, bytes).unwrap();
    }
    let error = read_error(&path);
    assert!(error.contains("holds at most"), "{error}");
    // Shards whose index points past their end; a sharding this reader does not know.
    let (_dir, path) = copy_fixture("sharded-cseg-u64");
    for shard in ["0", "1", "2", "3"] {
        let file = path.join(format!("4_4_40/{shard}.shard"));
        let mut bytes = std::fs::read(&file).unwrap();
        bytes[8..16].copy_from_slice(&(1u64 << 40).to_le_bytes());
        bytes[24..32].copy_from_slice(&(1u64 << 40).to_le_bytes());
        std::fs::write(&file, bytes).unwrap();
    }
    let error = read_error(&path);
    assert!(error.contains(".shard"), "{error}");
    let (_dir, path) = copy_fixture("sharded-u16");
    let info = std::fs::read_to_string(path.join("info")).unwrap();
    std::fs::write(
        path.join("info"),
        info.replace("murmurhash3_x86_128", "xxhash"),
    )
    .unwrap();
    let error = read_error(&path);
    assert!(error.contains("hash 'xxhash'"), "{error}");
    // info documents: a type it lacks, a key leaving the volume.
    let (_dir, path) = copy_fixture("raw-u16");
    let info = std::fs::read_to_string(path.join("info")).unwrap();
    std::fs::write(
        path.join("info"),
        info.replace("\"uint16\"", "\"complex64\""),
    )
    .unwrap();
    let error = read_error(&path);
    assert!(error.contains("data_type 'complex64'"), "{error}");
    std::fs::write(path.join("info"), info.replace("\"8_8_80\"", "\"../up\"")).unwrap();
    let error = read_error(&path);
    assert!(error.contains("not a path inside the volume"), "{error}");
}
