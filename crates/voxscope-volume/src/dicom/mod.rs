//! DICOM: a folder holding a series of single-frame files, or one multi-frame file. Slices
//! are sorted by ImagePositionPatient along the slice normal; RescaleSlope/Intercept give the
//! data's units; PixelSpacing and the slice positions give the spacing; the patient axes are
//! reordered to RAS. Uncompressed (implicit/explicit VR, little/big endian) and RLE Lossless
//! pixel data; other transfer syntaxes (JPEG…) fail with their name. Several series in a
//! folder: the largest is opened, the others are listed in the metadata.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::file::ReadPreamble;
use dicom_object::{DefaultDicomObject, OpenFileOptions};

use super::error::{Problem, number, printable};
use super::io::{io_reason, not_a_file};
use super::orientation::reorient_to_ras;
use super::{MAX_VOXELS, ValueScale, Volume, VoxelData};

mod walk;

const IMPLICIT_LE: &str = "1.2.840.10008.1.2";
const EXPLICIT_LE: &str = "1.2.840.10008.1.2.1";
const EXPLICIT_BE: &str = "1.2.840.10008.1.2.2";
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// DICOM files larger than this are refused before they are read.
const MAX_FILE_BYTES: u64 = 1 << 32;

/// PackBits (RLE Lossless segments) expands at most 64-fold: a replicate run is 2 bytes for
/// up to 128. A frame claiming more pixels than its segments can hold is refused before its
/// buffer exists.
const MAX_RLE_EXPANSION: usize = 64;

/// True when the first bytes of a file are the 128-byte preamble and `DICM`.
pub(super) fn sniff(head: &[u8]) -> bool {
    head.get(128..132) == Some(b"DICM")
}

/// True when `path` starts with the DICOM preamble and `DICM`.
pub(super) fn is_dicom(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| sniff(&head))
}

/// The DICOM files of `dir` (by their `DICM` marker).
pub(super) fn dicom_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_file() && is_dicom(p))
        .collect();
    files.sort();
    files
}

/// One file's header (read up to the pixel data, once) and what sorting and grouping need.
struct SliceHeader {
    path: PathBuf,
    object: DefaultDicomObject,
    series: String,
    description: String,
    position: Option<[f64; 3]>,
    orientation: Option<[f64; 6]>,
    frames: usize,
}

impl SliceHeader {
    /// Where the slice lies along the series' `normal` (0 without a position or normal).
    fn along(&self, normal: Option<[f64; 3]>) -> f64 {
        match (self.position, normal) {
            (Some(p), Some(n)) => dot(p, n),
            _ => 0.0,
        }
    }
}

/// Reads a file's header (up to the pixel data). Every element length is checked against the
/// bytes that remain before dicom-object sees the file (see [`walk`]).
fn open_header(path: &Path) -> Result<DefaultDicomObject, Problem> {
    let metadata =
        std::fs::metadata(path).map_err(|e| format!("cannot open: {}", io_reason(&e)))?;
    if let Some(what) = not_a_file(&metadata) {
        return Err(what.into());
    }
    if metadata.len() > MAX_FILE_BYTES {
        return Err(format!(
            "{} bytes is beyond the {MAX_FILE_BYTES}-byte limit",
            metadata.len()
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    walk::check_lengths(&bytes)?;
    OpenFileOptions::new()
        .read_until(tags::PIXEL_DATA)
        .read_preamble(ReadPreamble::Always)
        .from_reader(&bytes[..])
        .map_err(|e| format!("not a readable DICOM file: {}", walk::root_cause(&e)))
}

fn text(object: &DefaultDicomObject, tag: dicom_core::Tag) -> Option<String> {
    object
        .element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_str().ok())
        .map(|s| printable(s.trim()))
        .filter(|s| !s.is_empty())
}

fn floats(object: &DefaultDicomObject, tag: dicom_core::Tag) -> Option<Vec<f64>> {
    object
        .element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_multi_float64().ok())
}

fn integer(object: &DefaultDicomObject, tag: dicom_core::Tag) -> Option<i64> {
    object
        .element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_int::<i64>().ok())
}

