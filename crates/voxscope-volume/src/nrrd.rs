//! NRRD (`.nrrd` with an attached header, `.nhdr` with a detached data file): raw, gzip and
//! ascii encodings, little and big endian, `sizes`, `spacings` or `space directions`; a
//! channel axis (`kinds` list, vector, color…) and a time axis (`time`), one frame read.
//! Written here because no maintained crate reads NRRD.

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;

use super::error::{Problem, quoted, short_list};
use super::io::{
    MAX_DEFLATE_RATIO, Storage, checked_payload_bytes, io_reason, open, read_payload,
    regular_file_size, skip_bytes, skip_lines,
};
use super::orientation::{keeps_stored_order, reorient_to_ras};
use super::{
    Endian, MAX_AXIS, Selection, Series, Volume, VoxelData, VoxelType, checked_voxel_count,
};

/// The header is text; anything longer than this is not a NRRD header.
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// How the voxel bytes are encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NrrdEncoding {
    Raw,
    Gzip,
    Ascii,
}

#[derive(Debug, Default)]
struct Header {
    voxel_type: Option<VoxelType>,
    dimension: Option<usize>,
    sizes: Option<Vec<usize>>,
    encoding: Option<NrrdEncoding>,
    endian: Option<Endian>,
    spacings: Option<Vec<f64>>,
    space_directions: Option<Vec<Option<[f64; 3]>>>,
    /// Each axis's `kinds` entry, lower case (`domain`, `space`, `time`, `list`, `rgb-color`…).
    kinds: Option<Vec<String>>,
    /// Sign flips that take the header's space to RAS (LPS flips x and y).
    to_ras: Option<[f64; 3]>,
    data_file: Option<String>,
    byte_skip: i64,
    line_skip: u64,
}

/// Every NRRD file starts with `NRRD` (then the version, `0004`).
pub(super) fn sniff(head: &[u8]) -> bool {
    head.starts_with(b"NRRD")
}

