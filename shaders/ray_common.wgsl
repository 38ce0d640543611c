// Shared by raycast.wgsl and dense.wgsl: src/render/shaders.rs prepends this file to each
// (WGSL has no includes). The parameters, the per-pixel ray, and small helpers.

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
    brick_grid: vec4<u32>,  // xyz: brick cells along each volume axis (the walked grid)
    atlas_texel: vec4<f32>, // xyz: 1 / the atlas's size in texels (texel to normalized)
}

const MODE_DVR: u32 = 0u;
const MODE_MIP: u32 = 1u;
const FLAG_OPACITY_CORRECTION: u32 = 1u;
const FLAG_PIXEL_LOD: u32 = 2u;
const FLAG_HEATMAP: u32 = 4u;
// Keep in sync with `EARLY_TERMINATION_ALPHA` in src/render/settings.rs.
const EARLY_TERMINATION_ALPHA: f32 = 0.99;

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

// The ray through the center of pixel `id`, in voxel space.
struct PixelRay {
    dir: vec3<f32>,
    // World length of `dir` (the image center's direction has length 1 in world space).
    world_length: f32,
}

fn pixel_ray(id: vec2<u32>) -> PixelRay {
    let size = params.image_size;
    let ndc = vec2<f32>(
        2.0 * (f32(id.x) + 0.5) / f32(size.x) - 1.0,
        1.0 - 2.0 * (f32(id.y) + 0.5) / f32(size.y),
    );
    let dir = params.forward.xyz + ndc.x * params.right.xyz + ndc.y * params.up.xyz;
    let world_length = sqrt(1.0 + ndc.x * ndc.x * params.right.w * params.right.w
        + ndc.y * ndc.y * params.up.w * params.up.w);
    return PixelRay(dir, world_length);
}

// Entry (clamped to the eye) and exit distances of a ray through the volume's box [0, dims].
fn volume_interval(origin: vec3<f32>, inv: vec3<f32>) -> vec2<f32> {
    let t_low = (vec3<f32>(0.0) - origin) * inv;
    let t_high = (params.volume.xyz - origin) * inv;
    return vec2<f32>(max(max_component(min(t_low, t_high)), 0.0), min_component(max(t_low, t_high)));
}

// Samples are fetched in batches of four: their texture reads do not depend on each other, so
// a ray waits for one memory latency per batch instead of one per sample (the frame is bound by
// its longest rays' chains of dependent reads: docs/benchmarks.md, attempt 7). The dense march
// and the bricks' grid walk fetch two batches per loop iteration (attempt 17).
const BATCH: u32 = 4u;
const BATCH_OFFSETS: vec4<f32> = vec4<f32>(0.5, 1.5, 2.5, 3.5);
const BATCH_PAIR: u32 = 2u * BATCH;

// A ray's front-to-back state: DVR color and opacity, or the MIP running maximum.
struct Accumulation {
    color: vec3<f32>,
    alpha: f32,
    running_max: u32,
    // Opaque (DVR) or saturated (MIP): nothing behind can change the pixel.
    done: bool,
}

// Takes the first `count` of four value levels in order along the ray, as one-voxel samples,
// and returns how many it took before the ray was done. The four lookups are issued before
// any is blended, for the same reason as the batched fetches.
fn accumulate(acc: ptr<function, Accumulation>, levels: vec4<u32>, count: u32) -> u32 {
    if params.mode == MODE_MIP {
        for (var j = 0u; j < count; j++) {
            (*acc).running_max = max((*acc).running_max, levels[j]);
            if (*acc).running_max >= params.mip_saturation {
                (*acc).done = true;
                return j + 1u;
            }
        }
        return count;
    }
    let colors = vec4<u32>(lookup_table[levels.x], lookup_table[levels.y],
                           lookup_table[levels.z], lookup_table[levels.w]);
    for (var j = 0u; j < count; j++) {
        let rgba = unpack4x8unorm(colors[j]);
        // A step is one voxel long, so opacity correction leaves alpha as it is.
        let a = min(rgba.a * params.density, 1.0);
        (*acc).color += (1.0 - (*acc).alpha) * a * rgba.rgb;
        (*acc).alpha += (1.0 - (*acc).alpha) * a;
        if (*acc).alpha >= EARLY_TERMINATION_ALPHA {
            (*acc).done = true;
            return j + 1u;
        }
    }
    return count;
}

// `accumulate` for two batches fetched together: the first `count` of their eight levels.
fn accumulate_pair(acc: ptr<function, Accumulation>, first: vec4<u32>, second: vec4<u32>, count: u32) -> u32 {
    var taken = accumulate(acc, first, min(count, BATCH));
    if !(*acc).done && count > BATCH {
        taken += accumulate(acc, second, count - BATCH);
    }
    return taken;
}

// How many of the four sample distances `t` lie before `t_end`.
fn count_before(t: vec4<f32>, t_end: f32) -> u32 {
    let inside = select(vec4<u32>(0u), vec4<u32>(1u), t < vec4<f32>(t_end));
    return inside.x + inside.y + inside.z + inside.w;
}

// A texel of value levels (0…1 in the texture) as a lookup-table index.
fn value_index(texel: f32) -> u32 {
    return u32(clamp(round(texel * params.atlas_scale), 0.0, 65535.0));
}

// The pixel's color once the ray is finished: blended over black, or the MIP's color.
fn final_color(acc: Accumulation) -> vec3<f32> {
    if params.mode == MODE_MIP {
        return unpack4x8unorm(lookup_table[acc.running_max]).rgb;
    }
    return acc.color;
}

// Writes a pixel: the color, or the heat map of `work` (nodes or samples) when asked.
fn write_pixel(id: vec2<u32>, color: vec3<f32>, work: u32) {
    var rgb = color;
    if (params.flags & FLAG_HEATMAP) != 0u {
        rgb = heat(clamp(log2(1.0 + f32(work)) / 10.0, 0.0, 1.0));
    }
    textureStore(output, vec2<i32>(id), vec4<f32>(rgb, 1.0));
    visits[id.y * params.image_size.x + id.x] = work;
}
