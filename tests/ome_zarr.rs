//! OME-Zarr and plain Zarr: the fixtures written by the reference implementation
//! (tests/data/ome-zarr, see its README) read equal to the arrays they were written from;
//! levels, spacing, channels, time points and omero windows; missing chunks read as the fill
//! value; every kind of damage is a one-line error naming what is wrong; `convert` writes what
//! reads back equal to its input (0.4 and 0.5, every compression, streamed or not).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;
use voxscope_volume::ome_zarr::{
    Compression, Downsampling, Pyramid, PyramidOptions, PyramidWriter, WriteOptions, ZarrVersion,
    level_dims,
};
use voxscope_volume::{LoadOptions, ValueWindow, VoxelData};

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr")
}

fn expected() -> Value {
    let text = std::fs::read_to_string(fixtures().join("expected.json")).expect("expected.json");
    serde_json::from_str(&text).expect("expected.json parses")
}

fn open(name: &str, options: PyramidOptions) -> Pyramid {
    Pyramid::open(&fixtures().join(name), options).unwrap_or_else(|e| panic!("{e}"))
}

/// The checksum of make_fixtures.py: sum of value_i * (i + 1) * GOLDEN mod 2^64, x fastest.
fn checksum(data: &VoxelData) -> u64 {
    const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..data.len()).fold(0u64, |sum, i| {
        let value = data.get(i).unwrap() as i64 as u64;
        sum.wrapping_add(value.wrapping_mul((i as u64 + 1).wrapping_mul(GOLDEN)))
    })
}

fn range(data: &VoxelData) -> (i64, i64, i64) {
    (0..data.len()).fold((0, i64::MAX, i64::MIN), |(sum, lo, hi), i| {
        let v = data.get(i).unwrap() as i64;
        (sum + v, lo.min(v), hi.max(v))
    })
}

/// Every level of every fixture, and every (t, c) volume of each, equals what the script wrote.
#[test]
fn fixtures_read_equal_to_the_arrays_they_were_written_from() {
    let expected = expected();
    let fixtures = expected["fixtures"].as_object().unwrap();
    assert_eq!(fixtures.len(), 7);
    for (name, fixture) in fixtures {
        let levels = fixture["levels"].as_array().unwrap();
        for volume in levels[0]["volumes"].as_array().unwrap() {
            let index: Vec<usize> = volume["index"]
                .as_array()
                .unwrap()
                .iter()
                .map(|i| i.as_u64().unwrap() as usize)
                .collect();
            let options = match index[..] {
                [] => PyramidOptions::default(),
                [time] => PyramidOptions { channel: 0, time },
                [time, channel] => PyramidOptions { channel, time },
                _ => panic!("{name}: index {index:?}"),
            };
            let pyramid = open(name, options);
            assert_eq!(pyramid.levels.len(), levels.len(), "{name}");
            for (level, want) in levels.iter().enumerate() {
                let shape: Vec<usize> = want["shape"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|n| n.as_u64().unwrap() as usize)
                    .collect();
                let zyx = &shape[shape.len() - 3..];
                assert_eq!(
                    pyramid.levels[level].dims,
                    [zyx[2], zyx[1], zyx[0]],
                    "{name} level {level}"
                );
                let data = pyramid.read_level(level).unwrap();
                let want = want["volumes"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|v| v["index"] == volume["index"])
                    .unwrap();
                assert_eq!(
                    checksum(&data).to_string(),
                    want["checksum"].as_str().unwrap(),
                    "{name} level {level} {index:?}"
                );
                let (sum, lo, hi) = range(&data);
                assert_eq!(
                    (sum, lo, hi),
                    (
                        want["sum"].as_i64().unwrap(),
                        want["min"].as_i64().unwrap(),
                        want["max"].as_i64().unwrap()
                    ),
                    "{name} level {level}"
                );
            }
        }
    }
}

#[test]
fn regions_equal_the_same_voxels_of_the_whole_level() {
    // Regions crossing chunk and shard edges, and a single voxel.
    for name in [
        "nuclei-v04-blosc-lz4.ome.zarr",
        "head-v05-sharded-blosc-zstd.ome.zarr",
        "plain-v2-gzip.zarr",
    ] {
        let pyramid = open(name, PyramidOptions::default());
        let whole = pyramid.read_level(0).unwrap();
        let [nx, ny, _] = pyramid.levels[0].dims;
        for (origin, size) in [
            ([5, 7, 3], [30, 20, 14]),
            ([31, 15, 15], [2, 2, 2]),
            ([0, 0, 0], [1, 1, 1]),
        ] {
            let region = pyramid.read_region(0, origin, size).unwrap();
            assert_eq!(region.len(), size.iter().product::<usize>());
            let mut i = 0;
            for z in origin[2]..origin[2] + size[2] {
                for y in origin[1]..origin[1] + size[1] {
                    for x in origin[0]..origin[0] + size[0] {
                        assert_eq!(region.get(i), whole.get(x + nx * (y + ny * z)), "{name}");
                        i += 1;
                    }
                }
            }
        }
        let error = pyramid
            .read_region(0, [40, 0, 0], [30, 1, 1])
            .unwrap_err()
            .to_string();
        assert!(error.contains("lies outside level 0"), "{error}");
    }
}

