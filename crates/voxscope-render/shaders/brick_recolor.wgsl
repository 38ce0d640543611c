// Recolors the brick level of the bricks renderer: a collapsed leaf from the lookup table, a
// brick as the opacity-weighted average of its voxels' colors (alpha: the mean rounded up, so
// a brick is transparent only when all its voxels are). A label volume's brick takes, with that
// alpha, the color of its visible voxels' majority label (a majority vote, Boyer and Moore's:
// the label more than half of them show where there is one, else one of theirs; never a mix of
// two labels' colors). One workgroup per node: its threads share the brick's voxels and reduce
// in workgroup memory. The levels above are recolored by recolor.wgsl afterwards. (Sums fit
// u32: 32³ voxels × 255 × 255 < 2³².)

// Keep in sync with `BrickRecolorParams` in src/render/gpu_data.rs.
struct Params {
    level_start: u32,
    level_count: u32,
    groups_x: u32,
    brick_size: u32,
    atlas_grid: vec4<u32>, // xyz: bricks along each atlas axis
    dims: vec4<u32>,       // xyz: volume dims in voxels
    atlas_scale: f32,
    labels: u32,  // 1: the values are labels (the majority vote)
    _pad0: u32,
    _pad1: u32,
}

// One workgroup per node of the brick level; its threads share the brick's voxels.
const WORKGROUP: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(4) var atlas: texture_3d<f32>;
@group(0) @binding(5) var<storage, read> brick_origins: array<vec4<u32>>;

// Per thread: alpha sum, alpha-weighted red, green, blue; and voxel count.
var<workgroup> partial_color: array<vec4<u32>, WORKGROUP>;
var<workgroup> partial_count: array<u32, WORKGROUP>;
// Labels: per thread, the vote's candidate color (0: none yet) and its lead.
var<workgroup> partial_vote: array<vec2<u32>, WORKGROUP>;
var<workgroup> shared_first_child: u32;

// One step of the majority vote: `vote` (candidate, lead) meets one more visible color.
fn vote_for(vote: vec2<u32>, color: u32) -> vec2<u32> {
    if vote.y == 0u {
        return vec2<u32>(color, 1u);
    }
    if vote.x == color {
        return vec2<u32>(color, vote.y + 1u);
    }
    return vec2<u32>(vote.x, vote.y - 1u);
}

// Two votes over disjoint voxels as one: the same candidate adds its leads, two differ cancel
// (the larger lead's stays); a vote that saw no visible voxel (candidate 0) yields.
fn merge_votes(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    if a.x == 0u {
        return b;
    }
    if b.x == 0u {
        return a;
    }
    if a.x == b.x {
        return vec2<u32>(a.x, a.y + b.y);
    }
    if a.y >= b.y {
        return vec2<u32>(a.x, a.y - b.y);
    }
    return vec2<u32>(b.x, b.y - a.y);
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let offset = group.y * params.groups_x + group.x;
    if offset >= params.level_count {
        return;
    }
    let index = params.level_start + offset;
    if lane == 0u {
        shared_first_child = nodes[index].first_child;
    }
    // The same value for the whole workgroup, so the barriers below stay in uniform control flow.
    let first_child = workgroupUniformLoad(&shared_first_child);
    if first_child == LEAF {
        if lane == 0u {
            let b = bounds[index];
            if (b & 0xffffu) > (b >> 16u) {
                nodes[index].color = 0u;
            } else {
                nodes[index].color = lookup_table[b & 0xffffu];
            }
        }
        return;
    }
    let slot = first_child & ~BRICK_FLAG;
    let grid = params.atlas_grid.xyz;
    let cell = vec3<u32>(slot % grid.x, (slot / grid.x) % grid.y, slot / (grid.x * grid.y));
    let base = cell * (params.brick_size + 2u) + vec3<u32>(1u);
    let origin = brick_origins[slot].xyz;
    let size = params.brick_size;
    var sums = vec4<u32>(0u);
    var count = 0u;
    var vote = vec2<u32>(0u);
    for (var i = lane; i < size * size * size; i += WORKGROUP) {
        let local = vec3<u32>(i % size, (i / size) % size, i / (size * size));
        if any(origin + local >= params.dims.xyz) {
            continue; // padding
        }
        let texel = textureLoad(atlas, vec3<i32>(base + local), 0).r;
        let level = u32(clamp(round(texel * params.atlas_scale), 0.0, 65535.0));
        let color = lookup_table[level];
        sums += weighted_sums(color);
        count += 1u;
        if params.labels != 0u && (color >> 24u) != 0u {
            vote = vote_for(vote, color);
        }
    }
    partial_color[lane] = sums;
    partial_count[lane] = count;
    partial_vote[lane] = vote;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride >>= 1u) {
        if lane < stride {
            partial_color[lane] += partial_color[lane + stride];
            partial_count[lane] += partial_count[lane + stride];
            partial_vote[lane] = merge_votes(partial_vote[lane], partial_vote[lane + stride]);
        }
        workgroupBarrier();
    }
    if lane != 0u {
        return;
    }
    let mean = weighted_mean(partial_color[0], partial_count[0]);
    if params.labels != 0u && mean != 0u {
        nodes[index].color = (partial_vote[0].x & 0x00ffffffu) | (mean & 0xff000000u);
    } else {
        nodes[index].color = mean;
    }
}
