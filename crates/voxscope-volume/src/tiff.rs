//! Multi-page TIFF stacks (microscopy): one grayscale page per z slice, 8/16/32-bit integer or
//! 16/32/64-bit float samples; spacing from ImageJ's or OME-TIFF's metadata when present.
//! ImageJ hyperstacks (`channels`, `slices`, `frames`; pages XYCZT) and OME-TIFF (`SizeC`,
//! `SizeZ`, `SizeT`, `DimensionOrder`) give one channel and time point; samples of a pixel
//! (RGB, or channels stored as samples) are channels too. ImageJ's LUTs and slice labels
//! (IJMetadata) give the channels' colors and names.

use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;
use tiff::{ColorType, TiffUnsupportedError};

use super::error::{Problem, printable};
use super::io::{io_reason, open};
use super::series::parse_ome_color;
use super::{ChannelInfo, MAX_VOXELS, Selection, Series, Volume, VoxelData};

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
/// overlap, so all of them together fit in the file too, which bounds the time. Returns the
/// pages found (those before a directory that cannot be read: the decoder reports that one).
fn check_tag_counts(path: &Path, file_bytes: u64) -> Result<usize, Problem> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = open(path)?;
    let mut read_at = |offset: u64, buffer: &mut [u8]| -> bool {
        file.seek(SeekFrom::Start(offset)).is_ok() && file.read_exact(buffer).is_ok()
    };
    let mut header = [0u8; 16];
    if !read_at(0, &mut header[..8]) {
        return Ok(1); // too short: the decoder says so
    }
    let big_endian = match &header[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return Ok(1),
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
            return Ok(1);
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
            return Ok(page);
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
            return Ok(page);
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
            return Ok(page);
        }
        next = number(&pointer[..word]);
    }
    // A chain that points outside the file or back into itself: count the bad page, so the
    // decoder, reaching it, says what is wrong.
    let bad_link = (next != 0) as usize;
    Ok((page + bad_link).max(1))
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

/// Reads frame `select` of `path`: a stack of TIFF pages (z = page order), or one channel
/// and time point of an ImageJ hyperstack or OME-TIFF (only that frame's pages are decoded;
/// a channel stored as samples of each pixel is picked out of them).
pub(super) fn load(path: &Path, select: Selection) -> Result<Volume, Problem> {
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| format!("cannot open: {}", io_reason(&e)))?
        .len();
    let page_count = check_tag_counts(path, file_bytes)?;
    // What all pages together may decode to.
    let mut budget = file_bytes.saturating_mul(MAX_EXPANSION);
    let mut decoder = Decoder::new(open(path)?)
        .map_err(|e| format!("not a readable TIFF: {}", tiff_reason(&e, budget)))?
        .with_limits(page_limits(budget));
    let (width, height) = decoder
        .dimensions()
        .map_err(|e| format!("bad TIFF page 1: {}", tiff_reason(&e, budget)))?;
    let samples = check_samples(&mut decoder, 1, budget)?;
    let description = decoder.get_tag_ascii_string(Tag::ImageDescription).ok();
    let metadata = StackMetadata::parse(description.as_deref(), &mut decoder);
    let layout = PageLayout::new(&metadata, samples, page_count)?;
    select.check(layout.channels(), layout.frames)?;
    let (page_channel, sample) = (select.channel / samples, select.channel % samples);
    let wanted: Vec<usize> = (0..layout.slices)
        .map(|z| layout.page(page_channel, z, select.time))
        .collect();

    let page_voxels = width as usize * height as usize;
    if page_voxels.saturating_mul(wanted.len()) > MAX_VOXELS {
        return Err(format!(
            "more than {MAX_VOXELS} voxels ({width}x{height} pages, {} of them)",
            wanted.len()
        ));
    }
    let mut stack: Option<VoxelData> = None;
    let mut page = 0usize;
    for &index in &wanted {
        // Pages between the wanted ones are passed by their directories alone.
        while page < index {
            if !decoder.more_images() {
                return Err(format!(
                    "the file ends after {} pages; frame (channel {}, time point {}) needs page {}",
                    page + 1,
                    select.channel,
                    select.time,
                    index + 1
                ));
            }
            decoder
                .next_image()
                .map_err(|e| format!("bad TIFF page {}: {}", page + 2, tiff_reason(&e, budget)))?;
            page += 1;
        }
        let number = page + 1;
        let (w, h) = decoder
            .dimensions()
            .map_err(|e| format!("bad TIFF page {number}: {}", tiff_reason(&e, budget)))?;
        if (w, h) != (width, height) {
            return Err(format!(
                "page {number} is {w}x{h} but page 1 is {width}x{height}; a stack needs equal pages"
            ));
        }
        if check_samples(&mut decoder, number, budget)? != samples {
            return Err(format!(
                "page {number} has a different number of samples per pixel than page 1"
            ));
        }
        let planar = decoder
            .find_tag_unsigned::<u16>(Tag::PlanarConfiguration)
            .ok()
            .flatten()
            == Some(2);
        let mut decoded = DecodingResult::U8(Vec::new());
        decoder
            .read_image_to_buffer(&mut decoded)
            .map_err(|e| format!("cannot decode page {number}: {}", tiff_reason(&e, budget)))?;
        budget = budget.saturating_sub(page_bytes(&decoded));
        decoder = decoder.with_limits(page_limits(budget));
        let values = one_sample(decoded, samples, sample, planar, page_voxels)
            .map_err(|p| format!("page {number}: {p}"))?;
        append_page(&mut stack, values, number)?;
    }
    let data = stack.expect("at least one page was read");
    if data.len() != page_voxels * wanted.len() {
        return Err(format!(
            "pages hold {} samples, expected {} ({width}x{height}x{})",
            data.len(),
            page_voxels * wanted.len(),
            wanted.len()
        ));
    }
    let name = path.display().to_string();
    let mut volume = Volume::new(
        name,
        "TIFF",
        [width as usize, height as usize, wanted.len()],
        metadata.spacing,
        data,
    )
    .map_err(|e| e.problem)?;
    volume.metadata = metadata.facts(page_count);
    let mut series = Series::plain(layout.channels(), layout.frames, select);
    for (channel, info) in series.channels.iter_mut().enumerate() {
        if let Some(named) = metadata.channel_info.get(channel) {
            *info = named.clone();
        } else if samples == 1 {
            // ImageJ: the channel's LUT color, and the label of its first page.
            let imagej = &metadata.imagej;
            info.color = imagej.lut_colors.get(channel).copied();
            info.name = imagej
                .labels
                .get(layout.page(channel, 0, 0))
                .filter(|label| !label.is_empty())
                .cloned();
        }
    }
    volume.series = series;
    Ok(volume)
}

