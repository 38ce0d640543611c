//! Writers for the loader tests and the fuzzer's seeds: NIfTI-1, NRRD, TIFF, MRC, VTK
//! ImageData and DICOM files in the variants voxscope reads.

use std::io::Write;
use std::path::Path;

use dicom_core::value::{PixelFragmentSequence, Value};
use dicom_core::{DataElement, PrimitiveValue, VR, dicom_value};
use dicom_dictionary_std::tags;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use flate2::Compression;
use flate2::write::{GzEncoder, ZlibEncoder};
use tiff::encoder::{Rational, TiffEncoder, TiffValue, colortype};
use tiff::tags::Tag;
use voxscope_volume::{Endian, NrrdEncoding, Scalar, VoxelType};

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
    std::fs::write(path, nrrd_bytes(spec, raw, ascii)).unwrap();
}

/// A detached `.nhdr` with its data file `data_name` beside it.
pub fn write_nhdr(path: &Path, data_name: &str, spec: &NrrdSpec, raw: &[u8], ascii: &str) {
    let (header, data) = nhdr_bytes(data_name, spec, raw, ascii);
    std::fs::write(path, header).unwrap();
    std::fs::write(path.with_file_name(data_name), data).unwrap();
}

/// The bytes of an attached-header `.nrrd` file.
pub fn nrrd_bytes(spec: &NrrdSpec, raw: &[u8], ascii: &str) -> Vec<u8> {
    let mut bytes = nrrd_header(spec, None).into_bytes();
    bytes.push(b'\n');
    bytes.extend(encoded_payload(spec, raw, ascii));
    bytes
}

/// The header and data file of a detached `.nhdr` naming `data_name`.
pub fn nhdr_bytes(data_name: &str, spec: &NrrdSpec, raw: &[u8], ascii: &str) -> (Vec<u8>, Vec<u8>) {
    (
        nrrd_header(spec, Some(data_name)).into_bytes(),
        encoded_payload(spec, raw, ascii),
    )
}

// ---- TIFF -----------------------------------------------------------------------------------

/// A TIFF stack of `pages` pages of `width`×`height`, voxel (x, y, z) = `value(x, y, z)`, with
/// an optional ImageDescription and resolution (pixels per unit) on the first page.
pub fn tiff_stack<C: colortype::ColorType>(
    [width, height, pages]: [u32; 3],
    description: Option<&str>,
    resolution: Option<f64>,
    compression: tiff::encoder::Compression,
    value: impl Fn(u32, u32, u32) -> C::Inner,
) -> Vec<u8>
where
    [C::Inner]: TiffValue,
{
    let mut file = std::io::Cursor::new(Vec::new());
    let mut encoder = TiffEncoder::new(&mut file)
        .expect("encoder")
        .with_compression(compression);
    for z in 0..pages {
        let mut image = encoder.new_image::<C>(width, height).expect("page");
        if z == 0 {
            if let Some(text) = description {
                image
                    .encoder()
                    .write_tag(Tag::ImageDescription, text)
                    .expect("description");
            }
            if let Some(per_unit) = resolution {
                let value = Rational {
                    n: (per_unit * 1000.0).round() as u32,
                    d: 1000,
                };
                image.x_resolution(value.clone());
                image.y_resolution(value);
            }
        }
        let data: Vec<C::Inner> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| value(x, y, z))
            .collect();
        image.write_data(&data).expect("write page");
    }
    file.into_inner()
}

// ---- MRC ------------------------------------------------------------------------------------

/// What goes into a test MRC map; the stored value of voxel n (in stored order) is `n % 100`.
pub struct MrcMap {
    pub dims: [i32; 3],
    pub mode: i32,
    pub big_endian: bool,
    pub axis_order: [i32; 3],
    pub cell: [f32; 3],
    pub extended: Vec<u8>,
}

