//! neuroglancer's `compressed_segmentation` encoding: per channel, a grid of blocks, each a
//! lookup table of the labels it holds and the voxels' indices into it, packed in 0, 1, 2, 4,
//! 8, 16 or 32 bits (little-endian 32-bit words throughout; a uint64 label is two words, low
//! first). See neuroglancer's `src/sliceview/compressed_segmentation/README.md`.
//!
//! Every offset and index is checked against the data before it is followed: a damaged chunk
//! is an error, never a read outside it.

/// Decodes a chunk of `extent` voxels (x, y, z) and `channels` channels, in blocks of `block`
/// voxels, to its labels, x fastest then y, z, channel: 4 bytes a label, or 8 if `wide`
/// (uint64), little-endian.
pub(super) fn decode(
    encoded: &[u8],
    extent: [usize; 3],
    block: [usize; 3],
    channels: usize,
    wide: bool,
) -> Result<Vec<u8>, String> {
    if !encoded.len().is_multiple_of(4) {
        return Err(format!(
            "a compressed_segmentation chunk of {} bytes, not whole 32-bit words",
            encoded.len()
        ));
    }
    let words: Vec<u32> = encoded
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect();
    let label_words = if wide { 2 } else { 1 };
    let voxels = extent.iter().product::<usize>();
    let mut out = vec![0u8; voxels * channels * 4 * label_words];
    let grid: [usize; 3] = std::array::from_fn(|a| extent[a].div_ceil(block[a]));
    let block_voxels = block.iter().product::<usize>();
    for c in 0..channels {
        let start = *words
            .get(c)
            .ok_or_else(|| format!("no offset of channel {c}"))? as usize;
        let channel = words
            .get(start..)
            .ok_or_else(|| format!("channel {c} begins at word {start}, past the chunk"))?;
        for b in 0..grid.iter().product::<usize>() {
            let (bx, by, bz) = (b % grid[0], b / grid[0] % grid[1], b / grid[0] / grid[1]);
            let header = channel
                .get(2 * b..2 * b + 2)
                .ok_or_else(|| format!("block {b} of channel {c} has no header"))?;
            let table = (header[0] & 0x00FF_FFFF) as usize;
            let bits = (header[0] >> 24) as usize;
            let values = header[1] as usize;
            if ![0, 1, 2, 4, 8, 16, 32].contains(&bits) {
                return Err(format!("block {b} of channel {c} packs {bits}-bit indices"));
            }
            let packed_words = (block_voxels * bits).div_ceil(32);
            let packed = channel.get(values..values + packed_words).ok_or_else(|| {
                format!("block {b} of channel {c}: its indices lie past the chunk")
            })?;
            let lookup = channel.get(table..).ok_or_else(|| {
                format!("block {b} of channel {c}: its table lies past the chunk")
            })?;
            let mask = if bits == 32 {
                u32::MAX
            } else {
                (1u32 << bits) - 1
            };
            for z in 0..block[2] {
                let vz = bz * block[2] + z;
                for y in 0..block[1] {
                    let vy = by * block[1] + y;
                    if vz >= extent[2] || vy >= extent[1] {
                        continue;
                    }
                    for x in 0..block[0] {
                        let vx = bx * block[0] + x;
                        if vx >= extent[0] {
                            continue;
                        }
                        let v = x + block[0] * (y + block[1] * z);
                        let index = if bits == 0 {
                            0
                        } else {
                            let bit = v * bits;
                            ((packed[bit / 32] >> (bit % 32)) & mask) as usize
                        };
                        let entry = lookup
                            .get(index * label_words..(index + 1) * label_words)
                            .ok_or_else(|| {
                                format!("block {b} of channel {c}: index {index} past its table")
                            })?;
                        let at = (((c * extent[2] + vz) * extent[1] + vy) * extent[0] + vx)
                            * 4
                            * label_words;
                        for (w, word) in entry.iter().enumerate() {
                            out[at + 4 * w..at + 4 * w + 4].copy_from_slice(&word.to_le_bytes());
                        }
                    }
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(words: &[u32]) -> Vec<u8> {
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }

    #[test]
    fn blocks_of_one_label_and_of_packed_indices_decode() {
        // One channel, extent 3x1x1 in blocks of 2x1x1: block 0 holds labels 7 and 9 (1-bit
        // indices 0, 1), block 1 (cut to one voxel) only label 5 (0 bits).
        let words = [
            1,             // channel 0 at word 1; offsets below count from there
            (1 << 24) | 4, // block 0: table at 4, 1-bit indices
            6,             // block 0's indices at 6
            7,             // block 1: table at 7, 0 bits
            6,             // (no indices)
            7,             // block 0's table: labels 7 and 9
            9,
            0b10, // block 0's indices: voxel 0 -> 0, voxel 1 -> 1
            5,    // block 1's table
        ];
        let labels = decode(&bytes(&words), [3, 1, 1], [2, 1, 1], 1, false).unwrap();
        assert_eq!(labels, bytes(&[7, 9, 5]));
    }

    #[test]
    fn offsets_past_the_chunk_are_errors() {
        let words = [1, (1 << 24) | 500, 7];
        let error = decode(&bytes(&words), [2, 1, 1], [2, 1, 1], 1, false).unwrap_err();
        assert!(error.contains("past the chunk"), "{error}");
        let words = [1, 3 << 24, 3, 0];
        let error = decode(&bytes(&words), [2, 1, 1], [2, 1, 1], 1, false).unwrap_err();
        assert!(error.contains("3-bit"), "{error}");
        assert!(decode(&[1, 2, 3], [1, 1, 1], [1, 1, 1], 1, false).is_err());
    }
}
