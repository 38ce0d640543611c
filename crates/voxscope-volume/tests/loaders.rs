//! Loaders: the real files in ../shared/data, files written here in every variant, and bad
//! input, which must give a one-line error naming the file and the problem.

mod support;

use std::path::Path;

use support::shared_data;
use support::writers::{
    NiftiSpec, NrrdSpec, encode, gzip, nifti_bytes, nifti_datatype, write_nhdr, write_nrrd,
};
use voxscope_volume::{
    self, Endian, LoadOptions, NrrdEncoding, Orientation, QuantizedVolume, RawLayout, Scalar,
    Volume, VoxelType,
};

fn load(path: &Path) -> Result<Volume, String> {
    voxscope_volume::load(path.to_str().unwrap(), &LoadOptions::default())
        .map_err(|e| e.to_string())
}

fn load_raw(path: &Path, layout: &str) -> Result<Volume, String> {
    let options = LoadOptions {
        raw: Some(RawLayout::parse(layout).unwrap()),
        ..LoadOptions::default()
    };
    voxscope_volume::load(path.to_str().unwrap(), &options).map_err(|e| e.to_string())
}

/// A test pattern: value depends on (x, y, z) so axis mix-ups show.
fn pattern(dims: [usize; 3]) -> Vec<f64> {
    let mut values = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                values.push((x + 3 * y + 7 * z) as f64 % 100.0);
            }
        }
    }
    values
}

fn assert_pattern(volume: &Volume, dims: [usize; 3]) {
    assert_eq!(volume.dims, dims);
    let expected = pattern(dims);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                assert_eq!(
                    volume.value(x, y, z).unwrap(),
                    expected[x + dims[0] * (y + dims[1] * z)],
                    "({x},{y},{z})"
                );
            }
        }
    }
}

/// Payload bytes of the pattern in `voxel_type`, in `endian`.
fn pattern_bytes(voxel_type: VoxelType, dims: [usize; 3], endian: Endian) -> Vec<u8> {
    fn as_type<T: Scalar>(values: &[f64], endian: Endian) -> Vec<u8> {
        encode(
            &values.iter().map(|&v| T::from_f64(v)).collect::<Vec<T>>(),
            endian,
        )
    }
    let values = pattern(dims);
    match voxel_type {
        VoxelType::U8 => as_type::<u8>(&values, endian),
        VoxelType::I8 => as_type::<i8>(&values, endian),
        VoxelType::U16 => as_type::<u16>(&values, endian),
        VoxelType::I16 => as_type::<i16>(&values, endian),
        VoxelType::U32 => as_type::<u32>(&values, endian),
        VoxelType::I32 => as_type::<i32>(&values, endian),
        VoxelType::F32 => as_type::<f32>(&values, endian),
        VoxelType::F64 => as_type::<f64>(&values, endian),
    }
}

fn nrrd_type_name(voxel_type: VoxelType) -> &'static str {
    match voxel_type {
        VoxelType::U8 => "uchar",
        VoxelType::I8 => "signed char",
        VoxelType::U16 => "ushort",
        VoxelType::I16 => "short",
        VoxelType::U32 => "uint",
        VoxelType::I32 => "int",
        VoxelType::F32 => "float",
        VoxelType::F64 => "double",
    }
}

// ---- real files -------------------------------------------------------------------------

