//! The valid files every case starts from: small files of each format in the variants the
//! loaders read, written by `tests/support/writers.rs`, plus any real files given.

use std::path::Path;

use dicom_core::{DataElement, PrimitiveValue, VR, dicom_value};
use dicom_dictionary_std::tags;
use tiff::encoder::{Compression as TiffCompression, DeflateLevel, colortype};
use voxscope_volume::{Endian, NrrdEncoding};

use super::Kind;
use super::writers::{
    DICOM_FRAMES, MrcMap, NiftiSpec, NrrdSpec, VTI_FOOTER, dicom_bytes, dicom_native_pixels,
    dicom_object, dicom_rle_pixels, gzip, nhdr_bytes, nifti_bytes, nrrd_bytes, tiff_stack,
    vti_block, vti_header, vti_word,
};

/// What a file of a seed is, which decides how it is mutated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A file in the seed's format (header and all).
    Main,
    /// A detached data file (NRRD's data file, NIfTI's `.img`): bytes without structure.
    Data,
}

/// One file of a seed.
#[derive(Debug, Clone)]
pub struct SeedFile {
    pub name: String,
    pub bytes: Vec<u8>,
    pub role: Role,
}

/// A valid input: the files written into an empty folder, and what is opened.
#[derive(Debug, Clone)]
pub struct Seed {
    pub kind: Kind,
    pub name: String,
    pub files: Vec<SeedFile>,
    /// A file name of `files`, or `.` for the folder itself.
    pub open: String,
}

impl Seed {
    fn single(kind: Kind, name: &str, file_name: &str, bytes: Vec<u8>) -> Self {
        Self {
            kind,
            name: name.to_owned(),
            files: vec![SeedFile {
                name: file_name.to_owned(),
                bytes,
                role: Role::Main,
            }],
            open: file_name.to_owned(),
        }
    }

    /// Bytes of all files together (the memory bound is derived from it).
    pub fn total_bytes(&self) -> usize {
        self.files.iter().map(|f| f.bytes.len()).sum()
    }
}

/// Values 0…99 over a volume, so every voxel type holds them.
fn pattern(count: usize) -> Vec<f64> {
    (0..count).map(|i| ((i * 7) % 100) as f64).collect()
}

fn encode_u8(values: &[f64]) -> Vec<u8> {
    values.iter().map(|&v| v as u8).collect()
}

fn encode_i16(values: &[f64], endian: Endian) -> Vec<u8> {
    values
        .iter()
        .flat_map(|&v| match endian {
            Endian::Little => (v as i16).to_le_bytes(),
            Endian::Big => (v as i16).to_be_bytes(),
        })
        .collect()
}

fn encode_f32(values: &[f64], endian: Endian) -> Vec<u8> {
    values
        .iter()
        .flat_map(|&v| match endian {
            Endian::Little => (v as f32).to_le_bytes(),
            Endian::Big => (v as f32).to_be_bytes(),
        })
        .collect()
}

/// Every seed of every format; `real_files` adds files from disk (format by extension).
pub fn all(real_files: &[&Path]) -> Vec<Seed> {
    let mut seeds = Vec::new();
    seeds.extend(nifti());
    seeds.extend(nrrd());
    seeds.extend(tiff());
    seeds.extend(dicom());
    seeds.extend(vti());
    seeds.extend(mrc());
    seeds.extend(real_files.iter().filter_map(|path| real(path)));
    seeds
}

/// A real file as a seed (format by extension), named `real NAME`; `None` for an extension
/// of no format.
pub fn real(path: &Path) -> Option<Seed> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let kind = Kind::of_file_name(&name)?;
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("seed file {}: {e}", path.display()));
    Some(Seed::single(kind, &format!("real {name}"), &name, bytes))
}

