//! Per-level node statistics: what `info` prints and the app charts.

use rayon::prelude::*;
use serde::Serialize;

use super::{Node, Octree, TransferFunction, unpack_rgba};

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
            count_level(level, nodes, nodes.par_iter().map(|node| node.alpha()))
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
        statistics.push(count_level(level, nodes, alphas.par_iter().copied()));
        below = alphas;
    }
    statistics.reverse();
    statistics
}

/// Counts one level's `nodes` whose alphas are `alphas` (in the same order).
fn count_level(
    level: u32,
    nodes: &[Node],
    alphas: impl IndexedParallelIterator<Item = u8>,
) -> LevelStatistics {
    let (leaves, transparent, opaque) = nodes
        .par_iter()
        .zip(alphas)
        .map(|(node, alpha)| {
            (
                node.is_leaf() as u64,
                (alpha == 0) as u64,
                (alpha == 255) as u64,
            )
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    LevelStatistics {
        level,
        nodes: nodes.len() as u64,
        leaves,
        transparent,
        opaque,
        bytes: std::mem::size_of_val(nodes) as u64,
        full_tree_nodes: 8u64.pow(level),
    }
}
