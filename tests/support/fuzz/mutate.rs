//! Structure-aware mutations: each format's header fields set to boundary values, bit flips
//! in its header, truncations, and for gzip or zlib data both layers (the compressed bytes,
//! and the decompressed content mutated and compressed again). Every mutation appends what it
//! did to the case's log, so a failure can be read without a hex editor.

use std::io::{Read, Write};

use flate2::Compression;
use flate2::read::{MultiGzDecoder, ZlibDecoder};
use flate2::write::GzEncoder;

use super::Kind;
use super::rng::Rng;
use super::seeds::Role;

/// Mutates one file of a seed in place; `log` gets one line per mutation.
pub fn mutate(kind: Kind, role: Role, bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    if role == Role::Data {
        return data_file(bytes, rng, log);
    }
    match kind {
        Kind::Nifti => nifti(bytes, rng, log),
        Kind::Nrrd => nrrd(bytes, rng, log),
        Kind::Tiff => tiff(bytes, rng, log),
        Kind::Dicom => dicom(bytes, rng, log),
        Kind::Vti => vti(bytes, rng, log),
        Kind::Mrc => mrc(bytes, rng, log),
    }
}

// ---- primitives ---------------------------------------------------------------------------

/// A binary header field: where it is, its width in bytes, byte order and kind.
#[derive(Debug, Clone)]
pub struct Field {
    pub name: String,
    pub offset: usize,
    pub width: usize,
    pub big_endian: bool,
    pub float: bool,
}

impl Field {
    fn int(name: impl Into<String>, offset: usize, width: usize, big_endian: bool) -> Self {
        Self {
            name: name.into(),
            offset,
            width,
            big_endian,
            float: false,
        }
    }

    fn float(name: impl Into<String>, offset: usize, big_endian: bool) -> Self {
        Self {
            name: name.into(),
            offset,
            width: 4,
            big_endian,
            float: true,
        }
    }

    fn read(&self, bytes: &[u8]) -> Option<u64> {
        let slice = bytes.get(self.offset..self.offset + self.width)?;
        let mut value = 0u64;
        for i in 0..self.width {
            let byte = if self.big_endian {
                slice[i]
            } else {
                slice[self.width - 1 - i]
            };
            value = (value << 8) | byte as u64;
        }
        Some(value)
    }

    fn write(&self, bytes: &mut [u8], value: u64) {
        let Some(slice) = bytes.get_mut(self.offset..self.offset + self.width) else {
            return;
        };
        for i in 0..self.width {
            let byte = (value >> (8 * i)) as u8;
            if self.big_endian {
                slice[self.width - 1 - i] = byte;
            } else {
                slice[i] = byte;
            }
        }
    }
}

/// Sets `field` to a boundary value (for its width and kind) or a value near the old one.
fn set_field(bytes: &mut [u8], field: &Field, rng: &mut Rng, log: &mut Vec<String>) {
    let Some(old) = field.read(bytes) else {
        return;
    };
    if field.float {
        let old_value = f32::from_bits(old as u32);
        let values = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            1e-40,
            348.0,
            352.0,
            1e10,
            4.3e9,
            1e20,
            old_value * 1e6,
            -old_value,
            old_value + 1.0,
        ];
        let value = *rng.pick(&values);
        field.write(bytes, value.to_bits() as u64);
        log.push(format!("{} = {value:e} (was {old_value:e})", field.name));
        return;
    }
    let bits = 8 * field.width as u32;
    let max = if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    let values = [
        0,
        1,
        2,
        3,
        7,
        8,
        255,
        256,
        1023,
        1024,
        1025,
        32767,
        32768,
        65535,
        65536,
        0x7fff_ffff,
        0x8000_0000,
        0xffff_ffff,
        1 << 32,
        max,
        max - 1,
        max >> 1,
        (max >> 1) + 1,
        old.wrapping_add(1),
        old.wrapping_sub(1),
        old.wrapping_mul(2),
        old.wrapping_mul(256),
        old / 2,
        rng.next_u64(),
    ];
    let value = *rng.pick(&values) & max;
    field.write(bytes, value);
    log.push(format!("{} = {value:#x} (was {old:#x})", field.name));
}

/// Flips one bit in `range` of `bytes`.
fn flip_bit(bytes: &mut [u8], range: std::ops::Range<usize>, rng: &mut Rng, log: &mut Vec<String>) {
    let end = range.end.min(bytes.len());
    if range.start >= end {
        return;
    }
    let at = range.start + rng.below(end - range.start);
    let bit = rng.below(8);
    bytes[at] ^= 1 << bit;
    log.push(format!("flip bit {bit} of byte {at}"));
}

/// Sets one byte in `range` to a boundary value.
fn set_byte(bytes: &mut [u8], range: std::ops::Range<usize>, rng: &mut Rng, log: &mut Vec<String>) {
    let end = range.end.min(bytes.len());
    if range.start >= end {
        return;
    }
    let at = range.start + rng.below(end - range.start);
    let value = *rng.pick(&[0u8, 1, 0x7f, 0x80, 0xff, b'\n', 0x1b, b'9', b' ']);
    log.push(format!("byte {at} = {value:#04x} (was {:#04x})", bytes[at]));
    bytes[at] = value;
}

