//! VTK XML ImageData: every encoding ParaView writes (ascii, base64 binary, appended raw and
//! base64; zlib or not; 32- and 64-bit headers; both byte orders), and broken files.

mod support;

use std::path::Path;

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD;
use support::writers::{
    VTI_DIMS as DIMS, VTI_FOOTER as FOOTER, vti_block as block, vti_header as vtk_header,
    vti_values as values, vti_word as word,
};
use voxscope_volume::{LoadOptions, VoxelType};

fn check(path: &Path) {
    let volume = voxscope_volume::load(&path.display().to_string(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(volume.format, "VTK ImageData");
    assert_eq!(volume.dims, DIMS);
    assert_eq!(volume.voxel_type(), VoxelType::F32);
    assert_eq!(volume.spacing, [0.5, 0.75, 2.0]);
    for (i, v) in values().iter().enumerate() {
        assert_eq!(
            volume.data.get(i),
            Some(*v as f64),
            "{} voxel {i}",
            path.display()
        );
    }
}

#[test]
fn every_encoding_reads_back_value_for_value() {
    let dir = tempfile::tempdir().unwrap();
    // ascii
    let ascii: Vec<String> = values().iter().map(|v| v.to_string()).collect();
    let text = format!(
        "{}        <DataArray type=\"Float32\" Name=\"density\" format=\"ascii\">\n{}\n        </DataArray>\n{FOOTER}</VTKFile>\n",
        vtk_header(false, false, false),
        ascii.join(" ")
    );
    let path = dir.path().join("ascii.vti");
    std::fs::write(&path, text).unwrap();
    check(&path);

    for header64 in [false, true] {
        for big in [false, true] {
            for compressed in [false, true] {
                let (header, data) = block(header64, big, compressed, 64);
                let tag = format!(
                    "h{}-{}-{}",
                    if header64 { 64 } else { 32 },
                    if big { "be" } else { "le" },
                    if compressed { "zlib" } else { "raw" }
                );
                // Inline base64: compressed arrays encode header and blocks separately.
                let encoded = if compressed {
                    format!("{}{}", STANDARD.encode(&header), STANDARD.encode(&data))
                } else {
                    STANDARD.encode([header.clone(), data.clone()].concat())
                };
                let text = format!(
                    "{}        <DataArray type=\"Float32\" Name=\"density\" format=\"binary\">\n          {encoded}\n        </DataArray>\n{FOOTER}</VTKFile>\n",
                    vtk_header(header64, big, compressed)
                );
                let path = dir.path().join(format!("binary-{tag}.vti"));
                std::fs::write(&path, text).unwrap();
                check(&path);

                // Appended raw, after another (unused) array at offset 0.
                let unused = [word(4, header64, big), vec![0u8; 4]].concat();
                let mut bytes = format!(
                    "{}        <DataArray type=\"Float32\" Name=\"other\" format=\"appended\" offset=\"0\"/>\n        <DataArray type=\"Float32\" Name=\"density\" format=\"appended\" offset=\"{}\"/>\n{FOOTER}  <AppendedData encoding=\"raw\">\n   _",
                    vtk_header(header64, big, false),
                    unused.len()
                )
                .into_bytes();
                if !compressed {
                    bytes.extend(&unused);
                    bytes.extend(&header);
                    bytes.extend(&data);
                    bytes.extend(b"\n  </AppendedData>\n</VTKFile>\n");
                    let path = dir.path().join(format!("appended-{tag}.vti"));
                    std::fs::write(&path, bytes).unwrap();
                    check(&path);
                }
            }
        }
    }

    // Appended raw with zlib blocks, and appended base64.
    let (header, data) = block(false, false, true, 100);
    let mut bytes = format!(
        "{}        <DataArray type=\"Float32\" Name=\"density\" format=\"appended\" offset=\"0\"/>\n{FOOTER}  <AppendedData encoding=\"raw\">\n   _",
        vtk_header(false, false, true)
    )
    .into_bytes();
    bytes.extend(&header);
    bytes.extend(&data);
    bytes.extend(b"\n  </AppendedData>\n</VTKFile>\n");
    let path = dir.path().join("appended-zlib.vti");
    std::fs::write(&path, bytes).unwrap();
    check(&path);

    let (header, data) = block(true, false, false, 0);
    let text = format!(
        "{}        <DataArray type=\"Float32\" Name=\"density\" format=\"appended\" offset=\"0\"/>\n{FOOTER}  <AppendedData encoding=\"base64\">\n   _{}\n  </AppendedData>\n</VTKFile>\n",
        vtk_header(true, false, false),
        STANDARD.encode([header, data].concat())
    );
    let path = dir.path().join("appended-base64.vti");
    std::fs::write(&path, text).unwrap();
    check(&path);
}

#[test]
fn broken_files_fail_in_one_line_and_stay_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let (header, data) = block(false, false, false, 0);
    let good = format!(
        "{}        <DataArray type=\"Float32\" Name=\"density\" format=\"binary\">{}</DataArray>\n{FOOTER}</VTKFile>\n",
        vtk_header(false, false, false),
        STANDARD.encode([header, data].concat())
    );
    let cases = [
        (
            "cut.vti",
            good[..good.len() / 2].to_owned(),
            "not valid VTK XML",
        ),
        (
            "polydata.vti",
            good.replace("type=\"ImageData\"", "type=\"PolyData\""),
            "only ImageData",
        ),
        (
            "vector.vti",
            good.replace(
                "Name=\"density\" format",
                "NumberOfComponents=\"3\" Name=\"density\" format",
            ),
            "has 3 components",
        ),
        (
            "short.vti",
            good.replace(
                "WholeExtent=\"0 4 0 3 0 2\"",
                "WholeExtent=\"0 40 0 30 0 20\"",
            ),
            "expected",
        ),
        (
            "base64.vti",
            good.replace("format=\"binary\">", "format=\"binary\">@@@@"),
            "bad base64",
        ),
        (
            "int64.vti",
            good.replace("type=\"Float32\"", "type=\"Int64\""),
            "array 'density': DataArray type 'Int64' is not supported",
        ),
        // Number errors name the attribute, overflow is "too large", no debug formatting.
        (
            "extent-word.vti",
            good.replace("WholeExtent=\"0 4 0 3 0 2\"", "WholeExtent=\"0 4 0 x 0 2\""),
            "WholeExtent value 'x' is not a number",
        ),
        (
            "spacing-word.vti",
            good.replace("Spacing=\"0.5 0.75 2\"", "Spacing=\"0.5 y 2\""),
            "Spacing value 'y' is not a number",
        ),
        (
            "extent-overflow.vti",
            good.replace(
                "WholeExtent=\"0 4 0 3 0 2\"",
                "WholeExtent=\"-9223372036854775808 9223372036854775807 0 3 0 2\"",
            ),
            "WholeExtent -9223372036854775808, 9223372036854775807, 0, 3 … 2 more is too large",
        ),
        (
            "extent-huge.vti",
            good.replace(
                "WholeExtent=\"0 4 0 3 0 2\"",
                "WholeExtent=\"0 99999999999999999999 0 3 0 2\"",
            ),
            "WholeExtent value '99999999999999999999' is too large",
        ),
        (
            "components.vti",
            good.replace(
                "Name=\"density\" format",
                "NumberOfComponents=\"-1\" Name=\"density\" format",
            ),
            "array 'density': NumberOfComponents '-1' is not a whole number",
        ),
    ];
    for (name, content, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, &content).unwrap();
        let Err(error) =
            voxscope_volume::load(&path.display().to_string(), &LoadOptions::default())
        else {
            panic!("{name} loaded");
        };
        let error = error.to_string();
        assert!(
            error.starts_with(&path.display().to_string()) && !error.contains('\n'),
            "{error}"
        );
        assert!(error.contains(expected), "{name}: {error}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), content);
    }
}