/// Reads frame `select` of the NRRD at `path`: the span of the data file that holds the
/// frame, no more (all of it only when a channel axis is interleaved).
pub(crate) fn load(path: &Path, select: Selection) -> Result<Volume, Problem> {
    let mut reader = open(path)?;
    let (header, header_bytes) = read_header(&mut reader)?;
    let voxel_type = header
        .voxel_type
        .ok_or("NRRD header lacks the 'type' field")?;
    let encoding = header
        .encoding
        .ok_or("NRRD header lacks the 'encoding' field")?;
    let layout = Layout::of(&header)?;
    select.check(layout.channels(), layout.time_points())?;
    let frame = layout.frame(select);
    let endian = match header.endian {
        Some(endian) => endian,
        None if voxel_type.size() == 1 || encoding == NrrdEncoding::Ascii => Endian::Little,
        None => return Err("NRRD header lacks the 'endian' field for multi-byte voxels".into()),
    };

    // Where the voxel bytes are: after the header, or in the detached data file.
    let (data_path, mut data, data_offset) = match &header.data_file {
        None => (path.to_path_buf(), reader, header_bytes),
        Some(name) => {
            let data_path = detached_path(path, name)?;
            let in_data_file =
                |problem: String| format!("NRRD data file {} {problem}", quoted(name));
            regular_file_size(&data_path).map_err(in_data_file)?;
            let reader = std::fs::File::open(&data_path)
                .map(std::io::BufReader::new)
                .map_err(|e| in_data_file(format!("cannot be opened: {}", io_reason(&e))))?;
            (data_path, reader, 0)
        }
    };
    let file_bytes =
        regular_file_size(&data_path).map_err(|problem| format!("the voxel data {problem}"))?;
    skip_lines(&mut data, header.line_skip)?;
    let available = file_bytes.saturating_sub(data_offset);
    let size = voxel_type.size();
    let span_bytes = frame.span * size;
    let span_start = (frame.first * size) as u64;
    let span = match encoding {
        NrrdEncoding::Raw => {
            let bytes = layout.checked_bytes(voxel_type, available, Storage::Plain)?;
            let skip = if header.byte_skip == -1 {
                // -1: the data is the last bytes of the file.
                available - bytes as u64
            } else {
                header.byte_skip as u64
            };
            let start = skip.saturating_add(span_start);
            let within = i64::try_from(start)
                .ok()
                .filter(|&s| (s as u64).saturating_add(span_bytes as u64) <= available);
            let Some(start) = within else {
                return Err(format!(
                    "byte skip {skip}: the voxels end after the file's {file_bytes} bytes"
                ));
            };
            data.seek_relative(start)
                .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
            read_payload(data, span_bytes, Storage::Plain)?
        }
        NrrdEncoding::Gzip => {
            layout.checked_bytes(voxel_type, available, Storage::Gzip)?;
            let mut decoder = MultiGzDecoder::new(data);
            let skip = header.byte_skip.max(0) as u64;
            skip_bytes(&mut decoder, skip.saturating_add(span_start))
                .map_err(|p| format!("gzip data, byte skip {skip}: {p}"))?;
            read_payload(decoder, span_bytes, Storage::Gzip)
                .map_err(|p| format!("gzip data: {p}"))?
        }
        NrrdEncoding::Ascii => {
            let count = layout.total;
            // Each ascii value takes at least 2 bytes (digit and separator), bar the last.
            if (count as u64) > available / 2 + 1 {
                return Err(format!(
                    "truncated: {count} ascii values cannot fit in {available} bytes"
                ));
            }
            let mut bytes = Vec::new();
            data.take(available)
                .read_to_end(&mut bytes)
                .map_err(|e| format!("ascii data: {}", io_reason(&e)))?;
            let text = String::from_utf8(bytes).map_err(|e| {
                format!(
                    "ascii data holds a byte that is not text at offset {}",
                    e.utf8_error().valid_up_to()
                )
            })?;
            let values = parse_ascii(&text, voxel_type, frame.first + frame.span)?;
            let data = if frame.first == 0 && frame.contiguous() {
                values
            } else {
                values.gather(frame.voxels(), |i| frame.first + frame.offset(i))
            };
            return finish(path, &layout, &header, data, select);
        }
    };
    let data = if frame.contiguous() {
        VoxelData::decode(voxel_type, &span, endian)
    } else {
        let frame_bytes = gather_bytes(&span, size, &frame);
        drop(span);
        VoxelData::decode(voxel_type, &frame_bytes, endian)
    };
    finish(path, &layout, &header, data, select)
}

/// The voxels of `frame` (of `size` bytes each) picked from the span read.
fn gather_bytes(span: &[u8], size: usize, frame: &Frame) -> Vec<u8> {
    let mut out = Vec::with_capacity(frame.voxels() * size);
    for i in 0..frame.voxels() {
        out.extend_from_slice(&span[frame.offset(i) * size..][..size]);
    }
    out
}

/// How a header's axes divide into the three spatial ones, a channel axis and a time axis.
#[derive(Debug, Clone, PartialEq)]
struct Layout {
    /// Voxels along x, y, z.
    dims: [usize; 3],
    /// The header axes of x, y, z (`usize::MAX` for an axis the file lacks).
    axes: [usize; 3],
    /// The channel axis (a `list`, `vector`, color… kind, or no space direction).
    channel_axis: Option<usize>,
    /// The time axis (kind `time`, or the fourth axis of a 4-D file without kinds).
    time_axis: Option<usize>,
    /// Every axis's size.
    sizes: Vec<usize>,
    /// Values in the whole file.
    total: usize,
}

/// Where one 3-D frame's voxels lie among a file's values.
#[derive(Debug, Clone, PartialEq)]
struct Frame {
    /// The frame's first value.
    first: usize,
    /// Values from the first to the last of the frame's, both included.
    span: usize,
    /// Voxels along x, y, z.
    dims: [usize; 3],
    /// Values between neighbours along x, y, z.
    strides: [usize; 3],
}

impl Frame {
    fn voxels(&self) -> usize {
        self.dims.iter().product()
    }

