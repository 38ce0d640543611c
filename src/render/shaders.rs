//! The WGSL the pipelines compile. WGSL has no includes, so the declarations that `raycast.wgsl`
//! and `dense.wgsl` share live in `ray_common.wgsl` and are prepended here.

/// The octree and bricks ray caster.
pub(crate) const RAYCAST: &str = concat!(
    include_str!("../../shaders/ray_common.wgsl"),
    include_str!("../../shaders/raycast.wgsl")
);

/// The dense baseline.
pub(crate) const DENSE: &str = concat!(
    include_str!("../../shaders/ray_common.wgsl"),
    include_str!("../../shaders/dense.wgsl")
);

/// Per-level recolor of octree nodes.
pub(crate) const RECOLOR: &str = include_str!("../../shaders/recolor.wgsl");

/// Recolor of the brick level.
pub(crate) const BRICK_RECOLOR: &str = include_str!("../../shaders/brick_recolor.wgsl");

/// Every shader voxscope compiles: its name, its composed source, and the files in `shaders/`
/// it is made of (so a test can validate each one and know no file is left out).
pub const ALL: [(&str, &str, &[&str]); 4] = [
    ("raycast", RAYCAST, &["ray_common.wgsl", "raycast.wgsl"]),
    ("dense", DENSE, &["ray_common.wgsl", "dense.wgsl"]),
    ("recolor", RECOLOR, &["recolor.wgsl"]),
    ("brick_recolor", BRICK_RECOLOR, &["brick_recolor.wgsl"]),
];