#[test]
fn levels_carry_spacing_origin_units_chunks_and_codecs() {
    let nuclei = open("nuclei-v04-blosc-lz4.ome.zarr", PyramidOptions::default());
    assert_eq!(nuclei.format, "OME-Zarr");
    assert_eq!(nuclei.ome_version.as_deref(), Some("0.4"));
    assert_eq!(nuclei.zarr_format, 2);
    assert_eq!(nuclei.name.as_deref(), Some("nuclei"));
    assert_eq!(
        nuclei.units,
        [
            Some("micrometer".to_owned()),
            Some("micrometer".to_owned()),
            Some("micrometer".to_owned())
        ]
    );
    assert_eq!(nuclei.levels[0].dims, [48, 48, 20]);
    assert_eq!(nuclei.levels[2].dims, [12, 12, 5]);
    for (level, info) in nuclei.levels.iter().enumerate() {
        let factor = (1 << level) as f64;
        let want = [1.04 * factor, 1.04 * factor, 0.29 * factor];
        for (axis, want) in want.iter().enumerate() {
            assert!((info.spacing[axis] - want).abs() < 1e-9, "{info:?}");
            let shift = want / factor * (factor - 1.0) / 2.0;
            assert!((info.origin[axis] - shift).abs() < 1e-9, "{info:?}");
        }
        assert_eq!(info.chunk, [32, 32, 16]);
        assert_eq!(info.shard, None);
        assert_eq!(info.codec, "blosc lz4");
    }
    assert_eq!(nuclei.voxel_type.name(), "u16");

    let sharded = open(
        "head-v05-sharded-blosc-zstd.ome.zarr",
        PyramidOptions::default(),
    );
    assert_eq!(sharded.ome_version.as_deref(), Some("0.5"));
    assert_eq!(sharded.zarr_format, 3);
    assert_eq!(sharded.levels[0].chunk, [16, 16, 16]);
    assert_eq!(sharded.levels[0].shard, Some([32, 32, 32]));
    assert_eq!(sharded.levels[0].codec, "sharding(blosc zstd)");
    assert_eq!(sharded.levels[1].spacing, [8.0, 8.0, 12.0]);
    assert_eq!(sharded.levels[1].origin, [2.0, 2.0, 3.0]);

    let zstd = open("head-v04-zstd.ome.zarr", PyramidOptions::default());
    assert_eq!(zstd.levels[0].codec, "zstd");
    assert_eq!(zstd.voxel_type.name(), "i16");

    // Plain arrays: one level, unit spacing, their own codec and fill value.
    let plain = open("plain-v2-gzip.zarr", PyramidOptions::default());
    assert_eq!((plain.format, plain.levels.len()), ("Zarr", 1));
    assert_eq!(plain.levels[0].codec, "gzip");
    assert_eq!(plain.levels[0].spacing, [1.0; 3]);
    let v3 = open("plain-v3-none.zarr", PyramidOptions::default());
    assert_eq!(v3.levels[0].codec, "none");
    assert_eq!(v3.levels[0].fill_value, -7.0);
    assert_eq!(v3.voxel_type.name(), "i32");
}

