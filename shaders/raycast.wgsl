// The octree ray caster: one invocation per pixel, front-to-back through the flat node list.
//
// Space: "voxel space", where voxel (x, y, z) is the unit cube [x, x+1)×[y, y+1)×[z, z+1) and
// the padded octree cube is [0, side]³. The camera's vectors arrive already in that space, so
// anisotropic spacing needs no work here, and a segment's length in voxels is `dt * |dir|`.
//
// Traversal: a short stack holds the path from the root to the current node, with each node's
// box corner and exit distance. After a node is composited or skipped, the ray's `t` moves to
// its exit; finished nodes are popped, and the descent continues from the deepest ancestor
// still containing the ray: the next sibling or an ancestor's sibling, never the root again.
// Children are picked, and ancestors popped, at a probe point a thousandth of a voxel ahead of
// `t`: a child's exit and its parent's mid-plane are the same plane, but the shader compiler
// may round the two distances differently, and deciding at `t` itself could then pick the
// child just left, forever. With the probe, `t` strictly advances at every step.

// Keep in sync with `Node` in src/octree/node.rs.
struct Node {
    color: u32,       // RGBA8, red lowest, straight alpha
    first_child: u32, // index of the first of 8 children, or LEAF
}

// Keep in sync with `RaycastParams` in src/render/gpu_data.rs.
struct Params {
    eye: vec4<f32>,         // xyz: camera position (voxel space)
    forward: vec4<f32>,     // xyz: view direction for the image center (voxel space)
    right: vec4<f32>,       // xyz: +1 ndc x offset (voxel space); w: its world length
    up: vec4<f32>,          // xyz: +1 ndc y offset (voxel space); w: its world length
    volume: vec4<f32>,      // xyz: volume dims in voxels; w: octree cube side
    image_size: vec2<u32>,
    depth: u32,
    max_level: u32,
    mode: u32,              // MODE_*
    flags: u32,             // FLAG_*
    density: f32,           // global opacity scale
    lod_factor: f32,        // pixel angle / smallest spacing: footprint in voxels per unit t
    mip_saturation: u32,    // value level at which MIP may stop
    brick_level: u32,       // level of brick leaves (bricks renderer), else beyond the depth
    brick_size: u32,        // voxels along a brick's side
    atlas_scale: f32,       // atlas texel value × this = value level (255 for unorm8, 1 for f16)
    atlas_grid: vec4<u32>,  // xyz: bricks along each atlas axis
}

const LEAF: u32 = 0xffffffffu;
// Keep in sync with `BRICK_FLAG` in src/octree/bricks.rs.
const BRICK_FLAG: u32 = 0x80000000u;
const MODE_DVR: u32 = 0u;
const MODE_MIP: u32 = 1u;
const FLAG_OPACITY_CORRECTION: u32 = 1u;
const FLAG_PIXEL_LOD: u32 = 2u;
const FLAG_HEATMAP: u32 = 4u;
// Keep in sync with `EARLY_TERMINATION_ALPHA` in src/render/settings.rs.
const EARLY_TERMINATION_ALPHA: f32 = 0.99;
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

struct RayResult {
    color: vec3<f32>,
    visited: u32,
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    // A zero component would give inf * 0 = NaN on the ray's own plane; a tiny one keeps
    // every comparison ordered.
    let tiny = vec3<f32>(1e-20);
    let sign = select(vec3<f32>(-1.0), vec3<f32>(1.0), d >= vec3<f32>(0.0));
    return 1.0 / select(d, sign * tiny, abs(d) < tiny);
}

fn max_component(v: vec3<f32>) -> f32 { return max(v.x, max(v.y, v.z)); }
fn min_component(v: vec3<f32>) -> f32 { return min(v.x, min(v.y, v.z)); }

// Inferno-like ramp for the nodes-visited heat map, x in 0…1.
fn heat(x: f32) -> vec3<f32> {
    let c0 = vec3<f32>(0.0, 0.0, 0.02);
    let c1 = vec3<f32>(0.47, 0.07, 0.43);
    let c2 = vec3<f32>(0.93, 0.41, 0.13);
    let c3 = vec3<f32>(0.99, 0.99, 0.64);
    if x < 0.33 { return mix(c0, c1, x / 0.33); }
    if x < 0.66 { return mix(c1, c2, (x - 0.33) / 0.33); }
    return mix(c2, c3, (x - 0.66) / 0.34);
}

