//! Imaris files (tests/data/imaris, written by h5py in Imaris's layout; see
//! make_fixtures.py): deflate with shuffle, LZ4, big-endian contiguous data, time points and
//! channels read equal to the voxels they were written from, levels placed by the file's
//! extent, channel names, colors and windows kept; a file renders equal to its OME-Zarr
//! conversion; another HDF5 file, a cut or damaged file are one-line errors that leave the
//! file as it was, and no damage makes the reader panic.

mod support;

use std::path::{Path, PathBuf};

use support::cli::{differing_pixels, renders, voxscope};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions, is_imaris_file, is_zarr_spec};

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/imaris")
}

/// u16 little-endian values, x fastest.
fn u16_file(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    bytes
        .chunks_exact(2)
        .map(|pair| f64::from(u16::from_le_bytes([pair[0], pair[1]])))
        .collect()
}

/// The voxels every fixture is made from (10 x 9 x 7).
fn voxels() -> Vec<f64> {
    u16_file(&fixtures().join("../codecs/voxels.u16le"))
}

fn open_with(path: &Path, options: PyramidOptions) -> Result<Pyramid, String> {
    Pyramid::open(path, options).map_err(|e| e.to_string())
}

fn open(path: &Path) -> Result<Pyramid, String> {
    open_with(path, PyramidOptions::default())
}

fn level(pyramid: &Pyramid, level: usize) -> Result<Vec<f64>, String> {
    let data = pyramid.read_level(level).map_err(|e| e.to_string())?;
    Ok((0..data.len()).map(|i| data.get(i).unwrap()).collect())
}

#[test]
fn levels_and_channels_read_equal_to_the_voxels_placed_by_the_extent() {
    let path = fixtures().join("cells.ims");
    assert!(is_imaris_file(&path) && is_zarr_spec(path.to_str().unwrap()));
    let pyramid = open(&path).unwrap();
    assert_eq!(pyramid.format, "Imaris");
    assert_eq!(pyramid.ome_version.as_deref(), Some("5.5.0"));
    assert_eq!(pyramid.format_description(), "Imaris 5.5.0");
    assert_eq!((pyramid.channels, pyramid.time_points), (2, 1));
    let [s0, s1] = [&pyramid.levels[0], &pyramid.levels[1]];
    assert_eq!((s0.dims, s1.dims), ([10, 9, 7], [5, 5, 4]));
    assert_eq!(s0.chunk, [6, 5, 4]);
    assert_eq!(s0.codec, "hdf5 shuffle deflate");
    // Voxels of 0.5 x 0.5 x 2 um filling (30, 20, 10) to (35, 24.5, 24) um: the first
    // voxel's center half a voxel inside; the coarser level fills the same box.
    assert_eq!(s0.spacing, [0.5, 0.5, 2.0]);
    assert_eq!(s0.origin, [30.25, 20.25, 11.0]);
    assert_eq!(s1.spacing, [1.0, 0.9, 3.5]);
    for a in 0..3 {
        let low = s1.origin[a] - s1.spacing[a] / 2.0;
        let high = low + s1.spacing[a] * s1.dims[a] as f64;
        let want = s0.origin[a] - s0.spacing[a] / 2.0;
        assert!((low - want).abs() < 1e-9, "axis {a}: {low} vs {want}");
        let want = want + s0.spacing[a] * s0.dims[a] as f64;
        assert!((high - want).abs() < 1e-9, "axis {a}: {high} vs {want}");
    }
    assert_eq!(pyramid.units[0].as_deref(), Some("micrometer"));
    // The channels' names, colors and windows.
    let labels: Vec<_> = pyramid.omero.iter().map(|c| c.label.clone()).collect();
    assert_eq!(labels, [Some("GFP".into()), Some("tdTomato".into())]);
    let colors: Vec<_> = pyramid.omero.iter().map(|c| c.color.clone()).collect();
    assert_eq!(colors, [Some("00FF00".into()), Some("FF00FF".into())]);
    let window = pyramid.omero[1].window.unwrap();
    assert_eq!((window.low, window.high), (1000.0, 1300.0));

    let want = voxels();
    assert!(level(&pyramid, 0).unwrap() == want, "level 0 differs");
    let coarse = u16_file(&fixtures().join("../n5/s1.u16le"));
    assert!(level(&pyramid, 1).unwrap() == coarse, "level 1 differs");
    let second = pyramid.of_channel(1).unwrap();
    let plus: Vec<f64> = want.iter().map(|v| v + 1000.0).collect();
    assert!(level(&second, 0).unwrap() == plus, "channel 1 differs");
}

