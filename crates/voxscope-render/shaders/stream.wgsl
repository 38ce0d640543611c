// The streaming renderer: a pyramid of bricks of which the GPU holds a few in an atlas, found
// through a page table (src/stream/page_table.rs). One invocation per pixel, in level-0 voxel
// space (raycast.wgsl's: voxel (x, y, z) of level 0 is the unit cube at (x, y, z)); a voxel of
// level l covers `level_scale[l]` level-0 voxels per axis.
//
// A ray goes segment by segment. At the start of each it picks the level it wants there (the
// finest allowed by the max-level slider, coarser where a pixel's footprint covers several
// voxels, as the octree's pixel LOD does), and the segment is that level's brick the ray is in, up to where the ray leaves it.
// If the page table has that brick in the atlas, the ray marches it; if the brick is uniform it
// composites a run of its value; if the table says its range is invisible under the transfer
// function it skips it. Otherwise it asks for the brick (the request buffer, read back by the
// CPU a frame or two later) and draws the segment from the finest coarser level the table has
// there (the coarsest level is always resident). Samples sit where the dense renderer's sit for
// the level marched, t_enter + (k + jitter)·step with step one voxel of that level and jitter
// the pixel's (`ray_jitter`), so a fully resident level 0 gives the bricks renderer's image.
// A label volume's bricks are sampled at the nearest voxel (the sampler) and its MIP draws the
// first visible label (`first_label`). Prepended with ray_common.wgsl and
// stream_common.wgsl.