#[test]
fn real_nifti_files_load_with_their_headers() {
    let head = load(&shared_data("mri-head-256.nii.gz")).unwrap();
    assert_eq!(head.dims, [256, 256, 256]);
    assert_eq!(head.voxel_type(), VoxelType::U8);
    assert_eq!(head.spacing, [1.0, 1.0, 1.0]);
    assert_eq!(
        head.orientation,
        Orientation::Reoriented {
            stored: "LIA".into()
        }
    );

    // scl_slope = NaN means no scaling; 2×2×3 mm stored LSA, shown RAS.
    let small = load(&shared_data("mri-head-128x128x62.nii.gz")).unwrap();
    assert_eq!(small.voxel_type(), VoxelType::I16);
    assert_eq!(small.value_scale, voxscope_volume::ValueScale::IDENTITY);
    assert_eq!(small.dims, [128, 62, 128]);
    assert_eq!(small.spacing, [2.0, 3.0, 2.0]);
    let quantized = QuantizedVolume::new(&small);
    assert_eq!(quantized.value_range, [0.0, 255.0]);

    let mni = load(&shared_data("mni152-t1-197x233x189.nii.gz")).unwrap();
    assert_eq!(mni.dims, [197, 233, 189]);
    assert_eq!(mni.voxel_type(), VoxelType::U8);
    // The embedded sample is the same file.
    let sample = voxscope_volume::sample().unwrap();
    assert_eq!(sample.dims, small.dims);
    assert_eq!(sample.data, small.data);
}

// ---- written variants -------------------------------------------------------------------

#[test]
fn nifti_every_voxel_type_both_byte_orders_plain_and_gzip() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [5, 4, 3];
    for voxel_type in VoxelType::ALL {
        for endian in [Endian::Little, Endian::Big] {
            for gz in [false, true] {
                let spec = NiftiSpec {
                    dims,
                    datatype: nifti_datatype(voxel_type),
                    spacing: [0.5, 0.7, 2.0],
                    slope: 0.0,
                    intercept: 0.0,
                    sform: None,
                    endian,
                };
                let mut bytes = nifti_bytes(&spec, &pattern_bytes(voxel_type, dims, endian));
                let name = format!(
                    "v-{}-{endian:?}.nii{}",
                    voxel_type.name(),
                    if gz { ".gz" } else { "" }
                );
                if gz {
                    bytes = gzip(&bytes);
                }
                let path = dir.path().join(name);
                std::fs::write(&path, bytes).unwrap();
                let volume = load(&path).unwrap();
                assert_eq!(volume.voxel_type(), voxel_type);
                assert_eq!(volume.spacing, [0.5, 0.699999988079071, 2.0]);
                assert_pattern(&volume, dims);
            }
        }
    }
}

#[test]
fn nifti_scaling_and_sform_orientation_are_honored() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [4, 3, 2];
    // x runs left (−x in RAS): the loader flips it back.
    let sform = [
        [-1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ];
    let spec = NiftiSpec {
        dims,
        datatype: 4,
        spacing: [1.0; 3],
        slope: 2.0,
        intercept: -10.0,
        sform: Some(sform),
        endian: Endian::Little,
    };
    let path = dir.path().join("scaled.nii");
    std::fs::write(
        &path,
        nifti_bytes(&spec, &pattern_bytes(VoxelType::I16, dims, Endian::Little)),
    )
    .unwrap();
    let volume = load(&path).unwrap();
    assert_eq!(
        volume.orientation,
        Orientation::Reoriented {
            stored: "LAS".into()
        }
    );
    let stored = pattern(dims);
    assert_eq!(volume.value(0, 0, 0).unwrap(), stored[3] * 2.0 - 10.0);
    assert_eq!(
        volume.value(3, 2, 1).unwrap(),
        stored[dims[0] * (2 + dims[1])] * 2.0 - 10.0
    );
}

#[test]
fn nrrd_attached_and_detached_raw_gzip_ascii_both_endians_every_type() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [6, 2, 5];
    let ascii: String = pattern(dims).iter().map(|v| format!("{v} ")).collect();
    for voxel_type in VoxelType::ALL {
        for endian in [Endian::Little, Endian::Big] {
            for encoding in [NrrdEncoding::Raw, NrrdEncoding::Gzip, NrrdEncoding::Ascii] {
                let spec = NrrdSpec {
                    type_name: nrrd_type_name(voxel_type),
                    sizes: &dims,
                    encoding,
                    endian,
                    extra: &["spacings: 0.5 1.5 3"],
                };
                let raw = pattern_bytes(voxel_type, dims, endian);
                let stem = format!("n-{}-{endian:?}-{encoding:?}", voxel_type.name());
                let attached = dir.path().join(format!("{stem}.nrrd"));
                write_nrrd(&attached, &spec, &raw, &ascii);
                let detached = dir.path().join(format!("{stem}.nhdr"));
                write_nhdr(&detached, &format!("{stem}.data"), &spec, &raw, &ascii);
                for path in [attached, detached] {
                    let volume = load(&path).unwrap_or_else(|e| panic!("{e}"));
                    assert_eq!(volume.voxel_type(), voxel_type, "{}", path.display());
                    assert_eq!(volume.spacing, [0.5, 1.5, 3.0]);
                    assert_pattern(&volume, dims);
                }
            }
        }
    }
}

