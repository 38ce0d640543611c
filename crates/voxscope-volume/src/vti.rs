//! VTK XML ImageData (`.vti`), ParaView's usual export: ascii, base64 `binary` and appended
//! (raw or base64) data arrays, uncompressed or zlib-compressed, 32- or 64-bit headers.
//! The point-data scalars are read (or the first one-component cell or point array).

use std::io::Read;
use std::path::Path;

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD;
use flate2::read::ZlibDecoder;

use super::error::{Problem, printable, quoted, short_list};
use super::io::{MAX_DEFLATE_RATIO, io_reason};
use super::{Endian, MAX_VOXELS, Scalar, Volume, VoxelData, VoxelType, checked_voxel_count};

/// Largest file read into memory (the XML and its data are parsed whole).
const MAX_FILE_BYTES: u64 = 1 << 34;

/// The appended data block of a file: its encoding (`raw` or `base64`) and its bytes after
/// the `_` that starts them.
type Appended<'a> = Option<(String, &'a [u8])>;

/// Reads a `.vti` file.
pub(super) fn load(path: &Path) -> Result<Volume, Problem> {
    let bytes = read_whole(path)?;
    let (text, appended) = split_appended(&bytes)?;
    let document =
        roxmltree::Document::parse(&text).map_err(|e| format!("not valid VTK XML: {e}"))?;
    let root = document.root_element();
    let encoding = image_data_encoding(root)?;
    let image = child(root, "ImageData").ok_or("no <ImageData> element")?;
    let extent = numbers::<i64>(
        "WholeExtent",
        image.attribute("WholeExtent").ok_or("no WholeExtent")?,
        6,
    )?;
    let spacing = image
        .attribute("Spacing")
        .map(|s| numbers::<f64>("Spacing", s, 3))
        .transpose()?
        .unwrap_or(vec![1.0; 3]);
    let pieces: Vec<_> = image
        .children()
        .filter(|n| n.has_tag_name("Piece"))
        .collect();
    if pieces.len() != 1 {
        return Err(format!(
            "{} pieces; only single-piece image data is supported",
            pieces.len()
        ));
    }
    let (array, dims) = scalar_array(pieces[0], point_dims(&extent)?)?;
    let array_name = quoted(array.attribute("Name").unwrap_or(""));
    let components_text = array.attribute("NumberOfComponents").unwrap_or("1");
    let components: usize = components_text.parse().map_err(|_| {
        format!(
            "array {array_name}: NumberOfComponents {} is not a whole number",
            quoted(components_text)
        )
    })?;
    if components != 1 {
        return Err(format!(
            "array {array_name} has {components} components; only scalars are supported"
        ));
    }
    let dims = dims.map(|n| n as usize);
    let count = checked_voxel_count(dims)?;
    let type_name = array.attribute("type").ok_or("a DataArray without type")?;
    let voxel_type = voxel_type_named(type_name).ok_or_else(|| {
        format!(
            "array {array_name}: DataArray type {} is not supported",
            quoted(type_name)
        )
    })?;
    let format = array.attribute("format").unwrap_or("ascii");
    let wanted = WantedArray {
        name: &array_name,
        count,
        voxel_type,
        encoding,
    };
    let data = match format {
        "ascii" => wanted.read_ascii(array.text().unwrap_or_default())?,
        "binary" => wanted.read_inline_binary(array.text().unwrap_or_default())?,
        "appended" => {
            let offset = array.attribute("offset").unwrap_or("0");
            wanted.read_appended(appended, offset)?
        }
        other => {
            return Err(format!(
                "array {array_name}: DataArray format {} is not supported",
                quoted(other)
            ));
        }
    };
    if count > MAX_VOXELS {
        return Err(format!("more than {MAX_VOXELS} voxels"));
    }
    let mut volume = Volume::new(
        path.display().to_string(),
        "VTK ImageData",
        dims,
        [spacing[0], spacing[1], spacing[2]],
        data,
    )
    .map_err(|e| e.problem)?;
    volume.metadata = vec![(
        "array".to_owned(),
        format!(
            "{} ({type_name}, {format}{})",
            printable(array.attribute("Name").unwrap_or("unnamed")),
            if encoding.compressed { ", zlib" } else { "" }
        ),
    )];
    if let Some(origin) = image.attribute("Origin") {
        volume
            .metadata
            .push(("origin".to_owned(), printable(origin)));
    }
    Ok(volume)
}

/// The whole file, if it is within [`MAX_FILE_BYTES`].
fn read_whole(path: &Path) -> Result<Vec<u8>, Problem> {
    let size = std::fs::metadata(path)
        .map_err(|e| format!("cannot open: {}", io_reason(&e)))?
        .len();
    if size > MAX_FILE_BYTES {
        return Err(format!(
            "{size} bytes is beyond the {MAX_FILE_BYTES}-byte limit"
        ));
    }
    std::fs::read(path).map_err(|e| format!("cannot read: {}", io_reason(&e)))
}