/// How the pages of a file map to channels, z slices and time points.
#[derive(Debug, Clone, PartialEq)]
struct PageLayout {
    /// Channels stored as pages (each may hold several samples per pixel).
    page_channels: usize,
    /// Samples per pixel (each a channel of its own).
    samples: usize,
    slices: usize,
    frames: usize,
    /// The page stride of channel, z and time.
    strides: [usize; 3],
}

impl PageLayout {
    /// The layout `metadata` describes for a file of `pages` pages with `samples` samples a
    /// pixel; a description that disagrees with the pages is an error.
    fn new(metadata: &StackMetadata, samples: usize, pages: usize) -> Result<Self, Problem> {
        // OME counts samples among SizeC; ImageJ counts page channels.
        let page_channels = if metadata.source == Some("OME-TIFF")
            && samples > 1
            && metadata.channels.is_multiple_of(samples)
        {
            metadata.channels / samples
        } else {
            metadata.channels
        }
        .max(1);
        let frames = metadata.frames.max(1);
        let plain = page_channels == 1 && frames == 1;
        let slices = match metadata.slices {
            // A plain stack is all its pages, whatever a description says of slices.
            _ if plain => pages,
            Some(slices) if slices > 0 => slices,
            _ => pages / (page_channels * frames),
        };
        let needed = page_channels
            .checked_mul(slices)
            .and_then(|n| n.checked_mul(frames));
        if slices == 0 || needed.is_none_or(|n| n > pages) {
            return Err(format!(
                "the {} description declares {page_channels} channels x {slices} slices x {frames} time points, but the file has {pages} pages",
                metadata.source.unwrap_or("TIFF")
            ));
        }
        // Fastest first: ImageJ stores channel, then z, then time (XYCZT).
        let order = metadata.dimension_order.as_deref().unwrap_or("XYCZT");
        let extent = |axis: char| match axis {
            'C' => page_channels,
            'Z' => slices,
            _ => frames,
        };
        let mut strides = [0usize; 3];
        let mut stride = 1;
        for axis in order.chars().skip(2) {
            let slot = match axis {
                'C' => 0,
                'Z' => 1,
                _ => 2,
            };
            strides[slot] = stride;
            stride *= extent(axis);
        }
        Ok(Self {
            page_channels,
            samples,
            slices,
            frames,
            strides,
        })
    }