#[test]
fn nrrd_space_directions_give_spacing_and_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [3, 4, 2];
    let spec = NrrdSpec {
        type_name: "short",
        sizes: &dims,
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &[
            "space: left-posterior-superior",
            "space directions: (0.8,0,0) (0,0.8,0) (0,0,2.5)",
        ],
    };
    let path = dir.path().join("lps.nrrd");
    write_nrrd(
        &path,
        &spec,
        &pattern_bytes(VoxelType::I16, dims, Endian::Little),
        "",
    );
    let volume = load(&path).unwrap();
    // LPS: +x is left and +y posterior, so both flip to reach RAS.
    assert_eq!(
        volume.orientation,
        Orientation::Reoriented {
            stored: "LPS".into()
        }
    );
    assert_eq!(volume.spacing, [0.8, 0.8, 2.5]);
    let stored = pattern(dims);
    assert_eq!(volume.value(0, 0, 0).unwrap(), stored[2 + 3 * 3]);
}

#[test]
fn nrrd_four_dimensional_with_a_unit_axis_and_byte_skip() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [4, 3, 2];
    let spec = NrrdSpec {
        type_name: "uint8",
        sizes: &[1, 4, 3, 2],
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &["byte skip: 3"],
    };
    let mut raw = vec![0xEE; 3];
    raw.extend(pattern_bytes(VoxelType::U8, dims, Endian::Little));
    let path = dir.path().join("skip.nrrd");
    write_nrrd(&path, &spec, &raw, "");
    assert_pattern(&load(&path).unwrap(), dims);
}

#[test]
fn raw_files_with_a_given_layout() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [7, 3, 4];
    for (layout, voxel_type, endian) in [
        ("7x3x4:u8", VoxelType::U8, Endian::Little),
        ("7x3x4:i16:be", VoxelType::I16, Endian::Big),
        ("7x3x4:f32", VoxelType::F32, Endian::Little),
        ("7x3x4:f64:le", VoxelType::F64, Endian::Little),
    ] {
        let path = dir.path().join(format!("{}.raw", layout.replace(':', "_")));
        std::fs::write(&path, pattern_bytes(voxel_type, dims, endian)).unwrap();
        let volume = load_raw(&path, layout).unwrap();
        assert_eq!(volume.voxel_type(), voxel_type);
        assert_pattern(&volume, dims);
    }
}

#[test]
fn synthetic_volumes_of_every_kind() {
    for kind in voxscope_volume::SyntheticKind::ALL {
        let spec = format!("synthetic:{}:9x5x7", kind.name());
        let volume = voxscope_volume::load(&spec, &LoadOptions::default()).unwrap();
        assert_eq!(volume.dims, [9, 5, 7]);
        let range = QuantizedVolume::new(&volume).value_range;
        assert!(range[1] > range[0], "{spec} is not constant");
    }
    assert!(
        voxscope_volume::load("synthetic:plasma:8", &LoadOptions::default())
            .unwrap_err()
            .to_string()
            .contains("unknown synthetic kind")
    );
}

// ---- bad input --------------------------------------------------------------------------

/// The error names the file, says `problem_part`, is one line, and came quickly.
fn assert_clean_error(path: &Path, result: Result<Volume, String>, problem_part: &str) {
    let error = result
        .err()
        .unwrap_or_else(|| panic!("{} loaded but should not", path.display()));
    assert!(
        error.starts_with(path.to_str().unwrap()),
        "names the file: {error}"
    );
    assert!(
        error.contains(problem_part),
        "expected '{problem_part}' in: {error}"
    );
    assert!(!error.contains('\n'), "one line: {error}");
}

