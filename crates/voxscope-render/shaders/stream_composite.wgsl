// The streaming renderer for up to 8 channels of one grid composited (docs/octree.md,
// "Composite of channels"): each channel's bricks are keys of their own in the one page table
// and atlas (`channel_key`), each channel's transfer function, tinted by its color, a table of
// its own in `lookup_table` (channel c's at c·65536), and only the channels whose bit is set in
// `stream.shown_channels` are looked up, asked for or drawn.
//
// A ray goes segment by segment as stream.wgsl's does: each segment is the brick of the level
// the ray wants there (the pixel's footprint, the max-level slider), and for each shown channel
// the page table gives that brick, or asks for it and gives the finest coarser one it has (a
// channel with nothing there yet, or nothing visible, is left out of the segment). The
// segment's samples sit on the lattice of the finest level any channel draws there,
// t_enter + (k + jitter)·step as the in-memory composite's (composite.wgsl) at level 0, so a
// fully resident level 0 draws its image.
//
// DVR: at each sample, every drawn channel's color·opacity from its own table; the sample's
// color is their sum (additive, premultiplied) and its opacity 1 − Π(1 − αc); front to back
// with early termination. MIP: each channel's maximum along the ray, its color from its table,
// the colors added. SHADING (DVR): each channel lit by the gradient of its own brick, weighted
// by its own window (`stream.channel_shading`), its highlight in its hue (`shade_tinted`), as
// the in-memory composite's. PROBE, as the in-memory composite's: in DVR the sample where the
// opacity reaches PROBE_ALPHA, in MIP the sample of the maximum of the channel whose color
// there is the brightest. Prepended with ray_common.wgsl and stream_common.wgsl.

// What one channel draws in the segment being marched.
struct ChannelSegment {
    // ATLAS: the ray's origin in the atlas coordinates of the channel's brick.
    atlas_origin: vec3<f32>,
    // SEGMENT_NONE, SEGMENT_ATLAS or SEGMENT_UNIFORM.
    kind: u32,
    // ATLAS: the brick's level (the ray's direction there: `atlas_direction`).
    level: u32,
    // UNIFORM: the brick's one value level.
    value: u32,
}

// The ray's direction `dir` in the atlas coordinates of a brick of `level` (per unit of t).
fn atlas_direction(dir: vec3<f32>, level: u32) -> vec3<f32> {
    return dir / stream.level_scale[level].xyz * params.atlas_texel.xyz;
}

const SEGMENT_NONE: u32 = 0u;
const SEGMENT_ATLAS: u32 = 1u;
const SEGMENT_UNIFORM: u32 = 2u;
const CHANNELS: u32 = 8u;
const TABLE_LEVELS: u32 = 65536u;
// A batch's samples after its first, in steps.
const BATCH_STEPS: vec4<f32> = vec4<f32>(0.0, 1.0, 2.0, 3.0);

// Channel c's color and opacity at value level `level`.
fn channel_rgba(c: u32, level: u32) -> vec4<f32> {
    return unpack4x8unorm(lookup_table[c * TABLE_LEVELS + level]);
}

fn channel_shown(c: u32) -> bool {
    return c < stream.channel_count && ((stream.shown_channels >> c) & 1u) != 0u;
}

