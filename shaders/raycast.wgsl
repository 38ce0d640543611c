// The octree ray caster: one invocation per pixel, front-to-back through the flat node list.
//
// Space: "voxel space", where voxel (x, y, z) is the unit cube [x, x+1)×[y, y+1)×[z, z+1) and
// the padded octree cube is [0, side]³. The camera's vectors arrive already in that space, so
// anisotropic spacing needs no work here, and a segment's length in voxels is `dt * |dir|`.
//
// Traversal: a short stack holds the path from the root to the current node, with each node's
// box corner and exit distance; the current node's own entry is also held in registers. After a node is composited or skipped, the ray's `t` moves to
// its exit; finished nodes are popped, and the descent continues from the deepest ancestor
// still containing the ray: the next sibling or an ancestor's sibling, never the root again.
// Children are picked, and ancestors popped, at a probe point a thousandth of a voxel ahead of
// `t`: a child's exit and its parent's mid-plane are the same plane, but the shader compiler
// may round the two distances differently, and deciding at `t` itself could then pick the
// child just left, forever. With the probe, `t` strictly advances at every step.

// MAX_DEPTH + 1 (src/octree/build.rs).
const STACK_SIZE: u32 = 11u;
const MAX_STEPS: u32 = 100000u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> bounds: array<u32>;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(4) var output: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(5) var<storage, read_write> visits: array<u32>;
// The bricks renderer's atlas of value levels (a 1-texel stand-in for the plain octree).
@group(0) @binding(6) var atlas: texture_3d<f32>;
@group(0) @binding(7) var atlas_sampler: sampler;

// A node's corner: integer voxel coordinates below the octree side (≤ 1024, MAX_DEPTH 10),
// ten bits each.
fn pack_corner(corner: vec3<f32>) -> u32 {
    let c = vec3<u32>(corner);
    return c.x | (c.y << 10u) | (c.z << 20u);
}

fn unpack_corner(packed: u32) -> vec3<f32> {
    return vec3<f32>(vec3<u32>(packed & 0x3ffu, (packed >> 10u) & 0x3ffu, packed >> 20u));
}

struct RayResult {
    color: vec3<f32>,
    visited: u32,
}