/// Loads the series that `path` (a folder, or one of its files) holds; the largest series
/// when a folder holds several.
pub(super) fn load(path: &Path) -> Result<Volume, Problem> {
    let (dir, chosen_file) = if path.is_dir() {
        (path.to_path_buf(), None)
    } else {
        (
            path.parent().map(Path::to_path_buf).unwrap_or_default(),
            Some(path.to_path_buf()),
        )
    };
    let files = if chosen_file.is_some() && path.parent().is_none() {
        vec![path.to_path_buf()]
    } else {
        dicom_files(&dir)
    };
    if files.is_empty() {
        return Err("holds no DICOM files".into());
    }
    let chosen_file = chosen_file.as_deref();
    let headers = read_headers(&files, chosen_file)?;
    let (mut slices, others) = choose_series(headers, chosen_file)?;

    // Sort along the slice normal.
    let orientation = slices[0].orientation;
    let normal = orientation.map(|o| cross([o[0], o[1], o[2]], [o[3], o[4], o[5]]));
    slices.sort_by(|a, b| {
        a.along(normal)
            .total_cmp(&b.along(normal))
            .then_with(|| a.path.cmp(&b.path))
    });
    if slices.len() > 1 && slices.iter().any(|s| s.frames > 1) {
        return Err(
            "mixes multi-frame files into a series of files; open one multi-frame file alone"
                .into(),
        );
    }

    let (data, size, scale) = stack_pixels(&slices, chosen_file)?;
    let first = &slices[0].object;
    let depth = data.len() / (size[0] * size[1]);

    // Spacing: PixelSpacing is row spacing (y), then column spacing (x).
    let pixel_spacing = floats(first, tags::PIXEL_SPACING)
        .filter(|v| v.len() == 2)
        .unwrap_or(vec![1.0, 1.0]);
    let slice_spacing = slice_spacing(&slices, normal);
    if slices.len() > 1 && slice_spacing <= 0.0 {
        return Err("two files share one slice position; the series is not a volume".into());
    }
    let spacing = [pixel_spacing[1], pixel_spacing[0], slice_spacing];
    let name = path.display().to_string();
    let mut volume = Volume::new(name, "DICOM", [size[0], size[1], depth], spacing, data)
        .map_err(|e| e.problem)?;
    volume.value_scale = scale;
    volume.metadata = series_metadata(first, slices.len(), scale, &others);

    // Patient axes (LPS in DICOM) to RAS: flip x and y.
    Ok(match (orientation, normal) {
        (Some(o), Some(n)) => {
            let ras = |v: [f64; 3]| [-v[0], -v[1], v[2]];
            reorient_to_ras(
                volume,
                [ras([o[0], o[1], o[2]]), ras([o[3], o[4], o[5]]), ras(n)],
            )
        }
        _ => volume,
    })
}

/// `problem` of `file`: as it is in the file the user named (the error starts with its
/// name); naming the file in another file of the folder.
fn in_file(chosen_file: Option<&Path>, file: &Path, problem: Problem) -> Problem {
    if chosen_file == Some(file) {
        problem
    } else {
        format!("{}: {problem}", file_name(file))
    }
}

/// The headers of `files`: a broken file beside a good series is skipped (and said on
/// stderr); the one asked for (`chosen_file`), or the only one, is not.
fn read_headers(
    files: &[PathBuf],
    chosen_file: Option<&Path>,
) -> Result<Vec<SliceHeader>, Problem> {
    let mut headers = Vec::with_capacity(files.len());
    for file in files {
        let object = match open_header(file) {
            Ok(object) => object,
            Err(problem) if chosen_file != Some(file.as_path()) && files.len() > 1 => {
                eprintln!(
                    "voxscope: skipping {}: {}",
                    file_name(file),
                    super::error::escape(&problem)
                );
                continue;
            }
            Err(problem) => return Err(in_file(chosen_file, file, problem)),
        };
        headers.push(SliceHeader {
            path: file.clone(),
            series: text(&object, tags::SERIES_INSTANCE_UID)
                .unwrap_or_else(|| "(no series UID)".into()),
            description: text(&object, tags::SERIES_DESCRIPTION).unwrap_or_default(),
            position: floats(&object, tags::IMAGE_POSITION_PATIENT).and_then(|v| v.try_into().ok()),
            orientation: floats(&object, tags::IMAGE_ORIENTATION_PATIENT)
                .and_then(|v| v.try_into().ok()),
            frames: frame_count(&object),
            object,
        });
    }
    Ok(headers)
}

