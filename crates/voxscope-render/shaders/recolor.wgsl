// Recolors one level of the octree: leaves from the transfer function's lookup table, inner
// nodes as the opacity-weighted average of their 8 children (alpha rounded up), or for labels
// the color most of their visible children show. Dispatched once per level, deepest first, so
// children are final before their parents read them. Integer math only: the result equals the
// CPU's `recolor` bit for bit.

const WORKGROUP: u32 = 256u;

@group(0) @binding(0) var<uniform> params: LevelParams;
@group(0) @binding(1) var<storage, read_write> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;

// The parent's color from its 8 children.
fn average_color(first: u32) -> u32 {
    var sums = vec4<u32>(0u);
    for (var c = 0u; c < 8u; c++) {
        sums += weighted_sums(nodes[first + c].color);
    }
    return weighted_mean(sums, 8u);
}

// A label volume's parent: the color most of its visible children show (ties to the first
// child), with the average's alpha. Keep in sync with `mode_color` in src/octree/node.rs.
fn mode_color(first: u32) -> u32 {
    let alpha = average_color(first) >> 24u;
    if alpha == 0u {
        return 0u;
    }
    var best = 0u;
    var best_count = 0u;
    for (var i = 0u; i < 8u; i++) {
        let color = nodes[first + i].color;
        if (color >> 24u) == 0u {
            continue;
        }
        var earlier = false;
        for (var j = 0u; j < i; j++) {
            earlier = earlier || nodes[first + j].color == color;
        }
        var count = 0u;
        for (var j = i; j < 8u; j++) {
            count += select(0u, 1u, nodes[first + j].color == color);
        }
        if !earlier && count > best_count {
            best = color;
            best_count = count;
        }
    }
    return (best & 0x00ffffffu) | (alpha << 24u);
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
    } else if params.labels != 0u {
        color = mode_color(node.first_child);
    } else {
        color = average_color(node.first_child);
    }
    nodes[index].color = color;
}