#[test]
fn channel_and_time_select_one_volume_and_omero_gives_its_window() {
    let expected = expected();
    let levels = &expected["fixtures"]["tczyx-v04.ome.zarr"]["levels"];
    let mut seen = Vec::new();
    for time in 0..2 {
        for channel in 0..2 {
            let pyramid = open("tczyx-v04.ome.zarr", PyramidOptions { channel, time });
            assert_eq!((pyramid.channels, pyramid.time_points), (2, 2));
            let sum = checksum(&pyramid.read_level(0).unwrap());
            let want = levels[0]["volumes"]
                .as_array()
                .unwrap()
                .iter()
                .find(|v| v["index"] == serde_json::json!([time, channel]))
                .unwrap();
            assert_eq!(sum.to_string(), want["checksum"].as_str().unwrap());
            seen.push(sum);
            let window = pyramid.omero_window().unwrap();
            let want = if channel == 0 {
                (2000.0, 30000.0)
            } else {
                (10.0, 200.0)
            };
            assert_eq!((window.low, window.high), want);
        }
    }
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), 4, "the four volumes differ");
    let pyramid = open("tczyx-v04.ome.zarr", PyramidOptions::default());
    assert_eq!(pyramid.omero[1].label.as_deref(), Some("head"));
    assert_eq!(pyramid.omero[1].color.as_deref(), Some("FF00FF"));
    assert_eq!(pyramid.omero[0].range, Some([0.0, 65535.0]));
    let names: Vec<&str> = pyramid.axes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["t", "c", "z", "y", "x"]);
    assert_eq!(pyramid.axes[0].unit.as_deref(), Some("second"));

    let error = Pyramid::open(
        &fixtures().join("tczyx-v04.ome.zarr"),
        PyramidOptions {
            channel: 2,
            time: 0,
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.ends_with("tczyx-v04.ome.zarr: channel 2 does not exist (the image has 2)"),
        "{error}"
    );
    let error = Pyramid::open(
        &fixtures().join("tczyx-v04.ome.zarr"),
        PyramidOptions {
            channel: 0,
            time: 5,
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.ends_with("time point 5 does not exist (the image has 2)"),
        "{error}"
    );

    // Through the loader: the channel's window is the volume's default window.
    let options = LoadOptions {
        select: PyramidOptions {
            channel: 1,
            time: 1,
        },
        ..LoadOptions::default()
    };
    let path = fixtures().join("tczyx-v04.ome.zarr");
    let volume = voxscope_volume::load(path.to_str().unwrap(), &options).unwrap();
    assert_eq!(
        volume.default_window,
        Some(ValueWindow {
            low: 10.0,
            high: 200.0
        })
    );
    assert_eq!(volume.dims, [16, 16, 8]);
    assert!(
        volume
            .metadata
            .contains(&("channel".to_owned(), "1 of 2 (head)".to_owned()))
    );
    assert!(
        volume
            .metadata
            .contains(&("time point".to_owned(), "1 of 2".to_owned()))
    );
}

/// Copies a fixture into a temporary folder to damage it there.
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

fn open_error(path: &Path) -> String {
    Pyramid::open(path, PyramidOptions::default())
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

fn read_error(path: &Path) -> String {
    let pyramid = Pyramid::open(path, PyramidOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    pyramid.read_level(0).map(|_| ()).unwrap_err().to_string()
}

/// A folder's chunk files are read ahead (Linux): every chunk asked for whose file exists is
/// advised, whatever its key's form (`/`, `.`, v3's `c/`); a sharded store reads nothing ahead.
#[cfg(target_os = "linux")]
#[test]
fn a_folder_s_chunk_files_are_read_ahead_by_their_keys() {
    for name in [
        "head-v04-zstd.ome.zarr",
        "plain-v2-gzip.zarr",
        "plain-v3-none.zarr",
    ] {
        let pyramid = open(name, PyramidOptions::default());
        let level = &pyramid.levels[0];
        let grid = level.chunk_grid();
        let chunks: Vec<(usize, [usize; 3])> = (0..grid[2])
            .flat_map(|z| (0..grid[1]).flat_map(move |y| (0..grid[0]).map(move |x| [x, y, z])))
            .map(|chunk| (0, chunk))
            .collect();
        let present = chunks
            .iter()
            .filter(|(_, chunk)| {
                let voxel = std::array::from_fn(|a| chunk[a] * level.chunk[a]);
                let key = pyramid.chunk_key(0, voxel).unwrap();
                fixtures().join(name).join(key).is_file()
            })
            .count() as u64;
        assert!(present > 0, "{name}");
        assert!(pyramid.can_fetch_ahead(), "{name}");
        assert_eq!(pyramid.fetch_ahead_chunks(&chunks), chunks.len(), "{name}");
        let started = std::time::Instant::now();
        while pyramid.files_read_ahead() < present {
            assert!(
                started.elapsed().as_secs() < 10,
                "{name}: {} of {present} read ahead",
                pyramid.files_read_ahead()
            );
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert_eq!(pyramid.files_read_ahead(), present, "{name}");
    }
    let sharded = open(
        "head-v05-sharded-blosc-zstd.ome.zarr",
        PyramidOptions::default(),
    );
    assert!(!sharded.can_fetch_ahead());
    assert_eq!(sharded.fetch_ahead_chunks(&[(0, [0, 0, 0])]), 0);
    assert_eq!(sharded.files_read_ahead(), 0);
}

#[test]
fn missing_chunks_read_as_the_fill_value() {
    // The reference writer skipped the head's all-zero corner chunks.
    let pyramid = open("head-v04-zstd.ome.zarr", PyramidOptions::default());
    let key = pyramid.chunk_key(0, [0, 48, 0]).unwrap();
    assert_eq!(key, "s0/0/3/0");
    assert!(
        !fixtures()
            .join("head-v04-zstd.ome.zarr")
            .join(&key)
            .exists()
    );
    let corner = pyramid.read_region(0, [0, 48, 0], [16, 16, 16]).unwrap();
    assert!((0..corner.len()).all(|i| corner.get(i) == Some(0.0)));

    // A deleted chunk of an array whose fill value is -7.
    let (_dir, path) = copy_fixture("plain-v3-none.zarr");
    let pyramid = Pyramid::open(&path, PyramidOptions::default()).unwrap();
    let key = pyramid.chunk_key(0, [8, 8, 4]).unwrap();
    assert_eq!(key, "c/1/1/1");
    std::fs::remove_file(path.join(&key)).unwrap();
    let region = pyramid.read_region(0, [8, 8, 4], [8, 4, 2]).unwrap();
    assert!((0..region.len()).all(|i| region.get(i) == Some(-7.0)));
    let before = pyramid.read_region(0, [0, 0, 0], [8, 8, 4]).unwrap();
    assert!((0..before.len()).all(|i| before.get(i) != Some(-7.0)));
}

#[test]
fn damaged_chunks_are_errors_that_name_the_chunk() {
    // Wrong size: an uncompressed chunk cut short.
    let (_dir, path) = copy_fixture("plain-v3-none.zarr");
    std::fs::write(path.join("c/0/1/0"), [1u8, 2, 3]).unwrap();
    let error = read_error(&path);
    assert!(error.contains("level 0, chunk 'c/0/1/0'"), "{error}");

    // Undecodable: garbage where blosc data should be.
    let (_dir, path) = copy_fixture("nuclei-v04-blosc-lz4.ome.zarr");
    std::fs::write(path.join("s0/1/0/1"), vec![0xAB; 300]).unwrap();
    let error = read_error(&path);
    assert!(
        error.contains("level 0 ('s0'), chunk 's0/1/0/1'"),
        "{error}"
    );
    assert!(!error.contains('\n'));

    // A zstd frame declaring 2^50 decoded bytes (zarrs would reserve them and abort).
    let (_dir, path) = copy_fixture("head-v04-zstd.ome.zarr");
    let mut frame = vec![0x28, 0xB5, 0x2F, 0xFD, 0xE0];
    frame.extend_from_slice(&(1u64 << 50).to_le_bytes());
    frame.extend_from_slice(&[0x01, 0x00, 0x00]);
    std::fs::write(path.join("s0/1/1/1"), frame).unwrap();
    let error = read_error(&path);
    assert!(error.contains("chunk 's0/1/1/1'"), "{error}");

    // A zstd stream holding more than its chunk.
    let big = zstd::encode_all(&vec![0u8; 100_000][..], 3).unwrap();
    std::fs::write(path.join("s0/1/1/1"), big).unwrap();
    let error = read_error(&path);
    assert!(
        error.contains("chunk 's0/1/1/1'") && error.contains("more than the chunk's 8192 bytes"),
        "{error}"
    );

    // A blosc header claiming more than the chunk.
    let (_dir, path) = copy_fixture("nuclei-v04-blosc-lz4.ome.zarr");
    let chunk = path.join("s0/0/0/0");
    let mut bytes = std::fs::read(&chunk).unwrap();
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(&chunk, bytes).unwrap();
    let error = read_error(&path);
    assert!(
        error.contains("chunk 's0/0/0/0'") && error.contains("declares 4294967295"),
        "{error}"
    );

    // A gzip chunk that is not gzip.
    let (_dir, path) = copy_fixture("plain-v2-gzip.zarr");
    std::fs::write(path.join("0.0.0"), b"not gzip at all").unwrap();
    let error = read_error(&path);
    assert!(error.contains("chunk '0.0.0'"), "{error}");
}

#[test]
fn malformed_metadata_is_a_one_line_error() {
    let edit = |name: &str, file: &str, change: &dyn Fn(&mut Value)| {
        let (dir, path) = copy_fixture(name);
        let text = std::fs::read_to_string(path.join(file)).unwrap();
        let mut json: Value = serde_json::from_str(&text).unwrap();
        change(&mut json);
        std::fs::write(path.join(file), json.to_string()).unwrap();
        (dir, path)
    };
    let cases: Vec<(tempfile::TempDir, PathBuf, &str)> = vec![
        {
            let (d, p) = edit("head-v04-zstd.ome.zarr", ".zattrs", &|j| {
                j["multiscales"][0]
                    .as_object_mut()
                    .unwrap()
                    .remove("datasets");
            });
            (d, p, "multiscales[0] lacks 'datasets'")
        },
        {
            let (d, p) = edit("head-v04-zstd.ome.zarr", ".zattrs", &|j| {
                j["multiscales"][0]["datasets"][1]["coordinateTransformations"][0]["scale"] =
                    serde_json::json!([1, 2]);
            });
            (
                d,
                p,
                "multiscales[0].datasets[1]: scale has 2 values for 3 axes",
            )
        },
        {
            let (d, p) = edit("head-v04-zstd.ome.zarr", ".zattrs", &|j| {
                j["multiscales"][0]["datasets"][2]["path"] = serde_json::json!("nothing");
            });
            (d, p, "array 'nothing'")
        },
        {
            let (d, p) = edit("head-v04-zstd.ome.zarr", ".zattrs", &|j| {
                j["multiscales"][0]["axes"][0]["type"] = serde_json::json!("channel");
                j["multiscales"][0]["axes"][1]["type"] = serde_json::json!("time");
            });
            (
                d,
                p,
                "axes 'z, y, x' have 1 space axes; a volume has 2 or 3",
            )
        },
        {
            let (d, p) = edit("head-v04-zstd.ome.zarr", "s0/.zarray", &|j| {
                j["compressor"] = serde_json::json!({"id": "snappy-brotli"});
            });
            (d, p, "array 's0'")
        },
        {
            let (d, p) = edit("head-v04-zstd.ome.zarr", "s1/.zarray", &|j| {
                j["dtype"] = serde_json::json!("<f4");
            });
            (d, p, "array 's1' holds float32 but level 0 holds int16")
        },
        {
            // A hostile chunk shape: refused before any chunk exists in memory.
            let (d, p) = edit("head-v04-zstd.ome.zarr", "s0/.zarray", &|j| {
                j["chunks"] = serde_json::json!([100000, 100000, 100000]);
            });
            (d, p, "at most 1073741824 are read")
        },
        {
            let (d, p) = edit(
                "head-v05-sharded-blosc-zstd.ome.zarr",
                "s0/zarr.json",
                &|j| {
                    j["codecs"][0]["configuration"]["chunk_shape"] = serde_json::json!([1, 1, 1]);
                    j["chunk_grid"]["configuration"]["chunk_shape"] =
                        serde_json::json!([1024, 1024, 1024]);
                },
            );
            (d, p, "shards of 1073741824 chunks")
        },
        {
            let (d, p) = edit("plain-v2-gzip.zarr", ".zarray", &|j| {
                j["dtype"] = serde_json::json!("<f2");
            });
            (d, p, "values; voxscope reads uint8/16/32/64")
        },
    ];
    for (_dir, path, wanted) in &cases {
        let error = open_error(path);
        assert!(error.contains(wanted), "{error} lacks {wanted}");
        assert!(error.starts_with(&path.display().to_string()), "{error}");
        assert!(!error.contains('\n') && error.len() < 1100, "{error}");
    }

    let (_dir, path) = copy_fixture("head-v04-zstd.ome.zarr");
    std::fs::write(path.join(".zattrs"), b"{\"multiscales\": [").unwrap();
    assert!(open_error(&path).contains(".zattrs is not valid JSON"));
    std::fs::write(path.join(".zattrs"), vec![b' '; 17 << 20]).unwrap();
    assert!(open_error(&path).contains(".zattrs is 17825792 bytes"));
    std::fs::write(path.join(".zattrs"), b"{}").unwrap();
    assert!(open_error(&path).contains("without OME-Zarr 'multiscales' metadata"));
    let empty = tempfile::tempdir().unwrap();
    assert!(open_error(empty.path()).contains("is not a Zarr store"));
}

/// A volume whose value depends on (x, y, z), so axis mix-ups show; `kind` picks the type.
fn pattern(dims: [usize; 3], kind: &str) -> VoxelData {
    let count = dims.iter().product::<usize>();
    let value = |i: usize| {
        let (x, y, z) = (
            i % dims[0],
            (i / dims[0]) % dims[1],
            i / (dims[0] * dims[1]),
        );
        ((x * 7 + y * 13 + z * 29) % 251) as f64
            + if (x / 9 + z / 5) % 3 == 0 { 0.0 } else { 300.0 }
    };
    let values: Vec<f64> = (0..count).map(value).collect();
    match kind {
        "u8" => VoxelData::U8(values.iter().map(|&v| (v as u64 % 256) as u8).collect()),
        "i16" => VoxelData::I16(values.iter().map(|&v| v as i16 - 200).collect()),
        "f32" => VoxelData::F32(values.iter().map(|&v| v as f32 * 0.25 - 3.0).collect()),
        _ => VoxelData::U16(values.iter().map(|&v| v as u16 * 3).collect()),
    }
}

/// An independent 2×2×2 reduction (f64, edge voxels repeated) for comparison.
fn reduce(data: &VoxelData, dims: [usize; 3], max: bool, integer: bool) -> (Vec<f64>, [usize; 3]) {
    let out = dims.map(|n| n.div_ceil(2));
    let mut values = Vec::new();
    for z in 0..out[2] {
        for y in 0..out[1] {
            for x in 0..out[0] {
                let mut picked = Vec::new();
                for dz in 0..2 {
                    for dy in 0..2 {
                        for dx in 0..2 {
                            let (sx, sy, sz) = (
                                (2 * x + dx).min(dims[0] - 1),
                                (2 * y + dy).min(dims[1] - 1),
                                (2 * z + dz).min(dims[2] - 1),
                            );
                            picked.push(data.get(sx + dims[0] * (sy + dims[1] * sz)).unwrap());
                        }
                    }
                }
                let v = if max {
                    picked.iter().cloned().fold(f64::MIN, f64::max)
                } else {
                    let mean = picked.iter().sum::<f64>() / 8.0;
                    if integer {
                        (mean + 0.5).floor()
                    } else {
                        mean as f32 as f64
                    }
                };
                values.push(v);
            }
        }
    }
    (values, out)
}

fn write(path: &Path, data: &VoxelData, dims: [usize; 3], options: &WriteOptions, slab: usize) {
    let mut writer =
        PyramidWriter::create(path, dims, data.voxel_type(), [0.5, 0.5, 2.0], options).unwrap();
    let plane = dims[0] * dims[1];
    let mut z = 0;
    while z < dims[2] {
        let n = slab.min(dims[2] - z);
        let part = match data {
            VoxelData::U8(v) => VoxelData::U8(v[z * plane..(z + n) * plane].to_vec()),
            VoxelData::I16(v) => VoxelData::I16(v[z * plane..(z + n) * plane].to_vec()),
            VoxelData::U16(v) => VoxelData::U16(v[z * plane..(z + n) * plane].to_vec()),
            VoxelData::F32(v) => VoxelData::F32(v[z * plane..(z + n) * plane].to_vec()),
            _ => unreachable!(),
        };
        writer.push(&part).unwrap();
        z += n;
    }
    let levels = writer.finish().unwrap();
    assert_eq!(levels, level_dims(dims, options.chunk));
}

#[test]
fn convert_output_reads_back_equal_to_its_input() {
    let dims = [45, 37, 29];
    let cases = [
        (
            ZarrVersion::V04,
            Compression::BloscLz4,
            "u16",
            Downsampling::Mean,
            7,
        ),
        (
            ZarrVersion::V04,
            Compression::Zstd,
            "f32",
            Downsampling::Mean,
            29,
        ),
        (
            ZarrVersion::V04,
            Compression::Gzip,
            "u8",
            Downsampling::Max,
            3,
        ),
        (
            ZarrVersion::V04,
            Compression::None,
            "i16",
            Downsampling::Mean,
            16,
        ),
        (
            ZarrVersion::V05,
            Compression::BloscZstd,
            "u16",
            Downsampling::Mean,
            5,
        ),
        (
            ZarrVersion::V05,
            Compression::Gzip,
            "i16",
            Downsampling::Max,
            40,
        ),
        (
            ZarrVersion::V05,
            Compression::None,
            "f32",
            Downsampling::Mean,
            1,
        ),
    ];
    for (version, compression, kind, downsampling, slab) in cases {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.ome.zarr");
        let data = pattern(dims, kind);
        let options = WriteOptions {
            version,
            chunk: 8,
            shard_chunks: 2,
            compression,
            downsampling,
            name: "pattern".into(),
            unit: Some("micrometer".into()),
        };
        write(&path, &data, dims, &options, slab);
        let what = format!("{version:?} {compression:?} {kind}");
        let pyramid = Pyramid::open(&path, PyramidOptions::default()).unwrap();
        assert_eq!(pyramid.levels.len(), 4, "{what}: 45 -> 23 -> 12 -> 6");
        assert_eq!(pyramid.read_level(0).unwrap(), data, "{what}");
        assert_eq!(pyramid.units[0].as_deref(), Some("micrometer"));
        assert_eq!(pyramid.levels[1].spacing, [1.0, 1.0, 4.0], "{what}");
        assert_eq!(pyramid.levels[1].origin, [0.25, 0.25, 1.0], "{what}");
        assert_eq!(
            pyramid.levels[0].shard.is_some(),
            version == ZarrVersion::V05
        );
        // Every coarser level is the reduction of the one before.
        let mut finer = data.clone();
        let mut finer_dims = dims;
        for level in 1..pyramid.levels.len() {
            let integer = kind != "f32";
            let (want, want_dims) = reduce(
                &finer,
                finer_dims,
                downsampling == Downsampling::Max,
                integer,
            );
            let got = pyramid.read_level(level).unwrap();
            assert_eq!(pyramid.levels[level].dims, want_dims);
            for (i, w) in want.iter().enumerate() {
                assert_eq!(got.get(i).unwrap(), *w, "{what} level {level} voxel {i}");
            }
            finer = got;
            finer_dims = want_dims;
        }
        // The chunk ranges are each chunk's own minimum and maximum.
        let ranges = pyramid
            .chunk_ranges(0)
            .unwrap()
            .expect("convert writes chunk ranges");
        let grid = pyramid.levels[0].chunk_grid();
        assert_eq!(ranges.len(), grid.iter().product::<usize>());
        for (i, [low, high]) in ranges.iter().enumerate() {
            let (cx, cy, cz) = (
                i % grid[0],
                (i / grid[0]) % grid[1],
                i / (grid[0] * grid[1]),
            );
            let region = pyramid
                .read_region(
                    0,
                    [cx * 8, cy * 8, cz * 8],
                    [
                        8.min(dims[0] - cx * 8),
                        8.min(dims[1] - cy * 8),
                        8.min(dims[2] - cz * 8),
                    ],
                )
                .unwrap();
            let values: Vec<f64> = (0..region.len()).map(|j| region.get(j).unwrap()).collect();
            assert_eq!(
                *low,
                values.iter().cloned().fold(f64::MAX, f64::min),
                "{what}"
            );
            assert_eq!(
                *high,
                values.iter().cloned().fold(f64::MIN, f64::max),
                "{what}"
            );
        }
        assert!(pyramid.chunk_ranges(3).unwrap().is_some());
    }
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn convert_command_streams_raw_input_and_info_describes_the_pyramid() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [40, 24, 70];
    let data = pattern(dims, "u16");
    let VoxelData::U16(values) = &data else {
        unreachable!()
    };
    let raw = dir.path().join("pattern.raw");
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&raw, bytes).unwrap();
    let out = dir.path().join("pattern.ome.zarr");
    let output = voxscope(&[
        "convert",
        raw.to_str().unwrap(),
        out.to_str().unwrap(),
        "--raw",
        "40x24x70:u16",
        "--spacing",
        "0.5,0.5,1.5",
        "--format",
        "0.5",
        "--chunk",
        "8",
        "--compression",
        "zstd",
        "--unit",
        "micrometer",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("read in slabs"), "{stderr}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("5 levels: 40x24x70, 20x12x35, 10x6x18, 5x3x9, 3x2x5"),
        "{stdout}"
    );
    let pyramid = Pyramid::open(&out, PyramidOptions::default()).unwrap();
    assert_eq!(pyramid.read_level(0).unwrap(), data);
    assert_eq!(pyramid.levels[0].spacing, [0.5, 0.5, 1.5]);

    // Writing over an existing folder, or a bad option, is refused.
    let again = voxscope(&[
        "convert",
        raw.to_str().unwrap(),
        out.to_str().unwrap(),
        "--raw",
        "40x24x70:u16",
    ]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("exists; convert writes a new folder"));
    let bad = voxscope(&[
        "convert",
        raw.to_str().unwrap(),
        "x.ome.zarr",
        "--compression",
        "lzma",
    ]);
    assert!(
        String::from_utf8_lossy(&bad.stderr)
            .contains("compression 'lzma' is not one of blosc-lz4, blosc-zstd, zstd, gzip, none")
    );

    let info = voxscope(&["info", out.to_str().unwrap(), "--json"]);
    assert!(
        info.status.success(),
        "{}",
        String::from_utf8_lossy(&info.stderr)
    );
    let json: Value = serde_json::from_slice(&info.stdout).unwrap();
    let pyramid = &json["pyramid"];
    assert_eq!(pyramid["ome_version"], "0.5");
    assert_eq!(pyramid["levels"].as_array().unwrap().len(), 5);
    assert_eq!(pyramid["levels"][0]["codec"], "sharding(zstd)");
    assert_eq!(
        pyramid["levels"][0]["shard"],
        serde_json::json!([16, 16, 16])
    );
    assert_eq!(pyramid["axes"][0]["unit"], "micrometer");
    assert_eq!(json["volume"]["dims"], serde_json::json!([40, 24, 70]));
    assert_eq!(json["volume"]["format"], "OME-Zarr");
}

#[test]
fn convert_streams_raw_nrrd_in_place_and_loads_an_oriented_one_whole() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [30, 20, 50];
    let data = pattern(dims, "i16");
    let VoxelData::I16(values) = &data else {
        unreachable!()
    };
    let voxels: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    for (name, space, streams) in [
        ("plain.nrrd", "spacings: 0.5 0.5 2\n", true),
        (
            "ras.nrrd",
            "space: right-anterior-superior\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\n",
            true,
        ),
        (
            "lps.nrrd",
            "space: left-posterior-superior\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\n",
            false,
        ),
    ] {
        let header = format!(
            "NRRD0004\ntype: int16\ndimension: 3\nsizes: 30 20 50\nendian: big\nencoding: raw\n{space}\n"
        );
        let input = dir.path().join(name);
        std::fs::write(&input, [header.as_bytes(), &voxels].concat()).unwrap();
        let out = dir.path().join(format!("{name}.ome.zarr"));
        let output = voxscope(&[
            "convert",
            input.to_str().unwrap(),
            out.to_str().unwrap(),
            "--chunk",
            "16",
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        let how = if streams {
            "read in slabs"
        } else {
            "loaded whole"
        };
        assert!(stderr.contains(how), "{name}: {stderr}");
        // Level 0 holds what voxscope loads from the input (LPS reordered to RAS).
        let loaded =
            voxscope_volume::load(input.to_str().unwrap(), &LoadOptions::default()).unwrap();
        let pyramid = Pyramid::open(&out, PyramidOptions::default()).unwrap();
        assert_eq!(pyramid.read_level(0).unwrap(), loaded.data, "{name}");
        assert_eq!(pyramid.levels[0].spacing, [0.5, 0.5, 2.0], "{name}");
        assert_eq!(
            loaded.data == data,
            streams,
            "{name}: only LPS is reordered"
        );
    }
}

#[test]
fn convert_reads_a_folder_of_slices_one_slab_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let slices = dir.path().join("slices");
    std::fs::create_dir(&slices).unwrap();
    let dims = [24, 16, 20];
    let data = pattern(dims, "u16");
    let VoxelData::U16(values) = &data else {
        unreachable!()
    };
    let plane = dims[0] * dims[1];
    for z in 0..dims[2] {
        let pixels = values[z * plane..(z + 1) * plane].to_vec();
        let image = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(24, 16, pixels).unwrap();
        image.save(slices.join(format!("z{z}.png"))).unwrap();
    }
    let out = dir.path().join("slices.ome.zarr");
    let output = voxscope(&[
        "convert",
        slices.to_str().unwrap(),
        out.to_str().unwrap(),
        "--chunk",
        "8",
        "--format",
        "0.5",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("read in slabs"), "{stderr}");
    let pyramid = Pyramid::open(&out, PyramidOptions::default()).unwrap();
    assert_eq!(pyramid.read_level(0).unwrap(), data);
    assert_eq!(pyramid.levels.len(), 3, "24x16x20 -> 12x8x10 -> 6x4x5");
}

#[test]
fn info_lists_levels_channels_and_windows() {
    let path = fixtures().join("tczyx-v04.ome.zarr");
    let output = voxscope(&[
        "info",
        path.to_str().unwrap(),
        "--channel",
        "1",
        "--time",
        "1",
    ]);
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for wanted in [
        "zarr         OME-Zarr 0.4 (Zarr v2), image 'two channels'",
        "axes         t (second), c, z (micrometer), y (micrometer), x (micrometer)",
        "time points  2 (showing 1)",
        "channels     2 (showing 1)",
        "  channel 0  nuclei, color #00FF00, window 2000 … 30000",
        "  channel 1  head, color #FF00FF, window 10 … 200",
        "window       10 … 200",
    ] {
        assert!(text.contains(wanted), "{wanted}\n{text}");
    }
    let level_row = text
        .lines()
        .find(|l| l.trim_start().starts_with("1 s1"))
        .unwrap_or_default();
    assert!(
        level_row.contains("8x8x4") && level_row.contains("blosc lz4"),
        "{text}"
    );

    let missing = voxscope(&["info", path.to_str().unwrap(), "--channel", "3"]);
    assert_eq!(missing.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&missing.stderr);
    assert!(
        stderr
            .trim_end()
            .ends_with("channel 3 does not exist (the image has 2)"),
        "{stderr}"
    );
}

#[test]
fn a_zarr_folder_loads_as_a_volume_through_the_registry() {
    let path = fixtures().join("head-v04-zstd.ome.zarr");
    let volume = voxscope_volume::load(path.to_str().unwrap(), &LoadOptions::default()).unwrap();
    assert_eq!(volume.format, "OME-Zarr");
    assert_eq!(volume.dims, [64, 64, 31]);
    assert_eq!(volume.spacing, [4.0, 4.0, 6.0]);
    assert_eq!(volume.default_window, None);
    assert!(
        volume
            .metadata
            .iter()
            .any(|(k, v)| k == "zarr" && v == "OME-Zarr 0.4 (Zarr v2)")
    );
    let format = voxscope_volume::format::by_extension("cells.ome.zarr").unwrap();
    assert_eq!((format.name, format.opens_folders), ("OME-Zarr", true));
}

/// A small deterministic generator for the mutation test (no test may depend on chance).
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn files_under(path: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(path).unwrap() {
        let entry = entry.unwrap();
        if entry.file_type().unwrap().is_dir() {
            files_under(&entry.path(), out);
        } else {
            out.push(entry.path());
        }
    }
}

/// Replaces one leaf of `value` (picked by `pick`) with an edge value, or removes a key.
fn mutate_json(value: &mut Value, rng: &mut XorShift) {
    const NUMBERS: [f64; 9] = [
        0.0,
        -1.0,
        1.0,
        2147483648.0,
        4294967295.0,
        9007199254740992.0,
        1e300,
        -1e300,
        0.5,
    ];
    const TEXTS: [&str; 8] = [
        "",
        "blosc",
        "zstd",
        "../x",
        "int64",
        "float16",
        "sharding_indexed",
        "\u{1b}[31m",
    ];
    let mut leaves = Vec::new();
    fn collect(value: &Value, pointer: String, leaves: &mut Vec<String>) {
        match value {
            Value::Object(map) => {
                for (key, child) in map {
                    collect(child, format!("{pointer}/{key}"), leaves);
                }
            }
            Value::Array(list) => {
                for (index, child) in list.iter().enumerate() {
                    collect(child, format!("{pointer}/{index}"), leaves);
                }
            }
            _ => leaves.push(pointer),
        }
    }
    collect(value, String::new(), &mut leaves);
    if leaves.is_empty() {
        return;
    }
    let pointer = leaves[rng.below(leaves.len())].clone();
    let choice = rng.below(3);
    if choice == 2 {
        if let Some((parent, key)) = pointer.rsplit_once('/')
            && let Some(Value::Object(map)) = value.pointer_mut(parent)
        {
            map.remove(key);
        }
        return;
    }
    if let Some(leaf) = value.pointer_mut(&pointer) {
        *leaf = if choice == 0 {
            serde_json::json!(NUMBERS[rng.below(NUMBERS.len())])
        } else {
            serde_json::json!(TEXTS[rng.below(TEXTS.len())])
        };
    }
}

/// Damaged copies of every fixture (metadata fields set to edge values or removed, chunk
/// bytes flipped, cut or replaced) open and read without a panic, and every error is one line.
#[test]
fn mutated_fixtures_fail_cleanly_never_panic() {
    let names = [
        "nuclei-v04-blosc-lz4.ome.zarr",
        "head-v04-zstd.ome.zarr",
        "head-v05-sharded-blosc-zstd.ome.zarr",
        "tczyx-v04.ome.zarr",
        "plain-v2-gzip.zarr",
        "plain-v3-none.zarr",
    ];
    let mut rng = XorShift(0x5EED_2026);
    let (mut opened, mut failed) = (0, 0);
    for case in 0..240 {
        let (_dir, path) = copy_fixture(names[case % names.len()]);
        let mut files = Vec::new();
        files_under(&path, &mut files);
        for _ in 0..1 + rng.below(2) {
            let file = &files[rng.below(files.len())];
            let mut bytes = std::fs::read(file).unwrap();
            let name = file.file_name().unwrap().to_string_lossy().into_owned();
            let is_json = name.starts_with('.') || name == "zarr.json";
            if is_json && let Ok(mut json) = serde_json::from_slice::<Value>(&bytes) {
                mutate_json(&mut json, &mut rng);
                bytes = json.to_string().into_bytes();
            } else {
                match rng.below(4) {
                    0 => {
                        for _ in 0..1 + rng.below(8) {
                            let at = rng.below(bytes.len());
                            if let Some(b) = bytes.get_mut(at) {
                                *b ^= 1 << rng.below(8);
                            }
                        }
                    }
                    1 => bytes.truncate(rng.below(bytes.len())),
                    2 => bytes.extend((0..rng.below(64)).map(|_| rng.next() as u8)),
                    _ => bytes = (0..rng.below(256)).map(|_| rng.next() as u8).collect(),
                }
            }
            std::fs::write(file, bytes).unwrap();
        }
        let outcome = std::panic::catch_unwind(|| {
            let pyramid = Pyramid::open(&path, PyramidOptions::default())?;
            for level in 0..pyramid.levels.len() {
                pyramid.read_level(level)?;
            }
            Ok::<(), voxscope_volume::LoadError>(())
        });
        match outcome {
            Ok(Ok(())) => opened += 1,
            Ok(Err(error)) => {
                failed += 1;
                let text = error.to_string();
                assert!(
                    !text.contains('\n') && text.len() < 1200,
                    "case {case}: {text}"
                );
            }
            Err(_) => panic!("case {case} ({}) panicked", names[case % names.len()]),
        }
    }
    // Both outcomes occur: the mutations reach what matters, and harmless ones stay harmless.
    assert!(
        opened > 20 && failed > 20,
        "{opened} opened, {failed} failed"
    );
}

#[test]
fn convert_upsample_interpolates_the_input_onto_a_finer_grid() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let input = fixtures().join("plain-v3-none.zarr");
    let convert = |name: &str, options: &[&str]| {
        let output = dir.path().join(name);
        let run = Command::new(env!("CARGO_BIN_EXE_voxscope"))
            .arg("convert")
            .arg(&input)
            .arg(&output)
            .args(options)
            .output()
            .expect("voxscope runs");
        (output, run)
    };
    let original = voxscope_volume::load(input.to_str().expect("UTF-8"), &LoadOptions::default())
        .expect("the fixture loads");
    let [dx, dy, dz] = original.dims;
    let VoxelData::I32(source) = &original.data else {
        panic!("the fixture is i32");
    };
    let at = |x: usize, y: usize, z: usize| source[x + dx * (y + dy * z)];
    let read = |name: &str, options: &[&str]| {
        let (output, run) = convert(name, options);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let pyramid = Pyramid::open(&output, PyramidOptions::default()).expect("the output opens");
        assert_eq!(pyramid.levels[0].dims, [3 * dx, 3 * dy, 3 * dz]);
        let spacing = pyramid.levels[0].spacing;
        for axis in 0..3 {
            assert!(
                (spacing[axis] * 3.0 - original.spacing[axis]).abs() < 1e-9,
                "{spacing:?} against {:?}",
                original.spacing
            );
        }
        let VoxelData::I32(finer) = pyramid.read_level(0).expect("level 0 reads") else {
            panic!("the output keeps i32");
        };
        finer
    };
    let finer = read("smooth.ome.zarr", &["--upsample", "3", "--chunk", "8"]);
    let (fx, fy) = (3 * dx, 3 * dy);
    for z in 0..3 * dz {
        for y in 0..fy {
            for x in 0..fx {
                let value = finer[x + fx * (y + fy * z)];
                let (i, j, k) = (x / 3, y / 3, z / 3);
                if x % 3 == 1 && y % 3 == 1 && z % 3 == 1 {
                    // A finer voxel's centre on an input voxel's centre: its value.
                    assert_eq!(value, at(i, j, k), "voxel ({x}, {y}, {z})");
                }
                // Otherwise between the values of the input voxels around it.
                let near = |c: usize, n: usize| [c.saturating_sub(1), c, (c + 1).min(n - 1)];
                let around: Vec<i32> = near(i, dx)
                    .into_iter()
                    .flat_map(|a| near(j, dy).into_iter().map(move |b| (a, b)))
                    .flat_map(|(a, b)| near(k, dz).into_iter().map(move |c| at(a, b, c)))
                    .collect();
                let (low, high) = (around.iter().min().unwrap(), around.iter().max().unwrap());
                assert!(
                    (*low..=*high).contains(&value),
                    "voxel ({x}, {y}, {z}): {value} outside {low}..={high}"
                );
            }
        }
    }
    // Along one axis, every voxel: a third of the way between two input voxels is their
    // weighted mean (1/3, 2/3, rounded; never a half), and the edges hold the end values.
    let (output, run) = convert("along-x.ome.zarr", &["--upsample", "3,1,1", "--chunk", "8"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let along_x = Pyramid::open(&output, PyramidOptions::default()).expect("the output opens");
    let VoxelData::I32(along_x) = along_x.read_level(0).expect("level 0 reads") else {
        panic!("the output keeps i32");
    };
    for z in 0..dz {
        for y in 0..dy {
            for x in 0..3 * dx {
                let i = x / 3;
                let mean = |low: usize, high: usize| {
                    (at(low, y, z) as f64 * 2.0 / 3.0 + at(high, y, z) as f64 / 3.0).round() as i32
                };
                let expected = match x % 3 {
                    1 => at(i, y, z),
                    0 if i == 0 => at(0, y, z),
                    0 => mean(i, i - 1),
                    _ if i + 1 == dx => at(i, y, z),
                    _ => mean(i, i + 1),
                };
                assert_eq!(
                    along_x[x + 3 * dx * (y + dy * z)],
                    expected,
                    "voxel ({x}, {y}, {z})"
                );
            }
        }
    }
    // Noise: within its bound of the smooth values, not all zero, the same each time.
    let noisy = read(
        "noisy.ome.zarr",
        &["--upsample", "3", "--noise", "4", "--chunk", "8"],
    );
    let again = read(
        "again.ome.zarr",
        &["--upsample", "3", "--noise", "4", "--chunk", "8"],
    );
    assert_eq!(noisy, again, "the noise is fixed by the voxel's place");
    let offsets: Vec<i32> = noisy.iter().zip(&finer).map(|(n, s)| n - s).collect();
    assert!(offsets.iter().all(|o| o.abs() <= 5), "within ±4, rounded");
    assert!(offsets.iter().filter(|&&o| o != 0).count() > offsets.len() / 2);
    // Refused: a zero factor, noise without upsampling, upsampled tiles, upsampled labels
    // (interpolation would invent ids).
    for (name, options, named) in [
        ("zero.ome.zarr", &["--upsample", "0"][..], "--upsample"),
        ("noise.ome.zarr", &["--noise", "1"][..], "--upsample"),
        (
            "both.ome.zarr",
            &["--upsample", "2", "--tile", "2"][..],
            "--tile",
        ),
    ] {
        let (output, run) = convert(name, options);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{options:?}");
        assert!(stderr.contains(named), "{options:?}: {stderr}");
        assert!(!output.exists(), "{options:?} wrote nothing");
    }
}

#[test]
fn convert_tile_repeats_the_input_along_each_axis() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let input = fixtures().join("plain-v3-none.zarr");
    let output = dir.path().join("tiled.ome.zarr");
    let run = Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .arg("convert")
        .arg(&input)
        .arg(&output)
        .args(["--tile", "2,1,3", "--chunk", "8"])
        .output()
        .expect("voxscope runs");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let original = voxscope_volume::load(input.to_str().expect("UTF-8"), &LoadOptions::default())
        .expect("the fixture loads");
    let tiled = Pyramid::open(&output, PyramidOptions::default()).expect("the output opens");
    let [dx, dy, dz] = original.dims;
    assert_eq!(tiled.levels[0].dims, [2 * dx, dy, 3 * dz]);
    let (VoxelData::I32(original), VoxelData::I32(tiled)) =
        (original.data, tiled.read_level(0).expect("level 0 reads"))
    else {
        panic!("the fixture is i32");
    };
    for z in 0..3 * dz {
        for y in 0..dy {
            for x in 0..2 * dx {
                assert_eq!(
                    tiled[x + 2 * dx * (y + dy * z)],
                    original[x % dx + dx * (y + dy * (z % dz))],
                    "voxel ({x}, {y}, {z})"
                );
            }
        }
    }
    // Not for inputs read slab by slab, and never zero copies.
    let refused = Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .arg("convert")
        .arg(&input)
        .arg(dir.path().join("none.ome.zarr"))
        .args(["--tile", "0"])
        .output()
        .expect("voxscope runs");
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--tile"), "{stderr}");
}