impl MrcMap {
    /// A little-endian map in x, y, z order, voxel size 1.5 × 1.5 × 2 Å.
    pub fn new(dims: [i32; 3], mode: i32) -> Self {
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

    /// The file bytes.
    pub fn bytes(&self) -> Vec<u8> {
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

// ---- VTK ImageData --------------------------------------------------------------------------

/// Points of the test `.vti` files.
pub const VTI_DIMS: [usize; 3] = [5, 4, 3];

/// The Float32 values of the test `.vti` files.
pub fn vti_values() -> Vec<f32> {
    (0..60).map(|i| i as f32 * 0.5 - 3.0).collect()
}

/// One header word of a VTK binary array (`UInt32` or `UInt64`, either byte order).
pub fn vti_word(value: usize, header64: bool, big: bool) -> Vec<u8> {
    match (header64, big) {
        (true, false) => (value as u64).to_le_bytes().to_vec(),
        (true, true) => (value as u64).to_be_bytes().to_vec(),
        (false, false) => (value as u32).to_le_bytes().to_vec(),
        (false, true) => (value as u32).to_be_bytes().to_vec(),
    }
}

/// The data block (header, data) of the Float32 values, as VTK lays it out: one byte-count
/// word, or zlib blocks of `block_size` bytes after `[blocks, block size, last size, sizes…]`.
pub fn vti_block(
    header64: bool,
    big: bool,
    compressed: bool,
    block_size: usize,
) -> (Vec<u8>, Vec<u8>) {
    let data: Vec<u8> = vti_values()
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
        return (vti_word(data.len(), header64, big), data);
    }
    let chunks: Vec<Vec<u8>> = data.chunks(block_size).map(zlib).collect();
    let mut header = vti_word(chunks.len(), header64, big);
    header.extend(vti_word(block_size, header64, big));
    header.extend(vti_word(
        data.len() - (chunks.len() - 1) * block_size,
        header64,
        big,
    ));
    for chunk in &chunks {
        header.extend(vti_word(chunk.len(), header64, big));
    }
    (header, chunks.concat())
}

/// zlib-compressed `bytes` (VTK's compressor).
pub fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = ZlibEncoder::new(Vec::new(), Compression::default());
    encoder.write_all(bytes).unwrap();
    encoder.finish().unwrap()
}

/// The XML up to the `<PointData>` that holds the test arrays.
pub fn vti_header(header64: bool, big: bool, compressed: bool) -> String {
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

/// What closes the test `.vti` files' `<ImageData>` (before `<AppendedData>` or the end).
pub const VTI_FOOTER: &str = "      </PointData>\n    </Piece>\n  </ImageData>\n";

// ---- DICOM ----------------------------------------------------------------------------------

/// Rows, columns and frames of the written multi-frame DICOM files.
pub const DICOM_ROWS: u16 = 6;
pub const DICOM_COLUMNS: u16 = 8;
pub const DICOM_FRAMES: usize = 3;

/// The stored value of pixel `n` of the written DICOM files.
pub fn dicom_pixel(n: usize) -> i16 {
    (n as i16 % 300) - 100
}

/// A signed 16-bit CT object of `DICOM_FRAMES` frames with the pixel data `samples`.
pub fn dicom_object(samples: Value<InMemDicomObject>, vr: VR) -> InMemDicomObject {
    let mut object = InMemDicomObject::new_empty();
    let mut put = |tag, vr, value: PrimitiveValue| object.put(DataElement::new(tag, vr, value));
    put(
        tags::SOP_CLASS_UID,
        VR::UI,
        dicom_value!(Str, "1.2.840.10008.5.1.4.1.1.4"),
    );
    put(
        tags::SOP_INSTANCE_UID,
        VR::UI,
        dicom_value!(Str, "1.2.3.4.5.6"),
    );
    put(
        tags::SERIES_INSTANCE_UID,
        VR::UI,
        dicom_value!(Str, "1.2.3.4.5"),
    );
    put(tags::MODALITY, VR::CS, dicom_value!(Str, "CT"));
    put(tags::SAMPLES_PER_PIXEL, VR::US, dicom_value!(U16, [1]));
    put(
        tags::PHOTOMETRIC_INTERPRETATION,
        VR::CS,
        dicom_value!(Str, "MONOCHROME2"),
    );
    put(
        tags::NUMBER_OF_FRAMES,
        VR::IS,
        dicom_value!(Str, DICOM_FRAMES.to_string()),
    );
    put(tags::ROWS, VR::US, dicom_value!(U16, [DICOM_ROWS]));
    put(tags::COLUMNS, VR::US, dicom_value!(U16, [DICOM_COLUMNS]));
    put(tags::BITS_ALLOCATED, VR::US, dicom_value!(U16, [16]));
    put(tags::BITS_STORED, VR::US, dicom_value!(U16, [16]));
    put(tags::HIGH_BIT, VR::US, dicom_value!(U16, [15]));
    put(tags::PIXEL_REPRESENTATION, VR::US, dicom_value!(U16, [1]));
    put(
        tags::PIXEL_SPACING,
        VR::DS,
        dicom_value!(Strs, ["0.5", "0.25"]),
    );
    put(tags::SLICE_THICKNESS, VR::DS, dicom_value!(Str, "2.5"));
    put(tags::RESCALE_SLOPE, VR::DS, dicom_value!(Str, "2"));
    put(tags::RESCALE_INTERCEPT, VR::DS, dicom_value!(Str, "-1024"));
    object.put(DataElement::new(tags::PIXEL_DATA, vr, samples));
    object
}

/// The native (uncompressed) pixel data of the written files.
pub fn dicom_native_pixels() -> Value<InMemDicomObject> {
    let count = DICOM_FRAMES * (DICOM_ROWS * DICOM_COLUMNS) as usize;
    let values: Vec<i16> = (0..count).map(dicom_pixel).collect();
    PrimitiveValue::I16(values.into()).into()
}

/// The pixel data of the written files as RLE Lossless fragments, one per frame.
pub fn dicom_rle_pixels() -> Value<InMemDicomObject> {
    let per_frame = (DICOM_ROWS * DICOM_COLUMNS) as usize;
    let values: Vec<i16> = (0..DICOM_FRAMES * per_frame).map(dicom_pixel).collect();
    let fragments: Vec<Vec<u8>> = values
        .chunks(per_frame)
        .map(|frame| {
            let high = pack_bits(
                &frame
                    .iter()
                    .map(|v| (*v as u16 >> 8) as u8)
                    .collect::<Vec<_>>(),
            );
            let low = pack_bits(&frame.iter().map(|v| *v as u16 as u8).collect::<Vec<_>>());
            let mut fragment = vec![0u8; 64];
            fragment[0..4].copy_from_slice(&2u32.to_le_bytes());
            fragment[4..8].copy_from_slice(&64u32.to_le_bytes());
            fragment[8..12].copy_from_slice(&(64 + high.len() as u32).to_le_bytes());
            fragment.extend(high);
            fragment.extend(low);
            if fragment.len() % 2 == 1 {
                fragment.push(0);
            }
            fragment
        })
        .collect();
    Value::from(PixelFragmentSequence::new(Vec::<u32>::new(), fragments))
}

/// The bytes of a DICOM file (preamble, `DICM`, meta group, data set) in `syntax`.
pub fn dicom_bytes(object: InMemDicomObject, syntax: &str) -> Vec<u8> {
    let mut bytes = Vec::new();
    object
        .with_meta(FileMetaTableBuilder::new().transfer_syntax(syntax))
        .unwrap()
        .write_all(&mut bytes)
        .unwrap();
    bytes
}

/// PackBits (RLE Lossless segments) with literal and replicate runs.
pub fn pack_bits(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let run = bytes[i..]
            .iter()
            .take(128)
            .take_while(|&&b| b == bytes[i])
            .count();
        if run >= 3 {
            out.push((1 - run as i32) as i8 as u8);
            out.push(bytes[i]);
            i += run;
        } else {
            let count = (bytes.len() - i).min(2);
            out.push((count - 1) as u8);
            out.extend(&bytes[i..i + count]);
            i += count;
        }
    }
    out
}
