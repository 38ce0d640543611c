// Shared by raycast.wgsl (the grid walk reads it) and brick_grid.wgsl (which refreshes it after
// a recolor): src/render/shaders.rs prepends this file to each.

// One cell of the bricks renderer's grid, x fastest (src/render/bricks.rs): a copy of the node
// covering the cell and that node's value bounds, so a ray walking the cells reads one 16-byte
// entry per cell instead of descending the tree; and the atlas cell of its brick.
// Keep in sync with `GridCell` in src/render/gpu_data.rs.
struct GridCell {
    color: u32,       // the node's RGBA8 color (`Node.color`)
    first_child: u32, // the node's `first_child`: LEAF, or a brick slot with BRICK_FLAG
    bounds: u32,      // the node's value bounds: minimum in the low 16 bits, maximum in the high
    atlas_cell: u32,  // the brick's atlas cell, ten bits per axis, x lowest; 0 if no brick
}

// The fields of a GridCell as components of the vec4<u32> the grid walk reads and keeps a cell
// in: `cell[CELL_BOUNDS]` is `cell.z`, by name (raycast.wgsl's `brick_grid` says why not
// GridCell values). Abstract integers, so that nothing of them reaches the SPIR-V: the walk's is
// byte for byte what `.x/.y/.z/.w` gave. In the order of GridCell's fields; a test in
// src/render/gpu_data.rs checks each name against its field.
const CELL_COLOR = 0;
const CELL_FIRST_CHILD = 1;
const CELL_BOUNDS = 2;
const CELL_ATLAS_CELL = 3;