// What channel `c` draws in the segment of brick `cell` of level `wanted` (the ray's point
// `p` in it), asking for what the table lacks as stream.wgsl's segment start does; its level
// in `level` (where it draws anything).
fn channel_segment(c: u32, wanted: u32, cell: vec3<u32>, p: vec3<f32>, origin: vec3<f32>,
                   dir: vec3<f32>, running_max: u32, level: ptr<function, u32>)
                   -> ChannelSegment {
    var segment = ChannelSegment(vec3<f32>(0.0), SEGMENT_NONE, 0u, 0u);
    let key = channel_key(wanted, cell, c);
    var entry = table_lookup(key);
    var used = cell;
    *level = wanted;
    if entry[TABLE_KEY] != key || (entry[TABLE_CELL] & ENTRY_FAILED) != 0u {
        request_brick(key);
    } else if !drawable(entry) {
        // Its range is known: asked for only if it can show.
        if !entry_visible(entry, running_max) {
            return segment;
        }
        request_brick(key);
    }
    if entry[TABLE_KEY] != key || !drawable(entry) {
        // The finest coarser level the table has here.
        var found = false;
        for (var l = wanted + 1u; l < stream.level_count; l++) {
            let c2 = brick_of(l, p);
            let k2 = channel_key(l, c2, c);
            let e = table_lookup(k2);
            if e[TABLE_KEY] == k2 && drawable(e) {
                entry = e;
                *level = l;
                used = c2;
                found = true;
                break;
            }
        }
        if !found {
            return segment;
        }
    }
    if !entry_visible(entry, running_max) {
        return segment;
    }
    if (entry[TABLE_CELL] & ENTRY_RESIDENT) == 0u {
        segment.kind = SEGMENT_UNIFORM;
        segment.value = entry[TABLE_RANGE] & 0xffffu;
        return segment;
    }
    let slot = entry[TABLE_SLOT] & SLOT_MASK;
    if !PROBE {
        mark_used(slot, usage_mark(*level == wanted), atomicLoad(&usage[slot]));
    }
    segment.kind = SEGMENT_ATLAS;
    segment.atlas_origin = atlas_origin(*level, used, entry[TABLE_CELL], origin);
    segment.level = *level;
    return segment;
}

