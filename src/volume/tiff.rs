//! Multi-page TIFF stacks (microscopy): one grayscale page per z slice, 8/16/32-bit integer or
//! 16/32/64-bit float samples; spacing from ImageJ's or OME-TIFF's metadata when present.

use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;
use tiff::{ColorType, TiffUnsupportedError};

use super::error::{Problem, printable};
use super::io::{io_reason, open};
use super::{MAX_VOXELS, Volume, VoxelData};

/// Bytes one decoded page may take at most.
const MAX_PAGE_BYTES: u64 = 1 << 31;

/// No TIFF compression (LZW, Deflate, PackBits) expands one byte to more than this many, so
/// pages claiming more than the file size times this (each, and all together: pages may share
/// one strip) are false and are refused before any buffer of that size exists.
const MAX_EXPANSION: u64 = 4096;

/// The tiff crate reads the first page's tags with its default limits (up to 256 MiB of
/// values for one tag) before limits can be set. So every tag of every page is checked here
/// first: a tag whose values are stored elsewhere must fit in the file after its offset. A
/// count that fails this is false, and nothing of its size is allocated. Pages are followed
/// until the chain ends, loops or leaves the file; the directories of a real file never
/// overlap, so all of them together fit in the file too, which bounds the time.
fn check_tag_counts(path: &Path, file_bytes: u64) -> Result<(), Problem> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = open(path)?;
    let mut read_at = |offset: u64, buffer: &mut [u8]| -> bool {
        file.seek(SeekFrom::Start(offset)).is_ok() && file.read_exact(buffer).is_ok()
    };
    let mut header = [0u8; 16];
    if !read_at(0, &mut header[..8]) {
        return Ok(()); // too short: the decoder says so
    }
    let big_endian = match &header[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return Ok(()),
    };
    let number = |bytes: &[u8]| -> u64 {
        let mut value = 0u64;
        for i in 0..bytes.len() {
            let byte = if big_endian {
                bytes[i]
            } else {
                bytes[bytes.len() - 1 - i]
            };
            value = (value << 8) | byte as u64;
        }
        value
    };
    let bigtiff = number(&header[2..4]) == 43;
    let (count_bytes, entry_bytes, word) = if bigtiff { (8, 20, 8) } else { (2, 12, 4) };
    let mut next = if bigtiff {
        if !read_at(8, &mut header[8..16]) {
            return Ok(());
        }
        number(&header[8..16])
    } else {
        number(&header[4..8])
    };
    let mut seen = std::collections::HashSet::new();
    let mut page = 0usize;
    let mut directory_bytes = 0u64;
    while next != 0 && next < file_bytes && seen.insert(next) {
        page += 1;
        let mut count = [0u8; 8];
        if !read_at(next, &mut count[..count_bytes]) {
            return Ok(());
        }
        let entries = number(&count[..count_bytes]);
        let table = entries.saturating_mul(entry_bytes as u64);
        if table > file_bytes - next {
            return Err(format!(
                "TIFF page {page}: its directory at byte {next} declares {entries} tags, more than the file holds"
            ));
        }
        directory_bytes += table;
        if directory_bytes > file_bytes {
            return Err(format!(
                "TIFF page {page}: the pages' directories overlap (together larger than the file)"
            ));
        }
        let mut directory = vec![0u8; table as usize + word];
        if !read_at(next + count_bytes as u64, &mut directory[..table as usize]) {
            return Ok(());
        }
        for entry in directory[..table as usize].chunks_exact(entry_bytes) {
            let tag = number(&entry[0..2]);
            let size: u64 = match number(&entry[2..4]) {
                3 | 8 => 2,
                4 | 9 | 11 | 13 => 4,
                5 | 10 | 12 | 16 | 17 | 18 => 8,
                _ => 1,
            };
            let values = number(&entry[4..4 + word]);
            let bytes = values.saturating_mul(size);
            if bytes > word as u64 {
                let offset = number(&entry[4 + word..4 + 2 * word]);
                if bytes > file_bytes.saturating_sub(offset) {
                    return Err(format!(
                        "TIFF page {page}: tag {tag} declares {values} values of {size} bytes at byte {offset}, more than the file holds"
                    ));
                }
            }
        }
        let mut pointer = [0u8; 8];
        let after = next + count_bytes as u64 + table;
        if !read_at(after, &mut pointer[..word]) {
            return Ok(());
        }
        next = number(&pointer[..word]);
    }
    Ok(())
}