#[test]
fn bad_files_give_one_line_errors_and_stay_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    let good_header = |dims: [usize; 3], datatype: i16| {
        nifti_bytes(
            &NiftiSpec {
                dims,
                datatype,
                spacing: [1.0; 3],
                slope: 1.0,
                intercept: 0.0,
                sform: None,
                endian: Endian::Little,
            },
            &[],
        )
    };

    std::fs::write(path("empty.nii"), b"").unwrap();
    assert_clean_error(
        &path("empty.nii"),
        load(&path("empty.nii")),
        "file is empty",
    );

    let noise: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    std::fs::write(path("noise.nii"), &noise).unwrap();
    assert_clean_error(
        &path("noise.nii"),
        load(&path("noise.nii")),
        "not a NIfTI-1 file",
    );
    std::fs::write(path("noise.bin"), &noise).unwrap();
    assert_clean_error(
        &path("noise.bin"),
        load(&path("noise.bin")),
        "unrecognized format",
    );
    std::fs::write(path("noise.nrrd"), &noise).unwrap();
    assert_clean_error(&path("noise.nrrd"), load(&path("noise.nrrd")), "NRRD");

    // Truncated: the header promises 16³ bytes, the file has 100.
    let mut truncated = good_header([16, 16, 16], 2);
    truncated.extend(vec![7u8; 100]);
    std::fs::write(path("truncated.nii"), &truncated).unwrap();
    assert_clean_error(
        &path("truncated.nii"),
        load(&path("truncated.nii")),
        "truncated",
    );
    std::fs::write(path("truncated.nii.gz"), gzip(&truncated)).unwrap();
    assert_clean_error(
        &path("truncated.nii.gz"),
        load(&path("truncated.nii.gz")),
        "truncated",
    );
    std::fs::write(path("short-header.nii"), &truncated[..200]).unwrap();
    assert_clean_error(
        &path("short-header.nii"),
        load(&path("short-header.nii")),
        "too short",
    );

    // Sizes disagree with the data (NRRD says 10³ shorts, holds 10).
    let spec = NrrdSpec {
        type_name: "short",
        sizes: &[10, 10, 10],
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &[],
    };
    write_nrrd(&path("mismatch.nrrd"), &spec, &[0u8; 20], "");
    assert_clean_error(
        &path("mismatch.nrrd"),
        load(&path("mismatch.nrrd")),
        "need 2000 bytes",
    );
    let spec = NrrdSpec {
        type_name: "short",
        sizes: &[10, 10],
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &["dimension: 3"],
    };
    write_nrrd(&path("dimension.nrrd"), &spec, &[0u8; 200], "");
    assert_clean_error(
        &path("dimension.nrrd"),
        load(&path("dimension.nrrd")),
        "'sizes' has 2 entries",
    );

    // Absurd dimensions: rejected before anything of that size is allocated.
    let started = std::time::Instant::now();
    let absurd = NrrdSpec {
        type_name: "float",
        sizes: &[100000, 100000, 100000],
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &[],
    };
    write_nrrd(&path("absurd.nrrd"), &absurd, &[0u8; 64], "");
    assert_clean_error(
        &path("absurd.nrrd"),
        load(&path("absurd.nrrd")),
        "exceed the limit",
    );
    write_nrrd(
        &path("absurd-gz.nrrd"),
        &NrrdSpec {
            encoding: NrrdEncoding::Gzip,
            sizes: &[4000, 4000, 200],
            ..absurd
        },
        &[0u8; 64],
        "",
    );
    assert_clean_error(
        &path("absurd-gz.nrrd"),
        load(&path("absurd-gz.nrrd")),
        "gzip stream cannot hold",
    );
    let mut big = good_header([30000, 30000, 1000], 16);
    big.extend([0u8; 64]);
    std::fs::write(path("absurd.nii"), big).unwrap();
    assert_clean_error(
        &path("absurd.nii"),
        load(&path("absurd.nii")),
        "exceed the limit",
    );
    assert!(
        started.elapsed().as_secs_f64() < 1.0,
        "absurd sizes took {:?}",
        started.elapsed()
    );

    // Unknown types.
    let mut unknown = good_header([2, 2, 2], 1234);
    unknown.extend([0u8; 64]);
    std::fs::write(path("unknown.nii"), unknown).unwrap();
    assert_clean_error(
        &path("unknown.nii"),
        load(&path("unknown.nii")),
        "unknown NIfTI datatype 1234",
    );
    let spec = NrrdSpec {
        type_name: "quaternion",
        sizes: &[2, 2, 2],
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &[],
    };
    write_nrrd(&path("unknown.nrrd"), &spec, &[0u8; 64], "");
    assert_clean_error(
        &path("unknown.nrrd"),
        load(&path("unknown.nrrd")),
        "type 'quaternion' is not supported",
    );

    // Missing detached data file.
    std::fs::write(
        path("lonely.nhdr"),
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: gone.raw\n",
    )
    .unwrap();
    assert_clean_error(
        &path("lonely.nhdr"),
        load(&path("lonely.nhdr")),
        "NRRD data file 'gone.raw' does not exist",
    );

    // A directory, and a path that does not exist.
    std::fs::create_dir(path("folder.nii")).unwrap();
    assert_clean_error(
        &path("folder.nii"),
        load(&path("folder.nii")),
        "is a folder without slice images",
    );
    assert_clean_error(
        &path("missing.nii"),
        load(&path("missing.nii")),
        "No such file",
    );

    // Raw layout that does not match the file.
    std::fs::write(path("wrong.raw"), [0u8; 100]).unwrap();
    assert_clean_error(
        &path("wrong.raw"),
        load_raw(&path("wrong.raw"), "10x10x10:u8"),
        "need 1000 bytes of voxel data but the file holds only 100",
    );

    // Nothing was changed or deleted.
    assert_eq!(std::fs::read(path("noise.nii")).unwrap(), noise);
    assert_eq!(std::fs::read(path("truncated.nii")).unwrap(), truncated);
}

