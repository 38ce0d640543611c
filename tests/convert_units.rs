//! `convert` writes values in the data's units: a NIfTI's scl_slope/scl_inter or a DICOM
//! series' rescale is applied, into an integer type where it maps the stored integers exactly
//! (a CT's Hounsfield units as i16), else into f32; `info` of the output shows the input's
//! value range.

mod support;

use std::path::Path;
use std::process::{Command, Output};

use dicom_core::VR;
use support::writers::{
    NiftiSpec, dicom_bytes, dicom_native_pixels, dicom_object, encode, nifti_bytes, nifti_datatype,
};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};
use voxscope_volume::{Endian, LoadOptions, VoxelType};

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Converts `input` to `output` (0.4, small chunks) and returns convert's stderr.
fn convert(input: &Path, output: &Path) -> String {
    let out = voxscope(&[
        "convert",
        input.to_str().unwrap(),
        output.to_str().unwrap(),
        "--chunk",
        "8",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

/// The input as voxscope loads it (in its units) and the output's level 0, voxel by voxel.
fn assert_output_in_units(input: &Path, output: &Path, want_type: VoxelType) {
    let volume = voxscope_volume::load(input.to_str().unwrap(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let pyramid =
        Pyramid::open(output, PyramidOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(pyramid.voxel_type, want_type, "{}", output.display());
    assert_eq!(pyramid.levels[0].dims, volume.dims);
    let written = pyramid.read_level(0).unwrap();
    let scale = volume.value_scale;
    for i in 0..volume.data.len() {
        let want = scale.apply(volume.data.get(i).unwrap());
        let got = written.get(i).unwrap();
        assert!(
            (got - want).abs() <= want.abs() * 1e-6,
            "{} voxel {i}: {got}, want {want}",
            output.display()
        );
    }
}

/// `info`'s value range line of `path`.
fn info_range(path: &Path) -> String {
    let out = voxscope(&["info", path.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
        .lines()
        .find(|l| l.starts_with("value range"))
        .unwrap_or_else(|| panic!("no value range in {stdout}"))
        .to_owned()
}

fn write_nifti(path: &Path, values: &[u16], dims: [usize; 3], slope: f32, intercept: f32) {
    let spec = NiftiSpec {
        dims,
        datatype: nifti_datatype(VoxelType::U16),
        spacing: [1.0, 1.0, 2.0],
        slope,
        intercept,
        sform: None,
        endian: Endian::Little,
    };
    std::fs::write(path, nifti_bytes(&spec, &encode(values, Endian::Little))).unwrap();
}

#[test]
fn a_scaled_nifti_converts_into_its_units() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [12, 10, 9];
    // A CT stored as u16 0…4095 with scl_inter −1024: Hounsfield units from −1024.
    let values: Vec<u16> = (0..dims.iter().product::<usize>())
        .map(|i| ((i * 37) % 4096) as u16)
        .collect();
    let ct = dir.path().join("ct.nii");
    write_nifti(&ct, &values, dims, 1.0, -1024.0);
    let out = dir.path().join("ct.ome.zarr");
    let stderr = convert(&ct, &out);
    assert!(
        stderr.contains("stored u16 × 1 + -1024 written as i16"),
        "{stderr}"
    );
    assert_output_in_units(&ct, &out, VoxelType::I16);
    let range = info_range(&ct);
    assert_eq!(range, info_range(&out));
    let high = i64::from(*values.iter().max().unwrap()) - 1024;
    assert_eq!(range, format!("value range  -1024 … {high}"));

    // A slope that is not an integer: float32, the same values.
    let fractional = dir.path().join("fractional.nii");
    write_nifti(&fractional, &values, dims, 0.25, 10.5);
    let out = dir.path().join("fractional.ome.zarr");
    convert(&fractional, &out);
    assert_output_in_units(&fractional, &out, VoxelType::F32);
    assert_eq!(info_range(&fractional), info_range(&out));

    // Without a scale the stored type and values stay.
    let plain = dir.path().join("plain.nii");
    write_nifti(&plain, &values, dims, 1.0, 0.0);
    let out = dir.path().join("plain.ome.zarr");
    let stderr = convert(&plain, &out);
    assert!(!stderr.contains("data's units"), "{stderr}");
    assert_output_in_units(&plain, &out, VoxelType::U16);
}

#[test]
fn a_dicom_series_with_rescale_converts_into_its_units() {
    let dir = tempfile::tempdir().unwrap();
    // Stored i16 −100…199, rescale slope 2 and intercept −1024: −1224…−626 HU, as i16.
    let path = dir.path().join("ct.dcm");
    std::fs::write(
        &path,
        dicom_bytes(
            dicom_object(dicom_native_pixels(), VR::OW),
            "1.2.840.10008.1.2.1",
        ),
    )
    .unwrap();
    let out = dir.path().join("ct.ome.zarr");
    let stderr = convert(&path, &out);
    assert!(
        stderr.contains("stored i16 × 2 + -1024 written as i16"),
        "{stderr}"
    );
    assert_output_in_units(&path, &out, VoxelType::I16);
    assert_eq!(info_range(&path), info_range(&out));
}