/// Cuts the file at a random point, or at one of `points` (where a header ends…).
fn truncate(bytes: &mut Vec<u8>, points: &[usize], rng: &mut Rng, log: &mut Vec<String>) {
    let at = if !points.is_empty() && rng.percent(60) {
        let point = *rng.pick(points);
        (point + rng.below(5)).saturating_sub(2)
    } else {
        rng.below(bytes.len() + 1)
    };
    if at < bytes.len() {
        log.push(format!("truncate to {at} of {} bytes", bytes.len()));
        bytes.truncate(at);
    }
}

/// Inserts, deletes or duplicates a short run of bytes somewhere in `range`.
fn splice(
    bytes: &mut Vec<u8>,
    range: std::ops::Range<usize>,
    rng: &mut Rng,
    log: &mut Vec<String>,
) {
    let end = range.end.min(bytes.len());
    let at = range.start.min(end) + rng.below(end.saturating_sub(range.start) + 1);
    let length = 1 + rng.below(16);
    match rng.below(3) {
        0 => {
            let inserted: Vec<u8> = (0..length).map(|_| rng.next_u64() as u8).collect();
            bytes.splice(at..at, inserted);
            log.push(format!("insert {length} random bytes at {at}"));
        }
        1 => {
            let cut = length.min(bytes.len() - at);
            bytes.drain(at..at + cut);
            log.push(format!("delete {cut} bytes at {at}"));
        }
        _ => {
            let cut = length.min(bytes.len() - at);
            let copy = bytes[at..at + cut].to_vec();
            bytes.splice(at..at, copy);
            log.push(format!("duplicate {cut} bytes at {at}"));
        }
    }
}

/// A generic mutation of a region: bit flip, boundary byte, splice.
fn generic(
    bytes: &mut Vec<u8>,
    range: std::ops::Range<usize>,
    rng: &mut Rng,
    log: &mut Vec<String>,
) {
    match rng.below(3) {
        0 => flip_bit(bytes, range, rng, log),
        1 => set_byte(bytes, range, rng, log),
        _ => splice(bytes, range, rng, log),
    }
}

fn gunzip(bytes: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    MultiGzDecoder::new(bytes).read_to_end(&mut out).ok()?;
    Some(out)
}

fn gzip_fast(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = GzEncoder::new(Vec::new(), Compression::fast());
    encoder.write_all(bytes).expect("in memory");
    encoder.finish().expect("in memory")
}

fn unzlib(bytes: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    ZlibDecoder::new(bytes).read_to_end(&mut out).ok()?;
    Some(out)
}

fn zlib_fast(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), Compression::fast());
    encoder.write_all(bytes).expect("in memory");
    encoder.finish().expect("in memory")
}

/// The outer layer of a gzip stream: its 10-byte header (flags, time, OS), trailer (CRC,
/// size), deflate bytes, or a cut.
fn gzip_outer(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    log.push("gzip outer layer:".into());
    let len = bytes.len();
    match rng.below(5) {
        0 => {
            let fields = [
                Field::int("gzip flags", 3, 1, false),
                Field::int("gzip mtime", 4, 4, false),
                Field::int("gzip method", 2, 1, false),
                Field::int("gzip crc32", len.saturating_sub(8), 4, false),
                Field::int("gzip isize", len.saturating_sub(4), 4, false),
            ];
            set_field(bytes, rng.pick(&fields), rng, log);
        }
        1 => flip_bit(bytes, 10..len, rng, log),
        2 => truncate(bytes, &[10, len.saturating_sub(8)], rng, log),
        3 => {
            // A second member after the first (MultiGzDecoder reads on).
            let extra = gzip_fast(&vec![0u8; 1 + rng.below(4096)]);
            log.push(format!("append a gzip member of {} bytes", extra.len()));
            bytes.extend(extra);
        }
        _ => generic(bytes, 0..len, rng, log),
    }
}

/// The inner layer: decompress, let `inner` mutate the content, compress again.
fn gzip_inner(
    bytes: &mut Vec<u8>,
    rng: &mut Rng,
    log: &mut Vec<String>,
    inner: impl FnOnce(&mut Vec<u8>, &mut Rng, &mut Vec<String>),
) {
    let Some(mut content) = gunzip(bytes) else {
        return gzip_outer(bytes, rng, log);
    };
    log.push("gzip inner layer:".into());
    inner(&mut content, rng, log);
    *bytes = gzip_fast(&content);
}

/// A data file (NRRD's detached data, NIfTI's `.img`): cut, extend, flip, or a gzip layer.
fn data_file(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    log.push("data file:".into());
    if bytes.starts_with(&[0x1f, 0x8b]) {
        if rng.percent(50) {
            return gzip_outer(bytes, rng, log);
        }
        return gzip_inner(bytes, rng, log, |content, rng, log| {
            raw_payload(content, rng, log)
        });
    }
    raw_payload(bytes, rng, log);
}

/// Voxel bytes: shorter, longer, or flipped.
fn raw_payload(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    match rng.below(4) {
        0 => truncate(bytes, &[], rng, log),
        1 => {
            let extra = 1 + rng.below(4096);
            bytes.extend(std::iter::repeat_n(0xab, extra));
            log.push(format!("append {extra} bytes"));
        }
        _ => generic(bytes, 0..bytes.len(), rng, log),
    }
}