    /// Channels in all: page channels times samples per pixel.
    fn channels(&self) -> usize {
        self.page_channels * self.samples
    }

    /// The page (0-based) of page channel `channel`, slice `z`, time point `time`.
    fn page(&self, channel: usize, z: usize, time: usize) -> usize {
        channel * self.strides[0] + z * self.strides[1] + time * self.strides[2]
    }
}

/// The samples per pixel of the current page: grayscale, RGB(A) or any number of bands,
/// each read as a channel; palette and other color models are refused.
fn check_samples(
    decoder: &mut Decoder<impl std::io::Read + std::io::Seek>,
    page: usize,
    budget: u64,
) -> Result<usize, Problem> {
    match decoder.colortype() {
        Ok(ColorType::Gray(_)) => Ok(1),
        Ok(ColorType::GrayA(_)) => Ok(2),
        Ok(ColorType::RGB(_)) => Ok(3),
        Ok(ColorType::RGBA(_)) => Ok(4),
        Ok(ColorType::Multiband { num_samples, .. }) => Ok(num_samples.max(1) as usize),
        Ok(other) => Err(format!(
            "page {page} is {}; only grayscale pages and samples read as channels are supported",
            color_name(other)
        )),
        Err(e) => Err(format!("bad TIFF page {page}: {}", tiff_reason(&e, budget))),
    }
}