// `accumulate` of ray_common.wgsl for a level whose samples are `exponent` level-0 voxels
// apart, and whose gradients (SHADING) are per voxel of a level `level_scale` coarser.
fn accumulate_level(acc: ptr<function, Accumulation>, levels: vec4<u32>, count: u32,
                    ts: vec4<f32>, frame: SampleFrame, exponent: f32,
                    level_scale: vec3<f32>) -> u32 {
    // Labels, DVR and MIP (the first label shown): voxel cubes, never blended.
    if labels() {
        return accumulate_labels(acc, levels, count, ts, frame, exponent);
    }
    if params.mode == MODE_MIP {
        for (var j = 0u; j < count; j++) {
            if PROBE && levels[j] > (*acc).running_max {
                (*acc).probe_t = ts[j];
            }
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
        let a = step_alpha(rgba.a, exponent);
        var rgb = rgba.rgb;
        if SHADING && a > 0.0 {
            let coords = select(frame.next, frame.here, ts[j] < frame.split) + ts[j] * frame.dir;
            rgb = shade_sample(rgb, level_gradient(coords, frame.half_texel) / level_scale,
                               frame.light);
        }
        (*acc).color += (1.0 - (*acc).alpha) * a * rgb;
        (*acc).alpha += (1.0 - (*acc).alpha) * a;
        if PROBE && (*acc).probe_t < 0.0 && (*acc).alpha >= PROBE_ALPHA {
            (*acc).probe_t = ts[j];
        }
        if (*acc).alpha >= EARLY_TERMINATION_ALPHA {
            (*acc).done = true;
            return j + 1u;
        }
    }
    return count;
}

// `samples` equal samples of value level `level` (a uniform brick), the first at `first_t`,
// `step` apart: composited in one go (unshaded: a uniform region has no gradient).
fn accumulate_run(acc: ptr<function, Accumulation>, level: u32, samples: f32, first_t: f32,
                  step: f32, exponent: f32) {
    if samples <= 0.0 {
        return;
    }
    if first_label() {
        take_label(acc, level, first_t);
        return;
    }
    if params.mode == MODE_MIP {
        if PROBE && level > (*acc).running_max {
            (*acc).probe_t = first_t;
        }
        (*acc).running_max = max((*acc).running_max, level);
        (*acc).done = (*acc).running_max >= params.mip_saturation;
        return;
    }
    let rgba = unpack4x8unorm(lookup_table[level]);
    let sample_alpha = step_alpha(rgba.a, exponent);
    if sample_alpha <= 0.0 {
        return;
    }
    let a = 1.0 - pow(1.0 - sample_alpha, samples);
    let alpha_before = (*acc).alpha;
    (*acc).color += (1.0 - (*acc).alpha) * a * rgba.rgb;
    (*acc).alpha += (1.0 - (*acc).alpha) * a;
    (*acc).done = (*acc).alpha >= EARLY_TERMINATION_ALPHA;
    if PROBE && (*acc).probe_t < 0.0 && (*acc).alpha >= PROBE_ALPHA {
        let needed = log((1.0 - PROBE_ALPHA) / (1.0 - alpha_before)) / log(1.0 - sample_alpha);
        let j = clamp(ceil(needed) - 1.0, 0.0, samples - 1.0);
        (*acc).probe_t = first_t + j * step;
    }
}

// Marches `count` samples of a batch pair at `ts` then `ts2` (the level's, `exponent` and
// `level_scale` as in `accumulate_level`): those before `frame.split` in the brick whose
// atlas origin is `frame.here`, the rest in the next one's at `frame.next`. Returns the
// samples taken (fewer where the ray became opaque or saturated).
fn march_pair(acc: ptr<function, Accumulation>, ts: vec4<f32>, ts2: vec4<f32>, count: u32,
              frame: SampleFrame, exponent: f32, level_scale: vec3<f32>) -> u32 {
    let here = ts < vec4<f32>(frame.split);
    let there = ts2 < vec4<f32>(frame.split);
    let first = vec4<u32>(
        atlas_level_at(select(frame.next, frame.here, here.x) + ts.x * frame.dir),
        atlas_level_at(select(frame.next, frame.here, here.y) + ts.y * frame.dir),
        atlas_level_at(select(frame.next, frame.here, here.z) + ts.z * frame.dir),
        atlas_level_at(select(frame.next, frame.here, here.w) + ts.w * frame.dir));
    let second = vec4<u32>(
        atlas_level_at(select(frame.next, frame.here, there.x) + ts2.x * frame.dir),
        atlas_level_at(select(frame.next, frame.here, there.y) + ts2.y * frame.dir),
        atlas_level_at(select(frame.next, frame.here, there.z) + ts2.z * frame.dir),
        atlas_level_at(select(frame.next, frame.here, there.w) + ts2.w * frame.dir));
    var taken = accumulate_level(acc, first, min(count, BATCH), ts, frame, exponent, level_scale);
    if !(*acc).done && count > BATCH {
        taken += accumulate_level(acc, second, count - BATCH, ts2, frame, exponent, level_scale);
    }
    return taken;
}


// Whether a brick read ahead can be marched at once: its entry is the one for `key`, in the
// atlas, and can change the pixel.
fn marchable(entry: vec4<u32>, key: u32, running_max: u32) -> bool {
    return entry[TABLE_KEY] == key && (entry[TABLE_CELL] & ENTRY_RESIDENT) != 0u
        && entry_visible(entry, running_max);
}

// One ray through the pyramid. One flat loop: each iteration that finds the ray between
// segments starts one where the last ended (looking its brick up and skipping or compositing
// what needs no marching at once), then marches a batch pair of the current segment's samples,
// so a warp's lanes never wait for each other at nested loops' ends (the grid walk's lesson,
// raycast.wgsl). While the ray wants the same level from one brick to the next, it steps
// through that level's grid of bricks as the grid walk does (Amanatides & Woo), each brick's
// page-table entry read a segment ahead; where the level it wants changes, it finds the brick
// from the ray's point.
//
// The common step, from a brick in the atlas to the next one that is too, is taken where the
// batch reaching the brick's exit ends, in a few instructions: a segment's start is long (the
// lookup, requests, the fallback to coarser levels), and a warp runs it whenever any of its
// lanes needs it, so taking it at every brick cost the other lanes that time. Ray-long values
// that only a segment's start needs (1 / dir, the origin in the level's voxels) are worked out
// there again rather than held through the marching. (Runs 99–100, docs/performance-log.md:
// 2–4 % faster than holding them and starting a segment at every brick; the register count,
// 64 to 80 in the variants tried, changed the frame time little.)
fn stream_ray(origin: vec3<f32>, dir: vec3<f32>, world_length: f32, jitter: f32) -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u, -1.0);
    let interval = volume_interval(origin, dir, safe_inverse(dir));
    let t_enter = interval.x;
    let t_leave = interval.y;
    if t_enter >= t_leave {
        return result;
    }
    let mip = max_projection();
    // Sample k of a level sits at t_enter + (k + jitter)·step: (k + ½ + shift)·step.
    let shift = jitter - 0.5;
    let lod_per_t = world_length * params.lod_factor * stream.lod_scale;
    let light = headlight(dir);
    let half_texel = 0.5 * params.atlas_texel.xyz;
    var acc = new_accumulation();

    var t = t_enter;
    // The segment being marched: its exit, sample step and index, the level drawn, the
    // opacity correction's exponent, where its samples are in the atlas, and the brick's
    // maximum (MIP).
    var marching = false;
    var segment_out = 0.0;
    var step = 1.0;
    var k = 0.0;
    var k_level = 0xffffffffu;
    var exponent = 1.0;
    var atlas_here = vec3<f32>(0.0);
    var atlas_dir = vec3<f32>(0.0);
    var brick_max = 0u;
    // The slot being marched (USAGE_WANTED: at the level the ray wanted) and its usage mark as
    // read when the segment began.
    var usage_slot = 0u;
    var usage_seen = 0xffffffffu;
    // The next brick along the ray at the level drawn, where the ray wants that level there
    // too (NO_CELL: none; the next segment finds its brick from the ray's point), and its
    // page-table entry read ahead from its home slot.
    var next_cell = vec3<u32>(NO_CELL, 0u, 0u);
    var next_entry = vec4<u32>(EMPTY_KEY, 0u, 0u, 0u);
    for (var i = 0u; i < MAX_STEPS; i++) {
        if !marching {
            if t >= t_leave {
                break;
            }
            let inv = safe_inverse(dir);
            let ahead = max(1e-3 / max(length(dir), 1e-20), abs(t) * 5e-7);
            // The segment's brick: the one read ahead, else the one of the wanted level at
            // the ray's point.
            var wanted = k_level;
            var cell = next_cell;
            if cell.x == NO_CELL {
                wanted = wanted_level(max(t, 0.0), lod_per_t);
                cell = brick_of(wanted, origin + (t + ahead) * dir);
            }
            let exits = brick_exits(wanted, cell, origin, inv);
            let key = brick_key(wanted, cell);
            // (At least `ahead` past t, whatever the rounding: every segment moves the ray on.)
            let t_out = max(min(min_component(exits), t_leave), t + ahead);
            // The entry read ahead, if its home slot held it; else the lookup.
            var entry = next_entry;
            if entry[TABLE_KEY] != key {
                entry = table_lookup(key);
            }
            next_cell.x = NO_CELL;
            var level = wanted;
            var used_cell = cell;
            var skip = false;
            if entry[TABLE_KEY] != key {
                request_brick(key);
            } else if (entry[TABLE_CELL] & ENTRY_FAILED) != 0u {
                // Unreadable: asked for all the same, so that the streamer knows the view
                // needs it (it is counted unreadable, and its coarser brick is loaded instead).
                request_brick(key);
            } else if !drawable(entry) {
                // Its range is known: ask for it only if it can show.
                if entry_visible(entry, acc.running_max) {
                    request_brick(key);
                } else {
                    skip = true;
                }
            }
            if !skip && (entry[TABLE_KEY] != key || !drawable(entry)) {
                // The finest coarser level the table has here.
                skip = true;
                let p = origin + (t + ahead) * dir;
                for (var l = wanted + 1u; l < stream.level_count; l++) {
                    let c = brick_of(l, p);
                    let k2 = brick_key(l, c);
                    let e = table_lookup(k2);
                    if e[TABLE_KEY] == k2 && drawable(e) {
                        entry = e;
                        level = l;
                        used_cell = c;
                        skip = false;
                        break;
                    }
                }
            }
            result.visited += 1u;
            if !skip {
                skip = !entry_visible(entry, acc.running_max);
            }
            // The samples of the level drawn: t_enter + (k + jitter)·step, k continuing while
            // the level stays the same; what depends on the level only, worked out when it
            // changes.
            if level != k_level {
                let scale = stream.level_scale[level].xyz;
                step = 1.0 / max(length(dir / scale), 1e-20);
                // (Exactly 1 for level-0 voxels, as the bricks renderer's: the product's
                // rounding would otherwise cost a `pow` per sample.)
                let correct = (params.flags & FLAG_OPACITY_CORRECTION) != 0u;
                exponent = select(1.0, step * length(dir), correct && any(scale != vec3<f32>(1.0)));
                atlas_dir = dir / scale * params.atlas_texel.xyz;
                k = max(ceil((t - t_enter) / step - 0.5 - shift), 0.0);
                k_level = level;
            }
            // The next brick at this level, where the ray wants this level there too: its
            // entry read now, so that its latency hides behind this segment (the grid walk's
            // prefetch, raycast.wgsl).
            if level == wanted && t_out < t_leave && wanted_level(t_out, lod_per_t) == wanted {
                next_cell = next_brick(wanted, cell, exits, dir);
                if next_cell.x != NO_CELL {
                    next_entry = home_entry(brick_key(wanted, next_cell));
                }
            }
            if skip || (entry[TABLE_CELL] & ENTRY_RESIDENT) == 0u {
                let end = max(ceil((t_out - t_enter) / step - 0.5 - shift), k);
                if !skip {
                    accumulate_run(&acc, entry[TABLE_RANGE] & 0xffffu, end - k,
                                   t_enter + (k + 0.5 + shift) * step, step, exponent);
                }
                k = end;
                t = t_out;
            } else {
                let slot = entry[TABLE_SLOT] & SLOT_MASK;
                usage_slot = slot | select(0u, USAGE_WANTED, level == wanted);
                if !PROBE {
                    usage_seen = atomicLoad(&usage[slot]);
                }
                atlas_here = atlas_origin(level, used_cell, entry[TABLE_CELL], origin);
                segment_out = t_out;
                brick_max = entry[TABLE_RANGE] >> 16u;
                marching = true;
            }
        }
        if marching {
            let ts = t_enter + (vec4<f32>(k + shift) + BATCH_OFFSETS) * step;
            let ts2 = t_enter + (vec4<f32>(k + shift + f32(BATCH)) + BATCH_OFFSETS) * step;
            let count_here = count_before(ts, segment_out) + count_before(ts2, segment_out);
            // A batch that reaches this brick's exit goes on into the next brick when that one
            // is read ahead, in the atlas and visible (its entry is here already), so a brick
            // boundary costs no short batch (the grid walk's, raycast.wgsl). (Nested ifs: only
            // a batch at the exit looks at the next entry.)
            var count = count_here;
            var atlas_next = atlas_here;
            if count_here < BATCH_PAIR && next_cell.x != NO_CELL {
                if marchable(next_entry, brick_key(k_level, next_cell), acc.running_max) {
                    let next_exits = brick_exits(k_level, next_cell, origin, safe_inverse(dir));
                    let next_out = min(min_component(next_exits), t_leave);
                    count = count_before(ts, next_out) + count_before(ts2, next_out);
                    atlas_next = atlas_origin(k_level, next_cell, next_entry[TABLE_CELL], origin);
                }
            }
            if count > 0u {
                let frame = SampleFrame(atlas_here, atlas_next, segment_out, atlas_dir,
                                        half_texel, light, t_enter);
                result.visited += march_pair(&acc, ts, ts2, count, frame, exponent,
                                             stream.level_scale[k_level].xyz);
                k += f32(count);
            }
            // The brick is done at its exit, or (MIP) once nothing further in it can raise the
            // maximum.
            let leaving = count_here < BATCH_PAIR || (mip && acc.running_max >= brick_max);
            if leaving || acc.done {
                mark_used(usage_slot & SLOT_MASK, usage_mark((usage_slot & USAGE_WANTED) != 0u),
                          usage_seen);
            }
            if leaving {
                if count_here == BATCH_PAIR {
                    k = max(ceil((segment_out - t_enter) / step - 0.5 - shift), k);
                }
                t = segment_out;
                marching = false;
                // The next brick read ahead, where it can be marched at once, is the next
                // segment (its level the ray's wanted one): a step of the grid walk, without
                // the segment's start.
                if !acc.done && next_cell.x != NO_CELL
                    && marchable(next_entry, brick_key(k_level, next_cell), acc.running_max) {
                    let cell = next_cell;
                    let exits = brick_exits(k_level, cell, origin, safe_inverse(dir));
                    segment_out = min(min_component(exits), t_leave);
                    atlas_here = atlas_origin(k_level, cell, next_entry[TABLE_CELL], origin);
                    brick_max = next_entry[TABLE_RANGE] >> 16u;
                    let slot = next_entry[TABLE_SLOT] & SLOT_MASK;
                    usage_slot = slot | USAGE_WANTED;
                    if !PROBE {
                        usage_seen = atomicLoad(&usage[slot]);
                    }
                    result.visited += 1u;
                    next_cell.x = NO_CELL;
                    if segment_out < t_leave && wanted_level(segment_out, lod_per_t) == k_level {
                        next_cell = next_brick(k_level, cell, exits, dir);
                        if next_cell.x != NO_CELL {
                            next_entry = home_entry(brick_key(k_level, next_cell));
                        }
                    }
                    marching = true;
                }
            }
        }
        if acc.done {
            break;
        }
    }
    result.color = final_color(acc);
    result.probe_t = acc.probe_t;
    return result;
}

