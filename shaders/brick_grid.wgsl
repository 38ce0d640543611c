// Refreshes the bricks renderer's cell grid after a recolor: each brick cell gets a copy of the
// node covering it (its brick, or a leaf above the brick level) and that node's value bounds,
// so a ray walking the cells reads one 16-byte entry per cell instead of descending the tree.
// The fourth word, the brick's atlas cell, never changes (written at upload).

const WORKGROUP: u32 = 256u;

@group(0) @binding(0) var<uniform> params: LevelParams;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> grid_leaves: array<u32>;
// Keep in sync with `GridCell` in src/render/gpu_data.rs and the reader in raycast.wgsl.
@group(0) @binding(4) var<storage, read_write> grid: array<vec4<u32>>;

@compute @workgroup_size(256, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let cell = id.y * params.groups_x * WORKGROUP + id.x;
    if cell >= params.level_count {
        return;
    }
    let index = grid_leaves[cell];
    let node = nodes[index];
    grid[cell] = vec4<u32>(node.color, node.first_child, bounds[index], grid[cell].w);
}
