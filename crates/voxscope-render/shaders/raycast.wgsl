// The octree ray caster: one invocation per pixel, front-to-back through the flat node list.
//
// Space: "voxel space", where voxel (x, y, z) is the unit cube [x, x+1)×[y, y+1)×[z, z+1) and
// the padded octree cube is [0, side]³. The camera's vectors arrive already in that space, so
// anisotropic spacing needs no work here, and a segment's length in voxels is `dt * |dir|`.
//
// Traversal: a short stack holds the path from the root to the current node, with each node's
// box corner and exit distance; the current node's own entry is also held in registers. After a
// node is composited or skipped, the ray's `t` moves to its exit; finished nodes are popped, and
// the descent continues from the deepest ancestor still containing the ray: the next sibling or
// an ancestor's sibling, never the root again.
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
// The bricks renderer's grid of brick cells (`GridCell`, grid_cell.wgsl), read and kept as
// vectors whose components the CELL_* constants there name: `cell[CELL_BOUNDS]`. As GridCell
// values (read from an array<GridCell>, or built from the vector at the read or at each use) the
// grid walk ran 1–5 % slower on an H200 with driver 580, the driver's code 128–900 bytes longer
// (runs 40–42: docs/performance-log.md, attempt 25).
@group(0) @binding(8) var<storage, read> brick_grid: array<vec4<u32>>;
// What a PROBE pipeline found (ray_common.wgsl).
@group(0) @binding(9) var<storage, read_write> probe_out: ProbeResult;

// A node's corner: integer voxel coordinates below the octree side (≤ 1024, MAX_DEPTH 10),
// ten bits each.
fn pack_corner(corner: vec3<f32>) -> u32 {
    let c = vec3<u32>(corner);
    return c.x | (c.y << 10u) | (c.z << 20u);
}

fn unpack_corner(packed: u32) -> vec3<f32> {
    return vec3<f32>(vec3<u32>(packed & 0x3ffu, (packed >> 10u) & 0x3ffu, packed >> 20u));
}

// Invocations per workgroup (`@workgroup_size` below; 8×8, src/render/pipeline.rs).
const WORKGROUP: u32 = 64u;

// The traversal stack in workgroup memory, level-major: entry [level][lane] of invocation
// `lane`, so the 32 lanes of a warp always fall in distinct banks whatever their levels.
// Node index, packed corner, exit distance.
var<workgroup> stack_node: array<array<u32, WORKGROUP>, STACK_SIZE>;
var<workgroup> stack_corner: array<array<u32, WORKGROUP>, STACK_SIZE>;
var<workgroup> stack_exit: array<array<f32, WORKGROUP>, STACK_SIZE>;

struct RayResult {
    color: vec3<f32>,
    visited: u32,
    // PROBE: where the ray reached what it probes (`Accumulation.probe_t`).
    probe_t: f32,
}


// Marches a brick from `t` to `t_out` in the atlas with the sampler's filtering (trilinear, or
// nearest for labels), at the dense renderer's sample distances t_first + (k + ½)·step
// (`t_first`: the ray's entry moved by its pixel's jitter, `ray_jitter`). `to_atlas` maps a
// voxel-space point of this brick to its atlas texel (`brick_to_atlas`). Returns the samples
// taken.
// (Unlike the grid walk, this keeps the per-sample offset: the tree walk's entry point is
// shared with the plain octree, which ran 2–5 % slower with the grid walk's form, runs 34–35.)
fn march_brick(acc: ptr<function, Accumulation>, origin: vec3<f32>, dir: vec3<f32>, t_first: f32,
               sample_step: f32, t: f32, t_out: f32, to_atlas: vec3<f32>) -> u32 {
    var taken = 0u;
    var k = max(ceil((t - t_first) / sample_step - 0.5), 0.0);
    let texel = params.atlas_texel.xyz;
    let here = (origin + to_atlas) * texel;
    // (For labels, whose jitter is ½, `t_first` is the ray's entry.)
    let frame = SampleFrame(here, here, 3.4e38, dir * texel, 0.5 * sample_voxels() * texel,
                            headlight(dir), t_first);
    loop {
        let ts = t_first + (vec4<f32>(k) + BATCH_OFFSETS) * sample_step;
        let count = count_before(ts, t_out);
        if count == 0u {
            break;
        }
        let batch_levels = vec4<u32>(
            atlas_level(origin + ts.x * dir + to_atlas),
            atlas_level(origin + ts.y * dir + to_atlas),
            atlas_level(origin + ts.z * dir + to_atlas),
            atlas_level(origin + ts.w * dir + to_atlas),
        );
        taken += accumulate(acc, batch_levels, count, ts, frame);
        if (*acc).done || count < BATCH {
            break;
        }
        k += f32(BATCH);
    }
    return taken;
}