fn nifti() -> Vec<Seed> {
    let spec = |dims: [usize; 3], datatype: i16, endian: Endian| NiftiSpec {
        dims,
        datatype,
        spacing: [0.5, 0.75, 2.0],
        slope: 0.0,
        intercept: 0.0,
        sform: None,
        endian,
    };
    let dims = [9, 7, 5];
    let values = pattern(dims.iter().product());
    let u8_le = nifti_bytes(&spec(dims, 2, Endian::Little), &encode_u8(&values));
    let mut oriented = spec(dims, 4, Endian::Big);
    oriented.slope = 2.0;
    oriented.intercept = -10.0;
    oriented.sform = Some([
        [-1.0, 0.0, 0.0, 4.0],
        [0.0, 1.0, 0.0, -3.0],
        [0.0, 0.0, 1.5, 2.0],
    ]);
    let i16_be = nifti_bytes(&oriented, &encode_i16(&values, Endian::Big));
    let f32_gz = gzip(&nifti_bytes(
        &spec(dims, 16, Endian::Little),
        &encode_f32(&values, Endian::Little),
    ));
    // A header/image pair: magic ni1, vox_offset 0, the voxels in the .img.
    let mut pair_header = nifti_bytes(&spec(dims, 2, Endian::Little), &[]);
    pair_header.truncate(348);
    pair_header[108..112].copy_from_slice(&0f32.to_le_bytes());
    pair_header[344..348].copy_from_slice(b"ni1\0");
    vec![
        Seed::single(Kind::Nifti, "u8 little endian", "fuzz-case.nii", u8_le),
        Seed::single(
            Kind::Nifti,
            "i16 big endian, sform, scaled",
            "fuzz-case.nii",
            i16_be,
        ),
        Seed::single(Kind::Nifti, "f32 gzip", "fuzz-case.nii.gz", f32_gz),
        Seed {
            kind: Kind::Nifti,
            name: "header and image pair".into(),
            files: vec![
                SeedFile {
                    name: "fuzz-case.hdr".into(),
                    bytes: pair_header,
                    role: Role::Main,
                },
                SeedFile {
                    name: "fuzz-case.img".into(),
                    bytes: encode_u8(&values),
                    role: Role::Data,
                },
            ],
            open: "fuzz-case.hdr".into(),
        },
    ]
}

fn nrrd() -> Vec<Seed> {
    let dims = [7, 6, 5];
    let values = pattern(dims.iter().product());
    let ascii: String = values.iter().map(|v| format!("{v} ")).collect();
    let spec = |type_name, encoding, endian, extra| NrrdSpec {
        type_name,
        sizes: &dims,
        encoding,
        endian,
        extra,
    };
    let oriented: &[&str] = &[
        "space: left-posterior-superior",
        "space directions: (0.8,0,0) (0,0.8,0) (0,0,2.5)",
        "space origin: (0,0,0)",
    ];
    let raw = nrrd_bytes(
        &spec("short", NrrdEncoding::Raw, Endian::Little, oriented),
        &encode_i16(&values, Endian::Little),
        "",
    );
    let gz = nrrd_bytes(
        &spec(
            "float",
            NrrdEncoding::Gzip,
            Endian::Big,
            &["spacings: 0.5 1.5 3"],
        ),
        &encode_f32(&values, Endian::Big),
        "",
    );
    let text = nrrd_bytes(
        &spec("uchar", NrrdEncoding::Ascii, Endian::Little, &[]),
        &[],
        &ascii,
    );
    // Four dimensions with a unit axis, byte skip and line skip: the payload follows two
    // text lines and three junk bytes.
    let four_d = NrrdSpec {
        type_name: "uint8",
        sizes: &[1, 7, 6, 5],
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &[
            "line skip: 2",
            "byte skip: 3",
            "kinds: none domain domain domain",
        ],
    };
    let mut skipped = b"first line\nsecond line\n\xee\xee\xee".to_vec();
    skipped.extend(encode_u8(&values));
    let skips = nrrd_bytes(&four_d, &skipped, "");
    let (header, data) = nhdr_bytes(
        "fuzz-case.raw",
        &spec("ushort", NrrdEncoding::Raw, Endian::Big, &[]),
        &values
            .iter()
            .flat_map(|&v| (v as u16).to_be_bytes())
            .collect::<Vec<u8>>(),
        "",
    );
    let (gz_header, gz_data) = nhdr_bytes(
        "fuzz-case.raw.gz",
        &spec("uchar", NrrdEncoding::Gzip, Endian::Little, &[]),
        &encode_u8(&values),
        "",
    );
    let detached = |name: &str, header: Vec<u8>, data_name: &str, data: Vec<u8>| Seed {
        kind: Kind::Nrrd,
        name: name.into(),
        files: vec![
            SeedFile {
                name: "fuzz-case.nhdr".into(),
                bytes: header,
                role: Role::Main,
            },
            SeedFile {
                name: data_name.into(),
                bytes: data,
                role: Role::Data,
            },
        ],
        open: "fuzz-case.nhdr".into(),
    };
    vec![
        Seed::single(Kind::Nrrd, "raw i16, LPS directions", "fuzz-case.nrrd", raw),
        Seed::single(Kind::Nrrd, "gzip f32 big endian", "fuzz-case.nrrd", gz),
        Seed::single(Kind::Nrrd, "ascii u8", "fuzz-case.nrrd", text),
        Seed::single(
            Kind::Nrrd,
            "4-D, line and byte skip",
            "fuzz-case.nrrd",
            skips,
        ),
        detached("detached raw u16", header, "fuzz-case.raw", data),
        detached("detached gzip u8", gz_header, "fuzz-case.raw.gz", gz_data),
    ]
}