// The entry of brick `cell` of `level`, a walked level (`level_cells`: the walked level's
// cells, then from `walk_next` the next coarser level's).
fn level_cell(level: u32, cell: vec3<u32>) -> vec4<u32> {
    let grid = stream.level_grid[level].xyz;
    let first = select(0u, stream.walk_next, level != stream.walk_level);
    return level_cells[first + cell.x + grid.x * (cell.y + grid.y * cell.z)];
}

// Whether a brick in the atlas whose entry is `entry` can change the pixel (marched).
fn resident_visible(entry: vec4<u32>, running_max: u32) -> bool {
    return (entry[TABLE_CELL] & ENTRY_RESIDENT) != 0u && entry_visible(entry, running_max);
}

// Whether the level walk can take a brick as it is: known and readable, and drawable (in the
// atlas, or uniform) or unable to change the pixel. Keep in sync with `walkable` in
// src/stream/page_table.rs, which counts the level's bricks that are not (at a running
// maximum of 0, where the most bricks are visible).
fn walkable(entry: vec4<u32>, running_max: u32) -> bool {
    return entry[TABLE_KEY] != EMPTY_KEY && (entry[TABLE_CELL] & ENTRY_FAILED) == 0u
        && (drawable(entry) || !entry_visible(entry, running_max));
}