/// The XML text of `bytes` and its appended data, if any. Appended raw data is binary inside
/// the XML: the text before it is parsed (closed again), and the bytes after the `_` that
/// starts it are kept.
fn split_appended(bytes: &[u8]) -> Result<(String, Appended<'_>), Problem> {
    let Some(at) = find(bytes, b"<AppendedData") else {
        return Ok((String::from_utf8_lossy(bytes).into_owned(), None));
    };
    let tag_end = find(&bytes[at..], b">")
        .map(|i| at + i + 1)
        .ok_or("an unterminated <AppendedData> tag")?;
    let underscore = find(&bytes[tag_end..], b"_")
        .map(|i| tag_end + i + 1)
        .ok_or("<AppendedData> without its '_' marker")?;
    let encoding = attribute_in(&bytes[at..tag_end], "encoding").unwrap_or_else(|| "raw".into());
    let mut text = String::from_utf8_lossy(&bytes[..at]).into_owned();
    text.push_str("</VTKFile>");
    Ok((text, Some((encoding, &bytes[underscore..]))))
}

/// How the arrays of the `<VTKFile>` element `root` are encoded (byte order, header words,
/// zlib), once it is checked to hold ImageData.
fn image_data_encoding(root: roxmltree::Node<'_, '_>) -> Result<ArrayEncoding, Problem> {
    if root.tag_name().name() != "VTKFile" || root.attribute("type") != Some("ImageData") {
        return Err(format!(
            "a VTK XML file of type {}; only ImageData (.vti) holds a regular grid",
            quoted(root.attribute("type").unwrap_or("?"))
        ));
    }
    let endian = match root.attribute("byte_order") {
        Some("BigEndian") => Endian::Big,
        _ => Endian::Little,
    };
    let compressed = match root.attribute("compressor") {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(other) => {
            return Err(format!(
                "compressor {} is not supported (zlib is)",
                quoted(other)
            ));
        }
    };
    Ok(ArrayEncoding {
        header64: root.attribute("header_type") == Some("UInt64"),
        endian,
        compressed,
    })
}

/// Points along x, y, z of a `WholeExtent` (`x0 x1 y0 y1 z0 z1`, inclusive).
fn point_dims(extent: &[i64]) -> Result<[i64; 3], Problem> {
    let mut point_dims = [0i64; 3];
    for (axis, points) in point_dims.iter_mut().enumerate() {
        *points = extent[2 * axis + 1]
            .checked_sub(extent[2 * axis])
            .and_then(|d| d.checked_add(1))
            .ok_or_else(|| format!("WholeExtent {} is too large", short_list(extent)))?;
    }
    if point_dims.iter().any(|&n| n < 1) {
        return Err(format!("WholeExtent {} is empty", short_list(extent)));
    }
    Ok(point_dims)
}

/// The scalars of `piece` and their dimensions: PointData's named Scalars, else its first
/// one-component array, else CellData's (one fewer per axis, at least 1).
fn scalar_array<'a, 'input>(
    piece: roxmltree::Node<'a, 'input>,
    point_dims: [i64; 3],
) -> Result<(roxmltree::Node<'a, 'input>, [i64; 3]), Problem> {
    ["PointData", "CellData"]
        .iter()
        .filter_map(|section| child(piece, section).map(|s| (s, *section)))
        .find_map(|(section, name)| {
            let arrays: Vec<_> = section
                .children()
                .filter(|n| n.has_tag_name("DataArray"))
                .collect();
            let named = section
                .attribute("Scalars")
                .and_then(|s| arrays.iter().find(|a| a.attribute("Name") == Some(s)));
            let array = named.or_else(|| {
                arrays
                    .iter()
                    .find(|a| a.attribute("NumberOfComponents").is_none_or(|c| c == "1"))
            })?;
            let dims = if name == "PointData" {
                point_dims
            } else {
                point_dims.map(|n| (n - 1).max(1))
            };
            Some((*array, dims))
        })
        .ok_or_else(|| "no one-component point or cell data array".to_owned())
}

/// The voxel type of a DataArray's `type`, if voxscope reads it.
fn voxel_type_named(type_name: &str) -> Option<VoxelType> {
    Some(match type_name {
        "Int8" => VoxelType::I8,
        "UInt8" => VoxelType::U8,
        "Int16" => VoxelType::I16,
        "UInt16" => VoxelType::U16,
        "Int32" => VoxelType::I32,
        "UInt32" => VoxelType::U32,
        "Float32" => VoxelType::F32,
        "Float64" => VoxelType::F64,
        _ => return None,
    })
}