// ---- the format table -------------------------------------------------------------------

/// Rows of the README's Formats table that are not file formats of the table (a folder of
/// slices, `--raw`, `synthetic:`), and file names the README mentions beside a format's own
/// (`.img`: the data file of a `.hdr`, opened through it; `.png`: slices).
const README_ROWS_NOT_IN_THE_TABLE: [&str; 3] = ["slices", "raw", "synthetic"];
const README_COMPANION_EXTENSIONS: [&str; 2] = [".img", ".png"];

#[test]
fn the_readme_formats_table_matches_the_format_table() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md"))
            .expect("README.md");
    let section = readme
        .split("\n## Formats\n")
        .nth(1)
        .and_then(|rest| rest.split("\n## ").next())
        .expect("a Formats section");
    // Rows `| format | files | notes |`, after the header and the `|---|` line.
    let rows: Vec<Vec<&str>> = section
        .lines()
        .filter(|line| line.starts_with('|'))
        .skip(2)
        .map(|line| line.trim_matches('|').split(" | ").map(str::trim).collect())
        .collect();
    assert!(
        rows.len() >= voxscope_volume::format::FORMATS.len(),
        "{rows:?}"
    );
    let backticked = |cell: &str| -> Vec<String> {
        cell.split('`')
            .skip(1)
            .step_by(2)
            .filter(|token| token.starts_with('.'))
            .map(str::to_owned)
            .collect()
    };
    for format in &voxscope_volume::format::FORMATS {
        let row = rows
            .iter()
            .find(|row| row[0] == format.name || row[0].starts_with(&format!("{} ", format.name)))
            .unwrap_or_else(|| panic!("README's Formats table has no row for {}", format.name));
        let listed = backticked(row[1]);
        for extension in format.extensions {
            assert!(
                listed.iter().any(|l| l == extension),
                "README's {} row lacks `{extension}`",
                format.name
            );
        }
        for extension in &listed {
            assert!(
                format.extensions.contains(&extension.as_str())
                    || README_COMPANION_EXTENSIONS.contains(&extension.as_str()),
                "README's {} row lists `{extension}`, which the format table does not read",
                format.name
            );
        }
    }
    for row in &rows {
        let known = voxscope_volume::format::FORMATS
            .iter()
            .any(|f| row[0] == f.name || row[0].starts_with(&format!("{} ", f.name)));
        assert!(
            known || README_ROWS_NOT_IN_THE_TABLE.contains(&row[0]),
            "README's Formats row '{}' is not in the format table",
            row[0]
        );
    }
}