// ---- NIfTI --------------------------------------------------------------------------------

fn nifti(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        if rng.percent(30) {
            return gzip_outer(bytes, rng, log);
        }
        return gzip_inner(bytes, rng, log, nifti_plain);
    }
    nifti_plain(bytes, rng, log);
}

fn nifti_plain(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    let big = bytes.get(0..4).is_some_and(|b| b == 348i32.to_be_bytes());
    let mut fields = vec![Field::int("sizeof_hdr", 0, 4, big)];
    for i in 0..8 {
        fields.push(Field::int(format!("dim[{i}]"), 40 + 2 * i, 2, big));
        fields.push(Field::float(format!("pixdim[{i}]"), 76 + 4 * i, big));
    }
    for (name, offset) in [
        ("intent_code", 68),
        ("datatype", 70),
        ("bitpix", 72),
        ("slice_start", 74),
        ("slice_end", 120),
        ("qform_code", 252),
        ("sform_code", 254),
    ] {
        fields.push(Field::int(name, offset, 2, big));
    }
    for (name, offset) in [
        ("vox_offset", 108),
        ("scl_slope", 112),
        ("scl_inter", 116),
        ("quatern_b", 256),
        ("quatern_c", 260),
        ("quatern_d", 264),
        ("qoffset_x", 268),
    ] {
        fields.push(Field::float(name, offset, big));
    }
    for i in 0..12 {
        fields.push(Field::float(format!("srow[{i}]"), 280 + 4 * i, big));
    }
    match rng.below(10) {
        0..=4 => {
            let field = rng.pick(&fields).clone();
            set_field(bytes, &field, rng, log);
        }
        5 => {
            let magic = *rng.pick(&[b"n+1\0", b"ni1\0", b"n+2\0", b"\0\0\0\0"]);
            if bytes.len() >= 348 {
                bytes[344..348].copy_from_slice(magic);
                log.push(format!("magic = {magic:?}"));
            }
        }
        6 | 7 => flip_bit(bytes, 0..352, rng, log),
        8 => truncate(
            bytes,
            &[0, 4, 40, 348, 352, bytes.len().saturating_sub(1)],
            rng,
            log,
        ),
        _ => generic(bytes, 0..bytes.len(), rng, log),
    }
}

// ---- MRC ----------------------------------------------------------------------------------

fn mrc(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    let big = bytes.get(212) == Some(&0x11);
    const NAMES: [&str; 24] = [
        "NX", "NY", "NZ", "MODE", "NXSTART", "NYSTART", "NZSTART", "MX", "MY", "MZ", "CELLA.x",
        "CELLA.y", "CELLA.z", "CELLB.a", "CELLB.b", "CELLB.c", "MAPC", "MAPR", "MAPS", "DMIN",
        "DMAX", "DMEAN", "ISPG", "NSYMBT",
    ];
    let extended = Field::int("NSYMBT", 92, 4, big)
        .read(bytes)
        .unwrap_or(0)
        .min(1 << 20) as usize;
    match rng.below(10) {
        0..=5 => {
            let word = if rng.percent(80) {
                rng.below(24)
            } else {
                24 + rng.below(32)
            };
            let name = NAMES
                .get(word)
                .map_or(format!("word {word}"), |n| n.to_string());
            let float =
                (10..16).contains(&word) || (19..22).contains(&word) || (49..52).contains(&word);
            let field = if float && rng.percent(70) {
                Field::float(name, 4 * word, big)
            } else {
                Field::int(name, 4 * word, 4, big)
            };
            set_field(bytes, &field, rng, log);
        }
        6 => {
            let machst = *rng.pick(&[[0x44u8, 0x44], [0x11, 0x11], [0, 0], [0x44, 0x11]]);
            if bytes.len() >= 214 {
                bytes[212..214].copy_from_slice(&machst);
                log.push(format!("MACHST = {machst:02x?}"));
            }
        }
        7 => flip_bit(bytes, 0..1024, rng, log),
        8 => truncate(
            bytes,
            &[0, 212, 1024, 1024 + extended, bytes.len().saturating_sub(1)],
            rng,
            log,
        ),
        _ => generic(bytes, 0..bytes.len(), rng, log),
    }
}

// ---- TIFF ---------------------------------------------------------------------------------

