//! MRC / CCP4 maps: every supported mode in both byte orders, axis order, voxel size from the
//! cell, and broken files.

mod support;

use std::path::Path;

use support::writers::MrcMap as Map;

use voxscope_volume::{LoadOptions, VoxelType};

fn load(path: &Path) -> Result<voxscope_volume::Volume, String> {
    voxscope_volume::load(&path.display().to_string(), &LoadOptions::default())
        .map_err(|e| e.to_string())
}

#[test]
fn every_mode_in_both_byte_orders_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    for (mode, voxel_type) in [
        (0, VoxelType::I8),
        (1, VoxelType::I16),
        (2, VoxelType::F32),
        (6, VoxelType::U16),
        (12, VoxelType::F32),
    ] {
        for big_endian in [false, true] {
            let mut map = Map::new([6, 5, 4], mode);
            map.big_endian = big_endian;
            map.extended = vec![7; 96];
            let path = dir.path().join(format!("m{mode}-{big_endian}.mrc"));
            std::fs::write(&path, map.bytes()).unwrap();
            let volume = load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(volume.format, "MRC");
            assert_eq!(volume.dims, [6, 5, 4]);
            assert_eq!(volume.voxel_type(), voxel_type, "mode {mode}");
            assert_eq!(volume.spacing, [1.5, 1.5, 2.0]);
            for n in 0..120 {
                assert_eq!(
                    volume.data.get(n),
                    Some((n % 100) as f64),
                    "mode {mode} big {big_endian} voxel {n}"
                );
            }
            assert!(
                volume
                    .metadata
                    .contains(&("label".into(), "voxscope test".into()))
            );
        }
    }
}

#[test]
fn sections_first_axis_order_is_put_back_in_x_y_z() {
    let dir = tempfile::tempdir().unwrap();
    // Columns are z, rows are x, sections are y (MAPC=3, MAPR=1, MAPS=2).
    let mut map = Map::new([4, 6, 5], 2);
    map.axis_order = [3, 1, 2];
    let path = dir.path().join("zxy.map");
    std::fs::write(&path, map.bytes()).unwrap();
    let volume = load(&path).unwrap();
    assert_eq!(volume.dims, [6, 5, 4]);
    for (x, y, z) in [(0, 0, 0), (5, 0, 0), (0, 4, 0), (0, 0, 3), (2, 3, 1)] {
        // Stored index: column (z) fastest, then row (x), then section (y).
        let stored = z + 4 * (x + 6 * y);
        assert_eq!(
            volume.value(x, y, z),
            Some((stored % 100) as f64),
            "({x}, {y}, {z})"
        );
    }
}

#[test]
fn broken_maps_fail_in_one_line_and_stay_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let good = Map::new([8, 8, 8], 2).bytes();
    let mut complex = Map::new([4, 4, 4], 4).bytes();
    complex.truncate(1024);
    let mut huge = Map::new([2, 2, 2], 2).bytes();
    huge[0..4].copy_from_slice(&60000i32.to_le_bytes());
    huge[4..8].copy_from_slice(&60000i32.to_le_bytes());
    let mut negative = good.clone();
    negative[8..12].copy_from_slice(&(-3i32).to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "short.mrc",
            good[..500].to_vec(),
            "too short for an MRC header",
        ),
        (
            "truncated.mrc",
            good[..1024 + 100].to_vec(),
            "truncated or inconsistent",
        ),
        ("complex.mrc", complex, "complex values"),
        ("huge.mrc", huge, "exceed the limit"),
        ("negative.mrc", negative, "are not positive"),
    ];
    for (name, content, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, &content).unwrap();
        let started = std::time::Instant::now();
        let error = load(&path).expect_err(name);
        assert!(started.elapsed().as_secs_f64() < 1.0);
        assert!(
            error.starts_with(&path.display().to_string()) && !error.contains('\n'),
            "{error}"
        );
        assert!(error.contains(expected), "{name}: {error}");
        assert_eq!(std::fs::read(&path).unwrap(), content);
    }
}