// Four samples of the grid walk at distances `ts`: those before `t_out` in the current brick,
// the others in the next one. `atlas_here` and `atlas_next` are the ray's origin in each
// brick's normalized atlas coordinates (`atlas_origin`), `atlas_dir` its direction there: one
// multiply-add per coordinate and sample.
fn brick_batch(atlas_dir: vec3<f32>, ts: vec4<f32>, t_out: f32, atlas_here: vec3<f32>,
               atlas_next: vec3<f32>) -> vec4<u32> {
    let here = ts < vec4<f32>(t_out);
    return vec4<u32>(
        atlas_level_at(select(atlas_next, atlas_here, here.x) + ts.x * atlas_dir),
        atlas_level_at(select(atlas_next, atlas_here, here.y) + ts.y * atlas_dir),
        atlas_level_at(select(atlas_next, atlas_here, here.z) + ts.z * atlas_dir),
        atlas_level_at(select(atlas_next, atlas_here, here.w) + ts.w * atlas_dir),
    );
}

// The value level at normalized atlas coordinates, trilinear (nearest for labels: the sampler).
fn atlas_level_at(coords: vec3<f32>) -> u32 {
    return value_index(textureSampleLevel(atlas, atlas_sampler, coords, 0.0).r);
}

// The label at normalized atlas coordinates (`label_entry`, ray_common.wgsl).
fn label_level_at(coords: vec3<f32>) -> u32 {
    return atlas_level_at(coords);
}

// The gradient of the filtered value levels at normalized atlas coordinates `coords` (a sample
// inside its brick), central differences `half_texel` (half a voxel of the level sampled) either
// side: levels per level-0 voxel, voxel space. Half a voxel, not one: the one-voxel apron makes the atlas equal the
// volume's own trilinear values up to half a voxel past the brick's faces (the apron's texel
// centers), and a whole voxel out would blend in the next slot's brick.
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
    return (high - low) * (params.atlas_scale / sample_voxels());
}

// The value level at an atlas texel position (a voxel-space point plus its brick's `to_atlas`).
fn atlas_level(texel: vec3<f32>) -> u32 {
    return atlas_level_at(texel * params.atlas_texel.xyz);
}

// A ray's origin in the normalized atlas coordinates of the brick with atlas cell `atlas_cell`
// and first voxel `corner`: origin + t·atlas_dir is then the atlas place of voxel-space point
// origin + t·dir of that brick.
fn atlas_origin(origin: vec3<f32>, atlas_cell: u32, corner: vec3<f32>) -> vec3<f32> {
    return (origin + brick_to_atlas(atlas_cell, corner)) * params.atlas_texel.xyz;
}

// The offset from voxel space to atlas texels of the brick whose first voxel is `corner` and
// whose atlas cell is packed in `atlas_cell` (ten bits per axis): (p + offset) · atlas_texel is
// the normalized atlas place of voxel-space point p. COARSE: the texture bound is a whole
// pyramid level (`atlas_texel` = 1 / (its texels × sample_voxels)), the same for every brick.
fn brick_to_atlas(atlas_cell: u32, corner: vec3<f32>) -> vec3<f32> {
    if COARSE {
        return vec3<f32>(0.0);
    }
    let cell = vec3<u32>(atlas_cell & 0x3ffu, (atlas_cell >> 10u) & 0x3ffu, atlas_cell >> 20u);
    return vec3<f32>(cell * (params.brick_size + 2u)) + 1.0 - corner;
}

// A brick slot's atlas cell, packed as `brick_to_atlas` reads it.
fn atlas_cell_of_slot(slot: u32) -> u32 {
    let grid = params.atlas_grid.xyz;
    return (slot % grid.x) | (((slot / grid.x) % grid.y) << 10u) | ((slot / (grid.x * grid.y)) << 20u);
}

