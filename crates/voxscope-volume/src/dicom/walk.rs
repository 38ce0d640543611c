//! A bounded walk over a DICOM file's elements, done before dicom-object parses the file.
//!
//! dicom-object reserves and zero-fills each element's declared length before it reads the
//! value, so one damaged length (or a parser thrown out of step by one bad byte) made it
//! allocate up to 4 GiB for a 50 KB file. This walk reads the same elements in the same way —
//! the meta group with dicom-encoding's explicit VR little endian header decoder, the data set
//! with dicom-parser's own token reader, which dicom-object uses — but stops at each element
//! header and checks its length against the bytes that remain, before the value is read. A
//! file that passes can make dicom-object allocate at most about its own size per element.
//! The walk also gives the errors their tag and byte offset.

use std::cell::Cell;
use std::io::Read;
use std::rc::Rc;

use dicom_core::Tag;
use dicom_core::header::{HasLength, Header};
use dicom_encoding::decode::Decode;
use dicom_encoding::decode::explicit_le::ExplicitVRLittleEndianDecoder;
use dicom_encoding::transfer_syntax::{Codec, TransferSyntaxIndex};
use dicom_parser::dataset::{DataSetReader, DataToken};
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;

use crate::error::{Problem, quoted};

/// dicom-object stops reading at the first top-level element at or after Pixel Data.
const PIXEL_DATA: Tag = Tag(0x7fe0, 0x0010);

/// Where the meta group starts: after the 128-byte preamble and `DICM`.
const META_START: usize = 132;

/// A reader over the file's bytes that tells how far it has read.
struct Tracked<'a> {
    bytes: &'a [u8],
    position: Rc<Cell<usize>>,
}

impl Read for Tracked<'_> {
    fn read(&mut self, buffer: &mut [u8]) -> std::io::Result<usize> {
        let at = self.position.get();
        let rest = self.bytes.get(at..).unwrap_or_default();
        let count = buffer.len().min(rest.len());
        buffer[..count].copy_from_slice(&rest[..count]);
        self.position.set(at + count);
        Ok(count)
    }
}

/// `(0028,0010)`.
pub(super) fn tag_name(tag: Tag) -> String {
    format!("({:04x},{:04x})", tag.0, tag.1)
}

/// Checks every element length of the meta group and of the data set up to the pixel data
/// against the bytes that remain after it. Returns the transfer syntax UID.
pub(super) fn check_lengths(bytes: &[u8]) -> Result<String, Problem> {
    if bytes.get(128..META_START) != Some(b"DICM") {
        return Err("not a DICOM file (no 'DICM' at byte 128)".into());
    }
    let (syntax, meta_end) = check_meta_group(bytes)?;
    let transfer_syntax = TransferSyntaxRegistry
        .get(&syntax)
        .ok_or_else(|| format!("transfer syntax {} is not a known one", quoted(&syntax)))?;
    if let Codec::Dataset(_) = transfer_syntax.codec() {
        return Err(format!(
            "transfer syntax {} ({}) compresses the whole data set, which is not supported",
            syntax,
            transfer_syntax.name()
        ));
    }
    check_data_set(bytes, meta_end, transfer_syntax)?;
    Ok(syntax)
}