    /// Whether the frame's voxels are the span itself, in order.
    fn contiguous(&self) -> bool {
        self.span == self.voxels() && self.strides == [1, self.dims[0], self.dims[0] * self.dims[1]]
    }

    /// The offset within the span of the frame's voxel `index` (x fastest).
    fn offset(&self, index: usize) -> usize {
        let [dx, dy, _] = self.dims;
        let (x, y, z) = (index % dx, (index / dx) % dy, index / (dx * dy));
        x * self.strides[0] + y * self.strides[1] + z * self.strides[2]
    }
}

impl Layout {
    /// The axes of `header`: spatial (`domain`, `space`, or no kind), time (`time`), channel
    /// (any other kind, or `none` in `space directions`). More than three spatial axes lose
    /// their size-1 ones, then the last becomes the time axis (a 4-D file without kinds).
    fn of(header: &Header) -> Result<Self, Problem> {
        let sizes = header
            .sizes
            .as_ref()
            .ok_or("NRRD header lacks the 'sizes' field")?;
        let dimension = header
            .dimension
            .ok_or("NRRD header lacks the 'dimension' field")?;
        if sizes.len() != dimension {
            return Err(format!(
                "NRRD 'sizes' has {} entries but 'dimension' is {dimension}",
                sizes.len()
            ));
        }
        // Every byte count below (up to 8 bytes a value) is then without overflow.
        let total = sizes
            .iter()
            .try_fold(1usize, |acc, &n| acc.checked_mul(n))
            .filter(|total| total.checked_mul(8).is_some())
            .ok_or_else(|| format!("NRRD sizes {} overflow", short_list(sizes)))?;
        let mut spatial = Vec::new();
        let mut channel_axes = Vec::new();
        let mut time_axes = Vec::new();
        for axis in 0..dimension {
            let kind = header
                .kinds
                .as_ref()
                .and_then(|kinds| kinds.get(axis))
                .map(String::as_str);
            let no_direction = header
                .space_directions
                .as_ref()
                .is_some_and(|all| all.get(axis).is_some_and(Option::is_none));
            match kind {
                Some("time") => time_axes.push(axis),
                Some("domain" | "space") => spatial.push(axis),
                None | Some("none" | "???") if !no_direction => spatial.push(axis),
                _ => channel_axes.push(axis),
            }
        }
        let not_3d = || {
            format!(
                "NRRD of dimension {dimension} with sizes {} is not a 3D volume with at most one channel and one time axis",
                short_list(sizes)
            )
        };
        // Size-1 axes of any role carry nothing: drop them first.
        for axes in [&mut channel_axes, &mut time_axes] {
            if axes.len() > 1 {
                axes.retain(|&a| sizes[a] > 1);
            }
        }
        while spatial.len() > 3 {
            match spatial.iter().position(|&a| sizes[a] == 1) {
                Some(unit) => {
                    spatial.remove(unit);
                }
                None if time_axes.is_empty() && spatial.len() == 4 => {
                    time_axes.push(spatial.pop().expect("four axes"));
                }
                None => return Err(not_3d()),
            }
        }
        if channel_axes.len() > 1 || time_axes.len() > 1 {
            return Err(not_3d());
        }
        // Each channel is listed (`Volume::series`): as many as an axis may have voxels.
        if let Some(&axis) = channel_axes.first()
            && sizes[axis] > MAX_AXIS
        {
            return Err(format!(
                "NRRD channel axis {axis} has {} entries, more than {MAX_AXIS}",
                sizes[axis]
            ));
        }
        let axis = |i: usize| spatial.get(i).copied();
        let dims = std::array::from_fn(|i| axis(i).map_or(1, |a| sizes[a]));
        checked_voxel_count(dims)?;
        // Missing axes (dimension < 3) have size 1; point them at a non-existent field index.
        let axes = std::array::from_fn(|i| axis(i).unwrap_or(usize::MAX));
        Ok(Self {
            dims,
            axes,
            channel_axis: channel_axes.first().copied(),
            time_axis: time_axes.first().copied(),
            sizes: sizes.clone(),
            total,
        })
    }

