//! N5 containers (tests/data/n5, written by tensorstore and zarr-python 2; see
//! make_fixtures.py): every compression, Java-style edge blocks and lz4-java's framing read
//! equal to the voxels they were written from; n5-viewer, cosem and BigDataViewer pyramids
//! open with their levels where their conventions put them; a container reads the same over
//! HTTP as from its folder, renders equal to its OME-Zarr conversion, and damaged blocks or
//! metadata are one-line errors that leave the files as they were.

mod support;

use std::path::{Path, PathBuf};

use serde_json::Value;
use support::cli::{differing_pixels, renders, voxscope};
use support::http_server::{Faults, FileServer};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions, is_zarr_folder};
use voxscope_volume::remote::RemoteOptions;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/n5")
}

/// u16 little-endian values, x fastest.
fn u16_file(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    bytes
        .chunks_exact(2)
        .map(|pair| f64::from(u16::from_le_bytes([pair[0], pair[1]])))
        .collect()
}

/// The voxels every fixture's finest level holds (10 x 9 x 7).
fn voxels() -> Vec<f64> {
    u16_file(&fixtures().join("../codecs/voxels.u16le"))
}

fn open(path: &Path) -> Result<Pyramid, String> {
    Pyramid::open(path, PyramidOptions::default()).map_err(|e| e.to_string())
}

fn level(pyramid: &Pyramid, level: usize) -> Result<Vec<f64>, String> {
    let data = pyramid.read_level(level).map_err(|e| e.to_string())?;
    Ok((0..data.len()).map(|i| data.get(i).unwrap()).collect())
}

