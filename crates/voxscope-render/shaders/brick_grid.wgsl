// Refreshes the bricks renderer's cell grid after a recolor: each brick cell (`GridCell`,
// grid_cell.wgsl) gets a copy of the node covering it (its brick, or a leaf above the brick
// level) and that node's value bounds. The brick's atlas cell never changes (written at upload).

const WORKGROUP: u32 = 256u;

@group(0) @binding(0) var<uniform> params: LevelParams;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> grid_leaves: array<u32>;
@group(0) @binding(4) var<storage, read_write> grid: array<GridCell>;

@compute @workgroup_size(256, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let cell = id.y * params.groups_x * WORKGROUP + id.x;
    if cell >= params.level_count {
        return;
    }
    let index = grid_leaves[cell];
    let node = nodes[index];
    grid[cell].color = node.color;
    grid[cell].first_child = node.first_child;
    grid[cell].bounds = bounds[index];
}