    fn channels(&self) -> usize {
        self.channel_axis.map_or(1, |a| self.sizes[a])
    }

    fn time_points(&self) -> usize {
        self.time_axis.map_or(1, |a| self.sizes[a])
    }

    /// Whether the file is one 3-D frame.
    fn is_single_frame(&self) -> bool {
        self.channels() == 1 && self.time_points() == 1
    }

    /// Validates the whole file's data against the limits and the `available` bytes; its
    /// byte count.
    fn checked_bytes(
        &self,
        voxel_type: VoxelType,
        available: u64,
        storage: Storage,
    ) -> Result<usize, Problem> {
        let frames = self.total / self.dims.iter().product::<usize>().max(1);
        if frames == 1 {
            return checked_payload_bytes(self.dims, voxel_type, available, storage);
        }
        let bytes = self
            .total
            .checked_mul(voxel_type.size())
            .ok_or("NRRD data size overflows")?;
        let fits = match storage {
            Storage::Plain => bytes as u64 <= available,
            Storage::Gzip => bytes as u64 <= available.saturating_mul(MAX_DEFLATE_RATIO),
        };
        if !fits {
            return Err(format!(
                "truncated or inconsistent: sizes {} of {} need {bytes} bytes of voxel data but {}",
                short_list(&self.sizes),
                voxel_type.name(),
                match storage {
                    Storage::Plain => format!("the file holds only {available} bytes"),
                    Storage::Gzip =>
                        format!("a {available}-byte gzip stream cannot hold that much"),
                }
            ));
        }
        Ok(bytes)
    }

    /// Where frame `select` (within range) lies among the file's values.
    fn frame(&self, select: Selection) -> Frame {
        let mut strides = Vec::with_capacity(self.sizes.len());
        let mut stride = 1usize;
        for &size in &self.sizes {
            strides.push(stride);
            stride *= size;
        }
        let stride_of = |axis: usize| strides.get(axis).copied().unwrap_or(0);
        let first = self.channel_axis.map_or(0, |a| select.channel * strides[a])
            + self.time_axis.map_or(0, |a| select.time * strides[a]);
        let frame_strides = self.axes.map(stride_of);
        let last: usize = (0..3).map(|i| (self.dims[i] - 1) * frame_strides[i]).sum();
        Frame {
            first,
            span: last + 1,
            dims: self.dims,
            strides: frame_strides,
        }
    }
}

/// Builds the volume and applies the header's spacing and orientation.
fn finish(
    path: &Path,
    layout: &Layout,
    header: &Header,
    data: VoxelData,
    select: Selection,
) -> Result<Volume, Problem> {
    let (directions, spacing) = geometry(&layout.axes, header);
    let mut volume = Volume::new(
        path.display().to_string(),
        "NRRD",
        layout.dims,
        spacing,
        data,
    )
    .map_err(|e| e.problem)?;
    volume.series = Series::plain(layout.channels(), layout.time_points(), select);
    // Only a header that names its space says where RAS is.
    Ok(match (directions, header.to_ras) {
        (Some(directions), Some(_)) => reorient_to_ras(volume, directions),
        _ => volume,
    })
}

/// The spatial axes' directions in RAS (when the header gives them) and the voxel spacing.
fn geometry(axes: &[usize; 3], header: &Header) -> (Option<[[f64; 3]; 3]>, [f64; 3]) {
    let directions: Option<[[f64; 3]; 3]> = header.space_directions.as_ref().and_then(|all| {
        let flips = header.to_ras.unwrap_or([1.0; 3]);
        let picked: Option<Vec<[f64; 3]>> = axes
            .iter()
            .map(|&a| all.get(a).copied().flatten())
            .collect();
        picked.map(|v| std::array::from_fn(|i| std::array::from_fn(|w| v[i][w] * flips[w])))
    });
    let spacing: [f64; 3] = std::array::from_fn(|i| {
        if let Some(direction) = directions.map(|d| d[i]) {
            direction.iter().map(|c| c * c).sum::<f64>().sqrt()
        } else {
            header
                .spacings
                .as_ref()
                .and_then(|s| s.get(axes[i]).copied())
                .unwrap_or(1.0)
        }
    });
    (directions, spacing)
}

