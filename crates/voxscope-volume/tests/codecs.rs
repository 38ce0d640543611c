//! Every compressor real Zarr v2 and v3 stores use (blosc with each of its compressors and
//! shuffles, zstd, gzip, zlib, bz2, lz4, lzma in its xz, alone and raw formats, none): one tiny
//! array per codec written by zarr-python (tests/data/codecs, see make_fixtures.py) reads equal
//! to the voxels it was written from. A codec voxscope does not know, a raw LZMA filter chain
//! it does not read and a chunk that claims more than it holds are one-line errors.

use std::path::{Path, PathBuf};

use serde_json::Value;
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/codecs")
}

fn expected() -> Value {
    let text = std::fs::read_to_string(fixtures().join("expected.json")).expect("expected.json");
    serde_json::from_str(&text).expect("expected.json parses")
}

/// The voxels every fixture holds, x fastest.
fn voxels() -> Vec<f64> {
    let bytes = std::fs::read(fixtures().join("voxels.u16le")).expect("voxels.u16le");
    bytes
        .chunks_exact(2)
        .map(|pair| f64::from(u16::from_le_bytes([pair[0], pair[1]])))
        .collect()
}

fn open(path: &Path) -> Result<Pyramid, String> {
    Pyramid::open(path, PyramidOptions::default()).map_err(|e| e.to_string())
}

fn read(path: &Path) -> Result<Vec<f64>, String> {
    let pyramid = open(path)?;
    let data = pyramid.read_level(0).map_err(|e| e.to_string())?;
    Ok((0..data.len()).map(|i| data.get(i).unwrap()).collect())
}

#[test]
fn every_codec_reads_equal_to_the_voxels_it_was_written_from() {
    let expected = expected();
    let fixtures_json = expected["fixtures"].as_object().unwrap();
    assert_eq!(fixtures_json.len(), 27);
    let want = voxels();
    assert_eq!(want.len(), 10 * 9 * 7);
    let mut read_ok = 0;
    for (name, fixture) in fixtures_json {
        let path = fixtures().join(name);
        let pyramid = open(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(pyramid.levels[0].dims, [10, 9, 7], "{name}");
        assert_eq!(pyramid.levels[0].chunk, [6, 5, 4], "{name}");
        assert_eq!(
            pyramid.zarr_format,
            fixture["zarr_format"].as_u64().unwrap() as u8,
            "{name}"
        );
        assert_eq!(
            pyramid.levels[0].codec,
            fixture["codec"].as_str().unwrap(),
            "{name}"
        );
        match fixture.get("error").and_then(Value::as_str) {
            None => {
                let got = read(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
                assert!(got == want, "{name}: the voxels differ");
                read_ok += 1;
            }
            Some(error) => {
                let got = read(&path).unwrap_err();
                assert!(got.contains(error), "{name}: {got}");
                assert!(!got.contains('\n'), "{name}: {got}");
            }
        }
    }
    assert_eq!(read_ok, 26);
}

/// Copies a fixture into a temporary folder to change it there.
fn copy_fixture(name: &str) -> (tempfile::TempDir, PathBuf) {
    fn copy(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap() {
            let entry = entry.unwrap();
            let target = to.join(entry.file_name());
            if entry.file_type().unwrap().is_dir() {
                copy(&entry.path(), &target);
            } else {
                std::fs::copy(entry.path(), target).unwrap();
            }
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join(name);
    copy(&fixtures().join(name), &target);
    (dir, target)
}

#[test]
fn an_unknown_codec_is_one_line_naming_it() {
    let (_dir, path) = copy_fixture("v2-zlib.zarr");
    let zarray = path.join(".zarray");
    let text = std::fs::read_to_string(&zarray).unwrap();
    std::fs::write(&zarray, text.replace("\"zlib\"", "\"snappy9\"")).unwrap();
    let error = open(&path).map(|_| ()).unwrap_err();
    assert!(error.contains("snappy9"), "{error}");
    assert!(!error.contains('\n'), "{error}");

    let (_dir, path) = copy_fixture("v3-lz4.zarr");
    let json = path.join("zarr.json");
    let text = std::fs::read_to_string(&json).unwrap();
    std::fs::write(&json, text.replace("numcodecs.lz4", "numcodecs.jpeg9")).unwrap();
    let error = open(&path).map(|_| ()).unwrap_err();
    assert!(error.contains("numcodecs.jpeg9"), "{error}");
    assert!(!error.contains('\n'), "{error}");
}

#[test]
fn chunks_that_claim_more_than_they_hold_are_errors_naming_the_chunk() {
    // An LZ4 chunk whose size header claims 4 GiB: refused before anything of that size exists.
    let (_dir, path) = copy_fixture("v2-lz4.zarr");
    let chunk = path.join("0.0.0");
    let mut bytes = std::fs::read(&chunk).unwrap();
    bytes[..4].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(&chunk, bytes).unwrap();
    let error = read(&path).unwrap_err();
    assert!(
        error.contains("0.0.0") && error.contains("declares 4294967295"),
        "{error}"
    );

    // Damaged or cut streams of every numcodecs compressor: an error naming the chunk, never a
    // panic or other voxels.
    for name in [
        "v2-lz4.zarr",
        "v2-lzma.zarr",
        "v2-lzma-alone.zarr",
        "v2-lzma-raw-lzma2.zarr",
        "v2-zlib.zarr",
        "v2-bz2.zarr",
        "v3-lzma.zarr",
    ] {
        let key = if name.starts_with("v3") {
            "c/0/0/0"
        } else {
            "0.0.0"
        };
        let (_dir, path) = copy_fixture(name);
        let chunk = path.join(key);
        let bytes = std::fs::read(&chunk).unwrap();
        std::fs::write(&chunk, &bytes[..bytes.len() / 2]).unwrap();
        let error = read(&path).unwrap_err();
        assert!(error.contains(key), "{name}: {error}");
        assert!(!error.contains('\n'), "{name}: {error}");
    }
}