// A ray through level `stream.walk_level`, whose entries `level_cells` holds flat: the grid
// walk of the bricks renderer (raycast.wgsl's `walk_bricks`) over that level's bricks, each
// entry read at its index a brick ahead, with none of `stream_ray`'s per-segment work (the
// hash, the requests, the fallback to coarser levels, the level each segment wants, the usage
// marks: the CPU marks every brick of the level used in a frame the walk drew). Its samples
// and segments are those `stream_ray` takes at that level (its segment ends, the short step's
// included), so the image is the same where every ray wants that level and every brick of it
// is walkable: src/render/stream.rs runs it only then. Should a ray still meet a brick it
// cannot take, it asks for the brick and ends there.
// With `two_levels` (`main_levels`), rays want the next coarser level from some distance on:
// the ray goes on in that level's bricks where `stream_ray` would (at the first brick exit
// where the footprint reaches that level's voxel, as `wanted_level` tests it), its samples
// from there that level's, as `stream_ray`'s next segment takes them.
fn level_walk(origin: vec3<f32>, dir: vec3<f32>, world_length: f32, jitter: f32,
              two_levels: bool) -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u, -1.0);
    let inv = safe_inverse(dir);
    let interval = volume_interval(origin, dir, inv);
    let t_enter = interval.x;
    let t_leave = interval.y;
    if t_enter >= t_leave {
        return result;
    }
    // Two levels: the footprint per unit of t (`stream_ray`'s), and the voxel of the coarser
    // level, which the ray goes on in once its footprint reaches it (from its start, where
    // it does there already).
    let lod_per_t = world_length * params.lod_factor * stream.lod_scale;
    var coarser_from = 0.0;
    var level = stream.walk_level;
    if two_levels {
        coarser_from = stream.level_scale[level + 1u].w;
        if coarser_from <= max(t_enter, 0.0) * lod_per_t {
            level += 1u;
        }
    }
    let mip = max_projection();
    let shift = jitter - 0.5;
    var scale = stream.level_scale[level].xyz;
    var step = 1.0 / max(length(dir / scale), 1e-20);
    let correct = (params.flags & FLAG_OPACITY_CORRECTION) != 0u;
    var exponent = select(1.0, step * length(dir), correct && any(scale != vec3<f32>(1.0)));
    var atlas_dir = dir / scale * params.atlas_texel.xyz;
    let light = headlight(dir);
    let half_texel = 0.5 * params.atlas_texel.xyz;
    var acc = new_accumulation();
    var visited = 0u;
    var t = t_enter;
    var k = 0.0;
    let ahead = max(1e-3 / max(length(dir), 1e-20), abs(t) * 5e-7);
    var cell = brick_of(level, origin + (t + ahead) * dir);
    var entry = level_cell(level, cell);
    // The brick being walked: where the ray leaves it, the next brick (NO_CELL: none) and its
    // entry.
    var t_out = t;
    var next = vec3<u32>(NO_CELL, 0u, 0u);
    var next_entry = vec4<u32>(EMPTY_KEY, 0u, 0u, 0u);
    // A brick being marched: its atlas origin and maximum (MIP), and its usage mark (below).
    var marching = false;
    var atlas_here = vec3<f32>(0.0);
    var brick_max = 0u;
    var mark_seen = 0u;
    // The ray came into `cell` from a brick it marched (`stream_ray`'s short step).
    var marched_in = false;
    // Two levels: the ray wants the coarser level from this brick's exit on.
    var to_coarser = false;
    var deciding = true;
    for (var i = 0u; i < MAX_STEPS; i++) {
        if deciding {
            deciding = false;
            let short = marched_in && resident_visible(entry, acc.running_max);
            if !short && !walkable(entry, acc.running_max) {
                request_brick(brick_key(level, cell));
                break;
            }
            let exits = brick_exits(level, cell, origin, inv);
            let t_exit = min(min_component(exits), t_leave);
            // (A segment's start moves the ray on at least a little: `stream_ray`'s.)
            let nudge = max(1e-3 / max(length(dir), 1e-20), abs(t) * 5e-7);
            t_out = select(max(t_exit, t + nudge), t_exit, short);
            visited += 1u;
            next.x = NO_CELL;
            // The next brick at this level, where the ray still wants it there.
            let stays = !two_levels || level != stream.walk_level
                || !(coarser_from <= t_out * lod_per_t);
            to_coarser = !stays && t_out < t_leave;
            if t_out < t_leave && stays {
                next = next_brick(level, cell, exits, dir);
                if next.x != NO_CELL {
                    next_entry = level_cell(level, next);
                }
            }
            marching = resident_visible(entry, acc.running_max);
            if marching {
                // The brick's usage mark, read and not used (the CPU marks the level): with
                // this read NVIDIA's driver (580) gives the entry point 80 registers, without
                // it 96, and frames took 7–10 % longer (run 126, docs/performance-log.md).
                if !PROBE {
                    mark_seen = atomicLoad(&usage[entry[TABLE_SLOT] & SLOT_MASK]);
                }
                atlas_here = atlas_origin(level, cell, entry[TABLE_CELL], origin);
                brick_max = entry[TABLE_RANGE] >> 16u;
            } else {
                // Unable to change the pixel, or uniform (drawn from its value).
                let end = max(ceil((t_out - t_enter) / step - 0.5 - shift), k);
                if entry_visible(entry, acc.running_max) {
                    accumulate_run(&acc, entry[TABLE_RANGE] & 0xffffu, end - k,
                                   t_enter + (k + 0.5 + shift) * step, step, exponent);
                }
                k = end;
            }
        }
        var leaving = !marching;
        if marching {
            let ts = t_enter + (vec4<f32>(k + shift) + BATCH_OFFSETS) * step;
            let ts2 = t_enter + (vec4<f32>(k + shift + f32(BATCH)) + BATCH_OFFSETS) * step;
            let count_here = count_before(ts, t_out) + count_before(ts2, t_out);
            var count = count_here;
            var atlas_next = atlas_here;
            if count_here < BATCH_PAIR && next.x != NO_CELL {
                if resident_visible(next_entry, acc.running_max) {
                    let next_out = min(min_component(brick_exits(level, next, origin, inv)),
                                       t_leave);
                    count = count_before(ts, next_out) + count_before(ts2, next_out);
                    atlas_next = atlas_origin(level, next, next_entry[TABLE_CELL], origin);
                }
            }
            if count > 0u {
                let frame = SampleFrame(atlas_here, atlas_next, t_out, atlas_dir, half_texel,
                                        light, t_enter);
                visited += march_pair(&acc, ts, ts2, count, frame, exponent, scale);
                k += f32(count);
            }
            leaving = count_here < BATCH_PAIR || (mip && acc.running_max >= brick_max);
            if leaving && count_here == BATCH_PAIR {
                k = max(ceil((t_out - t_enter) / step - 0.5 - shift), k);
            }
        }
        if acc.done {
            break;
        }
        if leaving {
            marched_in = marching;
            marching = false;
            t = t_out;
            if next.x != NO_CELL {
                cell = next;
                entry = next_entry;
                deciding = true;
            } else if to_coarser {
                // On in the coarser level, as `stream_ray`'s next segment: its brick at the
                // ray's point, its samples' step, and the index of the first at or after t.
                level += 1u;
                scale = stream.level_scale[level].xyz;
                step = 1.0 / max(length(dir / scale), 1e-20);
                exponent = select(1.0, step * length(dir),
                                  correct && any(scale != vec3<f32>(1.0)));
                atlas_dir = dir / scale * params.atlas_texel.xyz;
                k = max(ceil((t - t_enter) / step - 0.5 - shift), 0.0);
                let ahead_here = max(1e-3 / max(length(dir), 1e-20), abs(t) * 5e-7);
                cell = brick_of(level, origin + (t + ahead_here) * dir);
                entry = level_cell(level, cell);
                marched_in = false;
                to_coarser = false;
                deciding = true;
            } else {
                break;
            }
        }
    }
    result.color = final_color(acc);
    result.visited = visited;
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
    let result = stream_ray(params.eye.xyz, ray.dir, ray.world_length, ray_jitter(pixel));
    if PROBE {
        write_probe(params.eye.xyz, ray.dir, result.probe_t);
    } else {
        write_pixel(pixel, result.color, result.visited);
    }
}