/// Where a raw-encoded NRRD's voxels lie, for reading them slab by slab in place.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RawExtent {
    /// The file holding the voxels (the `.nrrd` itself, or a `.nhdr`'s data file).
    pub data: PathBuf,
    /// Byte offset of the first voxel.
    pub offset: u64,
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    pub voxel_type: VoxelType,
    pub endian: Endian,
    pub spacing: [f64; 3],
}

/// The voxels of a raw-encoded NRRD as they lie in its data file (`convert` reads them in
/// slabs), or `None` when they cannot be read in place as x, y, z slices: gzip or ascii
/// encoding, line skips, or a `space` whose orientation reorders the axes on load. Checks the
/// voxels fit in the file.
pub(crate) fn raw_extent(path: &Path) -> Result<Option<RawExtent>, Problem> {
    let mut reader = open(path)?;
    let (header, header_bytes) = read_header(&mut reader)?;
    let voxel_type = header
        .voxel_type
        .ok_or("NRRD header lacks the 'type' field")?;
    let layout = Layout::of(&header)?;
    let (dims, axes) = (layout.dims, layout.axes);
    if header.encoding != Some(NrrdEncoding::Raw)
        || header.line_skip != 0
        || !layout.is_single_frame()
    {
        return Ok(None);
    }
    let (directions, spacing) = geometry(&axes, &header);
    if let (Some(directions), Some(_)) = (directions, header.to_ras)
        && !keeps_stored_order(directions)
    {
        return Ok(None);
    }
    let endian = match header.endian {
        Some(endian) => endian,
        None if voxel_type.size() == 1 => Endian::Little,
        None => return Err("NRRD header lacks the 'endian' field for multi-byte voxels".into()),
    };
    let (data, start) = match &header.data_file {
        None => (path.to_path_buf(), header_bytes),
        Some(name) => (detached_path(path, name)?, 0),
    };
    let file_bytes =
        regular_file_size(&data).map_err(|problem| format!("the voxel data {problem}"))?;
    let available = file_bytes.saturating_sub(start);
    let bytes = checked_payload_bytes(dims, voxel_type, available, Storage::Plain)? as u64;
    let offset = if header.byte_skip == -1 {
        Some(file_bytes - bytes)
    } else {
        start.checked_add(header.byte_skip as u64)
    };
    let Some(offset) = offset.filter(|o| o.checked_add(bytes).is_some_and(|end| end <= file_bytes))
    else {
        return Err(format!(
            "byte skip {}: the voxels end after the file's {file_bytes} bytes",
            header.byte_skip
        ));
    };
    Ok(Some(RawExtent {
        data,
        offset,
        dims,
        voxel_type,
        endian,
        spacing,
    }))
}

/// Reads header lines up to the blank line (or the end, in a detached `.nhdr`).
/// Returns the header and the byte offset where data begins.
fn read_header(reader: &mut impl BufRead) -> Result<(Header, u64), Problem> {
    let mut header = Header::default();
    let mut offset = 0u64;
    let mut line = Vec::new();
    let mut first = true;
    let mut line_number = 0usize;
    loop {
        line.clear();
        let read = reader
            .by_ref()
            .take(MAX_HEADER_BYTES)
            .read_until(b'\n', &mut line)
            .map_err(|e| format!("cannot read NRRD header: {}", io_reason(&e)))?;
        if read == 0 {
            break;
        }
        offset += read as u64;
        if offset > MAX_HEADER_BYTES {
            return Err("NRRD header is longer than 1 MiB (missing blank line?)".into());
        }
        let text = std::str::from_utf8(&line)
            .map_err(|e| {
                format!(
                    "NRRD header line {} holds a byte that is not text (offset {})",
                    line_number + 1,
                    offset as usize - line.len() + e.valid_up_to()
                )
            })?
            .trim_end_matches(['\n', '\r']);
        line_number += 1;
        if first {
            if !text.starts_with("NRRD000") {
                return Err("not a NRRD file (first line is not NRRD000X)".into());
            }
            first = false;
            continue;
        }
        if text.is_empty() {
            break;
        }
        if text.starts_with('#') || text.contains(":=") {
            continue; // comment or key/value pair
        }
        let (key, value) = text
            .split_once(": ")
            .or_else(|| text.split_once(':'))
            .ok_or_else(|| {
                format!(
                    "NRRD header line {line_number} {} is not 'field: value'",
                    quoted(text)
                )
            })?;
        parse_field(&mut header, &key.trim().to_lowercase(), value.trim())?;
    }
    if first {
        return Err("file is empty".into());
    }
    Ok((header, offset))
}

