//! VTK XML ImageData: every encoding ParaView writes (ascii, base64 binary, appended raw and
//! base64; zlib or not; 32- and 64-bit headers; both byte orders), and broken files.

use std::io::Write;
use std::path::Path;

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD;
use voxscope::volume::{self, LoadOptions, VoxelType};

const DIMS: [usize; 3] = [5, 4, 3];

fn values() -> Vec<f32> {
    (0..60).map(|i| i as f32 * 0.5 - 3.0).collect()
}

fn word(value: usize, header64: bool, big: bool) -> Vec<u8> {
    match (header64, big) {
        (true, false) => (value as u64).to_le_bytes().to_vec(),
        (true, true) => (value as u64).to_be_bytes().to_vec(),
        (false, false) => (value as u32).to_le_bytes().to_vec(),
        (false, true) => (value as u32).to_be_bytes().to_vec(),
    }
}

/// The data block (header + data) of the Float32 values, as VTK lays it out.
fn block(header64: bool, big: bool, compressed: bool, block_size: usize) -> (Vec<u8>, Vec<u8>) {
    let data: Vec<u8> = values()
        .iter()
        .flat_map(|v| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        })
        .collect();
    if !compressed {
        return (word(data.len(), header64, big), data);
    }
    let chunks: Vec<Vec<u8>> = data
        .chunks(block_size)
        .map(|chunk| {
            let mut encoder =
                flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            encoder.write_all(chunk).unwrap();
            encoder.finish().unwrap()
        })
        .collect();
    let mut header = word(chunks.len(), header64, big);
    header.extend(word(block_size, header64, big));
    header.extend(word(
        data.len() - (chunks.len() - 1) * block_size,
        header64,
        big,
    ));
    for chunk in &chunks {
        header.extend(word(chunk.len(), header64, big));
    }
    (header, chunks.concat())
}

fn vtk_header(header64: bool, big: bool, compressed: bool) -> String {
    format!(
        r#"<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="{}" header_type="{}"{}>
  <ImageData WholeExtent="0 4 0 3 0 2" Origin="0 0 0" Spacing="0.5 0.75 2">
    <Piece Extent="0 4 0 3 0 2">
      <PointData Scalars="density">
"#,
        if big { "BigEndian" } else { "LittleEndian" },
        if header64 { "UInt64" } else { "UInt32" },
        if compressed {
            r#" compressor="vtkZLibDataCompressor""#
        } else {
            ""
        },
    )
}

const FOOTER: &str = "      </PointData>\n    </Piece>\n  </ImageData>\n";

fn check(path: &Path) {
    let volume = volume::load(&path.display().to_string(), &LoadOptions::default())
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
            "Int64 is not supported",
        ),
    ];
    for (name, content, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, &content).unwrap();
        let Err(error) = volume::load(&path.display().to_string(), &LoadOptions::default()) else {
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