/// The slices of the series to read (the one `chosen_file` belongs to, else the one of the
/// most frames; a multi-frame file asked for by name alone), and the others described for
/// the metadata.
fn choose_series(
    headers: Vec<SliceHeader>,
    chosen_file: Option<&Path>,
) -> Result<(Vec<SliceHeader>, Vec<String>), Problem> {
    let mut series: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
    for header in headers {
        series
            .entry(header.series.clone())
            .or_default()
            .push(header);
    }
    let chosen_series = match chosen_file {
        Some(file) => series
            .iter()
            .find(|(_, slices)| slices.iter().any(|s| s.path == file))
            .map(|(uid, _)| uid.clone()),
        None => series
            .iter()
            .max_by_key(|(_, slices)| slices.iter().map(|s| s.frames).sum::<usize>())
            .map(|(uid, _)| uid.clone()),
    }
    .ok_or("holds no readable DICOM series")?;
    let others: Vec<String> = series
        .iter()
        .filter(|(uid, _)| **uid != chosen_series)
        .map(|(uid, slices)| {
            format!(
                "{} ({} files{})",
                printable(uid),
                slices.len(),
                describe(&slices[0].description)
            )
        })
        .collect();
    let mut slices = series.remove(&chosen_series).expect("chosen from the map");
    // A multi-frame file asked for by name is a volume of its own.
    if let Some(file) = chosen_file
        && let Some(index) = slices.iter().position(|s| s.path == file && s.frames > 1)
    {
        slices = vec![slices.swap_remove(index)];
    }
    Ok((slices, others))
}