fn tiff() -> Vec<Seed> {
    let dims = [9, 7, 4];
    let at = |x: u32, y: u32, z: u32| (x + 9 * (y + 7 * z)) % 100;
    let imagej = "ImageJ=1.54f\nimages=4\nslices=4\nunit=micron\nspacing=0.29\nloop=false\n";
    let ome = r#"<?xml version="1.0"?><OME><Image><Pixels DimensionOrder="XYZCT" SizeX="9" SizeY="7" SizeZ="4" SizeC="1" SizeT="1" PhysicalSizeX="0.5" PhysicalSizeY="0.5" PhysicalSizeZ="2.0" PhysicalSizeXUnit="um" Type="uint16"/></Image></OME>"#;
    let seed = |name: &str, bytes| Seed::single(Kind::Tiff, name, "fuzz-case.tif", bytes);
    vec![
        seed(
            "u8 uncompressed",
            tiff_stack::<colortype::Gray8>(
                dims,
                None,
                None,
                TiffCompression::Uncompressed,
                |x, y, z| at(x, y, z) as u8,
            ),
        ),
        seed(
            "u16 ImageJ, LZW",
            tiff_stack::<colortype::Gray16>(
                dims,
                Some(imagej),
                Some(3.5),
                TiffCompression::Lzw,
                |x, y, z| at(x, y, z) as u16,
            ),
        ),
        seed(
            "u16 OME, Deflate",
            tiff_stack::<colortype::Gray16>(
                dims,
                Some(ome),
                None,
                TiffCompression::Deflate(DeflateLevel::Fast),
                |x, y, z| at(x, y, z) as u16,
            ),
        ),
        seed(
            "f32 PackBits",
            tiff_stack::<colortype::Gray32Float>(
                dims,
                None,
                None,
                TiffCompression::Packbits,
                |x, y, z| at(x, y, z) as f32,
            ),
        ),
    ]
}

const EXPLICIT_LE: &str = "1.2.840.10008.1.2.1";

fn dicom() -> Vec<Seed> {
    let seed = |name: &str, bytes| Seed::single(Kind::Dicom, name, "fuzz-case.dcm", bytes);
    let native = || dicom_object(dicom_native_pixels(), VR::OW);
    // A series of three single-frame slices, opened as a folder.
    let slice = |z: usize| {
        let mut object = dicom_object(
            PrimitiveValue::I16((0..48).map(|i| (i * 5 + z as i16 * 100) % 300).collect()).into(),
            VR::OW,
        );
        object.put(DataElement::new(
            tags::NUMBER_OF_FRAMES,
            VR::IS,
            dicom_value!(Str, "1"),
        ));
        object.put(DataElement::new(
            tags::IMAGE_POSITION_PATIENT,
            VR::DS,
            dicom_value!(Strs, ["-2", "3.5", format!("{}", 2.5 * z as f64)]),
        ));
        object.put(DataElement::new(
            tags::IMAGE_ORIENTATION_PATIENT,
            VR::DS,
            dicom_value!(Strs, ["1", "0", "0", "0", "1", "0"]),
        ));
        object.put(DataElement::new(
            tags::INSTANCE_NUMBER,
            VR::IS,
            dicom_value!(Str, (z + 1).to_string()),
        ));
        dicom_bytes(object, EXPLICIT_LE)
    };
    let series = Seed {
        kind: Kind::Dicom,
        name: "series of 3 slices (folder)".into(),
        files: (0..3)
            .map(|z| SeedFile {
                name: format!("slice-{z}.dcm"),
                bytes: slice(z),
                role: Role::Main,
            })
            .collect(),
        open: ".".into(),
    };
    debug_assert_eq!(DICOM_FRAMES, 3);
    vec![
        seed(
            "explicit VR little endian, 3 frames",
            dicom_bytes(native(), EXPLICIT_LE),
        ),
        seed(
            "implicit VR little endian",
            dicom_bytes(native(), "1.2.840.10008.1.2"),
        ),
        seed(
            "explicit VR big endian",
            dicom_bytes(native(), "1.2.840.10008.1.2.2"),
        ),
        seed(
            "RLE lossless, 3 frames",
            dicom_bytes(
                dicom_object(dicom_rle_pixels(), VR::OB),
                "1.2.840.10008.1.2.5",
            ),
        ),
        series,
    ]
}

