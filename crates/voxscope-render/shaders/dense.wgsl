// The dense baseline: one 3D texture of value levels (8-bit when they fit), marched at fixed
// steps of one voxel with hardware filtering (trilinear, or nearest), the same transfer lookup
// table, early ray termination and MIP as the octree ray caster. This is what napari/vispy,
// pygfx and ParaView do; voxscope keeps it to measure against and to cross-check the octree.
// Below full detail it marches the max level's own pyramid level (a texture of its own, one
// step per voxel of that level), as the streaming renderer does.
//
// Space and parameters are those of raycast.wgsl (voxel space, camera vectors in voxels);
// both start with ray_common.wgsl.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var levels: texture_3d<f32>;
@group(0) @binding(2) var level_sampler: sampler;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(4) var output: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(5) var<storage, read_write> visits: array<u32>;
// What a PROBE pipeline found (ray_common.wgsl).
@group(0) @binding(6) var<storage, read_write> probe_out: ProbeResult;

struct MarchResult {
    color: vec3<f32>,
    samples: u32,
    probe_t: f32,
}

// The value level at a voxel-space point, trilinear (or nearest, by the sampler). The texture
// bound is the pyramid level of the max level: `atlas_texel` is 1 / (its texels × the level-0
// voxels each covers), so a level's voxel i covers level-0 voxels [i, i + 1) · sample_voxels.
fn level_at(p: vec3<f32>) -> u32 {
    if COARSE {
        return value_index(textureSampleLevel(levels, level_sampler, p * params.atlas_texel.xyz, 0.0).r);
    }
    // (At full detail the texture is the volume's: the expression of before, which ran 5 %
    // faster than the product on an H200, runs 54–55.)
    return value_index(textureSampleLevel(levels, level_sampler, p / params.volume.xyz, 0.0).r);
}

// The label at normalized texture coordinates (`label_entry`, ray_common.wgsl).
fn label_level_at(coords: vec3<f32>) -> u32 {
    return value_index(textureSampleLevel(levels, level_sampler, coords, 0.0).r);
}

// The gradient of the filtered value levels at normalized texture coordinates `coords`,
// central differences `half_texel` (half a voxel of the level) either side: levels per
// level-0 voxel, voxel space.
fn level_gradient(coords: vec3<f32>, half_texel: vec3<f32>) -> vec3<f32> {
    let dx = vec3<f32>(half_texel.x, 0.0, 0.0);
    let dy = vec3<f32>(0.0, half_texel.y, 0.0);
    let dz = vec3<f32>(0.0, 0.0, half_texel.z);
    let high = vec3<f32>(textureSampleLevel(levels, level_sampler, coords + dx, 0.0).r,
                         textureSampleLevel(levels, level_sampler, coords + dy, 0.0).r,
                         textureSampleLevel(levels, level_sampler, coords + dz, 0.0).r);
    let low = vec3<f32>(textureSampleLevel(levels, level_sampler, coords - dx, 0.0).r,
                        textureSampleLevel(levels, level_sampler, coords - dy, 0.0).r,
                        textureSampleLevel(levels, level_sampler, coords - dz, 0.0).r);
    return (high - low) * (params.atlas_scale / sample_voxels());
}

// `jitter` (`ray_jitter`) places the samples in their steps.
fn march(origin: vec3<f32>, dir: vec3<f32>, jitter: f32) -> MarchResult {
    var result = MarchResult(vec3<f32>(0.0), 0u, -1.0);
    let interval = volume_interval(origin, dir, safe_inverse(dir));
    let t_enter = interval.x;
    let t_leave = interval.y;
    if t_enter >= t_leave {
        return result;
    }
    // One voxel of the level drawn per step, the first `jitter` of a step in.
    let step = sample_voxels() / length(dir);
    let t_first = t_enter + (jitter - 0.5) * step;
    var acc = new_accumulation();
    let texel = select(1.0 / params.volume.xyz, params.atlas_texel.xyz, COARSE);
    let frame = SampleFrame(origin * texel, origin * texel, 3.4e38, dir * texel,
                            0.5 * sample_voxels() * texel, headlight(dir), t_enter);
    // Sample k sits at t_enter + (k + jitter) · step (as in the bricks renderer, sample for
    // sample), fetched two batches at a time.
    for (var k = 0.0; ; k += f32(BATCH_PAIR)) {
        let t = t_first + (vec4<f32>(k) + BATCH_OFFSETS) * step;
        let t2 = t_first + (vec4<f32>(k + f32(BATCH)) + BATCH_OFFSETS) * step;
        let count = count_before(t, t_leave) + count_before(t2, t_leave);
        if count == 0u {
            break;
        }
        let first = vec4<u32>(level_at(origin + t.x * dir), level_at(origin + t.y * dir),
                              level_at(origin + t.z * dir), level_at(origin + t.w * dir));
        let second = vec4<u32>(level_at(origin + t2.x * dir), level_at(origin + t2.y * dir),
                               level_at(origin + t2.z * dir), level_at(origin + t2.w * dir));
        result.samples += accumulate_pair(&acc, first, second, count, t, t2, frame);
        if acc.done || count < BATCH_PAIR {
            break;
        }
    }
    result.color = final_color(acc);
    result.probe_t = acc.probe_t;
    return result;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = ray_pixel(id.xy);
    if pixel.x >= params.image_size.x || pixel.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(pixel);
    let result = march(params.eye.xyz, ray.dir, ray_jitter(pixel));
    if PROBE {
        write_probe(params.eye.xyz, ray.dir, result.probe_t);
    } else {
        write_pixel(pixel, result.color, result.samples);
    }
}
