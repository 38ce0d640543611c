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
// first visible label (`first_label`). Prepended with ray_common.wgsl.

// Keep in sync with `StreamParams` in src/render/gpu_data.rs.
struct StreamParams {
    level_grid: array<vec4<u32>, 16>,  // per level: bricks along x, y, z
    level_scale: array<vec4<f32>, 16>, // per level: xyz its voxel in level-0 voxels; w their minimum
    level_count: u32,
    finest_level: u32,      // the level of the max-level slider (depth − max level)
    frame: u32,             // what rays mark the slots they use with
    table_mask: u32,        // page table entries − 1 (a power of two)
    request_capacity: u32,  // keys the request buffer holds
    request_set_mask: u32,  // entries of its deduplicating set − 1
    lod_scale: f32,         // footprint multiplier (0: no pixel LOD)
    walk_level: u32,        // the level `level_cells` copies (main_level)
    walk_next: u32,         // where the next coarser level's cells begin there (main_levels)
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> stream: StreamParams;
@group(0) @binding(2) var<storage, read> lookup_table: array<u32>;
@group(0) @binding(3) var output: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(4) var<storage, read_write> visits: array<u32>;
@group(0) @binding(5) var atlas: texture_3d<f32>;
@group(0) @binding(6) var atlas_sampler: sampler;
// The page table: TABLE_* components of each entry (src/stream/page_table.rs's TableEntry).
// Its ENTRY_VISIBLE bits follow the transfer function (the CPU rewrites them on an edit).
@group(0) @binding(7) var<storage, read> page_table: array<vec4<u32>>;
// [0]: requests made; [1, 1 + capacity): their keys; then the deduplicating set (key + 1 per
// entry, 0 when free), cleared by the CPU before each frame.
@group(0) @binding(8) var<storage, read_write> requests: array<atomic<u32>>;
// Per atlas slot: the last frame a ray used it, as 2·frame + 1 where a ray wanted its level,
// 2·frame where it stood in for a missing finer brick (the LRU's marks; `mark_used`).
@group(0) @binding(9) var<storage, read_write> usage: array<atomic<u32>>;
// What a PROBE pipeline found (ray_common.wgsl).
@group(0) @binding(10) var<storage, read_write> probe_out: ProbeResult;
// The page table's entries of level `stream.walk_level`, brick by brick (x fastest: a key's
// low bits), EMPTY_KEY where the table has none (src/stream/page_table.rs's level copy), then
// from `stream.walk_next` (where it is above 0) the next coarser level's. Read by `level_walk`
// only.
@group(0) @binding(11) var<storage, read> level_cells: array<vec4<u32>>;

// Keep in sync with src/stream (page_table.rs, pyramid.rs, source.rs).
const MAX_PROBES: u32 = 32u;
const ENTRY_RESIDENT: u32 = 0x80000000u;
const ENTRY_FAILED: u32 = 0x40000000u;
const ENTRY_VISIBLE: u32 = 0x80000000u; // in TABLE_SLOT
const SLOT_MASK: u32 = 0x3fffffffu;
const EMPTY_KEY: u32 = 0xffffffffu;
const KEY_LEVEL_SHIFT: u32 = 28u;
const BRICK: f32 = 32.0;
const TABLE_KEY = 0;
const TABLE_CELL = 1;
const TABLE_RANGE = 2;
const TABLE_SLOT = 3;
const MAX_STEPS: u32 = 1000000u;

// Keep in sync with `table_hash` in src/stream/page_table.rs.
fn table_hash(key: u32) -> u32 {
    let h = key * 0x9E3779B1u;
    return h ^ (h >> 16u);
}

// The entry at `key`'s home slot: `key`'s own where the table holds it there (most keys, at a
// load of at most a quarter), else another. The read ahead of the next brick takes this one
// read and leaves a miss to `table_lookup`.
fn home_entry(key: u32) -> vec4<u32> {
    return page_table[table_hash(key) & stream.table_mask];
}

// The entry of `key`, or one whose key differs (not in the table): linear probing from its
// hash until the key or an empty entry.
fn table_lookup(key: u32) -> vec4<u32> {
    let home = table_hash(key);
    for (var probe = 0u; probe < MAX_PROBES; probe++) {
        let entry = page_table[(home + probe) & stream.table_mask];
        if entry[TABLE_KEY] == key || entry[TABLE_KEY] == EMPTY_KEY {
            return entry;
        }
    }
    return vec4<u32>(EMPTY_KEY, 0u, 0u, 0u);
}

// Asks the CPU for brick `key`: appended once per entry of the set it hashes to (a collision
// may append a key twice; the CPU deduplicates).
fn request_brick(key: u32) {
    if PROBE {
        return;
    }
    let set_index = 1u + stream.request_capacity + (table_hash(key) & stream.request_set_mask);
    let tag = key + 1u;
    if atomicLoad(&requests[set_index]) == tag {
        return;
    }
    if atomicExchange(&requests[set_index], tag) != tag {
        let index = atomicAdd(&requests[0], 1u);
        if index < stream.request_capacity {
            atomicStore(&requests[1u + index], key);
        }
    }
}

// This frame's usage mark of a slot: 2·frame + 1 if the ray wanted its level, 2·frame as a
// stand-in for a missing finer brick (which the CPU may evict it for: src/stream/slots.rs).
fn usage_mark(wanted: bool) -> u32 {
    return 2u * stream.frame + select(0u, 1u, wanted);
}

// Marks `slot` with `mark` unless `seen` (its value read when the segment began, so that the
// read's latency hid behind the segment's samples) is as large: the larger mark wins, and most
// rays find it set already and write nothing.
fn mark_used(slot: u32, mark: u32, seen: u32) {
    if !PROBE && seen < mark {
        atomicMax(&usage[slot], mark);
    }
}

// The brick of `level` holding level-0 point `p` (clamped into the level's grid).
fn brick_of(level: u32, p: vec3<f32>) -> vec3<u32> {
    let side = BRICK * stream.level_scale[level].xyz;
    let cell = vec3<u32>(max(floor(p / side), vec3<f32>(0.0)));
    return min(cell, stream.level_grid[level].xyz - 1u);
}

fn brick_key(level: u32, cell: vec3<u32>) -> u32 {
    let grid = stream.level_grid[level].xyz;
    return (level << KEY_LEVEL_SHIFT) | (cell.x + grid.x * (cell.y + grid.y * cell.z));
}

// Whether a table entry can be drawn: in the atlas, or uniform (drawn from its value).
fn drawable(entry: vec4<u32>) -> bool {
    let range = entry[TABLE_RANGE];
    return (entry[TABLE_CELL] & ENTRY_RESIDENT) != 0u
        || ((entry[TABLE_CELL] & ENTRY_FAILED) == 0u && (range & 0xffffu) == (range >> 16u));
}

// Whether a brick can change the pixel: DVR (and a first label), some value level of its range
// is visible (the entry's bit); MIP, its maximum is above the ray's so far.
fn entry_visible(entry: vec4<u32>, running_max: u32) -> bool {
    if max_projection() {
        return (entry[TABLE_RANGE] >> 16u) > running_max;
    }
    return (entry[TABLE_SLOT] & ENTRY_VISIBLE) != 0u;
}

// The level a segment starting at distance `t` wants: the coarsest whose voxel is no larger
// than the pixel's footprint there (`lod_per_t` · t level-0 voxels), never finer than the
// slider's.
fn wanted_level(t: f32, lod_per_t: f32) -> u32 {
    let footprint = t * lod_per_t;
    var level = stream.finest_level;
    loop {
        if level + 1u >= stream.level_count || stream.level_scale[level + 1u].w > footprint {
            break;
        }
        level += 1u;
    }
    return level;
}

// The value level at normalized atlas coordinates, trilinear (nearest for labels: the sampler).
fn atlas_level_at(coords: vec3<f32>) -> u32 {
    return value_index(textureSampleLevel(atlas, atlas_sampler, coords, 0.0).r);
}

// The label at normalized atlas coordinates (`label_entry`, ray_common.wgsl).
fn label_level_at(coords: vec3<f32>) -> u32 {
    return atlas_level_at(coords);
}

// The gradient of the filtered levels at normalized atlas coordinates (raycast.wgsl's): levels
// per voxel of the level marched.
fn level_gradient(coords: vec3<f32>, half_texel: vec3<f32>) -> vec3<f32> {
    let dx = vec3<f32>(half_texel.x, 0.0, 0.0);
    let dy = vec3<f32>(0.0, half_texel.y, 0.0);
    let dz = vec3<f32>(0.0, 0.0, half_texel.z);
    let high = vec3<f32>(textureSampleLevel(atlas, atlas_sampler, coords + dx, 0.0).r,
                         textureSampleLevel(atlas, atlas_sampler, coords + dy, 0.0).r,
                         textureSampleLevel(atlas, atlas_sampler, coords + dz, 0.0).r);
    let low = vec3<f32>(textureSampleLevel(atlas, atlas_sampler, coords - dx, 0.0).r,
                        textureSampleLevel(atlas, atlas_sampler, coords - dy, 0.0).r,
                        textureSampleLevel(atlas, atlas_sampler, coords - dz, 0.0).r);
    return (high - low) * params.atlas_scale;
}

// A sample's opacity for a step of `exponent` level-0 voxels (opacity correction; 1 leaves it).
fn step_alpha(alpha: f32, exponent: f32) -> f32 {
    let a = min(alpha * params.density, 1.0);
    if exponent != 1.0 && a > 0.0 && a < 1.0 {
        return 1.0 - pow(1.0 - a, exponent);
    }
    return a;
}

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

struct RayResult {
    color: vec3<f32>,
    visited: u32,
    probe_t: f32,
}

// The usage mark's kind, kept in the top bit of the marched slot (above SLOT_MASK): the ray
// wanted the slot's level there (`usage_mark`).
const USAGE_WANTED: u32 = 0x80000000u;
// `next_cell.x` while no brick is read ahead.
const NO_CELL: u32 = 0xffffffffu;

// The distances where a ray (`origin`, `inv` = 1 / its direction) leaves brick `cell` of
// `level` across each axis' planes.
fn brick_exits(level: u32, cell: vec3<u32>, origin: vec3<f32>, inv: vec3<f32>) -> vec3<f32> {
    let side = BRICK * stream.level_scale[level].xyz;
    let far = (vec3<f32>(cell) + select(vec3<f32>(0.0), vec3<f32>(1.0), inv >= vec3<f32>(0.0)))
        * side;
    return (far - origin) * inv;
}

// The brick after `cell` of `level` along a ray of direction `dir` that leaves it across the
// nearest of the planes at `exits`; NO_CELL in x where that is outside the level's grid.
fn next_brick(level: u32, cell: vec3<u32>, exits: vec3<f32>, dir: vec3<f32>) -> vec3<u32> {
    var axis = 2u;
    if exits.x <= exits.y && exits.x <= exits.z {
        axis = 0u;
    } else if exits.y <= exits.z {
        axis = 1u;
    }
    var next = vec3<i32>(cell);
    next[axis] += select(-1, 1, dir[axis] >= 0.0);
    if all(next >= vec3<i32>(0)) && all(next < vec3<i32>(stream.level_grid[level].xyz)) {
        return vec3<u32>(next);
    }
    return vec3<u32>(NO_CELL, 0u, 0u);
}

// The ray's origin (level-0 voxels) in the normalized atlas coordinates of brick `cell` of
// `level`, whose atlas cell is packed in `packed` (TABLE_CELL): origin + t·atlas_dir is then
// the atlas place of the ray's point at t in that brick.
fn atlas_origin(level: u32, cell: vec3<u32>, packed: u32, origin: vec3<f32>) -> vec3<f32> {
    let atlas_cell = vec3<u32>(packed & 0x3ffu, (packed >> 10u) & 0x3ffu, (packed >> 20u) & 0x3ffu);
    let offset = vec3<f32>(atlas_cell * 34u) + 1.0 - vec3<f32>(cell) * BRICK;
    return (origin / stream.level_scale[level].xyz + offset) * params.atlas_texel.xyz;
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