/// The decoder's limits for a page when `budget` bytes of decoded pages remain.
fn page_limits(budget: u64) -> Limits {
    let page_limit = budget.min(MAX_PAGE_BYTES) as usize;
    let mut limits = Limits::default();
    limits.decoding_buffer_size = page_limit;
    limits.intermediate_buffer_size = page_limit;
    limits
}

/// TIFF and BigTIFF in either byte order.
pub(super) fn sniff(head: &[u8]) -> bool {
    [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"]
        .iter()
        .any(|magic| head.starts_with(*magic))
}

/// Reads `path` as a stack of TIFF pages (z = page order).
pub(super) fn load(path: &Path) -> Result<Volume, Problem> {
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| format!("cannot open: {}", io_reason(&e)))?
        .len();
    check_tag_counts(path, file_bytes)?;
    // What all pages together may decode to.
    let mut budget = file_bytes.saturating_mul(MAX_EXPANSION);
    let mut decoder = Decoder::new(open(path)?)
        .map_err(|e| format!("not a readable TIFF: {}", tiff_reason(&e, budget)))?
        .with_limits(page_limits(budget));
    let (width, height) = decoder
        .dimensions()
        .map_err(|e| format!("bad TIFF page 1: {}", tiff_reason(&e, budget)))?;
    check_gray(&mut decoder, 1, budget)?;
    let description = decoder.get_tag_ascii_string(Tag::ImageDescription).ok();
    let metadata = StackMetadata::parse(description.as_deref(), &mut decoder);
    if metadata.channels > 1 || metadata.frames > 1 {
        return Err(format!(
            "an ImageJ hyperstack with {} channels and {} time points; only single-channel 3-D stacks are supported (split it in ImageJ first)",
            metadata.channels, metadata.frames
        ));
    }

    let page_voxels = width as usize * height as usize;
    let mut stack: Option<VoxelData> = None;
    let mut pages = 0usize;
    loop {
        pages += 1;
        let (w, h) = decoder
            .dimensions()
            .map_err(|e| format!("bad TIFF page {pages}: {}", tiff_reason(&e, budget)))?;
        if (w, h) != (width, height) {
            return Err(format!(
                "page {pages} is {w}x{h} but page 1 is {width}x{height}; a stack needs equal pages"
            ));
        }
        check_gray(&mut decoder, pages, budget)?;
        if page_voxels.saturating_mul(pages) > MAX_VOXELS {
            return Err(format!(
                "more than {MAX_VOXELS} voxels ({width}x{height} pages, {pages} so far)"
            ));
        }
        let page = decoder
            .read_image()
            .map_err(|e| format!("cannot decode page {pages}: {}", tiff_reason(&e, budget)))?;
        budget = budget.saturating_sub(page_bytes(&page));
        decoder = decoder.with_limits(page_limits(budget));
        append_page(&mut stack, page, pages)?;
        if !decoder.more_images() {
            break;
        }
        decoder
            .next_image()
            .map_err(|e| format!("bad TIFF page {}: {}", pages + 1, tiff_reason(&e, budget)))?;
    }
    let data = stack.expect("at least one page was read");
    if data.len() != page_voxels * pages {
        return Err(format!(
            "pages hold {} samples, expected {} ({width}x{height}x{pages})",
            data.len(),
            page_voxels * pages
        ));
    }
    let name = path.display().to_string();
    let mut volume = Volume::new(
        name,
        "TIFF",
        [width as usize, height as usize, pages],
        metadata.spacing,
        data,
    )
    .map_err(|e| e.problem)?;
    volume.metadata = metadata.facts(pages);
    Ok(volume)
}

fn check_gray(
    decoder: &mut Decoder<impl std::io::Read + std::io::Seek>,
    page: usize,
    budget: u64,
) -> Result<(), Problem> {
    match decoder.colortype() {
        Ok(ColorType::Gray(_)) => Ok(()),
        Ok(other) => Err(format!(
            "page {page} is {}; only grayscale pages are supported (one value per voxel)",
            color_name(other)
        )),
        Err(e) => Err(format!("bad TIFF page {page}: {}", tiff_reason(&e, budget))),
    }
}

