//! The WGSL the pipelines compile. WGSL has no includes, so shared declarations live in
//! `ray_common.wgsl` (the ray casters' parameters and per-pixel ray), `node_common.wgsl` (the
//! octree node and its color arithmetic) and `grid_cell.wgsl` (the bricks renderer's cell), and
//! are prepended here.
//!
//! Each shader's files are written once, in the `shaders!` list below: the macro makes both
//! the composed source and the file list of [`ALL`] from it, so the test that every file in
//! `shaders/` is used reads the same list the sources are built from.

/// One shader voxscope compiles.
#[derive(Debug, Clone, Copy)]
pub struct Shader {
    /// Its name in labels and test messages (`raycast`).
    pub name: &'static str,
    /// The files of `shaders/` it is made of, in order.
    pub files: &'static [&'static str],
    /// Those files' text, concatenated.
    pub source: &'static str,
}

/// Declares each shader once: a `pub(crate) const NAME: &str` of its files concatenated, and
/// [`ALL`], every shader with its name and file list.
macro_rules! shaders {
    ($($(#[$doc:meta])* $constant:ident = $name:literal [$($file:literal),+ $(,)?];)+) => {
        $(
            $(#[$doc])*
            pub(crate) const $constant: &str =
                concat!($(include_str!(concat!("../shaders/", $file))),+);
        )+

        /// Every shader voxscope compiles: its name, the files in `shaders/` it is made of, and
        /// its composed source (so a test can validate each one and know no file is left out).
        pub const ALL: &[Shader] = &[
            $(Shader { name: $name, files: &[$($file),+], source: $constant },)+
        ];
    };
}

shaders! {
    /// The octree and bricks ray caster.
    RAYCAST = "raycast" ["ray_common.wgsl", "node_common.wgsl", "grid_cell.wgsl", "raycast.wgsl"];
    /// The dense baseline.
    DENSE = "dense" ["ray_common.wgsl", "dense.wgsl"];
    /// The dense renderer for up to 8 channels composited.
    COMPOSITE = "composite" ["ray_common.wgsl", "composite.wgsl"];
    /// The streaming renderer (a pyramid of bricks through a page table).
    STREAM = "stream" ["ray_common.wgsl", "stream_common.wgsl", "stream.wgsl"];
    /// The streaming renderer for up to 8 channels composited.
    STREAM_COMPOSITE = "stream_composite" ["ray_common.wgsl", "stream_common.wgsl", "stream_composite.wgsl"];
    /// Per-level recolor of octree nodes.
    RECOLOR = "recolor" ["node_common.wgsl", "recolor.wgsl"];
    /// Recolor of the brick level.
    BRICK_RECOLOR = "brick_recolor" ["node_common.wgsl", "brick_recolor.wgsl"];
    /// The refresh of the bricks renderer's cell grid after a recolor.
    BRICK_GRID = "brick_grid" ["node_common.wgsl", "grid_cell.wgsl", "brick_grid.wgsl"];
    /// Planar slices of the dense texture, the brick atlas or the octree.
    SLICE = "slice" ["node_common.wgsl", "grid_cell.wgsl", "slice.wgsl"];
    /// The streaming atlas's uploads written into their cells, one shader per texel format.
    ATLAS_SCATTER_R8UNORM = "atlas_scatter_r8unorm" ["atlas_r8unorm.wgsl", "atlas_scatter.wgsl"];
    ATLAS_SCATTER_R16UNORM = "atlas_scatter_r16unorm" ["atlas_r16unorm.wgsl", "atlas_scatter.wgsl"];
    ATLAS_SCATTER_R16FLOAT = "atlas_scatter_r16float" ["atlas_r16float.wgsl", "atlas_scatter.wgsl"];
    /// The measurements of the GPU's own ceilings (`voxscope ceilings`).
    CEILINGS = "ceilings" ["ceilings.wgsl"];
}