// A ray clipped to the volume's box (not the padded cube): 1 / dir, whether it runs towards +
// along each axis, and the distances where it enters (clamped to the eye) and leaves.
struct ClippedRay {
    inv: vec3<f32>,
    positive: vec3<bool>,
    t_enter: f32,
    t_leave: f32,
}

fn clip_ray(origin: vec3<f32>, dir: vec3<f32>) -> ClippedRay {
    let inv = safe_inverse(dir);
    let interval = volume_interval(origin, dir, inv);
    return ClippedRay(inv, inv >= vec3<f32>(0.0), interval.x, interval.y);
}

fn trace_ray(origin: vec3<f32>, dir: vec3<f32>, world_length: f32, lane: u32,
             jitter: f32) -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u, -1.0);
    let ray = clip_ray(origin, dir);
    if ray.t_enter >= ray.t_leave {
        return result;
    }

    let side = params.volume.w;
    let voxels_per_t = length(dir);
    let lod_per_t = world_length * params.lod_factor;
    let use_lod = (params.flags & FLAG_PIXEL_LOD) != 0u;
    let correct_opacity = (params.flags & FLAG_OPACITY_CORRECTION) != 0u;
    // (A first label is found as DVR finds its first visible node.)
    let mip = max_projection();
    let probe_step = 1e-3 / max(voxels_per_t, 1e-20);
    // Bricks are sampled once per voxel of path (of the level sampled), at the same places as
    // the dense renderer.
    let sample_step = sample_voxels() / max(voxels_per_t, 1e-20);
    let t_first = ray.t_enter + (jitter - 0.5) * sample_step;

    // The path from the root; entry `level` is the current node, also kept in registers
    // (`node_index`, `corner`, `t_out`) so that a descent step waits on one node read alone.
    // Three words a level, the corner packed, in this invocation's slice of workgroup memory:
    // stack traffic, more than node reads, bounds this loop (docs/performance-log.md,
    // attempts 8–12).
    var node_index = 0u;
    var corner = vec3<f32>(0.0);
    let root_exits = (select(vec3<f32>(0.0), vec3<f32>(side), ray.positive) - origin) * ray.inv;
    var t_out = min(min_component(root_exits), ray.t_leave);
    stack_node[0][lane] = node_index;
    stack_corner[0][lane] = 0u;
    stack_exit[0][lane] = t_out;
    var level = 0u;
    var t = ray.t_enter;

    var acc = new_accumulation();
    // SHADING: the value level of the node the ray was in before the current one (negative
    // until the first), for the step across the face it enters by; and the headlight.
    var previous_level = -1.0;
    let light = headlight(dir);

    for (var step = 0u; step < MAX_STEPS; step++) {
        let probe = t + max(probe_step, abs(t) * 5e-7);
        // Pop the nodes the ray has left, back to the deepest one still ahead.
        if t_out <= probe {
            while level > 0u && stack_exit[level - 1u][lane] <= probe {
                level -= 1u;
            }
            if level == 0u {
                break; // left the root: done
            }
            level -= 1u;
            node_index = stack_node[level][lane];
            corner = unpack_corner(stack_corner[level][lane]);
            t_out = stack_exit[level][lane];
        }
        // Descend from the deepest node still ahead until a node is composited or skipped.
        loop {
            let size = side / f32(1u << level);
            let node = nodes[node_index];
            var node_bounds = 0u;
            if mip || SHADING {
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
                if SHADING {
                    previous_level = node_level(node_bounds, previous_level);
                }
                t = max(t_out, probe);
                break;
            }
            let cut = node.first_child == LEAF || level >= params.max_level
                || (use_lod && size <= t * lod_per_t);
            if !cut && level == params.brick_level && (node.first_child & BRICK_FLAG) != 0u {
                let to_atlas = brick_to_atlas(atlas_cell_of_slot(node.first_child & ~BRICK_FLAG), corner);
                result.visited += march_brick(&acc, origin, dir, t_first, sample_step, t, t_out,
                                              to_atlas);
                if SHADING {
                    previous_level = node_level(node_bounds, previous_level);
                }
                t = max(t_out, probe);
                break;
            }
            if cut {
                if mip {
                    if PROBE && (node_bounds >> 16u) > acc.running_max {
                        // The middle of the ray's path through the node: inside it.
                        acc.probe_t = 0.5 * (t + t_out);
                    }
                    acc.running_max = max(acc.running_max, node_bounds >> 16u);
                } else if first_label() {
                    // A visible node (skipping passed it): its color, the pixel's. At the
                    // voxels it is the voxel's label; above, the one its children show most.
                    acc.color = unpack4x8unorm(node.color).rgb;
                    acc.alpha = 1.0;
                    if PROBE {
                        acc.probe_t = min(t + probe_step, t_out);
                    }
                } else {
                    let rgba = unpack4x8unorm(node.color);
                    let node_alpha = min(rgba.a * params.density, 1.0);
                    var a = node_alpha;
                    if correct_opacity && a < 1.0 {
                        a = 1.0 - pow(1.0 - a, max(t_out - t, 0.0) * voxels_per_t);
                    }
                    var rgb = rgba.rgb;
                    if SHADING {
                        let level_here = node_level(node_bounds, previous_level);
                        var level_step = abs(level_here - select(previous_level, level_here,
                                                                 previous_level < 0.0));
                        // Labels: any other label across the face is a surface, lit fully
                        // (their values' differences mean nothing).
                        if labels() && level_step > 0.0 {
                            level_step = 1e30;
                        }
                        rgb = shade_face(rgb, corner, size, origin, ray, light, level_step);
                        previous_level = level_here;
                    }
                    let alpha_before = acc.alpha;
                    acc.color += (1.0 - acc.alpha) * a * rgb;
                    acc.alpha += (1.0 - acc.alpha) * a;
                    if PROBE && acc.probe_t < 0.0 && acc.alpha >= PROBE_ALPHA {
                        acc.probe_t = crossing_in_node(alpha_before, node_alpha,
                                                       correct_opacity, voxels_per_t, t, t_out,
                                                       probe_step);
                    }
                }
                t = max(t_out, probe);
                break;
            }
            // The child containing the probe point: per axis, which side of the mid-plane.
            let half = size * 0.5;
            let t_mid = (corner + vec3<f32>(half) - origin) * ray.inv;
            let upper = select(vec3<bool>(probe < t_mid.x, probe < t_mid.y, probe < t_mid.z),
                               vec3<bool>(probe >= t_mid.x, probe >= t_mid.y, probe >= t_mid.z),
                               ray.positive);
            corner += select(vec3<f32>(0.0), vec3<f32>(half), upper);
            let exit_planes = corner + select(vec3<f32>(0.0), vec3<f32>(half), ray.positive);
            t_out = min(min_component((exit_planes - origin) * ray.inv), t_out);
            node_index = node.first_child + select(0u, 1u, upper.x) + select(0u, 2u, upper.y)
                + select(0u, 4u, upper.z);
            level += 1u;
            stack_node[level][lane] = node_index;
            stack_corner[level][lane] = pack_corner(corner);
            stack_exit[level][lane] = t_out;
        }
        if acc.alpha >= EARLY_TERMINATION_ALPHA || (mip && acc.running_max >= params.mip_saturation)
            || t >= ray.t_leave {
            break;
        }
    }
    result.color = final_color(acc);
    result.probe_t = acc.probe_t;
    return result;
}

