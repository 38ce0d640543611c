//! The paper's index arithmetic over a cubic voxel list of side `n` (x fastest):
//! listing 1 finds the 8 siblings of a block from its first voxel, listing 2 steps from one
//! block's first voxel to the next block's. The octree build, which keeps only the cells a
//! volume touches, addresses children by coordinates instead; these are the paper's form,
//! checked against that arithmetic by the tests.

/// Listing 1: the 8 voxels of the 2×2×2 block that starts at `start`, in child order
/// (bit 0: +x, bit 1: +y, bit 2: +z).
#[inline]
pub fn sibling_indices(start: usize, n: usize) -> [usize; 8] {
    [
        start,
        start + 1,
        start + n,
        start + n + 1,
        start + n * n,
        start + n * n + 1,
        start + n * n + n,
        start + n * n + n + 1,
    ]
}

/// Listing 2: the first voxel of the block after the one starting at `current`, blocks
/// ordered x, then y, then z. Three cases: next in the row; skip a row (the block's second
/// row); skip a layer (the block's second layer) when the rows of a layer are done.
#[inline]
pub fn next_block_start(current: usize, n: usize) -> usize {
    let mut next = current + 2;
    if (current + 2).is_multiple_of(n) {
        next += n;
        if ((current + 2) / n + 1).is_multiple_of(n) {
            next += n * n;
        }
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force from (x, y, z): block (bx, by, bz) starts at (2bx, 2by, 2bz).
    #[test]
    fn listings_match_coordinates_for_every_block() {
        for n in [2usize, 4, 8, 16] {
            let index = |x: usize, y: usize, z: usize| x + n * (y + n * z);
            let half = n / 2;
            let mut start = 0;
            for bz in 0..half {
                for by in 0..half {
                    for bx in 0..half {
                        assert_eq!(start, index(2 * bx, 2 * by, 2 * bz), "n={n}");
                        let siblings = sibling_indices(start, n);
                        for (child, &voxel) in siblings.iter().enumerate() {
                            let (dx, dy, dz) = (child & 1, (child >> 1) & 1, child >> 2);
                            assert_eq!(voxel, index(2 * bx + dx, 2 * by + dy, 2 * bz + dz));
                        }
                        start = next_block_start(start, n);
                    }
                }
            }
            assert_eq!(start, n * n * n, "after the last block comes the end");
        }
    }
}
