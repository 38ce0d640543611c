//! NRRD (`.nrrd` with an attached header, `.nhdr` with a detached data file): raw, gzip and
//! ascii encodings, little and big endian, `sizes`, `spacings` or `space directions`.
//! Written here because no maintained crate reads NRRD.

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;

use super::error::Problem;
use super::io::{Storage, checked_payload_bytes, io_reason, open, read_payload, skip_bytes};
use super::orientation::reorient_to_ras;
use super::{Endian, Volume, VoxelData, VoxelType, checked_voxel_count};

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
    /// Sign flips that take the header's space to RAS (LPS flips x and y).
    to_ras: Option<[f64; 3]>,
    data_file: Option<String>,
    byte_skip: i64,
    line_skip: usize,
}

/// Every NRRD file starts with `NRRD` (then the version, `0004`).
pub(super) fn sniff(head: &[u8]) -> bool {
    head.starts_with(b"NRRD")
}

pub(crate) fn load(path: &Path) -> Result<Volume, Problem> {
    let mut reader = open(path)?;
    let (header, header_bytes) = read_header(&mut reader)?;
    let voxel_type = header
        .voxel_type
        .ok_or("NRRD header lacks the 'type' field")?;
    let encoding = header
        .encoding
        .ok_or("NRRD header lacks the 'encoding' field")?;
    let (dims, axes) = spatial_axes(&header)?;
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
            if !data_path.is_file() {
                return Err(format!(
                    "NRRD data file {} does not exist",
                    data_path.display()
                ));
            }
            let reader = open(&data_path)?;
            (data_path, reader, 0)
        }
    };
    let file_bytes = std::fs::metadata(&data_path)
        .map_err(|e| format!("cannot open {}: {}", data_path.display(), io_reason(&e)))?
        .len();
    for _ in 0..header.line_skip {
        let mut line = Vec::new();
        data.read_until(b'\n', &mut line)
            .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    }
    let available = file_bytes.saturating_sub(data_offset);
    let payload = match encoding {
        NrrdEncoding::Raw => {
            let bytes = checked_payload_bytes(dims, voxel_type, available, Storage::Plain)?;
            if header.byte_skip == -1 {
                // -1: the data is the last bytes of the file.
                skip_bytes(&mut data, available - bytes as u64)?;
            } else {
                skip_bytes(&mut data, header.byte_skip as u64)?;
            }
            read_payload(data, bytes)?
        }
        NrrdEncoding::Gzip => {
            let bytes = checked_payload_bytes(dims, voxel_type, available, Storage::Gzip)?;
            let mut decoder = MultiGzDecoder::new(data);
            skip_bytes(&mut decoder, header.byte_skip.max(0) as u64)?;
            read_payload(decoder, bytes).map_err(|p| format!("gzip data: {p}"))?
        }
        NrrdEncoding::Ascii => {
            let count = checked_voxel_count(dims)?;
            // Each ascii value takes at least 2 bytes (digit and separator), bar the last.
            if (count as u64) > available / 2 + 1 {
                return Err(format!(
                    "truncated: {count} ascii values cannot fit in {available} bytes"
                ));
            }
            let mut text = String::new();
            data.take(available)
                .read_to_string(&mut text)
                .map_err(|e| format!("ascii data: {}", io_reason(&e)))?;
            return finish(
                path,
                dims,
                &axes,
                &header,
                parse_ascii(&text, voxel_type, count)?,
            );
        }
    };
    let data = VoxelData::decode(voxel_type, &payload, endian);
    finish(path, dims, &axes, &header, data)
}

/// Builds the volume and applies the header's spacing and orientation.
fn finish(
    path: &Path,
    dims: [usize; 3],
    axes: &[usize; 3],
    header: &Header,
    data: VoxelData,
) -> Result<Volume, Problem> {
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
    let volume = Volume::new(path.display().to_string(), "NRRD", dims, spacing, data)
        .map_err(|e| e.problem)?;
    // Only a header that names its space says where RAS is.
    Ok(match (directions, header.to_ras) {
        (Some(directions), Some(_)) => reorient_to_ras(volume, directions),
        _ => volume,
    })
}