fn trace_ray(origin: vec3<f32>, dir: vec3<f32>, world_length: f32) -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u);
    let inv = safe_inverse(dir);
    let positive = inv >= vec3<f32>(0.0);

    // Clip to the volume's box (not the padded cube).
    let interval = volume_interval(origin, inv);
    let t_enter = interval.x;
    let t_leave = interval.y;
    if t_enter >= t_leave {
        return result;
    }

    let side = params.volume.w;
    let voxels_per_t = length(dir);
    let lod_per_t = world_length * params.lod_factor;
    let use_lod = (params.flags & FLAG_PIXEL_LOD) != 0u;
    let correct_opacity = (params.flags & FLAG_OPACITY_CORRECTION) != 0u;
    let mip = params.mode == MODE_MIP;
    let probe_step = 1e-3 / max(voxels_per_t, 1e-20);
    // Bricks are sampled once per voxel of path, at the same places as the dense renderer.
    let sample_step = 1.0 / max(voxels_per_t, 1e-20);
    let atlas_texels = vec3<f32>(textureDimensions(atlas));

    // The path from the root; entry `level` is the current node, also kept in registers
    // (`node_index`, `corner`, `t_out`) so that a descent step waits on one node read alone.
    // Three words a level, the corner packed: local memory traffic, more than node reads,
    // bounds this loop (docs/benchmarks.md, attempts 8–11).
    var stack_node: array<u32, STACK_SIZE>;
    var stack_corner: array<u32, STACK_SIZE>; // pack_corner
    var stack_exit: array<f32, STACK_SIZE>;
    var node_index = 0u;
    var corner = vec3<f32>(0.0);
    var t_out = min(min_component((select(vec3<f32>(0.0), vec3<f32>(side), positive) - origin) * inv), t_leave);
    stack_node[0] = node_index;
    stack_corner[0] = 0u;
    stack_exit[0] = t_out;
    var level = 0u;
    var t = t_enter;

    var acc = Accumulation(vec3<f32>(0.0), 0.0, 0u, false);

    for (var step = 0u; step < MAX_STEPS; step++) {
        let probe = t + max(probe_step, abs(t) * 5e-7);
        // Pop the nodes the ray has left, back to the deepest one still ahead.
        if t_out <= probe {
            while level > 0u && stack_exit[level - 1u] <= probe {
                level -= 1u;
            }
            if level == 0u {
                break; // left the root: done
            }
            level -= 1u;
            node_index = stack_node[level];
            corner = unpack_corner(stack_corner[level]);
            t_out = stack_exit[level];
        }
        // Descend from the deepest node still ahead until a node is composited or skipped.
        loop {
            let size = side / f32(1u << level);
            let node = nodes[node_index];
            var node_bounds = 0u;
            if mip {
                node_bounds = bounds[node_index];
            }
            result.visited += 1u;

            var skip: bool;
            if mip {
                let b_min = node_bounds & 0xffffu;
                let b_max = node_bounds >> 16u;
                skip = b_min > b_max || b_max <= acc.running_max;
            } else {
                skip = (node.color >> 24u) == 0u;
            }
            if skip {
                t = max(t_out, probe);
                break;
            }
            let cut = node.first_child == LEAF || level >= params.max_level
                || (use_lod && size <= t * lod_per_t);
            if !cut && level == params.brick_level && (node.first_child & BRICK_FLAG) != 0u {
                // A brick: march its voxels in the atlas with hardware trilinear filtering.
                let slot = node.first_child & ~BRICK_FLAG;
                let grid = params.atlas_grid.xyz;
                let cell = vec3<u32>(slot % grid.x, (slot / grid.x) % grid.y, slot / (grid.x * grid.y));
                let brick_texel = vec3<f32>(cell) * f32(params.brick_size + 2u) + 1.0;
                var k = max(ceil((t - t_enter) / sample_step - 0.5), 0.0);
                loop {
                    let ts = t_enter + (vec4<f32>(k) + BATCH_OFFSETS) * sample_step;
                    let count = count_before(ts, t_out);
                    if count == 0u {
                        break;
                    }
                    let batch_levels = vec4<u32>(
                        value_index(textureSampleLevel(atlas, atlas_sampler, (brick_texel + (origin + ts.x * dir - corner)) / atlas_texels, 0.0).r),
                        value_index(textureSampleLevel(atlas, atlas_sampler, (brick_texel + (origin + ts.y * dir - corner)) / atlas_texels, 0.0).r),
                        value_index(textureSampleLevel(atlas, atlas_sampler, (brick_texel + (origin + ts.z * dir - corner)) / atlas_texels, 0.0).r),
                        value_index(textureSampleLevel(atlas, atlas_sampler, (brick_texel + (origin + ts.w * dir - corner)) / atlas_texels, 0.0).r),
                    );
                    result.visited += accumulate(&acc, batch_levels, count);
                    if acc.done || count < BATCH {
                        break;
                    }
                    k += f32(BATCH);
                }
                t = max(t_out, probe);
                break;
            }
            if cut {
                if mip {
                    acc.running_max = max(acc.running_max, node_bounds >> 16u);
                } else {
                    let rgba = unpack4x8unorm(node.color);
                    var a = min(rgba.a * params.density, 1.0);
                    if correct_opacity && a < 1.0 {
                        a = 1.0 - pow(1.0 - a, max(t_out - t, 0.0) * voxels_per_t);
                    }
                    acc.color += (1.0 - acc.alpha) * a * rgba.rgb;
                    acc.alpha += (1.0 - acc.alpha) * a;
                }
                t = max(t_out, probe);
                break;
            }
            // The child containing the probe point: per axis, which side of the mid-plane.
            let half = size * 0.5;
            let t_mid = (corner + vec3<f32>(half) - origin) * inv;
            let upper = select(vec3<bool>(probe < t_mid.x, probe < t_mid.y, probe < t_mid.z),
                               vec3<bool>(probe >= t_mid.x, probe >= t_mid.y, probe >= t_mid.z), positive);
            corner += select(vec3<f32>(0.0), vec3<f32>(half), upper);
            let exit_planes = corner + select(vec3<f32>(0.0), vec3<f32>(half), positive);
            t_out = min(min_component((exit_planes - origin) * inv), t_out);
            node_index = node.first_child + select(0u, 1u, upper.x) + select(0u, 2u, upper.y)
                + select(0u, 4u, upper.z);
            level += 1u;
            stack_node[level] = node_index;
            stack_corner[level] = pack_corner(corner);
            stack_exit[level] = t_out;
        }
        if acc.alpha >= EARLY_TERMINATION_ALPHA || (mip && acc.running_max >= params.mip_saturation)
            || t >= t_leave {
            break;
        }
    }
    result.color = final_color(acc);
    return result;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.image_size.x || id.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(id.xy);
    let result = trace_ray(params.eye.xyz, ray.dir, ray.world_length);
    write_pixel(id.xy, result.color, result.visited);
}
