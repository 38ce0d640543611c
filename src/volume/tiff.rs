//! Multi-page TIFF stacks (microscopy): one grayscale page per z slice, 8/16/32-bit integer or
//! 16/32/64-bit float samples; spacing from ImageJ's or OME-TIFF's metadata when present.

use std::path::Path;

use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

use super::error::Problem;
use super::io::{io_reason, open};
use super::{MAX_VOXELS, Volume, VoxelData};

/// Bytes one decoded page may take at most.
const MAX_PAGE_BYTES: u64 = 1 << 31;

/// No TIFF compression (LZW, Deflate, PackBits) expands one byte to more than this many, so
/// a page claiming more than the file size times this is false and is refused before any
/// buffer of that size exists.
const MAX_EXPANSION: u64 = 4096;

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
    let page_limit = file_bytes.saturating_mul(MAX_EXPANSION).min(MAX_PAGE_BYTES) as usize;
    let mut limits = Limits::default();
    limits.decoding_buffer_size = page_limit;
    limits.intermediate_buffer_size = page_limit;
    let mut decoder = Decoder::new(open(path)?)
        .map_err(|e| format!("not a readable TIFF: {}", tiff_reason(&e)))?
        .with_limits(limits);
    let (width, height) = decoder
        .dimensions()
        .map_err(|e| format!("bad TIFF page 1: {}", tiff_reason(&e)))?;
    check_gray(&mut decoder, 1)?;
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
            .map_err(|e| format!("bad TIFF page {pages}: {}", tiff_reason(&e)))?;
        if (w, h) != (width, height) {
            return Err(format!(
                "page {pages} is {w}x{h} but page 1 is {width}x{height}; a stack needs equal pages"
            ));
        }
        check_gray(&mut decoder, pages)?;
        if page_voxels.saturating_mul(pages) > MAX_VOXELS {
            return Err(format!(
                "more than {MAX_VOXELS} voxels ({width}x{height} pages, {pages} so far)"
            ));
        }
        let page = decoder
            .read_image()
            .map_err(|e| format!("cannot decode page {pages}: {}", tiff_reason(&e)))?;
        append_page(&mut stack, page, pages)?;
        if !decoder.more_images() {
            break;
        }
        decoder
            .next_image()
            .map_err(|e| format!("bad TIFF page {}: {}", pages + 1, tiff_reason(&e)))?;
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
) -> Result<(), Problem> {
    match decoder.colortype() {
        Ok(ColorType::Gray(_)) => Ok(()),
        Ok(other) => Err(format!(
            "page {page} is {other:?}; only grayscale pages are supported (one value per voxel)"
        )),
        Err(e) => Err(format!("bad TIFF page {page}: {}", tiff_reason(&e))),
    }
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
                    "unit" => metadata.unit = Some(value.trim().replace("\\u00B5", "µ")),
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
            metadata.unit = xml_attribute(description, "PhysicalSizeXUnit").map(str::to_owned);
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

fn tiff_reason(error: &tiff::TiffError) -> String {
    match error {
        tiff::TiffError::IoError(e) => io_reason(e),
        other => other
            .to_string()
            .lines()
            .next()
            .unwrap_or_default()
            .to_owned(),
    }
}