#[test]
fn time_points_lz4_and_big_endian_contiguous_data_read_as_written() {
    let path = fixtures().join("lz4-time.ims");
    let first: Vec<f64> = voxels().iter().map(|v| v % 256.0).collect();
    let pyramid = open(&path).unwrap();
    assert_eq!((pyramid.channels, pyramid.time_points), (1, 2));
    assert_eq!(pyramid.levels[0].codec, "hdf5 lz4");
    assert_eq!(pyramid.stored_type, "uint8");
    assert!(level(&pyramid, 0).unwrap() == first, "time point 0 differs");
    let later = open_with(
        &path,
        PyramidOptions {
            time: 1,
            ..Default::default()
        },
    )
    .unwrap();
    let second: Vec<f64> = first.iter().map(|v| 255.0 - v).collect();
    assert!(level(&later, 0).unwrap() == second, "time point 1 differs");
    // A time point the file lacks is named with the count.
    let error = open_with(
        &path,
        PyramidOptions {
            time: 2,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(error.contains('2'), "{error}");

    // Unchunked big-endian floats, no DataSetInfo: voxels of 1 from 0.
    let pyramid = open(&fixtures().join("contiguous-be.ims")).unwrap();
    assert_eq!(pyramid.stored_type, "float32");
    assert_eq!(pyramid.levels[0].codec, "hdf5 raw");
    assert_eq!(pyramid.levels[0].spacing, [1.0; 3]);
    assert_eq!(pyramid.levels[0].origin, [0.5; 3]);
    let half: Vec<f64> = voxels().iter().map(|v| v * 0.5).collect();
    assert!(level(&pyramid, 0).unwrap() == half, "floats differ");
}

#[test]
fn a_file_converts_to_ome_zarr_and_renders_equal_to_its_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let source = fixtures().join("cells.ims");
    // Every channel converts at full resolution (read by region, not loaded whole).
    for (channel, offset) in [("0", 0.0), ("1", 1000.0)] {
        let converted = dir.path().join(format!("channel{channel}.ome.zarr"));
        let out = voxscope(&[
            "convert",
            source.to_str().unwrap(),
            converted.to_str().unwrap(),
            "--channel",
            channel,
        ]);
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{said}");
        assert!(said.contains("read in slabs"), "{said}");
        let read_back = open(&converted).unwrap();
        let want: Vec<f64> = voxels().iter().map(|v| v + offset).collect();
        assert!(level(&read_back, 0).unwrap() == want, "channel {channel}");
        assert_eq!(read_back.levels[0].spacing, [0.5, 0.5, 2.0]);
        assert_eq!(read_back.units[0].as_deref(), Some("micrometer"));
    }

    let info = voxscope(&["info", source.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&info.stdout);
    for want in ["Imaris 5.5.0", "hdf5 shuffle deflate", "GFP", "tdTomato"] {
        assert!(text.contains(want), "{want} missing: {text}");
    }

    // One channel, drawn by the same renderer as its conversion, with the same window.
    let source = fixtures().join("lz4-time.ims");
    let converted = dir.path().join("lz4.ome.zarr");
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
    let images = renders(
        dir.path(),
        &[&source, &converted],
        &["--size", "96x72", "--window", "0:255"],
    );
    assert!(images[0].pixels().any(|p| p[0] > 0), "the image is blank");
    let differing = differing_pixels(&images[0], &images[1]);
    assert_eq!(differing, 0, "{differing} pixels differ");
}

/// The one-line error `voxscope info` gives for `path`.
fn info_error(path: &Path) -> String {
    let out = voxscope(&["info", path.to_str().unwrap()]);
    assert!(!out.status.success(), "{} opened", path.display());
    let error = String::from_utf8_lossy(&out.stderr).trim().to_owned();
    assert_eq!(error.lines().count(), 1, "{error}");
    error
}

#[test]
fn other_hdf5_files_and_cut_files_are_one_line_errors() {
    let error = info_error(&fixtures().join("plain.h5"));
    assert!(error.contains("plain.h5"), "{error}");
    assert!(
        error.contains("HDF5 file without Imaris's DataSet group"),
        "{error}"
    );
    // Cut short: inside the superblock, and past the metadata (a chunk is missing).
    let dir = tempfile::tempdir().unwrap();
    let whole = std::fs::read(fixtures().join("cells.ims")).unwrap();
    let cut = dir.path().join("cut.ims");
    std::fs::write(&cut, &whole[..40]).unwrap();
    let error = info_error(&cut);
    assert!(error.contains("is not a readable HDF5 file"), "{error}");
    assert_eq!(std::fs::read(&cut).unwrap(), whole[..40]);
    let mut errors = 0;
    for end in [whole.len() / 2, whole.len() * 3 / 4, whole.len() - 4000] {
        std::fs::write(&cut, &whole[..end]).unwrap();
        let result = open(&cut).and_then(|pyramid| {
            (0..pyramid.levels.len()).try_for_each(|l| level(&pyramid, l).map(drop))
        });
        if let Err(error) = result {
            assert!(!error.contains('\n'), "{error}");
            errors += 1;
        }
    }
    assert!(errors > 0, "every cut file read whole");
}

/// xorshift, for damage repeatable from its seed.
fn next(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

#[test]
fn no_damage_makes_the_reader_panic_or_change_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = 0x5eed_u64;
    let mut outcomes = [0usize; 2];
    for name in ["cells.ims", "lz4-time.ims", "contiguous-be.ims"] {
        let whole = std::fs::read(fixtures().join(name)).unwrap();
        for case in 0..150 {
            let mut bytes = whole.clone();
            if case % 5 == 0 {
                bytes.truncate(next(&mut state) as usize % bytes.len());
            } else {
                for _ in 0..1 + next(&mut state) % 4 {
                    let at = next(&mut state) as usize % bytes.len();
                    bytes[at] ^= 1 << (next(&mut state) % 8);
                }
            }
            let path = dir.path().join(format!("{case}.ims"));
            std::fs::write(&path, &bytes).unwrap();
            let result = open(&path).and_then(|pyramid| {
                (0..pyramid.levels.len()).try_for_each(|l| level(&pyramid, l).map(drop))
            });
            match result {
                Ok(()) => outcomes[0] += 1,
                Err(error) => {
                    assert!(!error.contains('\n'), "{name} case {case}: {error}");
                    outcomes[1] += 1;
                }
            }
            assert_eq!(std::fs::read(&path).unwrap(), bytes, "{name} case {case}");
            std::fs::remove_file(&path).unwrap();
        }
    }
    // Damage was found, and damage that spares what is read left files readable.
    assert!(outcomes[0] > 0 && outcomes[1] > 0, "{outcomes:?}");
}
