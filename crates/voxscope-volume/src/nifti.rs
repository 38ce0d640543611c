//! NIfTI-1 (`.nii`, `.nii.gz`, `.hdr` + `.img`): the 348-byte header, either byte order,
//! `scl_slope`/`scl_inter`, spacing from `pixdim`, orientation from the sform or qform.
//!
//! Our own reader rather than the `nifti` crate: it is ~200 lines, and it lets every size be
//! validated against the file before anything is allocated.

use std::io::{BufRead, Cursor, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;

use super::error::{Problem, number};
use super::io::{
    MAX_DEFLATE_RATIO, Storage, checked_payload_bytes, io_reason, open, read_payload,
    regular_file_size, skip_bytes,
};
use super::orientation::reorient_to_ras;
use super::{
    Endian, Selection, Series, ValueScale, Volume, VoxelData, VoxelType, checked_voxel_count,
};

const HEADER_BYTES: usize = 348;

/// The fields of a NIfTI-1 header that voxscope uses.
#[derive(Debug, Clone)]
struct Header {
    endian: Endian,
    dims: [usize; 3],
    /// 3-D frames along dim 4 (time).
    frames: usize,
    /// Components along dim 5 (a vector intent's elements, channels).
    components: usize,
    voxel_type: VoxelType,
    pixdim: [f32; 8],
    vox_offset: u64,
    scale: ValueScale,
    /// RAS direction of each index axis, when the header gives an orientation.
    directions: Option<[[f64; 3]; 3]>,
    /// `n+1` (one file) or `ni1` (header and `.img`).
    single_file: bool,
}

/// True when the first bytes of a file (maybe gzipped) are a NIfTI-1 header size field.
pub(super) fn sniff(head: &[u8]) -> bool {
    let mut first = [0u8; 4];
    decompressed(head).read_exact(&mut first).is_ok()
        && (i32::from_le_bytes(first) == HEADER_BYTES as i32
            || i32::from_be_bytes(first) == HEADER_BYTES as i32)
}

/// Reads frame `select` of the NIfTI file at `path`: only that frame's bytes are read (a
/// plain file seeks to it, a gzip stream is decompressed up to it and no further).
pub(crate) fn load(path: &Path, select: Selection) -> Result<Volume, Problem> {
    let file = open(path)?;
    read(&path.display().to_string(), file, Some(path), select)
}

/// Decodes a NIfTI-1 file held in memory (`bytes` is the file, maybe gzipped): its first
/// frame. `path` locates the `.img` of a header/image pair; without it only single files
/// (`n+1`) decode.
pub(crate) fn decode(name: &str, bytes: &[u8], path: Option<&Path>) -> Result<Volume, Problem> {
    read(name, Cursor::new(bytes), path, Selection::default())
}

/// Reads the header from `file` (maybe gzipped), then the voxels of frame `select` from it
/// or from the `.img` beside `path`.
fn read(
    name: &str,
    file: impl BufRead + Seek,
    path: Option<&Path>,
    select: Selection,
) -> Result<Volume, Problem> {
    let mut content = Content::new(file)?;
    let mut raw_header = [0u8; HEADER_BYTES];
    content.read_exact(&mut raw_header).map_err(|e| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            format!("too short for a NIfTI-1 header ({HEADER_BYTES} bytes)")
        } else {
            format!("cannot read NIfTI header: {}", io_reason(&e))
        }
    })?;
    let header = parse_header(&raw_header)?;
    select.check(header.components, header.frames)?;

    // The frame's place among the 3-D frames: time (dim 4) varies fastest, then the
    // component (dim 5).
    let frame_index = (select.channel as u64) * header.frames as u64 + select.time as u64;
    let payload = if header.single_file {
        content.read_frame(&header, header.vox_offset, frame_index)?
    } else {
        let path = path.ok_or("a NIfTI header/image pair needs its .img file")?;
        let image = image_path(path)?;
        let file = open(&image)?;
        Content::new(file)?
            .read_frame(&header, header.vox_offset, frame_index)
            .map_err(|p| format!("{}: {p}", image.display()))?
    };
    let voxels = VoxelData::decode(header.voxel_type, &payload, header.endian);
    drop(payload);

    let spacing = std::array::from_fn(|axis| header.pixdim[axis + 1] as f64);
    let mut volume =
        Volume::new(name, "NIfTI-1", header.dims, spacing, voxels).map_err(|e| e.problem)?;
    volume.value_scale = header.scale;
    volume.series = Series::plain(header.components, header.frames, select);
    Ok(match header.directions {
        Some(directions) => reorient_to_ras(volume, directions),
        None => volume,
    })
}

/// A file's content: as stored, or through a gzip decoder. Tracks how far it has been read.
enum Content<R: BufRead + Seek> {
    Plain(R),
    Gzip {
        decoder: Box<MultiGzDecoder<R>>,
        /// Decompressed bytes read so far.
        position: u64,
        /// The compressed stream's size.
        stored_bytes: u64,
    },
}