/// The fields of a classic TIFF's IFD chain: offsets, entry counts, each entry's tag, type,
/// count and value, the first items of arrays stored elsewhere; and where strips lie.
fn tiff_fields(bytes: &[u8]) -> (Vec<Field>, Vec<std::ops::Range<usize>>) {
    let big = bytes.starts_with(b"MM");
    let mut fields = vec![Field::int("first IFD offset", 4, 4, big)];
    let mut regions = Vec::new();
    let mut at = Field::int("", 4, 4, big).read(bytes).unwrap_or(0) as usize;
    let mut seen = Vec::new();
    for page in 0..64 {
        if at == 0 || at + 2 > bytes.len() || seen.contains(&at) {
            break;
        }
        seen.push(at);
        let count = Field::int("", at, 2, big).read(bytes).unwrap_or(0) as usize;
        fields.push(Field::int(format!("IFD {page} entry count"), at, 2, big));
        regions.push(at..(at + 2 + 12 * count + 4).min(bytes.len()));
        for entry in 0..count.min(64) {
            let e = at + 2 + 12 * entry;
            if e + 12 > bytes.len() {
                break;
            }
            let tag = Field::int("", e, 2, big).read(bytes).unwrap_or(0);
            let kind = Field::int("", e + 2, 2, big).read(bytes).unwrap_or(0);
            let values = Field::int("", e + 4, 4, big).read(bytes).unwrap_or(0);
            let label = format!("IFD {page} tag {tag}");
            fields.push(Field::int(format!("{label} tag"), e, 2, big));
            fields.push(Field::int(format!("{label} type"), e + 2, 2, big));
            fields.push(Field::int(format!("{label} count"), e + 4, 4, big));
            fields.push(Field::int(format!("{label} value"), e + 8, 4, big));
            fields.push(Field::int(format!("{label} value (short)"), e + 8, 2, big));
            let size = match kind {
                3 => 2,
                4 => 4,
                _ => 0,
            };
            if size > 0 && values as usize * size > 4 {
                let array = Field::int("", e + 8, 4, big).read(bytes).unwrap_or(0) as usize;
                for item in 0..(values as usize).min(4) {
                    fields.push(Field::int(
                        format!("{label}[{item}]"),
                        array + size * item,
                        size,
                        big,
                    ));
                }
            }
            // Strip offsets (273) point at the compressed data.
            if tag == 273 && size > 0 {
                let first = if values == 1 {
                    Field::int("", e + 8, size, big).read(bytes).unwrap_or(0) as usize
                } else {
                    let array = Field::int("", e + 8, 4, big).read(bytes).unwrap_or(0) as usize;
                    Field::int("", array, size, big).read(bytes).unwrap_or(0) as usize
                };
                regions.push(first..(first + 64).min(bytes.len()));
            }
        }
        at = Field::int("", at + 2 + 12 * count, 4, big)
            .read(bytes)
            .unwrap_or(0) as usize;
    }
    (fields, regions)
}

fn tiff(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    let (fields, regions) = tiff_fields(bytes);
    match rng.below(10) {
        0..=5 => {
            let field = rng.pick(&fields).clone();
            set_field(bytes, &field, rng, log);
        }
        6 | 7 => {
            let region = if regions.is_empty() {
                0..8
            } else {
                rng.pick(&regions).clone()
            };
            flip_bit(bytes, region, rng, log);
        }
        8 => {
            let mut points: Vec<usize> = regions.iter().flat_map(|r| [r.start, r.end]).collect();
            points.push(8);
            truncate(bytes, &points, rng, log);
        }
        _ => generic(bytes, 0..bytes.len(), rng, log),
    }
}

// ---- NRRD ---------------------------------------------------------------------------------

/// Values any text field may be set to: numbers at the edges of every integer type, floats
/// that print long, empty, control bytes, a long token, a long list.
fn text_tokens(rng: &mut Rng) -> String {
    let tokens = [
        "0",
        "-1",
        "1",
        "2",
        "3",
        "1024",
        "65536",
        "2147483648",
        "-2147483649",
        "4294967296",
        "9223372036854775807",
        "18446744073709551615",
        "18446744073709551616",
        "1e308",
        "-1e308",
        "1e-320",
        "nan",
        "inf",
        "-inf",
        "",
        " ",
        "1.5",
        "0x10",
        "\u{1b}[31mred\u{1b}[0m",
        "\u{7f}\u{0}\u{8}",
        "é😀",
        "a",
    ];
    match rng.below(10) {
        0 => "9".repeat(400),
        1 => "x".repeat(5000),
        2 => vec!["1"; 1 + rng.below(3000)].join(" "),
        _ => rng.pick(&tokens).to_string(),
    }
}

/// A value for a NRRD field, chosen for what the field means.
fn nrrd_value(key: &str, own_name: &str, rng: &mut Rng) -> String {
    let choices: &[&str] = match key {
        "sizes" => &[
            "1 1 1",
            "0 5 5",
            "1024 1 1",
            "1 1024 1",
            "65536 1 1",
            "65537 1 1",
            "100000 100000 100000",
            "-1 2 3",
            "7 6",
            "7 6 5 4",
            "1 7 6 5",
            "4294967296 4294967296 2",
            "18446744073709551615 1 1",
        ],
        "type" => &["uchar", "double", "short", "int64", "block", "", "float"],
        "encoding" => &["raw", "gzip", "ascii", "bzip2", "hex", ""],
        "endian" => &["little", "big", "middle", ""],
        "dimension" => &["0", "1", "2", "3", "4", "16", "17", "99999999999999999999"],
        "byte skip" => &[
            "-1",
            "-2",
            "0",
            "1",
            "1000000000",
            "9223372036854775807",
            "99999999999999999999",
        ],
        "line skip" => &[
            "0",
            "1",
            "3",
            "1000000000",
            "9223372036854775807",
            "18446744073709551615",
            "-1",
        ],
        "data file" => &[
            "/dev/zero",
            "/dev/null",
            ".",
            "..",
            "/",
            "missing.raw",
            "LIST",
            "slice%03d.raw 0 4 1",
            "fuzz-case.raw",
        ],
        "spacings" => &["1 1 1", "0 0 0", "nan nan nan", "-1 2 1e308", "1 1"],
        "space directions" => &[
            "(1,0,0) (0,1,0) (0,0,1)",
            "(nan,nan,nan) (0,1,0) (0,0,1)",
            "none none none",
            "(1,0) (0,1) (0,0)",
            "(1e308,0,0) (0,1e308,0) (0,0,1e308)",
            "(0,0,0) (0,0,0) (0,0,0)",
            "1,0,0",
        ],
        "space" => &["RAS", "left-posterior-superior", "scanner-xyz", "nowhere"],
        _ => &[],
    };
    if key == "data file" && rng.percent(10) {
        return own_name.to_owned();
    }
    if !choices.is_empty() && rng.percent(70) {
        rng.pick(choices).to_string()
    } else {
        text_tokens(rng)
    }
}

