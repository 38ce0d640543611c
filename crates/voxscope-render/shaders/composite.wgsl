// The dense renderer for up to 8 channels on one grid (docs/octree.md, "Composite of
// channels"): each channel's value levels in one component of two RGBA 3D textures (channels
// 0–3, 4–7), each channel's transfer function as its own 65536-entry table, one after another
// in `lookup_table` (its length says how many channels there are). Marched like dense.wgsl,
// one voxel a step.
//
// DVR: at each sample, every channel's color·opacity from its own table; the sample's color is
// their sum (additive, premultiplied) and its opacity 1 − Π(1 − αc); then front-to-back.
// MIP: each channel's maximum along the ray, its color from its table, the colors added.
// SHADING (DVR): each channel lit by its own gradient, its highlight in its own hue (`channel_gradients`: the central
// differences of all four channels of a texture at once), weighted by its magnitude in widths of
// the channel's own window (`channel_shading`). PROBE: in DVR the sample where the composite's opacity reaches PROBE_ALPHA, in MIP
// the sample of the maximum of the channel whose color there is the brightest (none where
// every channel's maximum is black: the pixel shows nothing).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var channels_low: texture_3d<f32>;
@group(0) @binding(2) var level_sampler: sampler;
@group(0) @binding(3) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(4) var output: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(5) var<storage, read_write> visits: array<u32>;
@group(0) @binding(6) var<storage, read_write> probe_out: ProbeResult;
@group(0) @binding(7) var channels_high: texture_3d<f32>;
// Empty-space skipping (DVR): per block of SKIP_BLOCK³ voxels, 1 where some channel's opacity
// is above 0 for some level its samples there can take (the union of the channels' visible
// ranges), else 0; x fastest. Rebuilt with the tables.
@group(0) @binding(8) var<storage, read> visible_blocks: array<u32>;
// SHADING: per channel, 1 / the gradient (value levels per voxel) that shades it fully.
@group(0) @binding(9) var<storage, read> channel_shading: array<f32>;

const TABLE_LEVELS: u32 = 65536u;
// Keep in sync with `SKIP_BLOCK` in src/composite/skipping.rs.
const SKIP_BLOCK: f32 = 8.0;

// Where the ray leaves the block holding voxel-space point `p`, if no channel is visible
// anywhere in it; else -1.
fn empty_block_exit(p: vec3<f32>, origin: vec3<f32>, inv: vec3<f32>) -> f32 {
    let blocks = vec3<u32>(ceil(params.volume.xyz / SKIP_BLOCK));
    let block = min(vec3<u32>(max(floor(p / SKIP_BLOCK), vec3<f32>(0.0))), blocks - 1u);
    if visible_blocks[block.x + blocks.x * (block.y + blocks.y * block.z)] != 0u {
        return -1.0;
    }
    let low = vec3<f32>(block) * SKIP_BLOCK;
    let high = low + SKIP_BLOCK;
    let t_low = (low - origin) * inv;
    let t_high = (high - origin) * inv;
    return min_component(max(t_low, t_high));
}

// ray_common.wgsl's `accumulate` (not used here) samples a gradient: channel 0's.
fn level_gradient(coords: vec3<f32>, half_texel: vec3<f32>) -> vec3<f32> {
    let dx = vec3<f32>(half_texel.x, 0.0, 0.0);
    let dy = vec3<f32>(0.0, half_texel.y, 0.0);
    let dz = vec3<f32>(0.0, 0.0, half_texel.z);
    let high = vec3<f32>(textureSampleLevel(channels_low, level_sampler, coords + dx, 0.0).r,
                         textureSampleLevel(channels_low, level_sampler, coords + dy, 0.0).r,
                         textureSampleLevel(channels_low, level_sampler, coords + dz, 0.0).r);
    let low = vec3<f32>(textureSampleLevel(channels_low, level_sampler, coords - dx, 0.0).r,
                        textureSampleLevel(channels_low, level_sampler, coords - dy, 0.0).r,
                        textureSampleLevel(channels_low, level_sampler, coords - dz, 0.0).r);
    return (high - low) * params.atlas_scale;
}

// ray_common.wgsl's `label_entry` (not used here: the composite is of intensities) reads a
// label: channel 0's.
fn label_level_at(coords: vec3<f32>) -> u32 {
    return value_index(textureSampleLevel(channels_low, level_sampler, coords, 0.0).r);
}

// The four channels' gradients of `volume` at texture coordinates `coords` (value levels per
// voxel, central differences `half_texel` either side): x, y and z, a channel per component.
fn channel_gradients(volume: texture_3d<f32>, coords: vec3<f32>, half_texel: vec3<f32>)
                     -> array<vec4<f32>, 3> {
    let dx = vec3<f32>(half_texel.x, 0.0, 0.0);
    let dy = vec3<f32>(0.0, half_texel.y, 0.0);
    let dz = vec3<f32>(0.0, 0.0, half_texel.z);
    return array<vec4<f32>, 3>(
        textureSampleLevel(volume, level_sampler, coords + dx, 0.0)
            - textureSampleLevel(volume, level_sampler, coords - dx, 0.0),
        textureSampleLevel(volume, level_sampler, coords + dy, 0.0)
            - textureSampleLevel(volume, level_sampler, coords - dy, 0.0),
        textureSampleLevel(volume, level_sampler, coords + dz, 0.0)
            - textureSampleLevel(volume, level_sampler, coords - dz, 0.0));
}

fn channel_count() -> u32 {
    return arrayLength(&lookup_table) / TABLE_LEVELS;
}

