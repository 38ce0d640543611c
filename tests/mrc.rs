//! MRC / CCP4 maps: every supported mode in both byte orders, axis order, voxel size from the
//! cell, and broken files.

use std::path::Path;

use voxscope::volume::{self, LoadOptions, VoxelType};

struct Map {
    dims: [i32; 3],
    mode: i32,
    big_endian: bool,
    axis_order: [i32; 3],
    cell: [f32; 3],
    extended: Vec<u8>,
}

impl Map {
    fn new(dims: [i32; 3], mode: i32) -> Self {
        Self {
            dims,
            mode,
            big_endian: false,
            axis_order: [1, 2, 3],
            cell: [
                dims[0] as f32 * 1.5,
                dims[1] as f32 * 1.5,
                dims[2] as f32 * 2.0,
            ],
            extended: Vec::new(),
        }
    }

    /// The file bytes; the stored value of voxel n (in stored order) is `n % 100`.
    fn bytes(&self) -> Vec<u8> {
        let word = |v: [u8; 4]| {
            if self.big_endian {
                let mut r = v;
                r.reverse();
                r
            } else {
                v
            }
        };
        let mut header = vec![0u8; 1024];
        let mut put = |index: usize, bytes: [u8; 4]| {
            header[4 * index..4 * index + 4].copy_from_slice(&word(bytes))
        };
        for a in 0..3 {
            put(a, self.dims[a].to_le_bytes());
            put(7 + a, self.dims[a].to_le_bytes());
            put(10 + a, self.cell[a].to_le_bytes());
            put(13 + a, 90f32.to_le_bytes());
            put(16 + a, self.axis_order[a].to_le_bytes());
        }
        put(3, self.mode.to_le_bytes());
        put(23, (self.extended.len() as i32).to_le_bytes());
        put(55, 1i32.to_le_bytes());
        header[208..212].copy_from_slice(b"MAP ");
        header[212..214].copy_from_slice(if self.big_endian {
            &[0x11, 0x11]
        } else {
            &[0x44, 0x44]
        });
        header[224..238].copy_from_slice(b"voxscope test ");
        header.extend(&self.extended);
        let count = self.dims.iter().product::<i32>() as usize;
        for n in 0..count {
            let value = (n % 100) as f64;
            let mut bytes = match self.mode {
                0 => vec![value as i8 as u8],
                1 => (value as i16).to_le_bytes().to_vec(),
                2 => (value as f32).to_le_bytes().to_vec(),
                6 => (value as u16).to_le_bytes().to_vec(),
                12 => half::f16::from_f64(value).to_le_bytes().to_vec(),
                _ => vec![0; 8],
            };
            if self.big_endian {
                bytes.reverse();
            }
            header.extend(bytes);
        }
        header
    }
}

fn load(path: &Path) -> Result<volume::Volume, String> {
    volume::load(&path.display().to_string(), &LoadOptions::default()).map_err(|e| e.to_string())
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