const NRRD_KEYS: [&str; 12] = [
    "sizes",
    "type",
    "encoding",
    "endian",
    "dimension",
    "byte skip",
    "line skip",
    "data file",
    "spacings",
    "space directions",
    "space",
    "kinds",
];

fn nrrd(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    // The header ends at the first blank line (attached) or the end (detached).
    let header_end = bytes
        .windows(2)
        .position(|w| w == b"\n\n")
        .map_or(bytes.len(), |p| p + 1);
    let mut lines: Vec<Vec<u8>> = bytes[..header_end]
        .split(|&b| b == b'\n')
        .map(<[u8]>::to_vec)
        .collect();
    if lines.last().is_some_and(Vec::is_empty) {
        lines.pop();
    }
    if lines.is_empty() {
        // Cut to nothing by an earlier mutation: start again from a magic line.
        lines.push(b"NRRD0004".to_vec());
    }
    let payload = bytes[header_end..].to_vec();
    let gzip_payload = payload.get(1..3) == Some(&[0x1f, 0x8b][..]);
    let choice = rng.below(20);
    if choice >= 16 && header_end < bytes.len() {
        // The payload after the blank line (its first byte is the blank line's newline).
        let mut body = payload[1..].to_vec();
        log.push("payload:".into());
        if gzip_payload {
            if rng.percent(50) {
                gzip_outer(&mut body, rng, log);
            } else {
                gzip_inner(&mut body, rng, log, raw_payload);
            }
        } else {
            raw_payload(&mut body, rng, log);
        }
        bytes.truncate(header_end + 1);
        bytes.extend(body);
        return;
    }
    match choice {
        0..=7 => {
            // A field's value replaced.
            let fields: Vec<usize> = (1..lines.len())
                .filter(|&i| lines[i].contains(&b':') && !lines[i].starts_with(b"#"))
                .collect();
            if fields.is_empty() {
                return generic(bytes, 0..header_end, rng, log);
            }
            let index = *rng.pick(&fields);
            let line = String::from_utf8_lossy(&lines[index]).into_owned();
            let (key, _) = line.split_once(':').unwrap_or((&line, ""));
            let key = key.trim().to_lowercase();
            let value = nrrd_value(&key, "fuzz-case.nhdr", rng);
            log.push(format!("line {index}: '{key}: {}'", shorten(&value)));
            lines[index] = format!("{key}: {value}").into_bytes();
        }
        8..=10 => {
            // A field added (or given twice).
            let key = *rng.pick(&NRRD_KEYS);
            let value = nrrd_value(key, "fuzz-case.nhdr", rng);
            let at = 1 + rng.below(lines.len());
            log.push(format!("insert line {at}: '{key}: {}'", shorten(&value)));
            lines.insert(at.min(lines.len()), format!("{key}: {value}").into_bytes());
        }
        11 => {
            if lines.len() > 1 {
                let index = 1 + rng.below(lines.len() - 1);
                log.push(format!("delete line {index}"));
                lines.remove(index);
            }
        }
        12 => {
            let index = rng.below(lines.len());
            log.push(format!("line {index} without its newline or with junk"));
            let junk = text_tokens(rng).into_bytes();
            lines[index].extend(junk);
        }
        13 => {
            let end = header_end;
            return generic(bytes, 0..end, rng, log);
        }
        _ => {
            let points = [
                0,
                4,
                8,
                header_end.saturating_sub(1),
                header_end,
                header_end + 1,
            ];
            return truncate(bytes, &points, rng, log);
        }
    }
    let mut rebuilt = lines.join(&b'\n');
    rebuilt.push(b'\n');
    rebuilt.extend(payload);
    *bytes = rebuilt;
}

/// `text` cut to 60 characters for the case log.
fn shorten(text: &str) -> String {
    let mut short: String = text.chars().take(60).collect();
    if text.chars().count() > 60 {
        short.push('…');
    }
    short.escape_debug().to_string()
}

// ---- VTK ImageData ------------------------------------------------------------------------

