// What the streaming renderer's shaders share (stream.wgsl, one channel; stream_composite.wgsl,
// several): the page table's layout and lookup, requests and usage marks, the pyramid's bricks
// and levels, and the atlas's samples. Prepended with ray_common.wgsl, before either.

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
    channel_count: u32,     // channels streamed together (1: stream.wgsl's one)
    shown_channels: u32,    // bit c: channel c is drawn (stream_composite.wgsl)
    _pad2: u32,
    channel_shading: array<vec4<f32>, 2>, // [c / 4][c % 4]: channel c's 1 / full-shading gradient
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

// The key of brick `cell` of `level` of channel `channel` (the level's bricks of channel c
// follow those of channels 0…c−1; `PyramidShape::key` in src/stream/pyramid.rs).
fn channel_key(level: u32, cell: vec3<u32>, channel: u32) -> u32 {
    let grid = stream.level_grid[level].xyz;
    return brick_key(level, cell) + channel * grid.x * grid.y * grid.z;
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
