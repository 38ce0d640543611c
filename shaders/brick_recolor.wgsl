// Recolors the brick level of the bricks renderer: a collapsed leaf from the lookup table, a
// brick as the opacity-weighted average of its voxels' colors (alpha: the mean rounded up, so
// a brick is transparent only when all its voxels are). The levels above are recolored by
// recolor.wgsl afterwards.

// Keep in sync with `Node` in src/octree/node.rs.
struct Node {
    color: u32,
    first_child: u32,
}

// Keep in sync with `BrickRecolorParams` in src/render/gpu_data.rs.
struct Params {
    level_start: u32,
    level_count: u32,
    groups_x: u32,
    brick_size: u32,
    atlas_grid: vec4<u32>, // xyz: bricks along each atlas axis
    dims: vec4<u32>,       // xyz: volume dims in voxels
    atlas_scale: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

const LEAF: u32 = 0xffffffffu;
const BRICK_FLAG: u32 = 0x80000000u;
const WORKGROUP: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(4) var atlas: texture_3d<f32>;
@group(0) @binding(5) var<storage, read> brick_origins: array<vec4<u32>>;

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let offset = (group.y * params.groups_x + group.x) * WORKGROUP + lane;
    if offset >= params.level_count {
        return;
    }
    let index = params.level_start + offset;
    let node = nodes[index];
    if node.first_child == LEAF {
        let b = bounds[index];
        if (b & 0xffffu) > (b >> 16u) {
            nodes[index].color = 0u;
        } else {
            nodes[index].color = lookup_table[b & 0xffffu];
        }
        return;
    }
    let slot = node.first_child & ~BRICK_FLAG;
    let grid = params.atlas_grid.xyz;
    let cell = vec3<u32>(slot % grid.x, (slot / grid.x) % grid.y, slot / (grid.x * grid.y));
    let base = cell * (params.brick_size + 2u) + vec3<u32>(1u);
    let origin = brick_origins[slot].xyz;
    let size = params.brick_size;
    var alpha_sum = 0u;
    var r = 0u;
    var g = 0u;
    var b = 0u;
    var count = 0u;
    for (var z = 0u; z < size; z++) {
        for (var y = 0u; y < size; y++) {
            for (var x = 0u; x < size; x++) {
                let voxel = origin + vec3<u32>(x, y, z);
                if any(voxel >= params.dims.xyz) {
                    continue; // padding
                }
                let texel = textureLoad(atlas, vec3<i32>(base + vec3<u32>(x, y, z)), 0).r;
                let level = u32(clamp(round(texel * params.atlas_scale), 0.0, 65535.0));
                let color = lookup_table[level];
                let a = color >> 24u;
                alpha_sum += a;
                r += (color & 0xffu) * a;
                g += ((color >> 8u) & 0xffu) * a;
                b += ((color >> 16u) & 0xffu) * a;
                count += 1u;
            }
        }
    }
    if alpha_sum == 0u {
        nodes[index].color = 0u;
        return;
    }
    let half = alpha_sum / 2u;
    nodes[index].color = ((r + half) / alpha_sum) | (((g + half) / alpha_sum) << 8u)
        | (((b + half) / alpha_sum) << 16u) | (((alpha_sum + count - 1u) / count) << 24u);
}
