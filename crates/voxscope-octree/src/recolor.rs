//! Recoloring on the CPU: one pass per level, deepest first. Leaves take their color from the
//! transfer function's lookup table, inner nodes average their 8 children (a label volume's take
//! their most frequent visible child color: [`mode_color`]). The topology is never touched.
//! (The GPU does the same in `recolor.wgsl` for live edits.)

use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::{Octree, TransferFunction, average_color, mode_color};

/// Recolors every node of `octree` with `transfer`. Returns the time it took, the lookup
/// table included.
pub fn recolor(octree: &mut Octree, transfer: &TransferFunction) -> Duration {
    let started = Instant::now();
    let lookup_table = transfer.lookup_table(octree.quantization);
    let parent_color = if octree.labels {
        mode_color
    } else {
        average_color
    };
    for level in (0..=octree.depth).rev() {
        let range = octree.level_range(level);
        let (upper, lower) = octree.nodes.split_at_mut(range.end);
        let children_start = range.end as u32;
        let level_nodes = &mut upper[range.start..];
        let bounds = &octree.bounds[range.clone()];
        level_nodes
            .par_iter_mut()
            .zip(bounds)
            .for_each(|(node, bounds)| {
                node.color = if node.is_leaf() {
                    if bounds.is_empty() {
                        0
                    } else {
                        lookup_table[bounds.min() as usize]
                    }
                } else {
                    let first = (node.first_child - children_start) as usize;
                    parent_color(std::array::from_fn(|c| lower[first + c].color))
                };
            });
    }
    started.elapsed()
}