// A node's value level for the shading step across faces: the middle of its value bounds (a
// voxel's own level); `otherwise` where it has none (padding).
fn node_level(node_bounds: u32, otherwise: f32) -> f32 {
    let low = node_bounds & 0xffffu;
    let high = node_bounds >> 16u;
    return select(0.5 * (f32(low) + f32(high)), otherwise, low > high);
}

// The octree's shading (SHADING): the normal is the face of the node (box `corner`, `size`) the
// ray enters by, the axis of its latest entry plane; the weight is the step of value levels
// across that face, `level_step`, per voxel of that axis in transfer-window widths per voxel of
// the smallest spacing (docs/octree.md, "Shading").
fn shade_face(rgb: vec3<f32>, corner: vec3<f32>, size: f32, origin: vec3<f32>, ray: ClippedRay,
              light: vec3<f32>, level_step: f32) -> vec3<f32> {
    let near = (corner + select(vec3<f32>(size), vec3<f32>(0.0), ray.positive) - origin) * ray.inv;
    let latest = max_component(near);
    var face = vec3<f32>(0.0, 0.0, 1.0);
    if near.x >= latest {
        face = vec3<f32>(1.0, 0.0, 0.0);
    } else if near.y >= latest {
        face = vec3<f32>(0.0, 1.0, 0.0);
    }
    let scale = params.shading_scale;
    let cosine = min(abs(dot(light / scale.xyz, face)), 1.0);
    let weight = min(level_step * dot(scale.xyz, face) * scale.w, 1.0);
    return shade_with(rgb, cosine, weight);
}

