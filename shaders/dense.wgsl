// The dense baseline: one 3D texture of value levels (8-bit when they fit), marched at fixed steps of one voxel
// with hardware filtering (trilinear, or nearest), the same transfer lookup table, early ray
// termination and MIP as the octree ray caster. This is what napari/vispy, pygfx and ParaView
// do; voxscope keeps it to measure against and to cross-check the octree.
//
// Space and parameters are those of raycast.wgsl (voxel space, camera vectors in voxels).

// Keep in sync with `RaycastParams` in src/render/gpu_data.rs (shared with raycast.wgsl).
struct Params {
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    volume: vec4<f32>,      // xyz: volume dims in voxels
    image_size: vec2<u32>,
    depth: u32,
    max_level: u32,
    mode: u32,
    flags: u32,
    density: f32,
    lod_factor: f32,
    mip_saturation: u32,
    brick_level: u32,
    brick_size: u32,
    atlas_scale: f32,       // texel value × this = value level (255 for 8-bit, 1 for f16)
    atlas_grid: vec4<u32>,
}

const MODE_MIP: u32 = 1u;
const FLAG_HEATMAP: u32 = 4u;
// Keep in sync with `EARLY_TERMINATION_ALPHA` in src/render/settings.rs.
const EARLY_TERMINATION_ALPHA: f32 = 0.99;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var levels: texture_3d<f32>;
@group(0) @binding(2) var level_sampler: sampler;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(4) var output: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(5) var<storage, read_write> visits: array<u32>;

fn max_component(v: vec3<f32>) -> f32 { return max(v.x, max(v.y, v.z)); }
fn min_component(v: vec3<f32>) -> f32 { return min(v.x, min(v.y, v.z)); }

fn heat(x: f32) -> vec3<f32> {
    let c0 = vec3<f32>(0.0, 0.0, 0.02);
    let c1 = vec3<f32>(0.47, 0.07, 0.43);
    let c2 = vec3<f32>(0.93, 0.41, 0.13);
    let c3 = vec3<f32>(0.99, 0.99, 0.64);
    if x < 0.33 { return mix(c0, c1, x / 0.33); }
    if x < 0.66 { return mix(c1, c2, (x - 0.33) / 0.33); }
    return mix(c2, c3, (x - 0.66) / 0.34);
}

struct MarchResult {
    color: vec3<f32>,
    samples: u32,
}

fn march(origin: vec3<f32>, dir: vec3<f32>) -> MarchResult {
    var result = MarchResult(vec3<f32>(0.0), 0u);
    let tiny = vec3<f32>(1e-20);
    let sign = select(vec3<f32>(-1.0), vec3<f32>(1.0), dir >= vec3<f32>(0.0));
    let inv = 1.0 / select(dir, sign * tiny, abs(dir) < tiny);
    let dims = params.volume.xyz;
    let t_low = (vec3<f32>(0.0) - origin) * inv;
    let t_high = (dims - origin) * inv;
    let t_enter = max(max_component(min(t_low, t_high)), 0.0);
    let t_leave = min_component(max(t_low, t_high));
    if t_enter >= t_leave {
        return result;
    }
    // One voxel per step.
    let step = 1.0 / length(dir);
    let mip = params.mode == MODE_MIP;
    var color = vec3<f32>(0.0);
    var alpha = 0.0;
    var running_max = 0u;
    // Sample k sits at t_enter + (k + 0.5) · step (as in the bricks renderer, sample for sample).
    for (var k = 0.0; ; k += 1.0) {
        let t = t_enter + (k + 0.5) * step;
        if t >= t_leave {
            break;
        }
        let position = origin + t * dir;
        let level = textureSampleLevel(levels, level_sampler, position / dims, 0.0).r;
        let index = u32(clamp(round(level * params.atlas_scale), 0.0, 65535.0));
        result.samples += 1u;
        if mip {
            running_max = max(running_max, index);
            if running_max >= params.mip_saturation {
                break;
            }
        } else {
            let rgba = unpack4x8unorm(lookup_table[index]);
            // A step is one voxel long, so opacity correction leaves alpha as it is.
            let a = min(rgba.a * params.density, 1.0);
            color += (1.0 - alpha) * a * rgba.rgb;
            alpha += (1.0 - alpha) * a;
            if alpha >= EARLY_TERMINATION_ALPHA {
                break;
            }
        }
    }
    if mip {
        result.color = unpack4x8unorm(lookup_table[running_max]).rgb;
    } else {
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
    let result = march(params.eye.xyz, dir);
    var rgb = result.color;
    if (params.flags & FLAG_HEATMAP) != 0u {
        rgb = heat(clamp(log2(1.0 + f32(result.samples)) / 10.0, 0.0, 1.0));
    }
    textureStore(output, vec2<i32>(id.xy), vec4<f32>(rgb, 1.0));
    visits[id.y * size.x + id.x] = result.samples;
}