impl<R: BufRead + Seek> Content<R> {
    fn new(mut file: R) -> Result<Self, Problem> {
        let stored_bytes = file
            .seek(SeekFrom::End(0))
            .and_then(|end| file.rewind().map(|()| end))
            .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
        let gzip = is_gzip_bytes(
            file.fill_buf()
                .map_err(|e| format!("cannot read: {}", io_reason(&e)))?,
        );
        Ok(if gzip {
            Self::Gzip {
                decoder: Box::new(MultiGzDecoder::new(file)),
                position: 0,
                stored_bytes,
            }
        } else {
            Self::Plain(file)
        })
    }

    fn read_exact(&mut self, buffer: &mut [u8]) -> std::io::Result<()> {
        match self {
            Self::Plain(file) => file.read_exact(buffer),
            Self::Gzip {
                decoder, position, ..
            } => {
                decoder.read_exact(buffer)?;
                *position += buffer.len() as u64;
                Ok(())
            }
        }
    }

    /// The bytes of 3-D frame `frame_index` of `header`'s voxels, which start `data_offset`
    /// bytes into the content. Sizes are checked against the stored bytes first.
    fn read_frame(
        self,
        header: &Header,
        data_offset: u64,
        frame_index: u64,
    ) -> Result<Vec<u8>, Problem> {
        let frame_bytes =
            checked_voxel_count(header.dims)? as u64 * header.voxel_type.size() as u64;
        let start = frame_index
            .checked_mul(frame_bytes)
            .and_then(|offset| offset.checked_add(data_offset))
            .ok_or("NIfTI frame offset overflows")?;
        let frame_name = if header.frames * header.components > 1 {
            format!(
                "frame {frame_index} of {}",
                header.frames * header.components
            )
        } else {
            "the voxel data".to_owned()
        };
        match self {
            Self::Plain(mut file) => {
                let stored_bytes = file
                    .seek(SeekFrom::End(0))
                    .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
                let available = stored_bytes.saturating_sub(start);
                let bytes = checked_payload_bytes(
                    header.dims,
                    header.voxel_type,
                    available,
                    Storage::Plain,
                )
                .map_err(|p| format!("{frame_name}: {p}"))?;
                file.seek(SeekFrom::Start(start))
                    .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
                read_payload(file, bytes, Storage::Plain)
            }
            Self::Gzip {
                mut decoder,
                position,
                stored_bytes,
            } => {
                let bytes = checked_payload_bytes(
                    header.dims,
                    header.voxel_type,
                    stored_bytes,
                    Storage::Gzip,
                )
                .map_err(|p| format!("{frame_name}: {p}"))?;
                if start.saturating_add(bytes as u64)
                    > stored_bytes.saturating_mul(MAX_DEFLATE_RATIO)
                {
                    return Err(format!(
                        "truncated or inconsistent: {frame_name} ends at byte {} of the content, more than a {stored_bytes}-byte gzip stream can hold",
                        start + bytes as u64
                    ));
                }
                if start < position {
                    return Err(format!(
                        "NIfTI vox_offset {data_offset} lies inside the header"
                    ));
                }
                skip_bytes(&mut decoder, start - position)
                    .map_err(|p| format!("{frame_name}: {p}"))?;
                read_payload(decoder, bytes, Storage::Gzip)
            }
        }
    }
}

fn is_gzip_bytes(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x1f, 0x8b])
}

/// A reader over the decompressed content of bytes held in memory.
fn decompressed(bytes: &[u8]) -> Box<dyn Read + '_> {
    if is_gzip_bytes(bytes) {
        Box::new(MultiGzDecoder::new(bytes))
    } else {
        Box::new(bytes)
    }
}

/// The `.img` (or `.img.gz`) beside a `.hdr`.
fn image_path(header_path: &Path) -> Result<PathBuf, Problem> {
    let gzipped = header_path.with_extension("img.gz");
    let image = header_path.with_extension("img");
    let chosen = if !image.exists() && gzipped.exists() {
        gzipped
    } else {
        image
    };
    regular_file_size(&chosen).map_err(|problem| {
        format!(
            "NIfTI header (ni1) needs its data file {}, which {problem}",
            chosen.display()
        )
    })?;
    Ok(chosen)
}

