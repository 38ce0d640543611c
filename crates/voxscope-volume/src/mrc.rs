//! MRC / CCP4 maps (`.mrc`, `.map`, `.rec`, `.ccp4`): cryo-EM density maps and electron
//! tomograms. Modes 0 (int8), 1 (int16), 2 (float32), 6 (uint16) and 12 (float16); voxel size
//! from the cell (Å); columns, rows and sections put back in x, y, z order.

use std::io::Read;
use std::path::Path;

use super::error::{Problem, number, printable};
use super::io::{Storage, checked_payload_bytes, io_reason, open, read_payload, skip_bytes};
use super::{Endian, Scalar, Volume, VoxelData, VoxelType};

/// The fixed header; an extended header of NSYMBT bytes may follow.
const HEADER_BYTES: usize = 1024;

/// MRC2014 and CCP4 write `MAP ` at byte 208.
pub(super) fn sniff(head: &[u8]) -> bool {
    head.get(208..212) == Some(b"MAP ")
}

/// Reads an MRC or CCP4 map.
pub(super) fn load(path: &Path) -> Result<Volume, Problem> {
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| format!("cannot open: {}", io_reason(&e)))?
        .len();
    let mut reader = open(path)?;
    let mut header = [0u8; HEADER_BYTES];
    reader
        .read_exact(&mut header)
        .map_err(|_| format!("too short for an MRC header ({HEADER_BYTES} bytes)"))?;
    let endian = byte_order(&header)?;
    let int = |word: usize| i32::decode(&header[4 * word..4 * word + 4], endian);
    let float = |word: usize| f32::decode(&header[4 * word..4 * word + 4], endian) as f64;

    let counts = [int(0), int(1), int(2)];
    if counts.iter().any(|&n| n <= 0) {
        return Err(format!(
            "NX, NY, NZ = {}, {}, {} are not positive",
            counts[0], counts[1], counts[2]
        ));
    }
    let mode = int(3);
    let voxel_type = match mode {
        0 => VoxelType::I8,
        1 => VoxelType::I16,
        2 | 12 => VoxelType::F32,
        6 => VoxelType::U16,
        3 | 4 => {
            return Err(format!(
                "mode {mode} holds complex values; only real maps (modes 0, 1, 2, 6, 12) are supported"
            ));
        }
        other => {
            return Err(format!(
                "mode {other} is not supported (modes 0, 1, 2, 6, 12 are)"
            ));
        }
    };
    let stored_bytes = if mode == 12 { 2 } else { voxel_type.size() };
    let axis_order = [int(16), int(17), int(18)];
    let mut sorted = axis_order;
    sorted.sort_unstable();
    let axis_order = if sorted == [1, 2, 3] {
        axis_order
    } else {
        [1, 2, 3]
    };
    let extended = int(23);
    if extended < 0 || extended as u64 > file_bytes {
        return Err(format!(
            "extended header size NSYMBT = {extended} is impossible for a {file_bytes}-byte file"
        ));
    }

    // Sizes are validated against the file before anything that large is allocated.
    let stored_dims = counts.map(|n| n as usize);
    let available = file_bytes.saturating_sub((HEADER_BYTES + extended as usize) as u64);
    let needed = checked_payload_bytes(stored_dims, voxel_type, u64::MAX, Storage::Plain)?
        / voxel_type.size()
        * stored_bytes;
    if needed as u64 > available {
        return Err(format!(
            "truncated or inconsistent: {}x{}x{} voxels of mode {mode} need {needed} bytes but the file holds {available} after its headers",
            stored_dims[0], stored_dims[1], stored_dims[2]
        ));
    }
    skip_bytes(&mut reader, extended as u64)?;
    let payload = read_payload(reader, needed, Storage::Plain)?;
    let stored = if mode == 12 {
        VoxelData::F32(
            payload
                .chunks_exact(2)
                .map(|c| half::f16::from_bits(u16::decode(c, endian)).to_f32())
                .collect(),
        )
    } else {
        VoxelData::decode(voxel_type, &payload, endian)
    };

    // Stored order: columns fastest, then rows, then sections; axis_order names the x/y/z
    // axis (1, 2, 3) of each. Put x fastest.
    let axis_of = axis_order.map(|a| (a - 1) as usize);
    let mut dims = [0usize; 3];
    for (stored_axis, &axis) in axis_of.iter().enumerate() {
        dims[axis] = stored_dims[stored_axis];
    }
    let data = if axis_of == [0, 1, 2] {
        stored
    } else {
        let strides = [1, stored_dims[0], stored_dims[0] * stored_dims[1]];
        stored.gather(dims.iter().product(), |n| {
            let xyz = [
                n % dims[0],
                (n / dims[0]) % dims[1],
                n / (dims[0] * dims[1]),
            ];
            (0..3).map(|s| xyz[axis_of[s]] * strides[s]).sum()
        })
    };

    // Voxel size: cell length over sampling (MX, MY, MZ), in Å.
    let sampling = [int(7), int(8), int(9)];
    let cell = [float(10), float(11), float(12)];
    let spacing: [f64; 3] = std::array::from_fn(|a| {
        if sampling[a] > 0 && cell[a].is_finite() && cell[a] > 0.0 {
            cell[a] / sampling[a] as f64
        } else {
            1.0
        }
    });
    let mut volume = Volume::new(path.display().to_string(), "MRC", dims, spacing, data)
        .map_err(|e| e.problem)?;
    let labels = int(55).clamp(0, 10) as usize;
    volume.metadata = vec![
        (
            "mode".to_owned(),
            format!(
                "{mode} ({})",
                if mode == 12 { "f16" } else { voxel_type.name() }
            ),
        ),
        ("unit".to_owned(), "Å".to_owned()),
        (
            "axis order".to_owned(),
            format!("{}, {}, {}", axis_order[0], axis_order[1], axis_order[2]),
        ),
        (
            "origin".to_owned(),
            format!(
                "{}, {}, {}",
                number(float(49)),
                number(float(50)),
                number(float(51))
            ),
        ),
    ];
    if let Some(label) = (0..labels)
        .map(|i| {
            printable(
                String::from_utf8_lossy(&header[224 + 80 * i..304 + 80 * i])
                    .trim_matches(|c: char| c == '\0' || c.is_whitespace()),
            )
        })
        .find(|l| !l.is_empty())
    {
        volume.metadata.push(("label".to_owned(), label));
    }
    Ok(volume)
}

/// The byte order from MACHST (0x44 0x4? little, 0x11 0x11 big); old files without it are
/// read in whichever order gives a sane mode.
fn byte_order(header: &[u8; HEADER_BYTES]) -> Result<Endian, Problem> {
    match header[212] {
        0x44 => return Ok(Endian::Little),
        0x11 => return Ok(Endian::Big),
        _ => {}
    }
    // Sane: a known mode and axis lengths below 2^20 in that order.
    let sane = |endian: Endian| {
        let word = |w: usize| i32::decode(&header[4 * w..4 * w + 4], endian);
        ((0..=12).contains(&word(3)) || word(3) == 101)
            && (0..3).all(|w| (1..1 << 20).contains(&word(w)))
    };
    if sane(Endian::Little) {
        Ok(Endian::Little)
    } else if sane(Endian::Big) {
        Ok(Endian::Big)
    } else {
        Err("not an MRC/CCP4 map: no byte order gives a known mode and sane sizes".into())
    }
}