/// The scalar array to read: its name (quoted, for messages), how many values of which type,
/// and how the file encodes its arrays.
struct WantedArray<'a> {
    name: &'a str,
    count: usize,
    voxel_type: VoxelType,
    encoding: ArrayEncoding,
}

impl WantedArray<'_> {
    /// Bytes the values take once decoded.
    fn needed(&self) -> usize {
        self.count * self.voxel_type.size()
    }

    /// The values of an `ascii` array's `text`.
    fn read_ascii(&self, text: &str) -> Result<VoxelData, Problem> {
        let values: Vec<f64> = text
            .split_ascii_whitespace()
            .take(self.count + 1)
            .map(|v| {
                v.parse::<f64>().map_err(|_| {
                    format!(
                        "array {}: ascii value {} is not a number",
                        self.name,
                        quoted(v)
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        if values.len() != self.count {
            return Err(format!(
                "the ascii array holds {} values, {} expected",
                values.len(),
                self.count
            ));
        }
        Ok(VoxelData::from_f64_values(self.voxel_type, &values))
    }

    /// The values of a `binary` (base64) array's `text`, whitespace left out.
    fn read_inline_binary(&self, text: &str) -> Result<VoxelData, Problem> {
        let text: String = text.chars().filter(|c| !c.is_ascii_whitespace()).collect();
        let raw = decode_inline_binary(&text, self.encoding, self.needed())?;
        Ok(VoxelData::decode(
            self.voxel_type,
            &raw,
            self.encoding.endian,
        ))
    }

    /// The values of an `appended` array at `offset_text` in the appended data (raw or
    /// base64).
    fn read_appended(
        &self,
        appended: Appended<'_>,
        offset_text: &str,
    ) -> Result<VoxelData, Problem> {
        let name = self.name;
        let (appended_encoding, appended) =
            appended.ok_or("an appended array without <AppendedData>")?;
        let offset: usize = offset_text.parse().map_err(|_| {
            format!(
                "array {name}: offset {} is not a whole number",
                quoted(offset_text)
            )
        })?;
        let block = appended.get(offset..).ok_or_else(|| {
            format!("array {name}: offset {offset} is past the end of the appended data")
        })?;
        let raw = if appended_encoding == "base64" {
            let end = block
                .iter()
                .position(|b| !(b.is_ascii_alphanumeric() || matches!(b, b'+' | b'/' | b'=')))
                .unwrap_or(block.len());
            decode_inline_binary(
                std::str::from_utf8(&block[..end]).unwrap_or_default(),
                self.encoding,
                self.needed(),
            )?
        } else {
            read_blocks(block, self.encoding, self.needed())?
        };
        Ok(VoxelData::decode(
            self.voxel_type,
            &raw,
            self.encoding.endian,
        ))
    }
}

/// Decodes a `binary` (base64) array: header and data encoded together, or (compressed)
/// the header and the blocks encoded separately.
fn decode_inline_binary(
    text: &str,
    encoding: ArrayEncoding,
    needed: usize,
) -> Result<Vec<u8>, Problem> {
    let word = encoding.word_bytes();
    if !encoding.compressed {
        let raw = STANDARD
            .decode(text)
            .map_err(|e| format!("bad base64 data: {e}"))?;
        return read_blocks(&raw, encoding, needed);
    }
    // The header (3 words + one per block) is a base64 string of its own.
    let first = STANDARD
        .decode(
            text.get(..base64_len(3 * word))
                .ok_or("a truncated base64 header")?,
        )
        .map_err(|e| format!("bad base64 header: {e}"))?;
    let blocks = encoding.word(&first, 0)?;
    if blocks > needed + 1 {
        return Err(format!("a header claiming {blocks} blocks"));
    }
    let header_text = base64_len((3 + blocks) * word);
    let header = STANDARD
        .decode(text.get(..header_text).ok_or("a truncated base64 header")?)
        .map_err(|e| format!("bad base64 header: {e}"))?;
    let data = STANDARD
        .decode(&text[header_text..])
        .map_err(|e| format!("bad base64 data: {e}"))?;
    let mut joined = header;
    joined.truncate((3 + blocks) * word);
    joined.extend(data);
    read_blocks(&joined, encoding, needed)
}

fn base64_len(bytes: usize) -> usize {
    bytes.div_ceil(3) * 4
}

/// Reads an array's bytes after its header: uncompressed (one byte-count word) or zlib
/// blocks (`[blocks, block size, last size, compressed sizes…]`).
fn read_blocks(block: &[u8], encoding: ArrayEncoding, needed: usize) -> Result<Vec<u8>, Problem> {
    let word = encoding.word_bytes();
    if !encoding.compressed {
        let length = encoding.word(block, 0)?;
        if length < needed {
            return Err(format!("the array holds {length} bytes, {needed} expected"));
        }
        return block
            .get(word..word + needed)
            .map(<[u8]>::to_vec)
            .ok_or_else(|| format!("truncated: {needed} bytes of data expected"));
    }
    let blocks = encoding.word(block, 0)?;
    let block_size = encoding.word(block, 1)?;
    if blocks == 0
        || block_size == 0
        || blocks.saturating_mul(block_size) < needed
        || blocks > needed / block_size + 2
    {
        return Err(format!(
            "a compression header of {blocks} blocks of {block_size} bytes for {needed} bytes"
        ));
    }
    let mut at = (3 + blocks) * word;
    if at > block.len() {
        return Err("truncated compression header".into());
    }
    // Every block inside the data, and all of them able to hold what is needed, before the
    // output buffer of `needed` bytes exists.
    let mut compressed_bytes = 0u64;
    for b in 0..blocks {
        compressed_bytes = compressed_bytes.saturating_add(encoding.word(block, 3 + b)? as u64);
    }
    if compressed_bytes > (block.len() - at) as u64 {
        return Err(format!(
            "truncated: {blocks} compressed blocks of {compressed_bytes} bytes, {} bytes in the file",
            block.len() - at
        ));
    }
    if compressed_bytes.saturating_mul(MAX_DEFLATE_RATIO) < needed as u64 {
        return Err(format!(
            "{compressed_bytes} bytes of zlib blocks cannot hold the {needed} bytes needed"
        ));
    }
    let mut out = Vec::with_capacity(needed);
    for b in 0..blocks {
        let size = encoding.word(block, 3 + b)?;
        let chunk = block
            .get(at..at + size)
            .ok_or("truncated: a compressed block runs past the end of the file")?;
        if (size as u64).saturating_mul(MAX_DEFLATE_RATIO)
            < block_size.min(needed - out.len()) as u64
        {
            return Err("a compressed block too small for its size".into());
        }
        let limit = (needed - out.len()).min(block_size) as u64;
        ZlibDecoder::new(chunk)
            .take(limit)
            .read_to_end(&mut out)
            .map_err(|e| format!("bad zlib data: {}", io_reason(&e)))?;
        at += size;
        if out.len() >= needed {
            break;
        }
    }
    if out.len() < needed {
        return Err(format!(
            "the compressed array holds {} bytes, {needed} expected",
            out.len()
        ));
    }
    Ok(out)
}

/// How the file's binary arrays are stored: the header's word size (`header_type`), the byte
/// order, and whether the data is in zlib blocks.
#[derive(Debug, Clone, Copy)]
struct ArrayEncoding {
    header64: bool,
    endian: Endian,
    compressed: bool,
}

impl ArrayEncoding {
    fn word_bytes(self) -> usize {
        if self.header64 { 8 } else { 4 }
    }

    /// Word `index` of an array header.
    fn word(self, bytes: &[u8], index: usize) -> Result<usize, Problem> {
        let word = self.word_bytes();
        let raw = bytes
            .get(index * word..(index + 1) * word)
            .ok_or("truncated array header")?;
        let value = match (self.header64, self.endian) {
            (true, Endian::Little) => u64::from_le_bytes(raw.try_into().expect("8 bytes")),
            (true, Endian::Big) => u64::from_be_bytes(raw.try_into().expect("8 bytes")),
            (false, _) => u32::decode(raw, self.endian) as u64,
        };
        usize::try_from(value)
            .map_err(|_| "an array header beyond this machine's address space".into())
    }
}

fn child<'a, 'input>(
    node: roxmltree::Node<'a, 'input>,
    name: &str,
) -> Option<roxmltree::Node<'a, 'input>> {
    node.children().find(|n| n.has_tag_name(name))
}

/// The `count` numbers of attribute `name`; the problem names the attribute.
fn numbers<T: std::str::FromStr>(name: &str, text: &str, count: usize) -> Result<Vec<T>, Problem> {
    let values: Vec<T> = text
        .split_ascii_whitespace()
        .map(|v| {
            v.parse().map_err(|_| {
                if v.trim_start_matches('-')
                    .bytes()
                    .all(|b| b.is_ascii_digit())
                {
                    format!("{name} value {} is too large", quoted(v))
                } else {
                    format!("{name} value {} is not a number", quoted(v))
                }
            })
        })
        .collect::<Result<_, _>>()?;
    if values.len() != count {
        return Err(format!(
            "{name} {} should hold {count} numbers, not {}",
            quoted(text),
            values.len()
        ));
    }
    Ok(values)
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn attribute_in(tag: &[u8], name: &str) -> Option<String> {
    let text = String::from_utf8_lossy(tag);
    let start = text.find(&format!("{name}=\""))? + name.len() + 2;
    let end = text[start..].find('"')?;
    Some(text[start..start + end].to_owned())
}
