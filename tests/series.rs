//! bioformats2raw containers of several series: the container written by zarr-python and
//! ome-zarr-py (tests/data/series, see make_fixtures.py) opens at its series 0 and says so;
//! `--series N` opens another; `info` lists the series with their OME-XML names and shapes; a
//! series the container lacks is one line naming the file and the count.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/series/two-series.zarr")
}

fn expected() -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/series/expected.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn the_container_opens_at_series_0_and_lists_every_series() {
    let pyramid =
        Pyramid::open(&root(), PyramidOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let found = pyramid
        .bioformats2raw
        .as_ref()
        .expect("a bioformats2raw container");
    assert_eq!((found.opened, found.chosen), (0, false));
    let expected = expected();
    assert_eq!(found.series.len(), 2);
    for (index, entry) in found.series.iter().enumerate() {
        let facts = &expected["series"][index.to_string()];
        assert_eq!(entry.path, index.to_string());
        assert_eq!(entry.name.as_deref(), facts["name"].as_str());
        let dims: Vec<u64> = facts["dims"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| d.as_u64().unwrap())
            .collect();
        let (shape, axes) = entry.dims.clone().expect("its shape");
        assert_eq!(
            (shape, axes),
            (dims, vec!["x".into(), "y".into(), "z".into()])
        );
    }
    assert_eq!(pyramid.levels[0].dims, [8, 6, 4]);

    let output = voxscope(&["info", root().to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stdout.contains(
            r#"2 (bioformats2raw): 0 "first image" 8x6x4 (x y z); 1 "second image" 5x4x3 (x y z)"#
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("0 (the first; --series N opens another)"),
        "{stdout}"
    );
    let notes: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("--series N"))
        .collect();
    assert_eq!(notes.len(), 1, "said once: {stderr}");
    assert!(notes[0].contains("2 series; opened series 0"), "{stderr}");
}

#[test]
fn series_1_holds_the_voxels_written() {
    // (z, y, x) = 1000 + 100 z + 10 y + x, as make_fixtures.py writes them.
    let pyramid = Pyramid::open(&root().join("1"), PyramidOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(pyramid.levels[0].dims, [5, 4, 3]);
    let found = pyramid
        .bioformats2raw
        .as_ref()
        .expect("the container's series listed");
    assert_eq!((found.opened, found.chosen), (1, true));
    let data = pyramid.read_level(0).unwrap();
    assert_eq!(data.len(), 60);
    for z in 0..3 {
        for y in 0..4 {
            for x in 0..5 {
                let value = data.get(x + 5 * (y + 4 * z)).unwrap();
                assert_eq!(
                    value,
                    (1000 + 100 * z + 10 * y + x) as f64,
                    "({x}, {y}, {z})"
                );
            }
        }
    }
    let sum: f64 = (0..data.len()).map(|i| data.get(i).unwrap()).sum();
    assert_eq!(
        sum as i64,
        expected()["series"]["1"]["sum"].as_i64().unwrap()
    );

    let root = root();
    let root = root.to_str().unwrap();
    let output = voxscope(&["probe", root, "--series", "1", "--at", "4,3,2"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("1234"), "{stdout}");
    let output = voxscope(&["info", root, "--series", "1"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("value range  1000 … 1234"), "{stdout}");
    assert!(stdout.contains("open series  1\n"), "{stdout}");
}

#[test]
fn a_series_the_container_lacks_is_one_line() {
    let root = root();
    let root = root.to_str().unwrap();
    for args in [
        vec!["info", root, "--series", "2"],
        vec!["probe", root, "--series", "7", "--at", "0,0,0"],
    ] {
        let output = voxscope(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(root), "{stderr}");
        assert!(
            stderr.contains("does not exist (the bioformats2raw container has 2 series, 0 to 1)"),
            "{stderr}"
        );
    }
    let output = voxscope(&["info", "--series", "1"]);
    assert!(!output.status.success());
}