/// A TIFF color type in words: `RGB, 8 bits per sample`, `4 samples of 16 bits`.
fn color_name(color: ColorType) -> String {
    let (name, bits) = match color {
        ColorType::Gray(bits) => ("grayscale", bits),
        ColorType::RGB(bits) => ("RGB", bits),
        ColorType::Palette(bits) => ("palette color", bits),
        ColorType::GrayA(bits) => ("grayscale with alpha", bits),
        ColorType::RGBA(bits) => ("RGBA", bits),
        ColorType::CMYK(bits) => ("CMYK", bits),
        ColorType::CMYKA(bits) => ("CMYK with alpha", bits),
        ColorType::YCbCr(bits) => ("YCbCr", bits),
        ColorType::Lab(bits) => ("CIE L*a*b*", bits),
        ColorType::Multiband {
            bit_depth,
            num_samples,
        } => return format!("{num_samples} samples of {bit_depth} bits per pixel"),
        // A color type added to the crate later.
        _ => return "a color type other than grayscale".into(),
    };
    format!("{name}, {bits} bits per sample")
}

/// Bytes of a decoded page.
fn page_bytes(page: &DecodingResult) -> u64 {
    let (count, size) = match page {
        DecodingResult::U8(v) => (v.len(), 1),
        DecodingResult::I8(v) => (v.len(), 1),
        DecodingResult::U16(v) => (v.len(), 2),
        DecodingResult::I16(v) => (v.len(), 2),
        DecodingResult::F16(v) => (v.len(), 2),
        DecodingResult::U32(v) => (v.len(), 4),
        DecodingResult::I32(v) => (v.len(), 4),
        DecodingResult::F32(v) => (v.len(), 4),
        DecodingResult::U64(v) => (v.len(), 8),
        DecodingResult::I64(v) => (v.len(), 8),
        DecodingResult::F64(v) => (v.len(), 8),
    };
    (count * size) as u64
}

/// Appends a decoded page to the stack, which takes the first page's sample type.
fn append_page(
    stack: &mut Option<VoxelData>,
    page: DecodingResult,
    number: usize,
) -> Result<(), Problem> {
    let page = match page {
        DecodingResult::U8(v) => VoxelData::U8(v),
        DecodingResult::I8(v) => VoxelData::I8(v),
        DecodingResult::U16(v) => VoxelData::U16(v),
        DecodingResult::I16(v) => VoxelData::I16(v),
        DecodingResult::U32(v) => VoxelData::U32(v),
        DecodingResult::I32(v) => VoxelData::I32(v),
        DecodingResult::F32(v) => VoxelData::F32(v),
        DecodingResult::F64(v) => VoxelData::F64(v),
        DecodingResult::F16(v) => VoxelData::F32(v.into_iter().map(f32::from).collect()),
        DecodingResult::U64(_) | DecodingResult::I64(_) => {
            return Err("64-bit integer samples are not supported".into());
        }
    };
    match stack {
        None => *stack = Some(page),
        Some(stack) => stack.append(page).map_err(|page| {
            format!(
                "page {number} holds {} samples but page 1 holds {}; a stack needs one sample type",
                page.voxel_type().name(),
                stack.voxel_type().name()
            )
        })?,
    }
    Ok(())
}

/// What ImageJ's or OME's description (and the resolution tags) say about the stack.
struct StackMetadata {
    spacing: [f64; 3],
    unit: Option<String>,
    source: Option<&'static str>,
    channels: usize,
    frames: usize,
}