#[test]
fn every_compression_reads_equal_to_the_voxels_it_was_written_from() {
    let versions: Value =
        serde_json::from_str(&std::fs::read_to_string(fixtures().join("versions.json")).unwrap())
            .unwrap();
    let codecs = versions["codecs"].as_object().unwrap();
    assert_eq!(codecs.len(), 13);
    let want = voxels();
    for (name, codec) in codecs {
        let path = fixtures().join(name);
        assert!(is_zarr_folder(&path), "{name} is not recognized");
        let pyramid = open(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(pyramid.format, "N5", "{name}");
        assert_eq!(pyramid.levels.len(), 1, "{name}");
        assert_eq!(pyramid.levels[0].dims, [10, 9, 7], "{name}");
        assert_eq!(pyramid.levels[0].chunk, [6, 5, 4], "{name}");
        assert_eq!(pyramid.levels[0].codec, codec.as_str().unwrap(), "{name}");
        let got = level(&pyramid, 0).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(got == want, "{name}: the voxels differ");
    }
}

#[test]
fn multiscale_conventions_open_as_pyramids_placed_where_they_say() {
    let coarse = u16_file(&fixtures().join("s1.u16le"));
    assert_eq!(coarse.len(), 5 * 5 * 4);
    let want = voxels();
    /// A fixture, level 0's spacing and origin, and the unit.
    type Case<'a> = (&'a str, [f64; 3], [f64; 3], Option<&'a str>);
    let cases: [Case; 3] = [
        (
            "n5-viewer.n5",
            [0.5, 0.5, 2.0],
            [0.0; 3],
            Some("micrometer"),
        ),
        (
            "cosem.n5",
            [0.5, 0.5, 2.0],
            [30.0, 20.0, 10.0],
            Some("nanometer"),
        ),
        ("bdv.n5", [1.0; 3], [0.0; 3], None),
    ];
    for (name, spacing, origin, unit) in cases {
        let pyramid = open(&fixtures().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(pyramid.levels.len(), 2, "{name}");
        let [s0, s1] = [&pyramid.levels[0], &pyramid.levels[1]];
        assert_eq!((s0.dims, s1.dims), ([10, 9, 7], [5, 5, 4]), "{name}");
        assert_eq!(s0.spacing, spacing, "{name}");
        assert_eq!(s0.origin, origin, "{name}");
        // The coarser level's voxels are twice as large, their centers half a finest voxel
        // further along each axis (2 voxels averaged).
        for a in 0..3 {
            assert_eq!(s1.spacing[a], 2.0 * spacing[a], "{name} axis {a}");
            assert_eq!(
                s1.origin[a],
                origin[a] + spacing[a] / 2.0,
                "{name} axis {a}"
            );
        }
        assert_eq!(pyramid.units[0].as_deref(), unit, "{name}");
        assert!(level(&pyramid, 0).unwrap() == want, "{name}: s0 differs");
        assert!(level(&pyramid, 1).unwrap() == coarse, "{name}: s1 differs");
    }
    // A BigDataViewer container opens its first setup; another opens by its path.
    let setup1 = open(&fixtures().join("bdv.n5/setup1")).unwrap();
    let plus: Vec<f64> = want.iter().map(|v| v + 1000.0).collect();
    assert!(level(&setup1, 0).unwrap() == plus);
    assert_eq!(setup1.levels[1].path, "timepoint0/s1");
    // A level opened by itself is a one-level pyramid.
    let s1 = open(&fixtures().join("cosem.n5/s1")).unwrap();
    assert_eq!(s1.levels.len(), 1);
    assert!(level(&s1, 0).unwrap() == coarse);
}

#[test]
fn a_container_reads_the_same_over_http_as_from_its_folder() {
    let server = FileServer::start(&fixtures(), Faults::default());
    for name in [
        "n5-viewer.n5",
        "edge-lz4.n5",
        "tensorstore-blosc.n5",
        "bdv.n5",
    ] {
        let folder = open(&fixtures().join(name)).unwrap();
        let url = server.url(name);
        let remote = Pyramid::open_url(&url, PyramidOptions::default(), RemoteOptions::default())
            .unwrap_or_else(|e| panic!("{url}: {e}"));
        assert_eq!(remote.format, "N5", "{name}");
        assert_eq!(remote.levels, folder.levels, "{name}");
        for l in 0..folder.levels.len() {
            assert!(
                level(&remote, l).unwrap() == level(&folder, l).unwrap(),
                "{name}: level {l} differs"
            );
        }
    }
    // A URL that is neither Zarr nor N5 says what it looked for.
    let error = Pyramid::open_url(
        &server.url("missing.n5"),
        PyramidOptions::default(),
        RemoteOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("no zarr.json"), "{error}");
}

#[test]
fn a_container_renders_equal_to_its_ome_zarr_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let source = fixtures().join("n5-viewer.n5");
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
    let read_back = open(&converted).unwrap();
    assert!(level(&read_back, 0).unwrap() == voxels());
    assert_eq!(read_back.levels[0].spacing, [0.5, 0.5, 2.0]);

    let info = voxscope(&["info", source.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(text.contains("N5 2.5.1"), "{text}");
    assert!(text.contains("n5 gzip"), "{text}");

    let images = renders(
        dir.path(),
        &[&source, &converted],
        &["--size", "96x72", "--window", "0:65535"],
    );
    assert!(images[0].pixels().any(|p| p[0] > 0), "the image is blank");
    let differing = differing_pixels(&images[0], &images[1]);
    assert_eq!(differing, 0, "{differing} pixels differ");
}

/// Copies fixture `name` into a temporary folder to damage it there.
fn copy_fixture(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    support::damage::copy_store(&fixtures().join(name), &path);
    (dir, path)
}

/// The one-line error of reading `path`'s finest level, and the files unchanged.
fn read_error(path: &Path) -> String {
    let before = std::fs::read(path.join("1/1/1")).ok();
    let error = match open(path) {
        Err(e) => e,
        Ok(pyramid) => level(&pyramid, 0).unwrap_err(),
    };
    assert!(!error.contains('\n'), "{error}");
    assert_eq!(std::fs::read(path.join("1/1/1")).ok(), before);
    error
}

#[test]
fn damaged_blocks_and_metadata_are_one_line_errors() {
    // A block cut inside its header, and one cut inside its values.
    let (_dir, path) = copy_fixture("edge-raw.n5");
    std::fs::write(path.join("1/1/1"), [0u8, 0, 0, 3, 0, 0]).unwrap();
    let error = read_error(&path);
    assert!(error.contains("cannot hold the block header"), "{error}");
    let block = std::fs::read(fixtures().join("edge-raw.n5/1/1/1")).unwrap();
    std::fs::write(path.join("1/1/1"), &block[..block.len() - 3]).unwrap();
    let error = read_error(&path);
    assert!(error.contains("decode to"), "{error}");

    // A header whose extent is larger than the block size (nothing of its size is made).
    let mut header = vec![0u8, 0, 0, 3];
    for extent in [60_000u32, 60_000, 60_000] {
        header.extend_from_slice(&extent.to_be_bytes());
    }
    std::fs::write(path.join("1/1/1"), &header).unwrap();
    let error = read_error(&path);
    assert!(
        error.contains("does not fit the block size 6x5x4"),
        "{error}"
    );

    // lz4 blocks that claim more than the block holds.
    let (_dir, path) = copy_fixture("edge-lz4.n5");
    let mut block = std::fs::read(path.join("0/0/0")).unwrap();
    let at = 16 + 8 + 1 + 4;
    block[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(path.join("0/0/0"), &block).unwrap();
    let error = read_error(&path);
    assert!(error.contains("more than the 240 bytes"), "{error}");

    // Metadata: a block size that does not match the dimensions, a compression N5 lacks.
    let (_dir, path) = copy_fixture("tensorstore-raw.n5");
    let attributes = path.join("attributes.json");
    let good = std::fs::read_to_string(&attributes).unwrap();
    std::fs::write(&attributes, good.replace("[6,5,4]", "[6,5]")).unwrap();
    let error = read_error(&path);
    assert!(
        error.contains("3 dimensions and a block size of 2"),
        "{error}"
    );
    std::fs::write(&attributes, good.replace("\"raw\"", "\"snappy\"")).unwrap();
    let error = read_error(&path);
    assert!(error.contains("compression 'snappy'"), "{error}");
    // Dimensions past what a voxel index holds are refused before anything is read.
    std::fs::write(
        &attributes,
        good.replace("[10,9,7]", "[100000000,100000000,100000000]"),
    )
    .unwrap();
    let error = read_error(&path);
    assert!(error.contains("too many to address"), "{error}");
}