/// The `name="value"` attributes of the XML part: (name, value range).
fn xml_attributes(text: &[u8]) -> Vec<(String, std::ops::Range<usize>)> {
    let mut found = Vec::new();
    let mut at = 0;
    while let Some(offset) = text[at..].windows(2).position(|w| w == b"=\"") {
        let equals = at + offset;
        let name_start = text[..equals]
            .iter()
            .rposition(|b| !(b.is_ascii_alphanumeric() || *b == b'_'))
            .map_or(0, |p| p + 1);
        let value_start = equals + 2;
        let Some(length) = text[value_start..].iter().position(|&b| b == b'"') else {
            break;
        };
        found.push((
            String::from_utf8_lossy(&text[name_start..equals]).into_owned(),
            value_start..value_start + length,
        ));
        at = value_start + length + 1;
    }
    found
}

fn vti_value(name: &str, rng: &mut Rng) -> String {
    let choices: &[&str] = match name {
        "WholeExtent" | "Extent" => &[
            "0 4 0 3 0 2",
            "0 -1 0 0 0 0",
            "0 1023 0 0 0 0",
            "0 0 0 1023 0 0",
            "0 65535 0 65535 0 65535",
            "-9223372036854775808 9223372036854775807 0 0 0 0",
            "9223372036854775807 -9223372036854775808 0 0 0 0",
            "0 4 0 3",
            "0 4 0 3 0 2 0 0",
            "a b c d e f",
            "0 4294967295 0 0 0 0",
        ],
        "Spacing" | "Origin" => &[
            "0 0 0",
            "nan nan nan",
            "1e308 1e308 1e308",
            "-1 -1 -1",
            "1 1",
        ],
        "type" => &[
            "Float32",
            "Float64",
            "Int8",
            "UInt16",
            "Int64",
            "UInt64",
            "ImageData",
            "Bogus",
        ],
        "format" => &["ascii", "binary", "appended", "raw", ""],
        "encoding" => &["raw", "base64", ""],
        "header_type" => &["UInt32", "UInt64", "UInt16", ""],
        "byte_order" => &["LittleEndian", "BigEndian", ""],
        "compressor" => &["vtkZLibDataCompressor", "vtkLZ4DataCompressor", ""],
        "NumberOfComponents" => &["0", "1", "3", "-1", "4294967297", "99999999999999999999"],
        "offset" => &[
            "0",
            "1",
            "8",
            "-1",
            "4294967295",
            "18446744073709551615",
            "999999",
        ],
        "Scalars" | "Name" => &["density", "other", "", "none"],
        _ => &[],
    };
    if !choices.is_empty() && rng.percent(70) {
        rng.pick(choices).to_string()
    } else {
        text_tokens(rng)
    }
}

fn vti(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    let xml_end = find(bytes, b"<AppendedData").unwrap_or(bytes.len());
    let underscore = find(&bytes[xml_end..], b"_").map(|p| xml_end + p + 1);
    let header64 = find(&bytes[..xml_end], b"UInt64").is_some();
    let big = find(&bytes[..xml_end], b"BigEndian").is_some();
    let word = if header64 { 8 } else { 4 };
    match rng.below(20) {
        0..=7 => {
            let attributes = xml_attributes(&bytes[..xml_end]);
            if attributes.is_empty() {
                return generic(bytes, 0..xml_end, rng, log);
            }
            let (name, range) = rng.pick(&attributes).clone();
            let value = vti_value(&name, rng);
            log.push(format!("{name}=\"{}\"", shorten(&value)));
            bytes.splice(range, value.into_bytes());
        }
        8..=10 => {
            // Header words of an appended array (blocks, block size, last size, sizes…).
            match underscore {
                Some(start) => {
                    let at = start + word * rng.below(6) + if rng.percent(30) { 8 } else { 0 };
                    let field = Field::int("appended header word", at, word, big);
                    set_field(bytes, &field, rng, log);
                }
                None => vti_inline_header(bytes, word, big, rng, log),
            }
        }
        11 | 12 => {
            // A zlib block inside: its compressed bytes, or its content compressed again.
            let Some(start) = find(bytes, b"\x78\x9c").or_else(|| find(bytes, b"\x78\x01")) else {
                return generic(bytes, 0..bytes.len(), rng, log);
            };
            if rng.percent(50) {
                log.push("zlib outer layer:".into());
                flip_bit(bytes, start..start + 64, rng, log);
            } else if let Some(content) = unzlib(&bytes[start..]) {
                let mut content = content;
                log.push("zlib inner layer:".into());
                raw_payload(&mut content, rng, log);
                let end = start + zlib_fast(&unzlib(&bytes[start..]).unwrap_or_default()).len();
                bytes.splice(start..end.min(bytes.len()), zlib_fast(&content));
            }
        }
        13 | 14 => {
            // An element removed or repeated.
            let opens: Vec<usize> = bytes[..xml_end]
                .iter()
                .enumerate()
                .filter(|(_, b)| **b == b'<')
                .map(|(i, _)| i)
                .collect();
            if opens.is_empty() {
                return generic(bytes, 0..bytes.len(), rng, log);
            }
            let start = *rng.pick(&opens);
            let end = find(&bytes[start..xml_end], b">").map_or(xml_end, |p| start + p + 1);
            if rng.percent(50) {
                log.push(format!("delete the tag at {start}"));
                bytes.drain(start..end);
            } else {
                log.push(format!("repeat the tag at {start}"));
                let copy = bytes[start..end].to_vec();
                bytes.splice(start..start, copy);
            }
        }
        15 | 16 => flip_bit(bytes, 0..xml_end, rng, log),
        17 => {
            let mut points = vec![xml_end, xml_end / 2];
            if let Some(start) = underscore {
                points.extend([start, start + word, start + 3 * word]);
            }
            truncate(bytes, &points, rng, log)
        }
        _ => generic(bytes, 0..bytes.len(), rng, log),
    }
}