fn composite_ray(origin: vec3<f32>, dir: vec3<f32>, world_length: f32, jitter: f32)
                 -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u, -1.0);
    let inv = safe_inverse(dir);
    let interval = volume_interval(origin, dir, inv);
    let t_enter = interval.x;
    let t_leave = interval.y;
    let mip = max_projection();
    var maxima = array<u32, CHANNELS>(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    // PROBE, MIP: where each channel's maximum was sampled.
    var maxima_t = array<f32, CHANNELS>(-1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0);
    let shift = jitter - 0.5;
    let lod_per_t = world_length * params.lod_factor * stream.lod_scale;
    let correct = (params.flags & FLAG_OPACITY_CORRECTION) != 0u;
    var color = vec3<f32>(0.0);
    var alpha = 0.0;
    var segments: array<ChannelSegment, CHANNELS>;
    let half_texel = 0.5 * params.atlas_texel.xyz;
    let light = headlight(dir);
    // (A ray that misses the volume takes no segment; its MIP is the channels' level 0, as the
    // in-memory composite's.)
    var t = select(t_leave, t_enter, t_enter < t_leave);
    for (var i = 0u; i < MAX_STEPS && t < t_leave; i++) {
        let ahead = max(1e-3 / max(length(dir), 1e-20), abs(t) * 5e-7);
        let wanted = wanted_level(max(t, 0.0), lod_per_t);
        let p = origin + (t + ahead) * dir;
        let cell = brick_of(wanted, p);
        let exits = brick_exits(wanted, cell, origin, inv);
        let t_out = max(min(min_component(exits), t_leave), t + ahead);
        result.visited += 1u;
        // Each shown channel's brick here; the finest level any of them draws.
        var finest = stream.level_count;
        var drawn = 0u;
        // (Over the shown channels' bits only: a loop of eight with a test each cost a warp the
        // hidden ones' turns.)
        var shown = stream.shown_channels & ((1u << stream.channel_count) - 1u);
        while shown != 0u {
            let c = firstTrailingBit(shown);
            shown &= shown - 1u;
            var level = 0u;
            segments[c] = channel_segment(c, wanted, cell, p, origin, dir, maxima[c], &level);
            if segments[c].kind != SEGMENT_NONE {
                finest = min(finest, level);
                drawn |= 1u << c;
            }
        }
        if drawn != 0u {
            let scale = stream.level_scale[finest].xyz;
            let step = 1.0 / max(length(dir / scale), 1e-20);
            let exponent = select(1.0, step * length(dir),
                                  correct && any(scale != vec3<f32>(1.0)));
            var k = max(ceil((t - t_enter) / step - 0.5 - shift), 0.0);
            // Four samples a batch: each channel's four texels fetched together, then the
            // samples blended front to back in turn (the same arithmetic as one at a time).
            for (var s = 0u; s < MAX_STEPS; s++) {
                let ts = t_enter + (vec4<f32>(k + 0.5 + shift) + BATCH_STEPS) * step;
                let count = count_before(ts, t_out);
                if count == 0u {
                    break;
                }
                k += f32(count);
                result.visited += count;
                let taken = vec4<u32>(0u, 1u, 2u, 3u) < vec4<u32>(count);
                var premultiplied = array<vec3<f32>, 4>();
                var transparency = vec4<f32>(1.0);
                var channels = drawn;
                while channels != 0u {
                    let c = firstTrailingBit(channels);
                    channels &= channels - 1u;
                    let segment = segments[c];
                    var values = vec4<u32>(segment.value);
                    let o = segment.atlas_origin;
                    let d = atlas_direction(dir, segment.level);
                    let atlas_samples = segment.kind == SEGMENT_ATLAS;
                    if atlas_samples {
                        values = vec4<u32>(atlas_level_at(o + ts.x * d), atlas_level_at(o + ts.y * d),
                                           atlas_level_at(o + ts.z * d), atlas_level_at(o + ts.w * d));
                    }
                    if mip {
                        // (Samples past the segment read beyond its brick: not taken.)
                        let inside = select(vec4<u32>(0u), values, taken);
                        if PROBE {
                            for (var j = 0u; j < 4u; j++) {
                                if inside[j] > maxima[c] {
                                    maxima[c] = inside[j];
                                    maxima_t[c] = ts[j];
                                }
                            }
                        }
                        maxima[c] = max(maxima[c], max(max(inside.x, inside.y), max(inside.z, inside.w)));
                        continue;
                    }
                    for (var j = 0u; j < 4u; j++) {
                        let rgba = channel_rgba(c, values[j]);
                        let a = step_alpha(rgba.a, exponent);
                        var rgb = rgba.rgb;
                        // (A uniform brick has no gradient: its color as it is.)
                        if SHADING && a > 0.0 && atlas_samples && taken[j] {
                            let scale = stream.level_scale[segment.level].xyz;
                            let gradient = level_gradient(o + ts[j] * d, half_texel) / scale;
                            rgb = shade_tinted(rgb, gradient, light,
                                               stream.channel_shading[c / 4u][c % 4u]);
                        }
                        premultiplied[j] += a * rgb;
                        transparency[j] *= 1.0 - a;
                    }
                }
                if mip {
                    continue;
                }
                for (var j = 0u; j < count; j++) {
                    color += (1.0 - alpha) * premultiplied[j];
                    alpha += (1.0 - alpha) * (1.0 - transparency[j]);
                    if PROBE && result.probe_t < 0.0 && alpha >= PROBE_ALPHA {
                        result.probe_t = ts[j];
                    }
                    if alpha >= EARLY_TERMINATION_ALPHA {
                        break;
                    }
                }
                if alpha >= EARLY_TERMINATION_ALPHA {
                    break;
                }
            }
        }
        if !mip && alpha >= EARLY_TERMINATION_ALPHA {
            break;
        }
        t = t_out;
    }
    if mip {
        var brightest = 0.0;
        for (var c = 0u; c < CHANNELS; c++) {
            if channel_shown(c) {
                let rgb = channel_rgba(c, maxima[c]).rgb;
                color += rgb;
                let brightness = rgb.r + rgb.g + rgb.b;
                if PROBE && brightness > brightest {
                    brightest = brightness;
                    result.probe_t = maxima_t[c];
                }
            }
        }
    }
    result.color = min(color, vec3<f32>(1.0));
    return result;
}

// The segment loop's entry points: stream.wgsl's `main` for the composite. (No level walk.)
@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = ray_pixel(id.xy);
    if pixel.x >= params.image_size.x || pixel.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(pixel);
    let result = composite_ray(params.eye.xyz, ray.dir, ray.world_length, ray_jitter(pixel));
    if PROBE {
        write_probe(params.eye.xyz, ray.dir, result.probe_t);
    } else {
        write_pixel(pixel, result.color, result.visited);
    }
}