fn parse_header(bytes: &[u8; HEADER_BYTES]) -> Result<Header, Problem> {
    let size_le = i32::from_le_bytes(bytes[0..4].try_into().expect("4 bytes"));
    let endian = match size_le {
        348 => Endian::Little,
        _ if i32::from_be_bytes(bytes[0..4].try_into().expect("4 bytes")) == 348 => Endian::Big,
        540 => return Err("NIfTI-2 files are not supported yet (only NIfTI-1)".into()),
        other => {
            return Err(format!(
                "not a NIfTI-1 file (header size field is {other}, expected 348)"
            ));
        }
    };
    let field = HeaderReader { bytes, endian };
    let single_file = match &bytes[344..348] {
        b"n+1\0" => true,
        b"ni1\0" => false,
        _ => return Err("not a NIfTI-1 file (bad magic at byte 344)".into()),
    };

    let dim: [i16; 8] = std::array::from_fn(|i| field.i16(40 + 2 * i));
    let rank = dim[0];
    if !(1..=7).contains(&rank) {
        return Err(format!("NIfTI dim[0] is {rank}, expected 1 to 7"));
    }
    let extent = |axis: usize| -> Result<usize, Problem> {
        if axis > rank as usize {
            return Ok(1);
        }
        let n = dim[axis];
        if n < 1 {
            return Err(format!("NIfTI dim[{axis}] is {n}, expected at least 1"));
        }
        Ok(n as usize)
    };
    let dims = [extent(1)?, extent(2)?, extent(3)?];
    let frames = extent(4)?;
    let components = extent(5)?;
    for axis in 6..=rank as usize {
        let n = extent(axis)?;
        if n != 1 {
            return Err(format!(
                "NIfTI image has {n} volumes along dimension {axis}; only time (dimension 4) and components (dimension 5) are read"
            ));
        }
    }
    let datatype = field.i16(70);
    let voxel_type = match datatype {
        2 => VoxelType::U8,
        4 => VoxelType::I16,
        8 => VoxelType::I32,
        16 => VoxelType::F32,
        64 => VoxelType::F64,
        256 => VoxelType::I8,
        512 => VoxelType::U16,
        768 => VoxelType::U32,
        32 | 128 | 1792 | 2048 | 2304 => {
            return Err(format!(
                "NIfTI datatype {datatype} (complex or RGB) is not a scalar volume"
            ));
        }
        other => return Err(format!("unknown NIfTI datatype {other}")),
    };
    let pixdim: [f32; 8] = std::array::from_fn(|i| field.f32(76 + 4 * i));
    let vox_offset = field.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= 0.0) {
        return Err(format!(
            "NIfTI vox_offset {} is invalid",
            number(vox_offset as f64)
        ));
    }
    // Beyond 2^53 an offset is no longer a whole number in f32 or f64: no file is that big.
    if vox_offset > (1u64 << 53) as f32 {
        return Err(format!(
            "NIfTI vox_offset {} is too large",
            number(vox_offset as f64)
        ));
    }
    if single_file && vox_offset < HEADER_BYTES as f32 {
        return Err(format!(
            "NIfTI vox_offset {} lies inside the 348-byte header",
            number(vox_offset as f64)
        ));
    }
    let slope = field.f32(112);
    let intercept = field.f32(116);
    // The standard: a slope of 0 (or NaN, written by some tools) means "no scaling".
    let scale = if slope.is_finite() && slope != 0.0 {
        ValueScale {
            slope: slope as f64,
            intercept: if intercept.is_finite() {
                intercept as f64
            } else {
                0.0
            },
        }
    } else {
        ValueScale::IDENTITY
    };

    let qform_code = field.i16(252);
    let sform_code = field.i16(254);
    let directions = if sform_code > 0 {
        let rows: [[f32; 4]; 3] =
            std::array::from_fn(|r| std::array::from_fn(|c| field.f32(280 + 16 * r + 4 * c)));
        Some(std::array::from_fn(|axis| {
            std::array::from_fn(|world| rows[world][axis] as f64)
        }))
    } else if qform_code > 0 {
        let [b, c, d] = [field.f32(256), field.f32(260), field.f32(264)].map(|v| v as f64);
        let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
        let rotation = [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a + c * c - b * b - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a + d * d - c * c - b * b,
            ],
        ];
        let qfac = if pixdim[0] < 0.0 { -1.0 } else { 1.0 };
        Some(std::array::from_fn(|axis| {
            let sign = if axis == 2 { qfac } else { 1.0 };
            std::array::from_fn(|world| rotation[world][axis] * sign)
        }))
    } else {
        None
    };

    Ok(Header {
        endian,
        dims,
        frames,
        components,
        voxel_type,
        pixdim,
        vox_offset: vox_offset as u64,
        scale,
        directions,
        single_file,
    })
}

/// Reads fixed-offset fields in the header's byte order.
struct HeaderReader<'a> {
    bytes: &'a [u8; HEADER_BYTES],
    endian: Endian,
}

impl HeaderReader<'_> {
    fn i16(&self, offset: usize) -> i16 {
        let b = [self.bytes[offset], self.bytes[offset + 1]];
        match self.endian {
            Endian::Little => i16::from_le_bytes(b),
            Endian::Big => i16::from_be_bytes(b),
        }
    }

    fn f32(&self, offset: usize) -> f32 {
        let b: [u8; 4] = self.bytes[offset..offset + 4].try_into().expect("4 bytes");
        match self.endian {
            Endian::Little => f32::from_le_bytes(b),
            Endian::Big => f32::from_be_bytes(b),
        }
    }
}