// PROBE: where in a node composited over [t, t_out] the ray's alpha reached PROBE_ALPHA, having
// been `alpha_before` on entering it; with opacity correction alpha grows continuously through
// the node, `1 − (1 − alpha_before)(1 − a)^(voxels)`, else all at once at its face. At least
// `nudge` (a thousandth of a voxel) inside, so the point's voxel is the node's.
fn crossing_in_node(alpha_before: f32, node_alpha: f32, correct_opacity: bool, voxels_per_t: f32,
                    t: f32, t_out: f32, nudge: f32) -> f32 {
    var t_cross = t;
    if correct_opacity && node_alpha < 1.0 {
        let voxels = log((1.0 - PROBE_ALPHA) / (1.0 - alpha_before)) / log(1.0 - node_alpha);
        t_cross = t + max(voxels, 0.0) / voxels_per_t;
    }
    return min(max(t_cross, t + nudge), t_out);
}

// A brick cell of the walk and the way out of it: where the ray leaves it, and the cell across
// that exit (Amanatides & Woo: the nearest of the three exit planes).
struct WalkCell {
    cell: vec3<i32>,
    // Ray distances to the cell's exit plane along each axis.
    exits: vec3<f32>,
    // Where the ray leaves the cell (or the volume).
    t_out: f32,
    next: vec3<i32>,
    next_exits: vec3<f32>,
    // The ray ends in this cell.
    last: bool,
}

fn walk_cell(cell: vec3<i32>, exits: vec3<f32>, t_leave: f32, step: vec3<i32>,
             cell_span: vec3<f32>) -> WalkCell {
    var axis = vec3<bool>(false, false, true);
    if exits.x <= exits.y && exits.x <= exits.z {
        axis = vec3<bool>(true, false, false);
    } else if exits.y <= exits.z {
        axis = vec3<bool>(false, true, false);
    }
    let next = cell + select(vec3<i32>(0), step, axis);
    let t_out = min(min_component(exits), t_leave);
    let grid = vec3<i32>(params.brick_grid.xyz);
    let last = t_out >= t_leave || any(next < vec3<i32>(0)) || any(next >= grid);
    return WalkCell(cell, exits, t_out, next, exits + select(vec3<f32>(0.0), cell_span, axis), last);
}

