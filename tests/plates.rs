//! HCS plates (OME-Zarr `plate` and `well`): the plate written by ome-zarr-py
//! (tests/data/plates, see make_fixtures.py) opens at its first well's first field and says
//! so; `--field ROW/COLUMN/FIELD` opens another; `info` lists rows, columns, wells and fields.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};

fn plate() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/plates/plate-v04.ome.zarr")
}

fn field_sum(field: &str) -> i64 {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/plates/expected.json");
    let expected: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    expected["field_sums"][field].as_i64().unwrap()
}

fn sum(pyramid: &Pyramid) -> i64 {
    let data = pyramid.read_level(0).unwrap();
    (0..data.len()).map(|i| data.get(i).unwrap() as i64).sum()
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn a_plate_opens_at_its_first_field_and_lists_its_wells() {
    let pyramid =
        Pyramid::open(&plate(), PyramidOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let layout = pyramid.plate.as_ref().expect("a plate");
    assert_eq!(layout.rows, ["A", "B"]);
    assert_eq!(layout.columns, ["1", "2", "3"]);
    assert_eq!(
        layout.wells,
        [
            ("A/1".to_owned(), vec!["0".to_owned(), "1".to_owned()]),
            ("B/3".to_owned(), vec!["0".to_owned(), "1".to_owned()])
        ]
    );
    assert_eq!(layout.field, "A/1/0");
    assert_eq!(pyramid.levels[0].dims, [8, 6, 4]);
    assert_eq!(sum(&pyramid), field_sum("A/1/0"));

    // Every field by its own path.
    for field in ["A/1/0", "A/1/1", "B/3/0", "B/3/1"] {
        let pyramid = Pyramid::open(&plate().join(field), PyramidOptions::default()).unwrap();
        assert!(pyramid.plate.is_none());
        assert_eq!(sum(&pyramid), field_sum(field), "{field}");
    }
}

#[test]
fn info_names_the_field_and_field_picks_another() {
    let path = plate();
    let path = path.to_str().unwrap();
    let output = voxscope(&["info", path]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains(
            "tiny plate: rows A, B; columns 1, 2, 3; 2 wells: A/1 (fields 0, 1), B/3 (fields 0, 1)"
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("A/1/0 (the first well's first field"),
        "{stdout}"
    );
    assert!(stdout.contains("value range  0 … 3"), "{stdout}");

    let output = voxscope(&["info", path, "--field", "B/3/1"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("value range  14 … 17"), "{stdout}");

    for (field, problem) in [
        ("B/3", "is not ROW/COLUMN/FIELD"),
        ("B/../0", "is not ROW/COLUMN/FIELD"),
    ] {
        let output = voxscope(&["info", path, "--field", field]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains(problem),
            "{stderr}"
        );
    }
    let output = voxscope(&["info", path, "--field", "C/9/0"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
}