fn parse_field(header: &mut Header, key: &str, value: &str) -> Result<(), Problem> {
    let numbers = |value: &str| -> Result<Vec<f64>, Problem> {
        value
            .split_whitespace()
            .map(|n| {
                n.parse::<f64>()
                    .map_err(|_| format!("NRRD {key} value {} is not a number", quoted(n)))
            })
            .collect()
    };
    match key {
        "type" => header.voxel_type = Some(parse_type(value)?),
        "dimension" => {
            let dimension: usize =
                parse_count(value).map_err(|why| format!("NRRD dimension {why}"))?;
            if !(1..=16).contains(&dimension) {
                return Err(format!("NRRD dimension {dimension} is not 1 to 16"));
            }
            header.dimension = Some(dimension);
        }
        "sizes" => {
            let sizes = value
                .split_whitespace()
                .map(|n| match parse_count(n) {
                    Ok(0) => Err(format!("NRRD sizes: entry {} is not positive", quoted(n))),
                    Ok(size) => Ok(size),
                    Err(why) => Err(format!("NRRD sizes: entry {why}")),
                })
                .collect::<Result<Vec<_>, _>>()?;
            header.sizes = Some(sizes);
        }
        "encoding" => {
            header.encoding = Some(match value.to_lowercase().as_str() {
                "raw" => NrrdEncoding::Raw,
                "gzip" | "gz" => NrrdEncoding::Gzip,
                "ascii" | "text" | "txt" => NrrdEncoding::Ascii,
                other => {
                    return Err(format!(
                        "NRRD encoding {} is not supported (raw, gzip, ascii)",
                        quoted(other)
                    ));
                }
            })
        }
        "endian" => {
            header.endian = Some(match value {
                "little" => Endian::Little,
                "big" => Endian::Big,
                other => {
                    return Err(format!(
                        "NRRD endian {} is not little or big",
                        quoted(other)
                    ));
                }
            })
        }
        "spacings" => {
            // "nan" marks non-spatial axes; f64 parsing accepts it.
            header.spacings = Some(numbers(value)?);
        }
        "space directions" => header.space_directions = Some(parse_directions(value)?),
        "kinds" => {
            header.kinds = Some(
                value
                    .split_whitespace()
                    .map(|kind| kind.trim_matches('"').to_lowercase())
                    .collect(),
            )
        }
        "space" => {
            header.to_ras = match value.to_lowercase().as_str() {
                "right-anterior-superior" | "ras" => Some([1.0, 1.0, 1.0]),
                "left-anterior-superior" | "las" => Some([-1.0, 1.0, 1.0]),
                "left-posterior-superior" | "lps" => Some([-1.0, -1.0, 1.0]),
                _ => None, // scanner-xyz, 3D-right-handed, …: no anatomical frame
            }
        }
        "data file" | "datafile" => {
            if value.starts_with("LIST") || value.contains('%') {
                return Err(format!(
                    "NRRD multi-file data ({}) is not supported",
                    quoted(value)
                ));
            }
            header.data_file = Some(value.to_owned());
        }
        "byte skip" | "byteskip" => {
            header.byte_skip = if value == "-1" {
                -1
            } else {
                let skip = parse_count(value)
                    .map_err(|why| format!("NRRD byte skip {why} (a count, or -1)"))?;
                i64::try_from(skip)
                    .map_err(|_| format!("NRRD byte skip {} is too large", quoted(value)))?
            }
        }
        "line skip" | "lineskip" => {
            header.line_skip =
                parse_count(value).map_err(|why| format!("NRRD line skip {why}"))? as u64
        }
        _ => {} // content, kinds, units, space origin, …: not needed to draw
    }
    Ok(())
}