// The value levels of four channels' texels (`value_index` of each).
fn value_indices(texels: vec4<f32>) -> vec4<u32> {
    return vec4<u32>(clamp(round(texels * params.atlas_scale), vec4<f32>(0.0), vec4<f32>(65535.0)));
}

// Channel c's color and opacity at value level `level`.
fn channel_rgba(c: u32, level: u32) -> vec4<f32> {
    return unpack4x8unorm(lookup_table[c * TABLE_LEVELS + level]);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = ray_pixel(id.xy);
    if pixel.x >= params.image_size.x || pixel.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(pixel);
    let origin = params.eye.xyz;
    let dir = ray.dir;
    let count = channel_count();
    var color = vec3<f32>(0.0);
    var alpha = 0.0;
    // MIP: the channels' maxima, 0–3 and 4–7, in vectors (a dynamically indexed array would live
    // in memory: 4 channels then cost 2.7× one, run 54).
    var maxima_low = vec4<u32>(0u);
    var maxima_high = vec4<u32>(0u);
    // PROBE, MIP: where each channel's maximum was sampled.
    var maxima_t_low = vec4<f32>(-1.0);
    var maxima_t_high = vec4<f32>(-1.0);
    var probe_t = -1.0;
    var samples = 0u;
    let interval = volume_interval(origin, dir, safe_inverse(dir));
    let t_enter = interval.x;
    let t_leave = interval.y;
    let step = 1.0 / length(dir);
    // Sample k at t_enter + (k + jitter)·step, the pixel's jitter (`pixel_jitter`).
    let t_first = t_enter + (pixel_jitter(pixel) - 0.5) * step;
    let texel = 1.0 / params.volume.xyz;
    let half_texel = 0.5 * texel;
    let light = headlight(dir);
    let inv = safe_inverse(dir);
    if t_enter < t_leave {
        for (var k = 0.0; ; k += 1.0) {
            let t = t_first + (k + 0.5) * step;
            if t >= t_leave {
                break;
            }
            if params.mode == MODE_DVR {
                // Samples in a block where every channel is transparent add nothing: go on
                // from the first sample past the block (on the same lattice of samples).
                let exit = empty_block_exit(origin + t * dir, origin, inv);
                if exit >= 0.0 {
                    k = max(k + 1.0, ceil((exit - t_first) / step - 0.5)) - 1.0;
                    continue;
                }
            }
            samples += 1u;
            let coords = (origin + t * dir) * texel;
            let low = textureSampleLevel(channels_low, level_sampler, coords, 0.0);
            var high = vec4<f32>(0.0);
            if count > 4u {
                high = textureSampleLevel(channels_high, level_sampler, coords, 0.0);
            }
            if params.mode == MODE_MIP {
                let levels_low = value_indices(low);
                let levels_high = value_indices(high);
                if PROBE {
                    maxima_t_low = select(maxima_t_low, vec4<f32>(t), levels_low > maxima_low);
                    maxima_t_high = select(maxima_t_high, vec4<f32>(t), levels_high > maxima_high);
                }
                maxima_low = max(maxima_low, levels_low);
                if count > 4u {
                    maxima_high = max(maxima_high, levels_high);
                }
                continue;
            }
            var premultiplied = vec3<f32>(0.0);
            var transparency = 1.0;
            // SHADING: the channels' gradients here, fetched once some channel shows.
            var gradients_low = array<vec4<f32>, 3>();
            var gradients_high = array<vec4<f32>, 3>();
            var have_gradients = false;
            for (var c = 0u; c < count; c++) {
                let level = value_index(select(high, low, c < 4u)[c & 3u]);
                let rgba = channel_rgba(c, level);
                let a = min(rgba.a * params.density, 1.0);
                var rgb = rgba.rgb;
                if SHADING && a > 0.0 {
                    if !have_gradients {
                        gradients_low = channel_gradients(channels_low, coords, half_texel);
                        if count > 4u {
                            gradients_high = channel_gradients(channels_high, coords, half_texel);
                        }
                        have_gradients = true;
                    }
                    var gradient: vec3<f32>;
                    if c < 4u {
                        gradient = vec3<f32>(gradients_low[0][c], gradients_low[1][c],
                                             gradients_low[2][c]);
                    } else {
                        gradient = vec3<f32>(gradients_high[0][c - 4u], gradients_high[1][c - 4u],
                                             gradients_high[2][c - 4u]);
                    }
                    rgb = shade_tinted(rgb, gradient * params.atlas_scale, light, channel_shading[c]);
                }
                premultiplied += a * rgb;
                transparency *= 1.0 - a;
            }
            color += (1.0 - alpha) * premultiplied;
            alpha += (1.0 - alpha) * (1.0 - transparency);
            if PROBE && probe_t < 0.0 && alpha >= PROBE_ALPHA {
                probe_t = t;
            }
            if alpha >= EARLY_TERMINATION_ALPHA {
                break;
            }
        }
    }
    if params.mode == MODE_MIP {
        var brightest = 0.0;
        for (var c = 0u; c < count; c++) {
            let rgb = channel_rgba(c, select(maxima_high, maxima_low, c < 4u)[c & 3u]).rgb;
            color += rgb;
            let brightness = rgb.r + rgb.g + rgb.b;
            if PROBE && brightness > brightest {
                brightest = brightness;
                probe_t = select(maxima_t_high, maxima_t_low, c < 4u)[c & 3u];
            }
        }
    }
    if PROBE {
        write_probe(origin, dir, probe_t);
    } else {
        write_pixel(pixel, min(color, vec3<f32>(1.0)), samples);
    }
}