/// The three spatial axes among the header's `dimension` axes (size-1 axes dropped when there
/// are more than three), as dims and as indices into the per-axis fields.
fn spatial_axes(header: &Header) -> Result<([usize; 3], [usize; 3]), Problem> {
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
    let mut axes: Vec<usize> = (0..dimension).collect();
    while axes.len() > 3 {
        match axes.iter().position(|&a| sizes[a] == 1) {
            Some(unit) => {
                axes.remove(unit);
            }
            None => {
                return Err(format!(
                    "NRRD of dimension {dimension} with sizes {sizes:?} is not a scalar 3D volume"
                ));
            }
        }
    }
    let axis = |i: usize| axes.get(i).copied();
    let dims = std::array::from_fn(|i| axis(i).map_or(1, |a| sizes[a]));
    // Missing axes (dimension < 3) have size 1; point them at a non-existent field index.
    let indices = std::array::from_fn(|i| axis(i).unwrap_or(usize::MAX));
    Ok((dims, indices))
}

/// Reads header lines up to the blank line (or the end, in a detached `.nhdr`).
/// Returns the header and the byte offset where data begins.
fn read_header(reader: &mut impl BufRead) -> Result<(Header, u64), Problem> {
    let mut header = Header::default();
    let mut offset = 0u64;
    let mut line = Vec::new();
    let mut first = true;
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
            .map_err(|_| "NRRD header contains bytes that are not text".to_owned())?
            .trim_end_matches(['\n', '\r']);
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
            .ok_or_else(|| format!("NRRD header line '{text}' is not 'field: value'"))?;
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
                    .map_err(|_| format!("NRRD '{key}' value '{n}' is not a number"))
            })
            .collect()
    };
    match key {
        "type" => header.voxel_type = Some(parse_type(value)?),
        "dimension" => {
            let dimension: usize = value
                .parse()
                .map_err(|_| format!("NRRD dimension '{value}' is not a number"))?;
            if !(1..=16).contains(&dimension) {
                return Err(format!("NRRD dimension {dimension} is not 1 to 16"));
            }
            header.dimension = Some(dimension);
        }
        "sizes" => {
            let sizes = value
                .split_whitespace()
                .map(|n| n.parse::<usize>().ok().filter(|&n| n >= 1))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| format!("NRRD sizes '{value}' are not positive integers"))?;
            header.sizes = Some(sizes);
        }
        "encoding" => {
            header.encoding = Some(match value.to_lowercase().as_str() {
                "raw" => NrrdEncoding::Raw,
                "gzip" | "gz" => NrrdEncoding::Gzip,
                "ascii" | "text" | "txt" => NrrdEncoding::Ascii,
                other => {
                    return Err(format!(
                        "NRRD encoding '{other}' is not supported (raw, gzip, ascii)"
                    ));
                }
            })
        }
        "endian" => {
            header.endian = Some(match value {
                "little" => Endian::Little,
                "big" => Endian::Big,
                other => return Err(format!("NRRD endian '{other}' is not little or big")),
            })
        }
        "spacings" => {
            // "nan" marks non-spatial axes; f64 parsing accepts it.
            header.spacings = Some(numbers(value)?);
        }
        "space directions" => header.space_directions = Some(parse_directions(value)?),
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
                return Err(format!("NRRD multi-file data ('{value}') is not supported"));
            }
            header.data_file = Some(value.to_owned());
        }
        "byte skip" | "byteskip" => {
            header.byte_skip = value
                .parse()
                .ok()
                .filter(|&n: &i64| n >= -1)
                .ok_or_else(|| format!("NRRD byte skip '{value}' is invalid"))?
        }
        "line skip" | "lineskip" => {
            header.line_skip = value
                .parse()
                .map_err(|_| format!("NRRD line skip '{value}' is invalid"))?
        }
        _ => {} // content, kinds, units, space origin, …: not needed to draw
    }
    Ok(())
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
        other => return Err(format!("NRRD type '{other}' is not supported")),
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
                .ok_or_else(|| format!("NRRD space direction '{vector}' is not (x,y,z)"))?;
            let components: Vec<f64> = inner
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("NRRD space direction '{vector}' is not (x,y,z)"))?;
            match components[..] {
                [x, y, z] => Ok(Some([x, y, z])),
                _ => Err(format!(
                    "NRRD space direction '{vector}' needs 3 components"
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
                .map_err(|_| format!("ascii value '{t}' is not a number"))
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