/// Why a header field is not a count: displays as the end of a line that names the field.
#[derive(Debug, thiserror::Error)]
enum CountError {
    /// Digits only, but more than a `usize` holds (the text quoted).
    #[error("{0} is too large")]
    TooLarge(String),
    /// Not a whole number (the text quoted).
    #[error("{0} is not a whole number")]
    NotWhole(String),
}

/// A whole number of a header field: `'x' is not a number`, or `'99…9' is too large`.
fn parse_count(text: &str) -> Result<usize, CountError> {
    text.parse::<usize>().map_err(|_| {
        if !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) {
            CountError::TooLarge(quoted(text))
        } else {
            CountError::NotWhole(quoted(text))
        }
    })
}

fn parse_type(value: &str) -> Result<VoxelType, Problem> {
    Ok(match value {
        "signed char" | "int8" | "int8_t" => VoxelType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => VoxelType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            VoxelType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            VoxelType::U16
        }
        "int" | "signed int" | "int32" | "int32_t" => VoxelType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => VoxelType::U32,
        "float" => VoxelType::F32,
        "double" => VoxelType::F64,
        other => return Err(format!("NRRD type {} is not supported", quoted(other))),
    })
}

/// `(1,0,0) (0,1,0) none (0,0,2.5)`.
fn parse_directions(value: &str) -> Result<Vec<Option<[f64; 3]>>, Problem> {
    value
        .split_whitespace()
        .map(|vector| {
            if vector == "none" {
                return Ok(None);
            }
            let inner = vector
                .strip_prefix('(')
                .and_then(|v| v.strip_suffix(')'))
                .ok_or_else(|| format!("NRRD space direction {} is not (x,y,z)", quoted(vector)))?;
            let components: Vec<f64> = inner
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("NRRD space direction {} is not (x,y,z)", quoted(vector)))?;
            match components[..] {
                [x, y, z] => Ok(Some([x, y, z])),
                _ => Err(format!(
                    "NRRD space direction {} needs 3 components",
                    quoted(vector)
                )),
            }
        })
        .collect()
}

fn detached_path(header_path: &Path, name: &str) -> Result<PathBuf, Problem> {
    let name = Path::new(name);
    Ok(if name.is_absolute() {
        name.to_path_buf()
    } else {
        header_path.parent().unwrap_or(Path::new(".")).join(name)
    })
}

fn parse_ascii(text: &str, voxel_type: VoxelType, count: usize) -> Result<VoxelData, Problem> {
    let values: Vec<f64> = text
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .take(count)
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("ascii value {} is not a number", quoted(t)))
        })
        .collect::<Result<_, _>>()?;
    if values.len() < count {
        return Err(format!(
            "truncated: expected {count} ascii values, found {}",
            values.len()
        ));
    }
    fn convert<T: super::Scalar>(values: &[f64]) -> VoxelData {
        T::wrap(values.iter().map(|&v| T::from_f64(v)).collect())
    }
    Ok(match voxel_type {
        VoxelType::U8 => convert::<u8>(&values),
        VoxelType::I8 => convert::<i8>(&values),
        VoxelType::U16 => convert::<u16>(&values),
        VoxelType::I16 => convert::<i16>(&values),
        VoxelType::U32 => convert::<u32>(&values),
        VoxelType::I32 => convert::<i32>(&values),
        VoxelType::F32 => convert::<f32>(&values),
        VoxelType::F64 => convert::<f64>(&values),
    })
}
