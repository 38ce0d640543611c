// Shared by raycast.wgsl, recolor.wgsl, brick_recolor.wgsl and brick_grid.wgsl:
// src/render/shaders.rs prepends this file to each (WGSL has no includes). The octree node, its
// color arithmetic, and the uniforms of a pass over one run of nodes.

// Keep in sync with `Node` in src/octree/node.rs.
struct Node {
    color: u32,       // RGBA8, red lowest, straight alpha
    first_child: u32, // index of the first of 8 children, or LEAF
}

// The uniforms of recolor.wgsl (one level's nodes) and brick_grid.wgsl (level_count: the
// cells; level_start and labels unused). Keep in sync with `RecolorParams` in
// src/render/gpu_data.rs.
struct LevelParams {
    level_start: u32,
    level_count: u32,
    // Workgroups along x of the 2D dispatch (a level can exceed 65535 workgroups).
    groups_x: u32,
    // 1: the values are labels, and a parent takes its children's most shown color.
    labels: u32,
}

const LEAF: u32 = 0xffffffffu;
// Keep in sync with `BRICK_FLAG` in src/octree/bricks.rs.
const BRICK_FLAG: u32 = 0x80000000u;

// The sums one color contributes to an opacity-weighted mean: (a, r·a, g·a, b·a).
fn weighted_sums(color: u32) -> vec4<u32> {
    let a = color >> 24u;
    return vec4<u32>(a, (color & 0xffu) * a, ((color >> 8u) & 0xffu) * a, ((color >> 16u) & 0xffu) * a);
}

// The opacity-weighted mean of `count` colors from their summed `weighted_sums`: color rounded,
// alpha the plain mean rounded up (so it is 0 only when every alpha is).
// Keep in sync with `average_color` in src/octree/node.rs.
fn weighted_mean(sums: vec4<u32>, count: u32) -> u32 {
    if sums.x == 0u {
        return 0u;
    }
    let half = sums.x / 2u;
    return ((sums.y + half) / sums.x) | (((sums.z + half) / sums.x) << 8u)
        | (((sums.w + half) / sums.x) << 16u) | (((sums.x + count - 1u) / count) << 24u);
}
