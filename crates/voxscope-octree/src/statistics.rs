//! Per-level node statistics: what `info` prints and the app charts.

use rayon::prelude::*;
use serde::Serialize;

use super::{Clip, Node, Octree, TransferFunction, unpack_rgba};

/// Counts of one level of the octree under the current colors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct LevelStatistics {
    pub level: u32,
    /// Nodes stored at this level.
    pub nodes: u64,
    /// Of those, leaves (voxels, or collapsed uniform subtrees).
    pub leaves: u64,
    /// Of those, fully transparent (alpha 0: skipped whole by the ray caster).
    pub transparent: u64,
    /// Of those, fully opaque (alpha 255).
    pub opaque: u64,
    /// Bytes of this level's nodes.
    pub bytes: u64,
    /// Nodes this level would have in the complete tree (8^level).
    pub full_tree_nodes: u64,
}

/// Statistics of every level, `0..=depth`.
pub fn level_statistics(octree: &Octree) -> Vec<LevelStatistics> {
    (0..=octree.depth)
        .map(|level| {
            let nodes = &octree.nodes[octree.level_range(level)];
            count_level(
                level,
                nodes,
                nodes.par_iter().map(|node| node.alpha()),
                None,
            )
        })
        .collect()
}

/// The statistics `octree` would have after [`super::recolor`] with `transfer`, without
/// touching its colors: only the alpha of every node is computed (one byte per node, deepest
/// level first), so the app can count while the GPU holds the live colors.
pub fn level_statistics_under(
    octree: &Octree,
    transfer: &TransferFunction,
) -> Vec<LevelStatistics> {
    level_statistics_within(octree, transfer, &Clip::NONE)
}

/// [`level_statistics_under`], counting only the nodes whose cells reach into `clip`'s region
/// (what a clipped view can draw).
pub fn level_statistics_within(
    octree: &Octree,
    transfer: &TransferFunction,
    clip: &Clip,
) -> Vec<LevelStatistics> {
    let inside = clip.is_active().then(|| nodes_inside(octree, clip));
    let lookup_table = transfer.lookup_table(octree.quantization);
    let mut below: Vec<u8> = Vec::new();
    let mut statistics = Vec::with_capacity(octree.depth as usize + 1);
    for level in (0..=octree.depth).rev() {
        let range = octree.level_range(level);
        let children_start = range.end as u32;
        let nodes = &octree.nodes[range.clone()];
        let alphas: Vec<u8> = nodes
            .par_iter()
            .zip(&octree.bounds[range])
            .map(|(node, bounds)| {
                if node.is_leaf() {
                    if bounds.is_empty() {
                        0
                    } else {
                        unpack_rgba(lookup_table[bounds.min() as usize])[3]
                    }
                } else {
                    // As in `average_color`: the plain average, rounded up.
                    let first = (node.first_child - children_start) as usize;
                    let sum: u32 = below[first..first + 8].iter().map(|&a| a as u32).sum();
                    sum.div_ceil(8) as u8
                }
            })
            .collect();
        let level_inside = inside.as_ref().map(|flags| &flags[level as usize][..]);
        statistics.push(count_level(
            level,
            nodes,
            alphas.par_iter().copied(),
            level_inside,
        ));
        below = alphas;
    }
    statistics.reverse();
    statistics
}

/// Per level, per node: whether its cell reaches into `clip`'s region. Cells are followed
/// top-down (a level's children are its inner nodes' blocks of 8, in order).
fn nodes_inside(octree: &Octree, clip: &Clip) -> Vec<Vec<bool>> {
    let mut corners: Vec<[u32; 3]> = vec![[0; 3]];
    let mut flags = Vec::with_capacity(octree.depth as usize + 1);
    for level in 0..=octree.depth {
        let size = (octree.side() >> level) as f64;
        let nodes = &octree.nodes[octree.level_range(level)];
        flags.push(
            corners
                .par_iter()
                .map(|c| clip.touches_cell(c.map(f64::from), size, octree.dims))
                .collect(),
        );
        let half = (octree.side() >> (level + 1)) as u32;
        corners = nodes
            .iter()
            .zip(&corners)
            .filter(|(node, _)| !node.is_leaf())
            .flat_map(|(_, c)| {
                (0..8u32).map(move |child| {
                    [
                        c[0] + (child & 1) * half,
                        c[1] + ((child >> 1) & 1) * half,
                        c[2] + (child >> 2) * half,
                    ]
                })
            })
            .collect();
    }
    flags
}

/// Counts one level's `nodes` whose alphas are `alphas` (in the same order); where `inside`
/// is given, only the nodes it flags.
fn count_level(
    level: u32,
    nodes: &[Node],
    alphas: impl IndexedParallelIterator<Item = u8>,
    inside: Option<&[bool]>,
) -> LevelStatistics {
    let (count, leaves, transparent, opaque) = nodes
        .par_iter()
        .zip(alphas)
        .enumerate()
        .filter(|(index, _)| inside.is_none_or(|flags| flags[*index]))
        .map(|(_, (node, alpha))| {
            (
                1u64,
                node.is_leaf() as u64,
                (alpha == 0) as u64,
                (alpha == 255) as u64,
            )
        })
        .reduce(
            || (0, 0, 0, 0),
            |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3),
        );
    LevelStatistics {
        level,
        nodes: count,
        leaves,
        transparent,
        opaque,
        bytes: count * std::mem::size_of::<Node>() as u64,
        full_tree_nodes: 8u64.pow(level),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BuildOptions, ClipPlane, build};
    use voxscope_volume::{LoadOptions, QuantizedVolume, load};

    #[test]
    fn a_clip_counts_only_the_nodes_it_reaches() {
        let volume = load("synthetic:noise:32", &LoadOptions::default()).expect("synthetic");
        let quantized = QuantizedVolume::new(&volume);
        let octree = build(
            &quantized,
            BuildOptions {
                collapse_uniform: false,
                ..BuildOptions::default()
            },
        )
        .expect("builds");
        let transfer = TransferFunction::gray(quantized.robust_window());
        let all = level_statistics_under(&octree, &transfer);
        assert_eq!(
            level_statistics_within(&octree, &transfer, &Clip::NONE),
            all
        );
        let half = Clip {
            bounds: Some([[0.0, 0.5], [0.0, 1.0], [0.0, 1.0]]),
            plane: None,
        };
        let clipped = level_statistics_within(&octree, &transfer, &half);
        let voxels = octree.depth as usize;
        assert_eq!(
            clipped[voxels].nodes * 2,
            all[voxels].nodes,
            "half the voxels"
        );
        assert_eq!(clipped[0].nodes, 1, "the root reaches in");
        // x ≥ 0.75 by a plane: a quarter of the voxels (the boundary plane included).
        let plane = Clip {
            bounds: None,
            plane: Some(ClipPlane {
                normal: [1.0, 0.0, 0.0],
                distance: 0.75,
            }),
        };
        let quarter = level_statistics_within(&octree, &transfer, &plane);
        assert_eq!(
            quarter[voxels].nodes * 4,
            all[voxels].nodes,
            "x from 24 to 31"
        );
    }
}
