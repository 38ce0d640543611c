//! The part of a chunk a region reaches, and a chunk's faces: the planes kept from a
//! decoded chunk for the neighbouring bricks' padding, so they need not decode it again.

use super::*;

/// A chunk that a region read from a stored level reaches ([`ZarrSource::region_parts`]):
/// its index, where it lies and the part of it inside the region, and where that part comes
/// from.
pub(super) struct RegionPart {
    pub(super) index: [usize; 3],
    pub(super) part: ChunkPart,
    pub(super) from: PartFrom,
}

/// Where a [`RegionPart`]'s voxels come from.
pub(super) enum PartFrom {
    /// The kept faces of the chunk ([`chunk_faces`]): the part is one voxel thick at the
    /// chunk's end along the face's axis (which, and whether its high end).
    Faces((usize, bool), Arc<Vec<u16>>),
    /// The decoded chunk, kept.
    Decoded(Arc<Vec<u16>>),
    /// Neither: the chunk is read and decoded.
    Missing,
}

/// Where chunk `index` of a stored level (of `dims` voxels in chunks of `chunk`) lies, and
/// the part of it inside the region `[origin, origin + size)`.
#[derive(Clone, Copy)]
pub(super) struct ChunkPart {
    pub(super) start: [usize; 3],
    pub(super) extent: [usize; 3],
    pub(super) lo: [usize; 3],
    pub(super) hi: [usize; 3],
}

impl ChunkPart {
    pub(super) fn of(
        chunk: [usize; 3],
        dims: [usize; 3],
        index: [usize; 3],
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Self {
        let start: [usize; 3] = std::array::from_fn(|a| index[a] * chunk[a]);
        let extent: [usize; 3] = std::array::from_fn(|a| chunk[a].min(dims[a] - start[a]));
        Self {
            start,
            extent,
            lo: std::array::from_fn(|a| origin[a].max(start[a])),
            hi: std::array::from_fn(|a| (origin[a] + size[a]).min(start[a] + extent[a])),
        }
    }

    /// The chunk's face (axis, high side) that holds all of the part, if one does: the part
    /// is one voxel thick at the chunk's low or high end along an axis.
    pub(super) fn face(&self) -> Option<(usize, bool)> {
        (0..3).find_map(|a| {
            if self.hi[a] - self.lo[a] != 1 {
                return None;
            }
            let local = self.lo[a] - self.start[a];
            if local == 0 {
                Some((a, false))
            } else if local == self.extent[a] - 1 {
                Some((a, true))
            } else {
                None
            }
        })
    }
}

/// The indices of the chunks (of `chunk` voxels) that the region `[origin, origin + size)`
/// reaches, x fastest.
pub(super) fn chunks_reached(
    chunk: [usize; 3],
    origin: [usize; 3],
    size: [usize; 3],
) -> impl Iterator<Item = [usize; 3]> {
    let first: [usize; 3] = std::array::from_fn(|a| origin[a] / chunk[a]);
    let last: [usize; 3] = std::array::from_fn(|a| (origin[a] + size[a] - 1) / chunk[a]);
    (first[2]..=last[2]).flat_map(move |z| {
        (first[1]..=last[1]).flat_map(move |y| (first[0]..=last[0]).map(move |x| [x, y, z]))
    })
}

/// The six one-voxel faces of a chunk of `extent` voxels (`levels` x fastest), one after the
/// other: for each axis a (x, y, z) its low face then its high face, each a plane over the
/// other two axes in their order (the lower one fastest).
pub(super) fn chunk_faces(levels: &[u16], extent: [usize; 3]) -> Vec<u16> {
    let at = |v: [usize; 3]| levels[v[0] + extent[0] * (v[1] + extent[1] * v[2])];
    let mut faces = Vec::with_capacity((0..3).map(|a| 2 * face_len(extent, a)).sum());
    for axis in 0..3 {
        let (b, c) = other_axes(axis);
        for side in [0, extent[axis] - 1] {
            for v in 0..extent[c] {
                for u in 0..extent[b] {
                    let mut voxel = [0; 3];
                    voxel[axis] = side;
                    voxel[b] = u;
                    voxel[c] = v;
                    faces.push(at(voxel));
                }
            }
        }
    }
    faces
}

/// Whether a decoded chunk of `extent` voxels keeps its faces ([`chunk_faces`]): where they
/// are fewer voxels than the chunk. A thin chunk's are not (one plane, 1×1024×1024 as an
/// acquisition writes it: its two faces across z are the plane twice over): copying them cost
/// eight times the plane's decoding (run of issue 54), for nothing a brick could not take from
/// the decoded chunk itself.
pub(super) fn keeps_faces(extent: [usize; 3]) -> bool {
    let faces: usize = (0..3).map(|a| 2 * face_len(extent, a)).sum();
    faces < extent.iter().product()
}

/// The two axes other than `axis`, lower first.
pub(super) fn other_axes(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Voxels of one face of a chunk of `extent` across `axis`.
pub(super) fn face_len(extent: [usize; 3], axis: usize) -> usize {
    let (b, c) = other_axes(axis);
    extent[b] * extent[c]
}

/// Copies a chunk's `part` that lies in its face `(axis, high)` ([`ChunkPart::face`]) from the
/// chunk's `faces` into `out`, the region at `origin` of `size` voxels: rows along x where the
/// face spans x, a voxel at a time across x.
pub(super) fn copy_from_face(
    faces: &[u16],
    (axis, high): (usize, bool),
    part: &ChunkPart,
    origin: [usize; 3],
    size: [usize; 3],
    out: &mut [u16],
) {
    let ChunkPart {
        start,
        extent,
        lo,
        hi,
    } = *part;
    let before: usize = (0..axis).map(|a| 2 * face_len(extent, a)).sum();
    let face = &faces[before + usize::from(high) * face_len(extent, axis)..];
    let (b, c) = other_axes(axis);
    // A face across x is one voxel wide in x: its rows are one voxel long.
    let run = hi[0] - lo[0];
    for z in lo[2]..hi[2] {
        for y in lo[1]..hi[1] {
            let to = (lo[0] - origin[0]) + size[0] * ((y - origin[1]) + size[1] * (z - origin[2]));
            let voxel = [lo[0], y, z];
            let (u, v) = (voxel[b] - start[b], voxel[c] - start[c]);
            let from = u + extent[b] * v;
            copy_run(&mut out[to..to + run], &face[from..from + run]);
        }
    }
}

/// Copies one row part: value by value where it is short (a brick's apron in the next
/// chunk: a call to copy costs more), else by a call.
pub(super) fn copy_run(out: &mut [u16], levels: &[u16]) {
    if out.len() <= SHORT_RUN {
        for (o, l) in out.iter_mut().zip(levels) {
            *o = *l;
        }
    } else {
        out.copy_from_slice(levels);
    }
}

/// The stored voxels `[first, last]` along one axis that the pyramid voxels `[c0, c1]` cover,
/// `ratio` stored voxels each, within `dims`.
pub(super) fn covered(c0: usize, c1: usize, ratio: usize, dims: usize) -> (usize, usize) {
    let first = (c0 * ratio).min(dims - 1);
    let last = ((c1 + 1) * ratio - 1).min(dims - 1).max(first);
    (first, last)
}
