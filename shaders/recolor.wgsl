// Recolors one level of the octree: leaves from the transfer function's lookup table, inner
// nodes as the opacity-weighted average of their 8 children (alpha rounded up). Dispatched
// once per level, deepest first, so children are final before their parents read them.
// Integer math only: the result equals the CPU's `recolor` bit for bit.

// Keep in sync with `Node` in src/octree/node.rs.
struct Node {
    color: u32,
    first_child: u32,
}

// Keep in sync with `RecolorParams` in src/render/gpu_data.rs.
struct Params {
    level_start: u32,
    level_count: u32,
    // Workgroups along x of the 2D dispatch (a level can exceed 65535 workgroups).
    groups_x: u32,
    _pad: u32,
}

const LEAF: u32 = 0xffffffffu;
const WORKGROUP: u32 = 256u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;

fn channel(color: u32, shift: u32) -> u32 {
    return (color >> shift) & 0xffu;
}

// Keep in sync with `average_color` in src/octree/node.rs.
fn average_color(first: u32) -> u32 {
    var alpha_sum = 0u;
    var r = 0u;
    var g = 0u;
    var b = 0u;
    for (var c = 0u; c < 8u; c++) {
        let color = nodes[first + c].color;
        let a = channel(color, 24u);
        alpha_sum += a;
        r += channel(color, 0u) * a;
        g += channel(color, 8u) * a;
        b += channel(color, 16u) * a;
    }
    if alpha_sum == 0u {
        return 0u;
    }
    let half = alpha_sum / 2u;
    return ((r + half) / alpha_sum) | (((g + half) / alpha_sum) << 8u)
        | (((b + half) / alpha_sum) << 16u) | (((alpha_sum + 7u) / 8u) << 24u);
}

@compute @workgroup_size(256, 1, 1)
fn main(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let offset = (group.y * params.groups_x + group.x) * WORKGROUP + lane;
    if offset >= params.level_count {
        return;
    }
    let index = params.level_start + offset;
    let node = nodes[index];
    var color: u32;
    if node.first_child == LEAF {
        let b = bounds[index];
        let b_min = b & 0xffffu;
        if b_min > (b >> 16u) {
            color = 0u; // padding
        } else {
            color = lookup_table[b_min];
        }
    } else {
        color = average_color(node.first_child);
    }
    nodes[index].color = color;
}
