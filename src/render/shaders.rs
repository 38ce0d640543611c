//! The WGSL the pipelines compile. WGSL has no includes, so shared declarations live in
//! `ray_common.wgsl` (the ray casters' parameters and per-pixel ray) and `node_common.wgsl`
//! (the octree node and its color arithmetic), and are prepended here.

/// The octree and bricks ray caster.
pub(crate) const RAYCAST: &str = concat!(
    include_str!("../../shaders/ray_common.wgsl"),
    include_str!("../../shaders/node_common.wgsl"),
    include_str!("../../shaders/raycast.wgsl")
);

/// The dense baseline.
pub(crate) const DENSE: &str = concat!(
    include_str!("../../shaders/ray_common.wgsl"),
    include_str!("../../shaders/dense.wgsl")
);

/// Per-level recolor of octree nodes.
pub(crate) const RECOLOR: &str = concat!(
    include_str!("../../shaders/node_common.wgsl"),
    include_str!("../../shaders/recolor.wgsl")
);

/// Recolor of the brick level.
pub(crate) const BRICK_RECOLOR: &str = concat!(
    include_str!("../../shaders/node_common.wgsl"),
    include_str!("../../shaders/brick_recolor.wgsl")
);

/// The refresh of the bricks renderer's cell grid after a recolor.
pub(crate) const BRICK_GRID: &str = concat!(
    include_str!("../../shaders/node_common.wgsl"),
    include_str!("../../shaders/brick_grid.wgsl")
);

/// The measurements of the GPU's own ceilings (`voxscope ceilings`).
pub(crate) const CEILINGS: &str = include_str!("../../shaders/ceilings.wgsl");

/// Every shader voxscope compiles: its name, its composed source, and the files in `shaders/`
/// it is made of (so a test can validate each one and know no file is left out).
pub const ALL: [(&str, &str, &[&str]); 6] = [
    (
        "raycast",
        RAYCAST,
        &["ray_common.wgsl", "node_common.wgsl", "raycast.wgsl"],
    ),
    ("dense", DENSE, &["ray_common.wgsl", "dense.wgsl"]),
    ("recolor", RECOLOR, &["node_common.wgsl", "recolor.wgsl"]),
    (
        "brick_recolor",
        BRICK_RECOLOR,
        &["node_common.wgsl", "brick_recolor.wgsl"],
    ),
    (
        "brick_grid",
        BRICK_GRID,
        &["node_common.wgsl", "brick_grid.wgsl"],
    ),
    ("ceilings", CEILINGS, &["ceilings.wgsl"]),
];