// The bricks renderer at full detail: instead of popping and descending the tree at every
// brick, the ray walks the grid of brick cells (Amanatides & Woo at brick resolution). Each cell
// costs one 16-byte read, issued a cell ahead so that it overlaps the marching of the current
// cell; a cell whose node is transparent (DVR) or cannot raise the maximum (MIP) is skipped.
// One flat loop, two batches of samples per iteration (moving to the next cell first when the
// last iteration reached the current one's exit): the lanes of a warp leave their cells at different
// samples, and nested cell and sample loops would make each wait for the others at every cell.
// The samples are the dense renderer's (t_enter + (k + ½)·step), as in `march_brick`.
fn walk_bricks(origin: vec3<f32>, dir: vec3<f32>, jitter: f32) -> RayResult {
    var result = RayResult(vec3<f32>(0.0), 0u, -1.0);
    let ray = clip_ray(origin, dir);
    if ray.t_enter >= ray.t_leave {
        return result;
    }
    let mip = max_projection();
    let sample_step = sample_voxels() / max(length(dir), 1e-20);
    // Sample k at t_first + (k + ½)·step: `jitter` of a step past the entry.
    let t_first = ray.t_enter + (jitter - 0.5) * sample_step;
    let brick = f32(params.brick_size);
    let grid = vec3<i32>(params.brick_grid.xyz);
    let step = select(vec3<i32>(-1), vec3<i32>(1), ray.positive);
    let cell_span = brick * abs(ray.inv);

    let first = clamp(vec3<i32>(floor((origin + ray.t_enter * dir) / brick)), vec3<i32>(0), grid - 1);
    let first_far_corner = vec3<f32>(first) * brick + select(vec3<f32>(0.0), vec3<f32>(brick), ray.positive);
    let first_exits = (first_far_corner - origin) * ray.inv;
    var here = walk_cell(first, first_exits, ray.t_leave, step, cell_span);
    var entry = brick_grid[grid_index(here.cell)];
    var next_entry = brick_grid[grid_index(here.next)];
    result.visited = 1u;
    // Decided once per cell (MIP: against the maximum when the ray enters it).
    var draw = draws_brick(entry, 0u);
    let atlas_dir = dir * params.atlas_texel.xyz;
    var atlas_here = atlas_origin(origin, entry[CELL_ATLAS_CELL], vec3<f32>(here.cell) * brick);
    var k = 0.0;
    var advance = false;
    var acc = new_accumulation();
    let light = headlight(dir);
    let half_texel = 0.5 * sample_voxels() * params.atlas_texel.xyz;
    for (var i = 0u; i < MAX_STEPS; i++) {
        if advance {
            if here.last {
                break;
            }
            here = walk_cell(here.next, here.next_exits, ray.t_leave, step, cell_span);
            entry = next_entry;
            next_entry = brick_grid[grid_index(here.next)];
            draw = draws_brick(entry, acc.running_max);
            atlas_here = atlas_origin(origin, entry[CELL_ATLAS_CELL], vec3<f32>(here.cell) * brick);
            result.visited += 1u;
            advance = false;
        }
        if draw {
            let ts = t_first + (vec4<f32>(k) + BATCH_OFFSETS) * sample_step;
            let ts2 = t_first + (vec4<f32>(k + f32(BATCH)) + BATCH_OFFSETS) * sample_step;
            let count_here = count_before(ts, here.t_out) + count_before(ts2, here.t_out);
            // Samples past the cell's exit come from the next cell when that one is drawn too
            // (its entry is already here), so a cell boundary costs no short iteration.
            // Samples past that cell too (a ray clipping its corner) wait for the next one.
            // (Nested ifs, not &&: only an iteration at the exit may wait for the next entry.)
            var count = count_here;
            var atlas_next = atlas_here;
            if count_here < BATCH_PAIR && !here.last {
                if draws_brick(next_entry, acc.running_max) {
                    let t_next = min(min_component(here.next_exits), ray.t_leave);
                    count = count_before(ts, t_next) + count_before(ts2, t_next);
                    atlas_next = atlas_origin(origin, next_entry[CELL_ATLAS_CELL],
                                              vec3<f32>(here.next) * brick);
                }
            }
            let first = brick_batch(atlas_dir, ts, here.t_out, atlas_here, atlas_next);
            let second = brick_batch(atlas_dir, ts2, here.t_out, atlas_here, atlas_next);
            let frame = SampleFrame(atlas_here, atlas_next, here.t_out, atlas_dir, half_texel, light,
                                    ray.t_enter);
            result.visited += accumulate_pair(&acc, first, second, count, ts, ts2, frame);
            k += f32(count);
            advance = count_here < BATCH_PAIR;
            // MIP: once the ray's maximum reaches the brick's (its own voxels' maximum, which
            // the cell skip trusts too), the rest of the brick cannot raise it.
            if mip && !COARSE && !advance && acc.running_max >= (entry[CELL_BOUNDS] >> 16u) {
                k = max(ceil((here.t_out - t_first) / sample_step - 0.5), k);
                advance = true;
            }
        } else {
            // Skipped, or a uniform region (a leaf above the bricks): its samples in one go.
            let end = max(ceil((here.t_out - t_first) / sample_step - 0.5), k);
            // (Only where a sample falls: a ray can clip a cell's corner between two samples.)
            // (Unshaded: a uniform region has no gradient.)
            if entry[CELL_FIRST_CHILD] == LEAF && (entry[CELL_BOUNDS] & 0xffffu) <= (entry[CELL_BOUNDS] >> 16u) && end > k {
                if mip {
                    if PROBE && (entry[CELL_BOUNDS] >> 16u) > acc.running_max {
                        acc.probe_t = t_first + (k + 0.5) * sample_step; // the run's first sample
                    }
                    acc.running_max = max(acc.running_max, entry[CELL_BOUNDS] >> 16u);
                    acc.done = acc.running_max >= params.mip_saturation;
                } else if first_label() {
                    // The run's value, where the transfer function shows it.
                    take_label(&acc, entry[CELL_BOUNDS] & 0xffffu, t_first + (k + 0.5) * sample_step);
                } else if (entry[CELL_COLOR] >> 24u) != 0u {
                    let rgba = unpack4x8unorm(entry[CELL_COLOR]);
                    let sample_alpha = min(rgba.a * params.density, 1.0);
                    let exponent = sample_exponent();
                    let a = 1.0 - pow(1.0 - sample_alpha, (end - k) * exponent);
                    let alpha_before = acc.alpha;
                    acc.color += (1.0 - acc.alpha) * a * rgba.rgb;
                    acc.alpha += (1.0 - acc.alpha) * a;
                    acc.done = acc.alpha >= EARLY_TERMINATION_ALPHA;
                    if PROBE && acc.probe_t < 0.0 && acc.alpha >= PROBE_ALPHA {
                        // The run's sample j where 1 − (1 − alpha_before)(1 − a)^(e(j + 1))
                        // first reaches PROBE_ALPHA (e: the exponent of a step).
                        let needed = log((1.0 - PROBE_ALPHA) / (1.0 - alpha_before))
                            / log(1.0 - sample_alpha);
                        let j = clamp(ceil(needed / exponent) - 1.0, 0.0, end - k - 1.0);
                        acc.probe_t = t_first + (k + j + 0.5) * sample_step;
                    }
                }
            }
            k = end;
            advance = true;
        }
        if acc.done {
            break;
        }
    }
    result.color = final_color(acc);
    result.probe_t = acc.probe_t;
    return result;
}