/// The header words of an inline base64 `binary` array, decoded, one set to a boundary value,
/// encoded again.
fn vti_inline_header(
    bytes: &mut Vec<u8>,
    word: usize,
    big: bool,
    rng: &mut Rng,
    log: &mut Vec<String>,
) {
    use base64::Engine as _;
    let base64 = base64::engine::general_purpose::STANDARD;
    let Some(open) = find(bytes, b"format=\"binary\">") else {
        return generic(bytes, 0..bytes.len(), rng, log);
    };
    let start = open + b"format=\"binary\">".len();
    let end = find(&bytes[start..], b"<").map_or(bytes.len(), |p| start + p);
    // The first base64 group that holds the header (3 words, rounded to whole groups).
    let header_text = (3 * word).div_ceil(3) * 4;
    let Some(text) = bytes.get(start..(start + header_text).min(end)) else {
        return;
    };
    let Ok(mut decoded) = base64.decode(text) else {
        return generic(bytes, start..end, rng, log);
    };
    let field = Field::int("base64 header word", word * rng.below(3), word, big);
    set_field(&mut decoded, &field, rng, log);
    let encoded = base64.encode(&decoded);
    bytes.splice(start..(start + header_text).min(end), encoded.into_bytes());
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

// ---- DICOM --------------------------------------------------------------------------------

/// One element of a DICOM file as the mutator sees it.
struct Element {
    tag: (u16, u16),
    start: usize,
    vr: Option<usize>,
    length: Field,
    value: std::ops::Range<usize>,
}

/// The elements of a DICOM file: the meta group (explicit VR little endian), then the data
/// set in the transfer syntax the meta group names, entering sequences and items.
fn dicom_elements(bytes: &[u8]) -> Vec<Element> {
    let mut elements = Vec::new();
    let mut at = 132;
    let mut explicit = true;
    let mut big = false;
    let mut in_meta = true;
    while at + 8 <= bytes.len() {
        let u16_at = |offset: usize, big: bool| {
            Field::int("", offset, 2, big).read(bytes).unwrap_or(0) as u16
        };
        let group_le = u16_at(at, false);
        if in_meta && group_le != 2 {
            in_meta = false;
            let syntax = elements
                .iter()
                .find(|e: &&Element| e.tag == (2, 0x10))
                .map(|e| {
                    String::from_utf8_lossy(&bytes[e.value.clone()])
                        .trim_end_matches('\0')
                        .to_owned()
                })
                .unwrap_or_default();
            explicit = syntax != "1.2.840.10008.1.2";
            big = syntax == "1.2.840.10008.1.2.2";
        }
        let tag = (u16_at(at, big), u16_at(at + 2, big));
        if tag.0 == 0xfffe {
            // Item or delimiter: a 4-byte length; enter items, skip nothing.
            let length = Field::int(
                format!("({:04x},{:04x}) length", tag.0, tag.1),
                at + 4,
                4,
                big,
            );
            let value_length = length.read(bytes).unwrap_or(0) as usize;
            let inside_pixel_item = tag.1 == 0xe000
                && value_length != 0xffff_ffff
                && elements.last().is_some_and(|e: &Element| {
                    e.tag == (0x7fe0, 0x10) || e.tag == (0xfffe, 0xe000)
                });
            elements.push(Element {
                tag,
                start: at,
                vr: None,
                value: at + 8
                    ..(at + 8 + if inside_pixel_item { value_length } else { 0 }).min(bytes.len()),
                length,
            });
            at += 8 + if inside_pixel_item { value_length } else { 0 };
            continue;
        }
        let (vr, length, header) = if explicit || in_meta {
            let vr = bytes.get(at + 4..at + 6).unwrap_or_default();
            let long = matches!(
                vr,
                b"OB"
                    | b"OD"
                    | b"OF"
                    | b"OL"
                    | b"OV"
                    | b"OW"
                    | b"SQ"
                    | b"SV"
                    | b"UC"
                    | b"UN"
                    | b"UR"
                    | b"UT"
                    | b"UV"
            );
            let name = format!("({:04x},{:04x}) length", tag.0, tag.1);
            if long {
                (
                    Some(at + 4),
                    Field::int(name, at + 8, 4, big && !in_meta),
                    12,
                )
            } else {
                (
                    Some(at + 4),
                    Field::int(name, at + 6, 2, big && !in_meta),
                    8,
                )
            }
        } else {
            (
                None,
                Field::int(
                    format!("({:04x},{:04x}) length", tag.0, tag.1),
                    at + 4,
                    4,
                    big,
                ),
                8,
            )
        };
        let value_length = length.read(bytes).unwrap_or(0) as usize;
        let undefined = value_length == 0xffff_ffff;
        let sequence = vr.is_some_and(|v| bytes.get(v..v + 2) == Some(b"SQ"));
        let value_end = if undefined || sequence {
            at + header
        } else {
            at + header + value_length
        };
        elements.push(Element {
            tag,
            start: at,
            vr,
            length,
            value: at + header..value_end.min(bytes.len()),
        });
        at = value_end;
        if tag == (0x7fe0, 0x10) && !undefined {
            break;
        }
    }
    elements
}

const TRANSFER_SYNTAXES: [&str; 9] = [
    "1.2.840.10008.1.2",
    "1.2.840.10008.1.2.1",
    "1.2.840.10008.1.2.2",
    "1.2.840.10008.1.2.5",
    "1.2.840.10008.1.2.4.50",
    "1.2.840.10008.1.2.1.99",
    "1.2.840.10008.1.2.4.90",
    "1.2.3",
    "",
];

fn dicom(bytes: &mut Vec<u8>, rng: &mut Rng, log: &mut Vec<String>) {
    let elements = dicom_elements(bytes);
    if elements.is_empty() {
        return generic(bytes, 0..bytes.len(), rng, log);
    }
    let header_end = elements
        .iter()
        .find(|e| e.tag == (0x7fe0, 0x10))
        .map_or(bytes.len(), |e| e.value.start);
    let element = &elements[rng.below(elements.len())];
    match rng.below(20) {
        0..=6 => {
            // The length field: the damaged-length case the issue found.
            set_field(bytes, &element.length, rng, log);
        }
        7 | 8 => {
            // A tag's group or element.
            let big = element.length.big_endian;
            let which = rng.below(2);
            let field = Field::int(
                format!(
                    "({:04x},{:04x}) tag word {which}",
                    element.tag.0, element.tag.1
                ),
                element.start + 2 * which,
                2,
                big,
            );
            set_field(bytes, &field, rng, log);
        }
        9 => {
            if let Some(vr) = element.vr {
                let codes: [&[u8; 2]; 10] = [
                    b"OB", b"OW", b"SQ", b"UN", b"US", b"UL", b"DS", b"IS", b"UT", b"\0\0",
                ];
                let code = rng.pick(&codes);
                log.push(format!(
                    "({:04x},{:04x}) VR = {}",
                    element.tag.0,
                    element.tag.1,
                    String::from_utf8_lossy(&code[..]).escape_debug()
                ));
                bytes[vr..vr + 2].copy_from_slice(&code[..]);
            }
        }
        10..=12 => {
            // A value: numbers (US/UL) at boundaries, text replaced keeping the length field.
            let value = element.value.clone();
            if element.tag == (0xfffe, 0xe000) && value.len() >= 64 {
                // A pixel data fragment: the words of an RLE header (segments, offsets).
                let word = rng.below(16);
                let field = Field::int(
                    format!("fragment at {} RLE header word {word}", value.start),
                    value.start + 4 * word,
                    4,
                    false,
                );
                return set_field(bytes, &field, rng, log);
            }
            if value.is_empty() || value.end > header_end {
                return flip_bit(bytes, 0..header_end, rng, log);
            }
            let vr = element.vr.map(|v| bytes[v..v + 2].to_vec());
            match vr.as_deref() {
                Some(b"US") | Some(b"UL") | None if value.len() <= 4 => {
                    let field = Field::int(
                        format!("({:04x},{:04x}) value", element.tag.0, element.tag.1),
                        value.start,
                        if value.len() >= 4 { 4 } else { 2 },
                        element.length.big_endian,
                    );
                    set_field(bytes, &field, rng, log);
                }
                _ => {
                    let text = if element.tag == (2, 0x10) {
                        rng.pick(&TRANSFER_SYNTAXES).to_string()
                    } else {
                        text_tokens(rng)
                    };
                    let mut text = text.into_bytes();
                    if text.len() % 2 == 1 {
                        text.push(b' ');
                    }
                    log.push(format!(
                        "({:04x},{:04x}) value = '{}'",
                        element.tag.0,
                        element.tag.1,
                        shorten(&String::from_utf8_lossy(&text))
                    ));
                    let new_length = text.len() as u64;
                    bytes.splice(value, text);
                    if rng.percent(80) && (element.length.width == 4 || new_length < 0x10000) {
                        element.length.write(bytes, new_length);
                    }
                }
            }
        }
        13 => {
            // An element claiming more than the file holds, inserted before another.
            let at = element.start;
            let mut inserted = vec![0x10, 0x00, 0x10, 0x00, b'U', b'T', 0, 0];
            let claim = *rng.pick(&[0xffff_fff0u32, 0x8000_0000, 0x0400_0000, 0x00ff_ffff]);
            inserted.extend(claim.to_le_bytes());
            log.push(format!("insert (0010,0010) UT of {claim:#x} bytes at {at}"));
            bytes.splice(at..at, inserted);
        }
        14 => {
            log.push(format!(
                "delete element ({:04x},{:04x})",
                element.tag.0, element.tag.1
            ));
            let end = element.value.end.max(element.start + 8).min(bytes.len());
            bytes.drain(element.start..end);
        }
        15 | 16 => flip_bit(bytes, 128..header_end, rng, log),
        17 | 18 => {
            let points: Vec<usize> = elements
                .iter()
                .flat_map(|e| [e.start, e.value.start, e.value.end])
                .collect();
            truncate(bytes, &points, rng, log)
        }
        _ => generic(bytes, 0..bytes.len(), rng, log),
    }
}