/// Sample `sample` of each of a page's `pixels` pixels, from samples interleaved (chunky) or
/// stored plane after plane (planar).
fn one_sample(
    page: DecodingResult,
    samples: usize,
    sample: usize,
    planar: bool,
    pixels: usize,
) -> Result<DecodingResult, Problem> {
    if samples == 1 {
        return Ok(page);
    }
    fn pick<T: Copy>(
        values: Vec<T>,
        samples: usize,
        sample: usize,
        planar: bool,
        pixels: usize,
    ) -> Result<Vec<T>, Problem> {
        if planar {
            values
                .get(sample * pixels..(sample + 1) * pixels)
                .map(<[T]>::to_vec)
                .ok_or_else(|| format!("its plane of sample {sample} did not decode"))
        } else if values.len() >= pixels * samples {
            Ok(values
                .into_iter()
                .skip(sample)
                .step_by(samples)
                .take(pixels)
                .collect())
        } else {
            Err(format!(
                "{} samples decoded for {pixels} pixels of {samples} samples",
                values.len()
            ))
        }
    }
    Ok(match page {
        DecodingResult::U8(v) => DecodingResult::U8(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::I8(v) => DecodingResult::I8(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::U16(v) => DecodingResult::U16(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::I16(v) => DecodingResult::I16(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::F16(v) => DecodingResult::F16(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::U32(v) => DecodingResult::U32(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::I32(v) => DecodingResult::I32(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::F32(v) => DecodingResult::F32(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::U64(v) => DecodingResult::U64(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::I64(v) => DecodingResult::I64(pick(v, samples, sample, planar, pixels)?),
        DecodingResult::F64(v) => DecodingResult::F64(pick(v, samples, sample, planar, pixels)?),
    })
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
                "page {number} holds {} samples but the first page read holds {}; a stack needs one sample type",
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
    /// z slices, where the description says (ImageJ `slices`, OME `SizeZ`).
    slices: Option<usize>,
    /// OME's `DimensionOrder` (`XYZCT`…), fastest first; ImageJ's is XYCZT.
    dimension_order: Option<String>,
    /// Names and colors of the channels (OME `Channel` elements), in order.
    channel_info: Vec<ChannelInfo>,
    /// ImageJ's slice labels (`Labels`, one per page) and channels' LUTs, from IJMetadata.
    imagej: ImageJExtras,
}

/// What ImageJ keeps in its IJMetadata tag (50839, item sizes in 50838) that voxscope shows:
/// the pages' labels and each channel's LUT (its color: the LUT's brightest entry).
#[derive(Debug, Clone, Default, PartialEq)]
struct ImageJExtras {
    labels: Vec<String>,
    lut_colors: Vec<[u8; 3]>,
}

impl ImageJExtras {
    /// Parses IJMetadata `data` with item sizes `counts` (the first: the header's). A
    /// malformed block gives nothing: it is display advice.
    fn parse(data: &[u8], counts: &[u32]) -> Self {
        let mut extras = Self::default();
        let little = match data.get(..4) {
            Some(b"IJIJ") => false,
            Some(b"JIJI") => true,
            _ => return extras,
        };
        let word = |bytes: &[u8]| -> u32 {
            let b: [u8; 4] = bytes.try_into().unwrap_or_default();
            if little {
                u32::from_le_bytes(b)
            } else {
                u32::from_be_bytes(b)
            }
        };
        let Some((&header_bytes, sizes)) = counts.split_first() else {
            return extras;
        };
        let header_bytes = header_bytes as usize;
        if header_bytes < 4 || header_bytes > data.len() || !(header_bytes - 4).is_multiple_of(8) {
            return extras;
        }
        // The items follow the header, as many of each type as its count says.
        let mut types = Vec::new();
        for entry in data[4..header_bytes].chunks_exact(8) {
            let (kind, count) = (word(&entry[..4]), word(&entry[4..]) as usize);
            if types.len() + count > sizes.len() {
                return extras;
            }
            types.extend(std::iter::repeat_n(kind, count));
        }
        let mut offset = header_bytes;
        for (&kind, &size) in types.iter().zip(sizes) {
            let Some(item) = data.get(offset..offset.saturating_add(size as usize)) else {
                return extras;
            };
            offset += size as usize;
            match &kind.to_be_bytes() {
                b"labl" => {
                    let units: Vec<u16> = item
                        .chunks_exact(2)
                        .map(|pair| {
                            let pair = [pair[0], pair[1]];
                            if little {
                                u16::from_le_bytes(pair)
                            } else {
                                u16::from_be_bytes(pair)
                            }
                        })
                        .collect();
                    extras
                        .labels
                        .push(printable(&String::from_utf16_lossy(&units)));
                }
                b"luts" if item.len() == 768 => {
                    extras
                        .lut_colors
                        .push([item[255], item[256 + 255], item[512 + 255]]);
                }
                _ => {}
            }
        }
        extras
    }
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
            slices: None,
            dimension_order: None,
            channel_info: Vec::new(),
            imagej: ImageJExtras::default(),
        };
        let description = description.unwrap_or_default();
        if description.starts_with("ImageJ=") {
            metadata.source = Some("ImageJ");
            // Sizes already checked against the file (`check_tag_counts`).
            if let (Ok(data), Ok(counts)) = (
                decoder.get_tag_u8_vec(Tag::Unknown(50839)),
                decoder.get_tag_u32_vec(Tag::Unknown(50838)),
            ) {
                metadata.imagej = ImageJExtras::parse(&data, &counts);
            }
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
                    "slices" => metadata.slices = value.trim().parse().ok(),
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
            metadata.slices = xml_attribute(description, "SizeZ").and_then(|v| v.parse().ok());
            metadata.dimension_order = xml_attribute(description, "DimensionOrder")
                .filter(|order| is_dimension_order(order))
                .map(str::to_owned);
            metadata.channel_info = ome_channels(description);
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

/// Whether `order` is one of OME's six dimension orders (`XY` and C, Z, T once each).
fn is_dimension_order(order: &str) -> bool {
    order.len() == 5
        && order.starts_with("XY")
        && ["C", "Z", "T"].iter().all(|axis| order[2..].contains(axis))
}

/// The `Channel` elements of the first image of an OME-XML document: names and colors.
fn ome_channels(xml: &str) -> Vec<ChannelInfo> {
    // The first image's channels: those before the second `<Pixels` (or `<ome:Pixels`).
    let first_pixels = xml.find("Pixels ").unwrap_or(0);
    let end = xml[first_pixels + 1..]
        .find("Pixels ")
        .map_or(xml.len(), |at| first_pixels + 1 + at);
    let mut channels = Vec::new();
    let mut rest = &xml[first_pixels..end];
    while let Some(at) = rest.find("Channel ") {
        let element = &rest[at..];
        let tag = &element[..element.find('>').unwrap_or(element.len())];
        // `<Channel ` or `<ome:Channel `, not `ChannelRef` and the like.
        if rest[..at].ends_with('<') || rest[..at].ends_with(':') {
            channels.push(ChannelInfo {
                name: xml_attribute(tag, "Name").map(|name| printable(&unescape_xml(name))),
                color: xml_attribute(tag, "Color").and_then(parse_ome_color),
                window: None,
                inactive: false,
            });
        }
        rest = &element[tag.len().max(1)..];
    }
    channels
}

/// The five predefined XML entities replaced by their characters.
fn unescape_xml(text: &str) -> String {
    text.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
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