fn vti() -> Vec<Seed> {
    let seed = |name: &str, text: Vec<u8>| Seed::single(Kind::Vti, name, "fuzz-case.vti", text);
    let values: Vec<String> = super::writers::vti_values()
        .iter()
        .map(|v| v.to_string())
        .collect();
    let array = |format: &str, body: &str| {
        format!(
            "        <DataArray type=\"Float32\" Name=\"density\" format=\"{format}\">{body}</DataArray>\n"
        )
    };
    let ascii = format!(
        "{}{}{VTI_FOOTER}</VTKFile>\n",
        vti_header(false, false, false),
        array("ascii", &values.join(" "))
    );
    use base64::Engine as _;
    let base64 = base64::engine::general_purpose::STANDARD;
    let (header, data) = vti_block(false, false, false, 0);
    let binary = format!(
        "{}{}{VTI_FOOTER}</VTKFile>\n",
        vti_header(false, false, false),
        array("binary", &base64.encode([header, data].concat()))
    );
    let (header, data) = vti_block(true, true, true, 64);
    let binary_zlib = format!(
        "{}{}{VTI_FOOTER}</VTKFile>\n",
        vti_header(true, true, true),
        array(
            "binary",
            &format!("{}{}", base64.encode(&header), base64.encode(&data))
        )
    );
    let appended = |header64: bool, compressed: bool| {
        let (header, data) = vti_block(header64, false, compressed, 100);
        // Another (unused) array first, so the scalars sit at a non-zero offset.
        let unused = [vti_word(4, header64, false), vec![0u8; 4]].concat();
        let mut bytes = format!(
            "{}        <DataArray type=\"Float32\" Name=\"other\" format=\"appended\" offset=\"0\"/>\n        <DataArray type=\"Float32\" Name=\"density\" format=\"appended\" offset=\"{}\"/>\n{VTI_FOOTER}  <AppendedData encoding=\"raw\">\n   _",
            vti_header(header64, false, compressed),
            if compressed { 0 } else { unused.len() },
        )
        .into_bytes();
        if !compressed {
            bytes.extend(&unused);
        }
        bytes.extend(&header);
        bytes.extend(&data);
        bytes.extend(b"\n  </AppendedData>\n</VTKFile>\n");
        bytes
    };
    let (header, data) = vti_block(true, false, false, 0);
    let appended_base64 = format!(
        "{}        <DataArray type=\"Float32\" Name=\"density\" format=\"appended\" offset=\"0\"/>\n{VTI_FOOTER}  <AppendedData encoding=\"base64\">\n   _{}\n  </AppendedData>\n</VTKFile>\n",
        vti_header(true, false, false),
        base64.encode([header, data].concat())
    );
    vec![
        seed("ascii", ascii.into_bytes()),
        seed("base64 binary", binary.into_bytes()),
        seed(
            "base64 zlib, UInt64 headers, big endian",
            binary_zlib.into_bytes(),
        ),
        seed("appended raw", appended(false, false)),
        seed("appended raw zlib", appended(false, true)),
        seed(
            "appended base64, UInt64 headers",
            appended_base64.into_bytes(),
        ),
    ]
}

fn mrc() -> Vec<Seed> {
    let seed = |name: &str, file_name: &str, map: MrcMap| {
        Seed::single(Kind::Mrc, name, file_name, map.bytes())
    };
    let mut big = MrcMap::new([6, 5, 4], 1);
    big.big_endian = true;
    big.extended = vec![7; 96];
    let mut sections_first = MrcMap::new([4, 6, 5], 2);
    sections_first.axis_order = [3, 1, 2];
    vec![
        seed("mode 0 int8", "fuzz-case.mrc", MrcMap::new([7, 6, 5], 0)),
        seed(
            "mode 1 int16 big endian, extended header",
            "fuzz-case.mrc",
            big,
        ),
        seed(
            "mode 2 float32, sections first",
            "fuzz-case.map",
            sections_first,
        ),
        seed("mode 6 uint16", "fuzz-case.rec", MrcMap::new([5, 5, 5], 6)),
        seed(
            "mode 12 float16",
            "fuzz-case.mrcs",
            MrcMap::new([8, 4, 3], 12),
        ),
    ]
}