impl StackMetadata {
    fn parse(
        description: Option<&str>,
        decoder: &mut Decoder<impl std::io::Read + std::io::Seek>,
    ) -> Self {
        let mut metadata = Self {
            spacing: [1.0; 3],
            unit: None,
            source: None,
            channels: 1,
            frames: 1,
        };
        let description = description.unwrap_or_default();
        if description.starts_with("ImageJ=") {
            metadata.source = Some("ImageJ");
            // XResolution / YResolution are pixels per unit.
            for (axis, tag) in [(0, Tag::XResolution), (1, Tag::YResolution)] {
                if let Some(per_unit) = rational(decoder, tag).filter(|r| *r > 0.0) {
                    metadata.spacing[axis] = 1.0 / per_unit;
                }
            }
            for line in description.lines() {
                let Some((key, value)) = line.split_once('=') else {
                    continue;
                };
                match key.trim() {
                    "spacing" => {
                        if let Ok(z) = value.trim().parse::<f64>() {
                            metadata.spacing[2] = z;
                        }
                    }
                    "unit" => {
                        metadata.unit = Some(printable(&value.trim().replace("\\u00B5", "µ")))
                    }
                    "channels" => metadata.channels = value.trim().parse().unwrap_or(1),
                    "frames" => metadata.frames = value.trim().parse().unwrap_or(1),
                    _ => {}
                }
            }
        } else if description.contains("<OME") {
            metadata.source = Some("OME-TIFF");
            for (axis, key) in ["PhysicalSizeX", "PhysicalSizeY", "PhysicalSizeZ"]
                .iter()
                .enumerate()
            {
                if let Some(value) = xml_attribute(description, key).and_then(|v| v.parse().ok()) {
                    metadata.spacing[axis] = value;
                }
            }
            metadata.unit = xml_attribute(description, "PhysicalSizeXUnit").map(printable);
            metadata.channels = xml_attribute(description, "SizeC")
                .and_then(|v| v.parse().ok())
                .unwrap_or(1);
            metadata.frames = xml_attribute(description, "SizeT")
                .and_then(|v| v.parse().ok())
                .unwrap_or(1);
        }
        if metadata
            .spacing
            .iter()
            .any(|s| !(s.is_finite() && *s > 0.0))
        {
            metadata.spacing = [1.0; 3];
        }
        metadata
    }

    fn facts(&self, pages: usize) -> Vec<(String, String)> {
        let mut facts = vec![("pages".to_owned(), pages.to_string())];
        facts.push((
            "spacing from".to_owned(),
            self.source.unwrap_or("nothing (1 per voxel)").to_owned(),
        ));
        if let Some(unit) = &self.unit {
            facts.push(("unit".to_owned(), unit.clone()));
        }
        facts
    }
}

fn rational(decoder: &mut Decoder<impl std::io::Read + std::io::Seek>, tag: Tag) -> Option<f64> {
    match decoder.find_tag(tag).ok()?? {
        tiff::decoder::ifd::Value::Rational(n, d) if d != 0 => Some(n as f64 / d as f64),
        other => other.into_f64().ok(),
    }
}

/// The value of the first `key="value"` in `xml`.
fn xml_attribute<'a>(xml: &'a str, key: &str) -> Option<&'a str> {
    let start = xml.find(&format!("{key}=\""))? + key.len() + 2;
    let end = xml[start..].find('"')?;
    Some(&xml[start..start + end])
}

/// What went wrong in the tiff crate, in words that say what pointed where: its own text for
/// format errors (lists shortened), and for the bare ones (`failed to fill whole buffer`,
/// `decoder limits exceeded`, `Invalid argument`) what they mean in a TIFF.
fn tiff_reason(error: &tiff::TiffError, budget: u64) -> String {
    match error {
        tiff::TiffError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends early: an offset or byte count points past its end".into()
        }
        tiff::TiffError::IoError(e) if e.kind() == std::io::ErrorKind::InvalidInput => {
            "an offset in the file points outside it".into()
        }
        tiff::TiffError::IoError(e) => io_reason(e),
        tiff::TiffError::LimitsExceeded => format!(
            "the page would decode to more than {} bytes, more than a file of this size can hold",
            budget.min(MAX_PAGE_BYTES)
        ),
        tiff::TiffError::IntSizeError => "a size in the file is too large".into(),
        // These print a color type with Rust's debug formatting: say it in words.
        tiff::TiffError::UnsupportedError(
            TiffUnsupportedError::FloatingPointPredictor(color)
            | TiffUnsupportedError::HorizontalPredictor(color),
        ) => format!("a predictor for {} is not supported", color_name(*color)),
        tiff::TiffError::UnsupportedError(TiffUnsupportedError::UnsupportedColorType(color)) => {
            format!("{} is not supported", color_name(*color))
        }
        other => shorten_lists(other.to_string().lines().next().unwrap_or_default()),
    }
}

/// `text` with every bracketed list of more than four items cut to its first four and a
/// count: the tiff crate prints all values of a tag (`[8, 8, 8, …]`, thousands of them).
fn shorten_lists(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(open) = rest.find('[') {
        let Some(close) = rest[open..].find(']').map(|c| open + c) else {
            break;
        };
        out.push_str(&rest[..open]);
        let items: Vec<&str> = rest[open + 1..close].split(',').map(str::trim).collect();
        out.push('[');
        out.push_str(&super::error::short_list(&items));
        out.push(']');
        rest = &rest[close + 1..];
    }
    out.push_str(rest);
    out
}