#[test]
fn an_unrecognized_file_lists_every_format_of_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mystery.bin");
    std::fs::write(&path, b"neither header nor magic").unwrap();
    let error = load(&path).unwrap_err();
    assert!(error.contains("unrecognized format"), "{error}");
    for format in &voxscope_volume::format::FORMATS {
        assert!(error.contains(format.name), "{error} lacks {}", format.name);
        for extension in format.extensions {
            assert!(error.contains(extension), "{error} lacks {extension}");
        }
    }
}

#[test]
fn files_without_an_extension_are_recognized_by_their_magic_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [3, 2, 2];
    let spec = NiftiSpec {
        dims,
        datatype: 2,
        spacing: [1.0; 3],
        slope: 0.0,
        intercept: 0.0,
        sform: None,
        endian: Endian::Little,
    };
    let nifti = dir.path().join("nifti-without-extension");
    std::fs::write(
        &nifti,
        gzip(&nifti_bytes(
            &spec,
            &pattern_bytes(VoxelType::U8, dims, Endian::Little),
        )),
    )
    .unwrap();
    assert_eq!(load(&nifti).unwrap().format, "NIfTI-1");
    let nrrd = dir.path().join("nrrd-without-extension");
    write_nrrd(
        &nrrd,
        &NrrdSpec {
            type_name: "uchar",
            sizes: &dims,
            encoding: NrrdEncoding::Raw,
            endian: Endian::Little,
            extra: &[],
        },
        &pattern_bytes(VoxelType::U8, dims, Endian::Little),
        "",
    );
    assert_eq!(load(&nrrd).unwrap().format, "NRRD");
}

// ---- hostile headers: bounded time, readable messages -----------------------------------

/// A small valid NRRD header (u8, 4×3×2, raw) with `extra` lines, and its payload.
fn nrrd_with(dir: &Path, name: &str, extra: &[&str]) -> std::path::PathBuf {
    let path = dir.join(name);
    write_nrrd(
        &path,
        &NrrdSpec {
            type_name: "uchar",
            sizes: &[4, 3, 2],
            encoding: NrrdEncoding::Raw,
            endian: Endian::Little,
            extra,
        },
        &[7u8; 24],
        "",
    );
    path
}

#[test]
fn a_huge_nrrd_line_skip_ends_at_the_end_of_the_file_and_says_line_skip() {
    let dir = tempfile::tempdir().unwrap();
    for skip in ["1000000000", "9223372036854775807", "18446744073709551615"] {
        let line = format!("line skip: {skip}");
        let path = nrrd_with(dir.path(), "skip.nrrd", &[&line]);
        let started = std::time::Instant::now();
        let error = load(&path).unwrap_err();
        assert!(started.elapsed().as_secs_f64() < 1.0, "{skip}");
        assert_clean_error(
            &path,
            Err(error.clone()),
            &format!("line skip {skip}: the data ends after"),
        );
        assert!(!error.contains("byte skip"), "{error}");
    }
    let path = nrrd_with(
        dir.path(),
        "skip.nrrd",
        &["line skip: 99999999999999999999"],
    );
    assert_clean_error(
        &path,
        load(&path),
        "NRRD line skip '99999999999999999999' is too large",
    );
}

