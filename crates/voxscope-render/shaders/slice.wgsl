// One planar slice of a volume on the GPU (src/render/slice.rs): each pixel is a point of the
// volume's voxel space, `origin + x · step_x + y · step_y`, whose value level is read from the
// volume as the renderer holds it, then colored through the slice's own lookup table (the value
// window and colormap, opaque). Points outside the volume are transparent black, so the app can
// paint its own background there. Starts with node_common.wgsl and grid_cell.wgsl.
//
// Voxel space is the ray casters': voxel (i, j, k) is the unit cube [i, i + 1) × [j, j + 1) ×
// [k, k + 1), its center at (i + ½, j + ½, k + ½).
//
// The value level of one voxel comes from one of three sources, exactly (no filtering):
// - the dense texture: one texel;
// - the bricks: the cell grid names the node covering the voxel's brick cell (the brick leaf, or a
//   uniform leaf above the brick level, whose bounds hold its one level), then the atlas texel;
// - the plain octree: a descent from the root to the leaf holding the voxel (a voxel, or a
//   collapsed uniform subtree: its bounds hold its one level).
// Linear slices interpolate the levels of the 8 voxels around a point (clamped to the volume's
// edge) by hand, so every source gives the same values and the CPU can check them.

// Keep in sync with `SliceParams` in src/render/gpu_data.rs.
struct SliceParams {
    origin: vec4<f32>,      // xyz: voxel-space point at the center of pixel (0, 0)
    step_x: vec4<f32>,      // xyz: voxel-space step per pixel to the right
    step_y: vec4<f32>,      // xyz: voxel-space step per pixel down
    dims: vec4<u32>,        // xyz: voxels along each axis; w: octree depth
    brick_grid: vec4<u32>,  // xyz: brick cells along each axis (bricks)
    image_size: vec2<u32>,
    source: u32,            // SOURCE_*
    nearest: u32,           // 1: the nearest voxel; 0: trilinear between voxel centers
    level_scale: f32,       // texel value × this = value level (dense texture, brick atlas)
    deepest_level: u32,     // octree: the deepest level on the GPU
    brick_size: u32,        // bricks: voxels along a brick's side
    _pad: u32,
}

// Keep in sync with `SliceSource` in src/render/slice.rs.
const SOURCE_DENSE: u32 = 0u;
const SOURCE_BRICKS: u32 = 1u;
const SOURCE_OCTREE: u32 = 2u;

@group(0) @binding(0) var<uniform> params: SliceParams;
// The dense texture or the brick atlas (a stand-in for the octree).
@group(0) @binding(1) var levels: texture_3d<f32>;
@group(0) @binding(2) var<storage, read> nodes: array<Node>;
@group(0) @binding(3) var<storage, read> bounds: array<u32>;
@group(0) @binding(4) var<storage, read> grid: array<GridCell>;
// Packed RGBA8 per value level: the window and colormap, opaque.
@group(0) @binding(5) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(6) var output: texture_storage_2d<rgba8unorm, write>;

// The value level of a texel of `levels`.
fn texel_level(texel: vec3<i32>) -> u32 {
    return u32(clamp(round(textureLoad(levels, texel, 0).r * params.level_scale), 0.0, 65535.0));
}

fn dense_level(voxel: vec3<u32>) -> u32 {
    return texel_level(vec3<i32>(voxel));
}

fn bricks_level(voxel: vec3<u32>) -> u32 {
    let size = params.brick_size;
    let cell = voxel / size;
    let entry = grid[cell.x + params.brick_grid.x * (cell.y + params.brick_grid.y * cell.z)];
    if entry.first_child == LEAF {
        // A uniform leaf at or above the brick level: all its voxels have its minimum.
        return entry.bounds & 0xffffu;
    }
    let packed = entry.atlas_cell;
    let atlas_cell = vec3<u32>(packed & 1023u, (packed >> 10u) & 1023u, (packed >> 20u) & 1023u);
    // Each brick's block has a one-voxel apron before its first voxel.
    let texel = atlas_cell * (size + 2u) + 1u + (voxel - cell * size);
    return texel_level(vec3<i32>(texel));
}

fn octree_level(voxel: vec3<u32>) -> u32 {
    let depth = params.dims.w;
    var index = 0u;
    var level = 0u;
    loop {
        let first_child = nodes[index].first_child;
        if first_child == LEAF || level >= params.deepest_level {
            break;
        }
        let shift = depth - 1u - level;
        let bit = (voxel >> vec3<u32>(shift)) & vec3<u32>(1u);
        index = first_child + (bit.x | (bit.y << 1u) | (bit.z << 2u));
        level += 1u;
    }
    let range = bounds[index];
    let low = range & 0xffffu;
    let high = range >> 16u;
    // A leaf holds one level (low = high). Where the octree is on the GPU only down to a level
    // above the voxels, a node there stands for several: the middle of its range.
    return (low + high) / 2u;
}

fn voxel_level(voxel: vec3<u32>) -> u32 {
    switch params.source {
        case SOURCE_DENSE: { return dense_level(voxel); }
        case SOURCE_BRICKS: { return bricks_level(voxel); }
        default: { return octree_level(voxel); }
    }
}

// The level of voxel `voxel` (signed, may lie one outside), clamped to the volume's edge.
fn clamped_level(voxel: vec3<i32>) -> f32 {
    let last = vec3<i32>(params.dims.xyz) - vec3<i32>(1);
    return f32(voxel_level(vec3<u32>(clamp(voxel, vec3<i32>(0), last))));
}

// Trilinear between the 8 voxel centers around `p`.
fn trilinear_level(p: vec3<f32>) -> u32 {
    let q = p - vec3<f32>(0.5);
    let base = floor(q);
    let f = q - base;
    let b = vec3<i32>(base);
    let c000 = clamped_level(b);
    let c100 = clamped_level(b + vec3<i32>(1, 0, 0));
    let c010 = clamped_level(b + vec3<i32>(0, 1, 0));
    let c110 = clamped_level(b + vec3<i32>(1, 1, 0));
    let c001 = clamped_level(b + vec3<i32>(0, 0, 1));
    let c101 = clamped_level(b + vec3<i32>(1, 0, 1));
    let c011 = clamped_level(b + vec3<i32>(0, 1, 1));
    let c111 = clamped_level(b + vec3<i32>(1, 1, 1));
    let x00 = mix(c000, c100, f.x);
    let x10 = mix(c010, c110, f.x);
    let x01 = mix(c001, c101, f.x);
    let x11 = mix(c011, c111, f.x);
    let level = mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
    return u32(clamp(round(level), 0.0, 65535.0));
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.image_size.x || id.y >= params.image_size.y {
        return;
    }
    let p = params.origin.xyz + f32(id.x) * params.step_x.xyz + f32(id.y) * params.step_y.xyz;
    let dims = vec3<f32>(params.dims.xyz);
    if any(p < vec3<f32>(0.0)) || any(p >= dims) {
        textureStore(output, vec2<i32>(id.xy), vec4<f32>(0.0));
        return;
    }
    var level: u32;
    if params.nearest != 0u {
        let last = params.dims.xyz - vec3<u32>(1u);
        level = voxel_level(min(vec3<u32>(floor(p)), last));
    } else {
        level = trilinear_level(p);
    }
    textureStore(output, vec2<i32>(id.xy), unpack4x8unorm(lookup_table[level]));
}