/// The meta group as dicom-object reads it: its length element (0002,0000) first, then
/// elements (explicit VR little endian) until that many bytes are read.
fn check_meta_group(bytes: &[u8]) -> Result<(String, usize), Problem> {
    let position = Rc::new(Cell::new(META_START));
    let mut reader = Tracked {
        bytes,
        position: position.clone(),
    };
    let decoder = ExplicitVRLittleEndianDecoder::default();
    let ends_early = |at: usize| format!("the meta group ends early (byte {at})");
    let (first, _) = decoder
        .decode_header(&mut reader)
        .map_err(|_| ends_early(META_START))?;
    if first.tag() != Tag(0x0002, 0x0000) || first.length().get() != Some(4) {
        return Err(format!(
            "the meta group starts with element {} of {} bytes, not its 4-byte length (0002,0000)",
            tag_name(first.tag()),
            first
                .length()
                .get()
                .map_or("undefined".into(), |l| l.to_string())
        ));
    }
    let mut length = [0u8; 4];
    reader
        .read_exact(&mut length)
        .map_err(|_| ends_early(position.get()))?;
    let group_length = u32::from_le_bytes(length);
    let mut read = 0u32;
    let mut syntax = String::new();
    while read < group_length {
        let at = position.get();
        let (header, header_bytes) = decoder
            .decode_header(&mut reader)
            .map_err(|_| ends_early(at))?;
        let length = header.length().get().ok_or_else(|| {
            format!(
                "meta element {} at byte {at} has an undefined length",
                tag_name(header.tag())
            )
        })?;
        let value_start = position.get();
        let remaining = bytes.len() - value_start;
        if length as usize > remaining {
            return Err(format!(
                "meta element {} at byte {at} declares {length} bytes, but only {remaining} remain",
                tag_name(header.tag())
            ));
        }
        if header.tag() == Tag(0x0002, 0x0010) {
            let value = &bytes[value_start..value_start + length as usize];
            syntax = String::from_utf8_lossy(value)
                .trim_end_matches(|c: char| c.is_whitespace() || c == '\0')
                .to_owned();
        }
        position.set(value_start + length as usize);
        read = read
            .saturating_add(header_bytes as u32)
            .saturating_add(length);
    }
    Ok((syntax, position.get()))
}

/// The data set, token by token, as dicom-object's reader produces them: each element's
/// length (and each item's) is checked before the token that reads its value is taken.
fn check_data_set(
    bytes: &[u8],
    start: usize,
    transfer_syntax: &dicom_encoding::TransferSyntax,
) -> Result<(), Problem> {
    let position = Rc::new(Cell::new(start));
    let reader = Tracked {
        bytes,
        position: position.clone(),
    };
    let mut tokens = DataSetReader::new_with_ts(reader, transfer_syntax)
        .map_err(|e| format!("cannot read the data set: {}", root_cause(&e)))?;
    // Open sequences (pixel data fragments included); 0 is the top level.
    let mut depth = 0usize;
    let mut last: Option<(Tag, usize)> = None;
    let check = |what: String, at: usize, length: u32| -> Result<(), Problem> {
        let remaining = bytes.len().saturating_sub(position.get());
        if length != u32::MAX && length as usize > remaining {
            return Err(format!(
                "{what} at byte {at} declares {length} bytes, but only {remaining} remain"
            ));
        }
        Ok(())
    };
    loop {
        let at = position.get();
        let token = match tokens.next() {
            None => return Ok(()),
            Some(Ok(token)) => token,
            Some(Err(error)) => {
                let after = last
                    .map(|(tag, at)| format!(" (after element {} at byte {at})", tag_name(tag)))
                    .unwrap_or_default();
                return Err(format!(
                    "cannot read the data set at byte {at}{after}: {}",
                    root_cause(&error)
                ));
            }
        };
        match token {
            DataToken::ElementHeader(header) => {
                if depth == 0 && header.tag >= PIXEL_DATA {
                    return Ok(());
                }
                check(
                    format!("element {}", tag_name(header.tag)),
                    at,
                    header.len.0,
                )?;
                last = Some((header.tag, at));
            }
            DataToken::SequenceStart { tag, len } => {
                if depth == 0 && tag >= PIXEL_DATA {
                    return Ok(());
                }
                check(format!("sequence {}", tag_name(tag)), at, len.0)?;
                depth += 1;
                last = Some((tag, at));
            }
            DataToken::PixelSequenceStart => {
                if depth == 0 {
                    return Ok(());
                }
                depth += 1;
            }
            DataToken::SequenceEnd => depth = depth.saturating_sub(1),
            DataToken::ItemStart { len } => check("an item".into(), at, len.0)?,
            _ => {}
        }
    }
}

/// The innermost cause of a parser error, in words: `the file ends early` for a read past
/// the end (the library says "failed to fill whole buffer"), else its own text.
pub(super) fn root_cause(error: &(dyn std::error::Error + 'static)) -> String {
    let mut innermost = error;
    while let Some(source) = innermost.source() {
        innermost = source;
    }
    if let Some(io) = innermost.downcast_ref::<std::io::Error>()
        && io.kind() == std::io::ErrorKind::UnexpectedEof
    {
        return "the file ends early".into();
    }
    let text = innermost.to_string();
    let first = text.lines().next().unwrap_or_default();
    first.to_owned()
}
