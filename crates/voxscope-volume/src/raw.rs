//! Headerless voxel files whose layout the user gives: `--raw 256x256x108:i16[:be]`.

use std::path::Path;

use super::error::{OptionError, Problem};
use super::io::{Storage, checked_payload_bytes, open, read_payload};
use super::{Endian, Volume, VoxelData, VoxelType, format_dims};

/// Dimensions, voxel type and byte order of a raw file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawLayout {
    pub dims: [usize; 3],
    pub voxel_type: VoxelType,
    pub endian: Endian,
}

impl RawLayout {
    /// Parses `XxYxZ:TYPE[:le|:be]`, e.g. `256x256x108:i16:be`.
    pub fn parse(text: &str) -> Result<Self, OptionError> {
        let layout = || text.to_owned();
        let mut parts = text.split(':');
        let dims_text = parts.next().unwrap_or_default();
        let dims = parse_dims(dims_text).ok_or_else(|| OptionError::RawDims {
            layout: layout(),
            dims: dims_text.to_owned(),
        })?;
        let type_text = parts
            .next()
            .ok_or_else(|| OptionError::RawNoType(layout()))?;
        let voxel_type = VoxelType::from_name(type_text).ok_or_else(|| OptionError::RawType {
            layout: layout(),
            name: type_text.to_owned(),
        })?;
        let endian = match parts.next() {
            None | Some("le") => Endian::Little,
            Some("be") => Endian::Big,
            Some(other) => {
                return Err(OptionError::RawOrder {
                    layout: layout(),
                    order: other.to_owned(),
                });
            }
        };
        if parts.next().is_some() {
            return Err(OptionError::RawParts(layout()));
        }
        Ok(Self {
            dims,
            voxel_type,
            endian,
        })
    }
}

/// Parses `N` (a cube) or `XxYxZ`.
pub fn parse_dims(text: &str) -> Option<[usize; 3]> {
    let numbers: Vec<usize> = text
        .split('x')
        .map(|n| n.trim().parse().ok())
        .collect::<Option<_>>()?;
    match numbers[..] {
        [n] => Some([n; 3]),
        [x, y, z] => Some([x, y, z]),
        _ => None,
    }
}

pub(crate) fn load(path: &Path, layout: &RawLayout, file_bytes: u64) -> Result<Volume, Problem> {
    let bytes = checked_payload_bytes(layout.dims, layout.voxel_type, file_bytes, Storage::Plain)?;
    if bytes as u64 != file_bytes {
        return Err(format!(
            "raw layout {}:{} needs {bytes} bytes but the file holds {file_bytes}",
            format_dims(layout.dims),
            layout.voxel_type.name()
        ));
    }
    let payload = read_payload(open(path)?, bytes, Storage::Plain)?;
    let data = VoxelData::decode(layout.voxel_type, &payload, layout.endian);
    Volume::new(
        path.display().to_string(),
        "raw",
        layout.dims,
        [1.0; 3],
        data,
    )
    .map_err(|e| e.problem)
}
