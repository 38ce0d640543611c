//! The paper's octree: one flat list of 8-byte nodes, root first, the 8 children of a node in
//! one block, levels breadth-first. Built bottom-up from the voxels; per-node value bounds in a
//! parallel list let a transfer-function edit recolor the nodes without touching the topology.
//! Pure CPU: nothing here knows about GPUs.

mod bricks;
mod build;
mod clip;
mod node;
mod presets;
mod recolor;
pub mod sibling_index;
mod statistics;
mod transfer;

use std::ops::Range;

pub use bricks::{BRICK_FLAG, BrickLayout, BrickLayoutError};
pub use build::{BuildError, BuildOptions, MAX_DEPTH, build, build_with_progress};
pub use clip::{Clip, ClipError, ClipPlane};
pub use node::{LEAF, Node, ValueBounds, average_color, mode_color, pack_rgba, unpack_rgba};
pub use presets::{DataKind, MAX_LABELS, Preset, default_transfer, labels_transfer};
pub use recolor::recolor;
pub use statistics::{
    LevelStatistics, level_statistics, level_statistics_under, level_statistics_within,
};
pub use transfer::{
    Colormap, ControlPoint, CurveError, MAX_CURVE_POINTS, OpacityCurve, OpacityMode,
    TransferFunction,
};

use voxscope_volume::Quantization;

/// A built octree over a volume padded to the enclosing `2^depth` cube.
#[derive(Debug, Clone)]
pub struct Octree {
    /// Voxels along x, y, z of the volume (the cube beyond them is transparent padding).
    pub dims: [usize; 3],
    /// Levels are `0..=depth`; level `depth` holds single voxels.
    pub depth: u32,
    /// The flat list: root at 0, then each level left to right.
    pub nodes: Vec<Node>,
    /// Per node, the range of value levels below it (same indexing as `nodes`).
    pub bounds: Vec<ValueBounds>,
    /// Level `l` occupies `nodes[level_starts[l]..level_starts[l + 1]]`; `depth + 2` entries.
    pub level_starts: Vec<usize>,
    /// What the 16-bit value levels mean in data units.
    pub quantization: Quantization,
    /// Whether subtrees of equal voxels were collapsed into single leaves.
    pub collapsed: bool,
    /// Whether the values are labels ([`BuildOptions::labels`]): an inner node shows its
    /// children's most frequent visible color ([`mode_color`]) rather than their average, and
    /// every renderer samples the volume at the nearest voxel.
    pub labels: bool,
    /// Wall time of [`build`].
    pub build_seconds: f64,
}

impl Octree {
    /// Side of the padded cube in voxels, `2^depth`.
    pub fn side(&self) -> usize {
        1 << self.depth
    }

    /// Node indices of one level.
    pub fn level_range(&self, level: u32) -> Range<usize> {
        self.level_starts[level as usize]..self.level_starts[level as usize + 1]
    }

    /// Number of nodes in levels `0..=max_level`: a prefix of the list, which is all a
    /// renderer stopping at `max_level` needs.
    pub fn nodes_through_level(&self, max_level: u32) -> usize {
        self.level_starts[max_level.min(self.depth) as usize + 1]
    }

    /// Bytes of the node list (8 per node).
    pub fn node_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }
}

/// Nodes of the complete octree of the given depth, the paper's equation 1:
/// `O = Σ_{p=0}^{n} 8^p` with `n = log(N) / log(8)` for `N = 8^depth` voxels.
pub fn full_tree_nodes(depth: u32) -> u64 {
    (0..=depth).map(|p| 8u64.pow(p)).sum()
}
