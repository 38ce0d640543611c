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