#[test]
fn control_bytes_from_a_file_are_escaped_and_long_values_shortened() {
    let dir = tempfile::tempdir().unwrap();
    let path = nrrd_with(dir.path(), "escape.nrrd", &[]);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("endian: little", "endian: \u{1b}[31mred\u{7}");
    std::fs::write(&path, text).unwrap();
    assert_clean_error(
        &path,
        load(&path),
        "NRRD endian '\\x1b[31mred\\x07' is not little or big",
    );

    let long = format!("type: {}", "x".repeat(5000));
    let path = nrrd_with(dir.path(), "long.nrrd", &[&long]);
    let error = load(&path).unwrap_err();
    assert!(error.len() < 200, "{error}");
    assert_clean_error(
        &path,
        Err(error),
        "… (4940 more characters)' is not supported",
    );
}

#[test]
fn overflowing_numbers_are_too_large_not_unreadable() {
    let dir = tempfile::tempdir().unwrap();
    let path = nrrd_with(dir.path(), "dimension.nrrd", &[]);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("dimension: 3", "dimension: 18446744073709551616");
    std::fs::write(&path, text).unwrap();
    assert_clean_error(
        &path,
        load(&path),
        "NRRD dimension '18446744073709551616' is too large",
    );

    let path = nrrd_with(dir.path(), "sizes.nrrd", &[]);
    let digits = "9".repeat(300);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("sizes: 4 3 2", &format!("sizes: 4 {digits} 2"));
    std::fs::write(&path, text).unwrap();
    assert_clean_error(
        &path,
        load(&path),
        "entry '9999999999999999… (300 digits)' is too large",
    );

    // NIfTI's vox_offset as f32::MAX: 3.4e38, not 39 digits.
    let mut bytes = nifti_bytes(
        &NiftiSpec {
            dims: [2, 2, 2],
            datatype: 2,
            spacing: [1.0; 3],
            slope: 0.0,
            intercept: 0.0,
            sform: None,
            endian: Endian::Little,
        },
        &[0; 8],
    );
    bytes[108..112].copy_from_slice(&f32::MAX.to_le_bytes());
    let path = dir.path().join("offset.nii");
    std::fs::write(&path, bytes).unwrap();
    assert_clean_error(
        &path,
        load(&path),
        "NIfTI vox_offset 3.4028234663852886e38 is too large",
    );
}

#[test]
fn folders_and_devices_are_named_as_such_not_as_missing() {
    let dir = tempfile::tempdir().unwrap();
    let path = nrrd_with(dir.path(), "folder-data.nhdr", &[]);
    let text = std::fs::read_to_string(&path).unwrap();
    let header = text.split("\n\n").next().unwrap();
    std::fs::write(&path, format!("{header}\ndata file: .\n")).unwrap();
    assert_clean_error(
        &path,
        load(&path),
        "NRRD data file '.' is a folder, not a file",
    );
    std::fs::write(&path, format!("{header}\ndata file: /dev/zero\n")).unwrap();
    assert_clean_error(
        &path,
        load(&path),
        "NRRD data file '/dev/zero' is a device, not a file",
    );

    // Opened directly: a device is refused before anything reads it (it would never end).
    let device = Path::new("/dev/zero");
    let started = std::time::Instant::now();
    assert_clean_error(device, load(device), "is a device, not a file");
    assert!(started.elapsed().as_secs_f64() < 1.0);

    // A NIfTI pair whose .img is a folder.
    let header = nifti_bytes(
        &NiftiSpec {
            dims: [2, 2, 2],
            datatype: 2,
            spacing: [1.0; 3],
            slope: 0.0,
            intercept: 0.0,
            sform: None,
            endian: Endian::Little,
        },
        &[],
    );
    let mut pair = header[..348].to_vec();
    pair[108..112].copy_from_slice(&0f32.to_le_bytes());
    pair[344..348].copy_from_slice(b"ni1\0");
    let hdr = dir.path().join("pair.hdr");
    std::fs::write(&hdr, pair).unwrap();
    std::fs::create_dir(dir.path().join("pair.img")).unwrap();
    assert_clean_error(&hdr, load(&hdr), "pair.img, which is a folder, not a file");
}