// The level walk's pixel `xy` (`main_level`, `main_levels`).
fn walk_pixel(xy: vec2<u32>, two_levels: bool) {
    let pixel = ray_pixel(xy);
    if pixel.x >= params.image_size.x || pixel.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(pixel);
    let result = level_walk(params.eye.xyz, ray.dir, ray.world_length, ray_jitter(pixel),
                            two_levels);
    write_pixel(pixel, result.color, result.visited);
}

// Frames whose rays all want one level that the page table copies flat, every brick of it
// walkable (src/render/stream.rs decides): each ray walks that level (`level_walk`). Its own
// pipeline, so that neither entry point carries the other's code (runs 103–107,
// docs/performance-log.md: carrying the segment loop behind the walk cost what the walk saved).
// Frames only: a probe takes `main`.
@compute @workgroup_size(8, 8, 1)
fn main_level(@builtin(global_invocation_id) id: vec3<u32>) {
    walk_pixel(id.xy, false);
}

// Frames whose rays all want one level up to some distance and the next coarser one beyond
// (each ray its own distance), the page table copying both flat, every brick of them walkable:
// each ray walks the one level, then the other (`level_walk`'s `two_levels`). Its own
// pipeline, so that `main_level` carries none of the switch.
@compute @workgroup_size(8, 8, 1)
fn main_levels(@builtin(global_invocation_id) id: vec3<u32>) {
    walk_pixel(id.xy, true);
}