fn trace_ray(origin: vec3<f32>, dir: vec3<f32>, world_length: f32) -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u);
    let inv = safe_inverse(dir);
    let positive = inv >= vec3<f32>(0.0);

    // Clip to the volume's box (not the padded cube).
    let t_low = (vec3<f32>(0.0) - origin) * inv;
    let t_high = (params.volume.xyz - origin) * inv;
    let t_enter = max(max_component(min(t_low, t_high)), 0.0);
    let t_leave = min_component(max(t_low, t_high));
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

    var stack_node: array<u32, STACK_SIZE>;
    var stack_corner: array<vec3<f32>, STACK_SIZE>;
    var stack_exit: array<f32, STACK_SIZE>;
    stack_node[0] = 0u;
    stack_corner[0] = vec3<f32>(0.0);
    stack_exit[0] = min(min_component((select(vec3<f32>(0.0), vec3<f32>(side), positive) - origin) * inv), t_leave);
    var level = 0u;
    var t = t_enter;

    var color = vec3<f32>(0.0);
    var alpha = 0.0;
    var running_max = 0u;

    for (var step = 0u; step < MAX_STEPS; step++) {
        let probe = t + max(probe_step, abs(t) * 5e-7);
        // Pop the nodes the ray has left.
        while level > 0u && stack_exit[level] <= probe {
            level -= 1u;
        }
        if stack_exit[level] <= probe {
            break; // left the root: done
        }
        // Descend from the deepest node still ahead until a node is composited or skipped.
        loop {
            let node = nodes[stack_node[level]];
            result.visited += 1u;
            let t_out = stack_exit[level];
            let size = side / f32(1u << level);

            var skip: bool;
            if mip {
                let b = bounds[stack_node[level]];
                let b_min = b & 0xffffu;
                let b_max = b >> 16u;
                skip = b_min > b_max || b_max <= running_max;
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
                let corner = stack_corner[level];
                var k = max(ceil((t - t_enter) / sample_step - 0.5), 0.0);
                loop {
                    let ts = t_enter + (k + 0.5) * sample_step;
                    if ts >= t_out || alpha >= EARLY_TERMINATION_ALPHA {
                        break;
                    }
                    let local = origin + ts * dir - corner;
                    let texel = textureSampleLevel(atlas, atlas_sampler, (brick_texel + local) / atlas_texels, 0.0).r;
                    let value_level = u32(clamp(round(texel * params.atlas_scale), 0.0, 65535.0));
                    result.visited += 1u;
                    if mip {
                        running_max = max(running_max, value_level);
                        if running_max >= params.mip_saturation {
                            break;
                        }
                    } else {
                        let rgba = unpack4x8unorm(lookup_table[value_level]);
                        let a = min(rgba.a * params.density, 1.0);
                        color += (1.0 - alpha) * a * rgba.rgb;
                        alpha += (1.0 - alpha) * a;
                    }
                    k += 1.0;
                }
                t = max(t_out, probe);
                break;
            }
            if cut {
                if mip {
                    running_max = max(running_max, bounds[stack_node[level]] >> 16u);
                } else {
                    let rgba = unpack4x8unorm(node.color);
                    var a = min(rgba.a * params.density, 1.0);
                    if correct_opacity && a < 1.0 {
                        a = 1.0 - pow(1.0 - a, max(t_out - t, 0.0) * voxels_per_t);
                    }
                    color += (1.0 - alpha) * a * rgba.rgb;
                    alpha += (1.0 - alpha) * a;
                }
                t = max(t_out, probe);
                break;
            }
            // The child containing the probe point: per axis, which side of the mid-plane.
            let half = size * 0.5;
            let corner = stack_corner[level];
            let t_mid = (corner + vec3<f32>(half) - origin) * inv;
            let upper = select(vec3<bool>(probe < t_mid.x, probe < t_mid.y, probe < t_mid.z),
                               vec3<bool>(probe >= t_mid.x, probe >= t_mid.y, probe >= t_mid.z), positive);
            let child_corner = corner + select(vec3<f32>(0.0), vec3<f32>(half), upper);
            let exit_planes = child_corner + select(vec3<f32>(0.0), vec3<f32>(half), positive);
            let child_exit = min_component((exit_planes - origin) * inv);
            let child = node.first_child + select(0u, 1u, upper.x) + select(0u, 2u, upper.y)
                + select(0u, 4u, upper.z);
            level += 1u;
            stack_node[level] = child;
            stack_corner[level] = child_corner;
            stack_exit[level] = min(child_exit, t_out);
        }
        if alpha >= EARLY_TERMINATION_ALPHA || (mip && running_max >= params.mip_saturation)
            || t >= t_leave {
            break;
        }
    }
    if mip {
        result.color = unpack4x8unorm(lookup_table[running_max]).rgb;
    } else {
        // The rest is blended with the black background.
        result.color = color;
    }
    return result;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = params.image_size;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let ndc = vec2<f32>(
        2.0 * (f32(id.x) + 0.5) / f32(size.x) - 1.0,
        1.0 - 2.0 * (f32(id.y) + 0.5) / f32(size.y),
    );
    let dir = params.forward.xyz + ndc.x * params.right.xyz + ndc.y * params.up.xyz;
    // World length of this ray's direction (forward is a unit vector in world space).
    let world_length = sqrt(1.0 + ndc.x * ndc.x * params.right.w * params.right.w
        + ndc.y * ndc.y * params.up.w * params.up.w);
    let result = trace_ray(params.eye.xyz, dir, world_length);
    var rgb = result.color;
    if (params.flags & FLAG_HEATMAP) != 0u {
        rgb = heat(clamp(log2(1.0 + f32(result.visited)) / 10.0, 0.0, 1.0));
    }
    textureStore(output, vec2<i32>(id.xy), vec4<f32>(rgb, 1.0));
    visits[id.y * size.x + id.x] = result.visited;
}