// Whether a grid cell is a brick that can change the pixel: DVR, not transparent; MIP, its
// maximum above the ray's so far. COARSE: every cell but padding, uniform regions (leaves above
// the bricks) included: a coarser level blurs each cell into its neighbours (half a voxel of
// that level, up to 16 voxels), so its samples there are not bounded by the cell's own values,
// and skipping by them let light through where the level has none (a bright wedge in the 256³
// head at level 4). A coarser level has few samples to take anyway (one per 2^k voxels).
fn draws_brick(cell: vec4<u32>, running_max: u32) -> bool {
    if COARSE {
        return (cell[CELL_BOUNDS] & 0xffffu) <= (cell[CELL_BOUNDS] >> 16u);
    }
    if cell[CELL_FIRST_CHILD] == LEAF {
        return false;
    }
    if max_projection() {
        return (cell[CELL_BOUNDS] >> 16u) > running_max;
    }
    return (cell[CELL_COLOR] >> 24u) != 0u;
}

// Index of a brick cell (clamped into the grid) in `brick_grid`.
fn grid_index(cell: vec3<i32>) -> u32 {
    let size = params.brick_grid.xyz;
    let c = vec3<u32>(clamp(cell, vec3<i32>(0), vec3<i32>(size) - 1));
    return c.x + size.x * (c.y + size.y * c.z);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>,
        @builtin(local_invocation_index) lane: u32) {
    let pixel = ray_pixel(id.xy);
    if pixel.x >= params.image_size.x || pixel.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(pixel);
    let result = trace_ray(params.eye.xyz, ray.dir, ray.world_length, lane, ray_jitter(pixel));
    if PROBE {
        write_probe(params.eye.xyz, ray.dir, result.probe_t);
    } else {
        write_pixel(pixel, result.color, result.visited);
    }
}

// Octrees with brick leaves when nothing may stop above the bricks (full level, no pixel
// LOD; src/render/raycaster.rs decides): the grid walk. Its own pipeline, so it allocates no
// workgroup memory for the tree's stack and keeps the whole L1 for texture reads.
@compute @workgroup_size(8, 8, 1)
fn main_bricks(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = ray_pixel(id.xy);
    if pixel.x >= params.image_size.x || pixel.y >= params.image_size.y {
        return;
    }
    let ray = pixel_ray(pixel);
    let result = walk_bricks(params.eye.xyz, ray.dir, ray_jitter(pixel));
    if PROBE {
        write_probe(params.eye.xyz, ray.dir, result.probe_t);
    } else {
        write_pixel(pixel, result.color, result.visited);
    }
}
