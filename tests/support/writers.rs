//! Writers for the loader tests: NIfTI-1 and NRRD files in every variant voxscope reads.

use std::io::Write;
use std::path::Path;

use flate2::Compression;
use flate2::write::GzEncoder;
use voxscope::volume::{Endian, NrrdEncoding, Scalar, VoxelType};

/// Encodes `values` of type `T` in `endian`.
pub fn encode<T: Scalar>(values: &[T], endian: Endian) -> Vec<u8> {
    values.iter().flat_map(|v| v.encode(endian)).collect()
}

pub fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = GzEncoder::new(Vec::new(), Compression::fast());
    encoder.write_all(bytes).unwrap();
    encoder.finish().unwrap()
}

/// NIfTI datatype code of a voxel type.
pub fn nifti_datatype(voxel_type: VoxelType) -> i16 {
    match voxel_type {
        VoxelType::U8 => 2,
        VoxelType::I16 => 4,
        VoxelType::I32 => 8,
        VoxelType::F32 => 16,
        VoxelType::F64 => 64,
        VoxelType::I8 => 256,
        VoxelType::U16 => 512,
        VoxelType::U32 => 768,
    }
}

/// What goes into a test NIfTI header.
pub struct NiftiSpec {
    pub dims: [usize; 3],
    pub datatype: i16,
    pub spacing: [f32; 3],
    pub slope: f32,
    pub intercept: f32,
    /// Rows of the sform (sform_code 1 when given).
    pub sform: Option<[[f32; 4]; 3]>,
    pub endian: Endian,
}

/// A 348-byte NIfTI-1 header plus 4 extension bytes (vox_offset 352), then `payload`.
pub fn nifti_bytes(spec: &NiftiSpec, payload: &[u8]) -> Vec<u8> {
    let mut header = vec![0u8; 352];
    let put = |h: &mut Vec<u8>, offset: usize, bytes: Vec<u8>| {
        h[offset..offset + bytes.len()].copy_from_slice(&bytes)
    };
    let e = spec.endian;
    put(&mut header, 0, 348i32.encode(e));
    let dim: [i16; 8] = [
        3,
        spec.dims[0] as i16,
        spec.dims[1] as i16,
        spec.dims[2] as i16,
        1,
        1,
        1,
        1,
    ];
    for (i, d) in dim.iter().enumerate() {
        put(&mut header, 40 + 2 * i, d.encode(e));
    }
    put(&mut header, 70, spec.datatype.encode(e));
    put(&mut header, 72, 8i16.encode(e));
    let pixdim = [
        1.0f32,
        spec.spacing[0],
        spec.spacing[1],
        spec.spacing[2],
        1.0,
        1.0,
        1.0,
        1.0,
    ];
    for (i, p) in pixdim.iter().enumerate() {
        put(&mut header, 76 + 4 * i, p.encode(e));
    }
    put(&mut header, 108, 352f32.encode(e));
    put(&mut header, 112, spec.slope.encode(e));
    put(&mut header, 116, spec.intercept.encode(e));
    if let Some(rows) = spec.sform {
        put(&mut header, 254, 1i16.encode(e));
        for (r, row) in rows.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                put(&mut header, 280 + 16 * r + 4 * c, v.encode(e));
            }
        }
    }
    header[344..348].copy_from_slice(b"n+1\0");
    header.extend_from_slice(payload);
    header
}

/// What goes into a test NRRD header.
pub struct NrrdSpec<'a> {
    pub type_name: &'a str,
    pub sizes: &'a [usize],
    pub encoding: NrrdEncoding,
    pub endian: Endian,
    /// Extra header lines (spacings, space directions, …).
    pub extra: &'a [&'a str],
}

fn nrrd_header(spec: &NrrdSpec, data_file: Option<&str>) -> String {
    let sizes: Vec<String> = spec.sizes.iter().map(|s| s.to_string()).collect();
    let mut text = format!(
        "NRRD0004\n# written by voxscope's tests\ntype: {}\ndimension: {}\nsizes: {}\nencoding: {}\nendian: {}\n",
        spec.type_name,
        spec.sizes.len(),
        sizes.join(" "),
        match spec.encoding {
            NrrdEncoding::Raw => "raw",
            NrrdEncoding::Gzip => "gzip",
            NrrdEncoding::Ascii => "ascii",
        },
        match spec.endian {
            Endian::Little => "little",
            Endian::Big => "big",
        }
    );
    for line in spec.extra {
        text.push_str(line);
        text.push('\n');
    }
    if let Some(name) = data_file {
        text.push_str(&format!("data file: {name}\n"));
    }
    text
}

/// Encodes the payload as the spec's encoding wants it (`raw` is already in its byte order).
fn encoded_payload(spec: &NrrdSpec, raw: &[u8], ascii: &str) -> Vec<u8> {
    match spec.encoding {
        NrrdEncoding::Raw => raw.to_vec(),
        NrrdEncoding::Gzip => gzip(raw),
        NrrdEncoding::Ascii => ascii.as_bytes().to_vec(),
    }
}

/// An attached-header `.nrrd` file.
pub fn write_nrrd(path: &Path, spec: &NrrdSpec, raw: &[u8], ascii: &str) {
    let mut bytes = nrrd_header(spec, None).into_bytes();
    bytes.push(b'\n');
    bytes.extend(encoded_payload(spec, raw, ascii));
    std::fs::write(path, bytes).unwrap();
}

/// A detached `.nhdr` with its data file `data_name` beside it.
pub fn write_nhdr(path: &Path, data_name: &str, spec: &NrrdSpec, raw: &[u8], ascii: &str) {
    std::fs::write(path, nrrd_header(spec, Some(data_name))).unwrap();
    std::fs::write(
        path.with_file_name(data_name),
        encoded_payload(spec, raw, ascii),
    )
    .unwrap();
}