/// The pixels of `slices` (sorted) stacked, the size of a slice (columns, rows) and the
/// series' rescale: every file of one size, pixel type and rescale.
fn stack_pixels(
    slices: &[SliceHeader],
    chosen_file: Option<&Path>,
) -> Result<(VoxelData, [usize; 2], ValueScale), Problem> {
    let in_file = |file: &Path, problem: Problem| in_file(chosen_file, file, problem);
    let mut data: Option<VoxelData> = None;
    let mut size = [0usize; 2];
    let mut first_scale: Option<ValueScale> = None;
    for (index, slice) in slices.iter().enumerate() {
        let (pixels, rows, columns, scale) = decode_pixels(&slice.object, &slice.path)
            .map_err(|problem| in_file(&slice.path, problem))?;
        if index == 0 {
            size = [columns, rows];
        } else if size != [columns, rows] {
            return Err(in_file(
                &slice.path,
                format!(
                    "is {columns}x{rows} but the series starts {}x{}",
                    size[0], size[1]
                ),
            ));
        }
        if (index + 1).saturating_mul(slice.frames.saturating_mul(rows * columns)) > MAX_VOXELS {
            return Err(format!("more than {MAX_VOXELS} voxels"));
        }
        match &mut data {
            None => data = Some(pixels),
            Some(data) => data.append(pixels).map_err(|_| {
                in_file(
                    &slice.path,
                    "stores another pixel type than the series' first file".into(),
                )
            })?,
        }
        match first_scale {
            None => first_scale = Some(scale),
            Some(first_scale) if first_scale != scale => {
                return Err(in_file(
                    &slice.path,
                    format!(
                        "rescales by {}·v + {} but the series' first file by {}·v + {}; mixed rescaling is not supported",
                        number(scale.slope),
                        number(scale.intercept),
                        number(first_scale.slope),
                        number(first_scale.intercept)
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    let data = data.expect("at least one slice");
    let scale = first_scale.expect("at least one slice");
    Ok((data, size, scale))
}

/// The distance between slices: the median gap between their positions along `normal`
/// where every slice has one, else the first file's SpacingBetweenSlices or SliceThickness
/// (1 without either).
fn slice_spacing(slices: &[SliceHeader], normal: Option<[f64; 3]>) -> f64 {
    let first = &slices[0].object;
    let positions: Vec<f64> = slices.iter().map(|s| s.along(normal)).collect();
    if positions.len() > 1 && slices.iter().all(|s| s.position.is_some()) && normal.is_some() {
        let mut gaps: Vec<f64> = positions.windows(2).map(|w| w[1] - w[0]).collect();
        gaps.sort_by(f64::total_cmp);
        gaps[gaps.len() / 2]
    } else {
        floats(first, tags::SPACING_BETWEEN_SLICES)
            .or_else(|| floats(first, tags::SLICE_THICKNESS))
            .and_then(|v| v.first().copied())
            .unwrap_or(1.0)
    }
}

/// What `info` shows of a series: the `first` file's descriptive tags, its transfer syntax,
/// how many files, the rescale, and the `others` series beside it.
fn series_metadata(
    first: &DefaultDicomObject,
    files: usize,
    scale: ValueScale,
    others: &[String],
) -> Vec<(String, String)> {
    let mut metadata = Vec::new();
    for (key, tag) in [
        ("modality", tags::MODALITY),
        ("series", tags::SERIES_DESCRIPTION),
        ("study", tags::STUDY_DESCRIPTION),
        ("body part", tags::BODY_PART_EXAMINED),
        ("units", tags::RESCALE_TYPE),
        ("photometric", tags::PHOTOMETRIC_INTERPRETATION),
    ] {
        if let Some(value) = text(first, tag) {
            metadata.push((key.to_owned(), value));
        }
    }
    metadata.push((
        "transfer syntax".to_owned(),
        printable(first.meta().transfer_syntax()),
    ));
    metadata.push(("files".to_owned(), files.to_string()));
    if scale != ValueScale::IDENTITY {
        metadata.push((
            "rescale".to_owned(),
            format!("{} · v + {}", number(scale.slope), number(scale.intercept)),
        ));
    }
    for (n, other) in others.iter().enumerate() {
        metadata.push((format!("other series {}", n + 1), other.clone()));
    }
    metadata
}

/// The pixels of every frame of `object` in its stored type, rows and columns, and the
/// rescale to the data's units.
fn decode_pixels(
    object: &DefaultDicomObject,
    path: &Path,
) -> Result<(VoxelData, usize, usize, ValueScale), Problem> {
    let rows = image_side(object, tags::ROWS, "Rows")?;
    let columns = image_side(object, tags::COLUMNS, "Columns")?;
    let frames = frame_count(object);
    let samples = integer(object, tags::SAMPLES_PER_PIXEL).unwrap_or(1);
    if samples != 1 {
        return Err(format!(
            "{samples} samples per pixel (color); only grayscale images are supported"
        ));
    }
    let bits = integer(object, tags::BITS_ALLOCATED).unwrap_or(16);
    let signed = integer(object, tags::PIXEL_REPRESENTATION).unwrap_or(0) == 1;
    let bytes_per = match bits {
        8 => 1,
        16 => 2,
        32 => 4,
        other => {
            return Err(format!(
                "{other} bits allocated per pixel is not supported (8, 16, 32 are)"
            ));
        }
    };
    let expected = rows
        .checked_mul(columns)
        .and_then(|n| n.checked_mul(frames))
        .filter(|&n| n <= MAX_VOXELS)
        .ok_or_else(|| format!("{columns}x{rows}x{frames} pixels is beyond the limit"))?
        * bytes_per;
    let syntax = object.meta().transfer_syntax().to_owned();
    let bytes: Vec<u8> = match syntax.as_str() {
        IMPLICIT_LE | EXPLICIT_LE | EXPLICIT_BE => {
            let big_endian = syntax == EXPLICIT_BE;
            let mut bytes = match pixel_element(path, big_endian, syntax != IMPLICIT_LE)? {
                PixelPayload::Native(bytes) => bytes,
                PixelPayload::Fragments(_) => {
                    return Err("encapsulated pixel data in an uncompressed transfer syntax".into());
                }
            };
            if big_endian && bytes_per > 1 {
                bytes.chunks_exact_mut(bytes_per).for_each(<[u8]>::reverse);
            }
            bytes
        }
        RLE_LOSSLESS => {
            let PixelPayload::Fragments(fragments) = pixel_element(path, false, true)? else {
                return Err("RLE pixel data is not encapsulated".into());
            };
            // What the fragments can hold, not what the header claims.
            let most = fragments
                .iter()
                .take(frames)
                .map(|f| f.len().saturating_mul(MAX_RLE_EXPANSION))
                .fold(0usize, usize::saturating_add);
            let mut out = Vec::with_capacity(expected.min(most));
            for (frame, fragment) in fragments.iter().take(frames).enumerate() {
                decode_rle_frame(fragment, rows * columns, bytes_per, &mut out)
                    .map_err(|p| format!("frame {}: {p}", frame + 1))?;
            }
            out
        }
        other => {
            return Err(format!(
                "transfer syntax {} ({}) is not supported; uncompressed and RLE Lossless are",
                printable(other),
                syntax_name(other)
            ));
        }
    };
    if bytes.len() < expected {
        return Err(format!(
            "truncated pixel data: {} bytes for {columns}x{rows}x{frames} pixels of {bits} bits ({expected} needed)",
            bytes.len()
        ));
    }
    let bytes = &bytes[..expected];
    let data = match (bytes_per, signed) {
        (1, false) => VoxelData::U8(bytes.to_vec()),
        (1, true) => VoxelData::I8(bytes.iter().map(|&b| b as i8).collect()),
        (2, false) => VoxelData::U16(
            bytes
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect(),
        ),
        (2, true) => VoxelData::I16(
            bytes
                .chunks_exact(2)
                .map(|c| i16::from_le_bytes([c[0], c[1]]))
                .collect(),
        ),
        (_, false) => VoxelData::U32(
            bytes
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
        ),
        (_, true) => VoxelData::I32(
            bytes
                .chunks_exact(4)
                .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
        ),
    };
    let slope = floats(object, tags::RESCALE_SLOPE)
        .and_then(|v| v.first().copied())
        .filter(|s| s.is_finite() && *s != 0.0)
        .unwrap_or(1.0);
    let intercept = floats(object, tags::RESCALE_INTERCEPT)
        .and_then(|v| v.first().copied())
        .filter(|s| s.is_finite())
        .unwrap_or(0.0);
    Ok((data, rows, columns, ValueScale { slope, intercept }))
}

/// The value of a file's Pixel Data element.
enum PixelPayload {
    /// Native (uncompressed) pixel bytes.
    Native(Vec<u8>),
    /// Encapsulated frames (the basic offset table dropped).
    Fragments(Vec<Vec<u8>>),
}

/// Finds the top-level Pixel Data element (7FE0,0010) of `path` and returns its value. The
/// header parser stops before it: some files carry bytes after the pixel data that are not
/// an element, and their pixels are still good.
fn pixel_element(path: &Path, big_endian: bool, explicit: bool) -> Result<PixelPayload, Problem> {
    let file = std::fs::read(path).map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    let tag: [u8; 4] = if big_endian {
        [0x7f, 0xe0, 0x00, 0x10]
    } else {
        [0xe0, 0x7f, 0x10, 0x00]
    };
    let u32_at = |at: usize| -> Option<u32> {
        let bytes: [u8; 4] = file.get(at..at + 4)?.try_into().ok()?;
        Some(if big_endian {
            u32::from_be_bytes(bytes)
        } else {
            u32::from_le_bytes(bytes)
        })
    };
    // The element header: explicit VR (OB or OW, two reserved bytes, 4-byte length) or
    // implicit (4-byte length). The first place where one parses is the element.
    let mut search = 132;
    let (value_start, length) = loop {
        let found = file[search.min(file.len())..]
            .windows(4)
            .position(|w| w == tag)
            .map(|p| p + search)
            .ok_or("no pixel data (7fe0,0010)")?;
        let parsed = if explicit {
            match file.get(found + 4..found + 8) {
                Some([b'O', b'B' | b'W', 0, 0]) => u32_at(found + 8).map(|len| (found + 12, len)),
                _ => None,
            }
        } else {
            u32_at(found + 4).map(|len| (found + 8, len))
        };
        match parsed {
            Some((start, len)) if len == u32::MAX || start + len as usize <= file.len() => {
                break (start, len);
            }
            _ => search = found + 1,
        }
    };
    if length != u32::MAX {
        return Ok(PixelPayload::Native(
            file[value_start..value_start + length as usize].to_vec(),
        ));
    }
    // Encapsulated: items (FFFE,E000) until the sequence delimiter (FFFE,E0DD).
    let mut at = value_start;
    let mut items = Vec::new();
    loop {
        let (group, element) = (
            u32_at(at).ok_or_else(|| format!("encapsulated pixel data ends early (byte {at})"))?,
            u32_at(at + 4),
        );
        let length = element
            .ok_or_else(|| format!("encapsulated pixel data ends early (byte {at})"))?
            as usize;
        let item_tag = if big_endian {
            group
        } else {
            group.rotate_right(16)
        };
        match item_tag {
            0xfffe_e000 => {
                let item = file
                    .get(at + 8..(at + 8).saturating_add(length))
                    .ok_or_else(|| {
                        format!(
                            "the pixel data fragment at byte {at} declares {length} bytes, past the end of the file"
                        )
                    })?;
                items.push(item.to_vec());
                at += 8 + length;
            }
            0xfffe_e0dd => break,
            other => {
                return Err(format!(
                    "unexpected element ({:04x},{:04x}) at byte {at} in encapsulated pixel data",
                    other >> 16,
                    other & 0xffff
                ));
            }
        }
    }
    // The first item is the basic offset table; one fragment per frame is assumed (RLE).
    Ok(PixelPayload::Fragments(items.into_iter().skip(1).collect()))
}

/// Decodes one RLE Lossless frame (PS3.5 annex G): a 64-byte header of segment offsets, one
/// segment per byte of a pixel, most significant first; appends little-endian pixels.
fn decode_rle_frame(
    fragment: &[u8],
    pixels: usize,
    bytes_per: usize,
    out: &mut Vec<u8>,
) -> Result<(), Problem> {
    if fragment.len() < 64 {
        return Err("RLE frame shorter than its header".into());
    }
    let word = |i: usize| {
        u32::from_le_bytes(fragment[4 * i..4 * i + 4].try_into().expect("4 bytes")) as usize
    };
    let segments = word(0);
    if segments != bytes_per {
        return Err(format!(
            "RLE frame has {segments} segments for {bytes_per}-byte pixels"
        ));
    }
    if pixels > fragment.len().saturating_mul(MAX_RLE_EXPANSION) {
        return Err(format!(
            "an RLE frame of {} bytes cannot hold {pixels} pixels",
            fragment.len()
        ));
    }
    let start = out.len();
    out.resize(start + pixels * bytes_per, 0);
    for segment in 0..segments {
        let begin = word(1 + segment);
        let end = if segment + 1 < segments {
            word(2 + segment)
        } else {
            fragment.len()
        };
        if begin < 64 || begin > end || end > fragment.len() {
            return Err("RLE segment offsets point outside the frame".into());
        }
        let data = &fragment[begin..end];
        // Segment 0 holds the most significant byte.
        let byte_index = bytes_per - 1 - segment;
        let mut pixel = 0usize;
        let mut i = 0usize;
        while i < data.len() && pixel < pixels {
            let n = data[i] as i8;
            i += 1;
            if n >= 0 {
                let count = n as usize + 1;
                let literal = data
                    .get(i..i + count)
                    .ok_or("RLE literal run past the segment end")?;
                for &b in literal.iter().take(pixels - pixel) {
                    out[start + pixel * bytes_per + byte_index] = b;
                    pixel += 1;
                }
                i += count;
            } else if n != -128 {
                let count = (1 - n as isize) as usize;
                let b = *data
                    .get(i)
                    .ok_or("RLE replicate run past the segment end")?;
                i += 1;
                for _ in 0..count.min(pixels - pixel) {
                    out[start + pixel * bytes_per + byte_index] = b;
                    pixel += 1;
                }
            }
        }
        if pixel < pixels {
            return Err(format!("RLE segment decodes {pixel} of {pixels} pixels"));
        }
    }
    Ok(())
}

fn syntax_name(uid: &str) -> &'static str {
    match uid {
        "1.2.840.10008.1.2.4.50" | "1.2.840.10008.1.2.4.51" => "JPEG baseline/extended",
        "1.2.840.10008.1.2.4.57" | "1.2.840.10008.1.2.4.70" => "JPEG lossless",
        "1.2.840.10008.1.2.4.80" | "1.2.840.10008.1.2.4.81" => "JPEG-LS",
        "1.2.840.10008.1.2.4.90" | "1.2.840.10008.1.2.4.91" => "JPEG 2000",
        "1.2.840.10008.1.2.4.201" | "1.2.840.10008.1.2.4.202" | "1.2.840.10008.1.2.4.203" => {
            "HTJ2K"
        }
        _ => "unknown",
    }
}

/// Rows or Columns: 1 to 65535 (an unsigned 16-bit value); the problem names the tag.
fn image_side(
    object: &DefaultDicomObject,
    tag: dicom_core::Tag,
    name: &str,
) -> Result<usize, Problem> {
    let element = object
        .element_opt(tag)
        .ok()
        .flatten()
        .ok_or_else(|| format!("no {name} {}", walk::tag_name(tag)))?;
    let value = element
        .to_int::<i64>()
        .map_err(|_| format!("{name} {} is not a number", walk::tag_name(tag)))?;
    if !(1..=65535).contains(&value) {
        return Err(format!(
            "{name} {} is {value}, expected 1 to 65535",
            walk::tag_name(tag)
        ));
    }
    Ok(value as usize)
}

/// NumberOfFrames, 1 when absent or not positive.
fn frame_count(object: &DefaultDicomObject) -> usize {
    integer(object, tags::NUMBER_OF_FRAMES)
        .filter(|&n| n >= 1)
        .map_or(1, |n| usize::try_from(n).unwrap_or(usize::MAX))
}

fn describe(description: &str) -> String {
    if description.is_empty() {
        String::new()
    } else {
        format!(", {description}")
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::decode_rle_frame;

    #[test]
    fn rle_frames_decode_to_little_endian_pixels() {
        // Two segments (high bytes, then low bytes), each a PackBits replicate run of four
        // and a literal run of two. (tests/dicom.rs writes whole RLE files with an encoder.)
        let pixels: Vec<u16> = vec![7, 7, 7, 7, 0x1234, 0xabcd];
        let high = [0xfd, 0x00, 0x01, 0x12, 0xab];
        let low = [0xfd, 0x07, 0x01, 0x34, 0xcd];
        let mut frame = vec![0u8; 64];
        frame[0..4].copy_from_slice(&2u32.to_le_bytes());
        frame[4..8].copy_from_slice(&64u32.to_le_bytes());
        frame[8..12].copy_from_slice(&(64 + high.len() as u32).to_le_bytes());
        frame.extend(high);
        frame.extend(low);
        let mut out = Vec::new();
        decode_rle_frame(&frame, pixels.len(), 2, &mut out).unwrap();
        let decoded: Vec<u16> = out
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(decoded, pixels);

        // A frame cut short is an error, not a panic.
        let mut out = Vec::new();
        assert!(decode_rle_frame(&frame[..frame.len() - 2], pixels.len(), 2, &mut out).is_err());
        assert!(decode_rle_frame(&frame[..30], pixels.len(), 2, &mut out).is_err());
    }
}
