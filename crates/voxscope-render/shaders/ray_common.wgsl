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
    atlas_scale: f32,       // atlas texel value × this = value level (255 for unorm8, 65535 for unorm16, 1 for f16)
    atlas_grid: vec4<u32>,  // xyz: bricks along each atlas axis
    brick_grid: vec4<u32>,  // xyz: brick cells along each volume axis (the walked grid)
    atlas_texel: vec4<f32>, // xyz: 1 / the atlas's size in texels (texel to normalized)
    clip_low: vec4<f32>,    // xyz: the crop box's low corner (voxel space; CLIP)
    clip_high: vec4<f32>,   // xyz: its high corner (CLIP)
    clip_plane: vec4<f32>,  // kept where dot(xyz, p) >= w, p in voxel space (CLIP)
    shading: vec4<f32>,     // ambient, diffuse, specular, shininess (SHADING)
    shading_scale: vec4<f32>, // xyz: smallest spacing / spacing; w: 1 / gradient of full shading
    probe_pixel: vec2<u32>, // the pixel a PROBE pipeline traces
    // Level-0 voxels per voxel of the texture bound and per sample step: 2^(depth − max level)
    // where dense or bricks draw a pyramid level finer than the nodes but not full detail; 1.
    sample_voxels: f32,
    _sample_pad: u32,
    // The pixels a frame draws: [xy, zw) of the image (a band of it where a slow device draws
    // a frame in parts; the whole image otherwise). Dispatches cover the tile alone.
    tile: vec4<u32>,
    // Where the target texture lies in the image: xy its first pixel, z its width. The whole
    // image at (0, 0); a tile of a still larger than the device's textures elsewhere.
    placement: vec4<u32>,
}

// Pipeline variants (src/render/raycaster.rs builds each as its own pipeline, so that a
// variant's code is compiled out of the others: the plain pipelines are the unshaded ones of
// before, register for register).
// Headlight Blinn-Phong shading of DVR (docs/octree.md, "Shading").
override SHADING: bool = false;
// One ray (`params.probe_pixel`) reports where it reached PROBE_ALPHA (DVR) or its maximum
// (MIP) into `probe_out` instead of drawing.
override PROBE: bool = false;
// A crop box or clip plane is set: every ray's interval is cut to them (`volume_interval`).
override CLIP: bool = false;
// A pyramid level coarser than full detail is sampled (dense and bricks below full detail):
// `params.sample_voxels` > 1. Elsewhere `sample_voxels()` is the constant 1, and the full-detail
// pipelines are the code of before (an opacity correction per sample cost them 7–15 %, run 54).
override COARSE: bool = false;
// The values are labels (FLAG_LABELS): samples meet the voxels the ray enters between them
// (`label_entry`), undithered (`ray_jitter`). A pipeline of its own, so that the other
// volumes' pipelines carry none of that code.
override LABELS: bool = false;

// Keep in sync with `ProbeResult` in src/render/gpu_data.rs.
struct ProbeResult {
    point: vec3<f32>, // voxel space
    found: u32,       // 1, or 0 where the ray never got there
}

// Keep in sync with `PROBE_ALPHA` in src/render/probe.rs.
const PROBE_ALPHA: f32 = 0.5;

const MODE_DVR: u32 = 0u;
const MODE_MIP: u32 = 1u;
const FLAG_OPACITY_CORRECTION: u32 = 1u;
const FLAG_PIXEL_LOD: u32 = 2u;
const FLAG_HEATMAP: u32 = 4u;
// The values are labels (categories): MIP draws the first label along the ray that the
// transfer function shows, unblended (`first_label`). Keep in sync with gpu_data.rs.
const FLAG_LABELS: u32 = 8u;
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

// MIP of a label volume: the largest label is no more meaningful than their mean, so a ray
// draws the first label the transfer function shows (label 0 is transparent), unblended.
fn first_label() -> bool {
    return params.mode == MODE_MIP && (params.flags & FLAG_LABELS) != 0u;
}

// MIP by value: the maximum along the ray (every MIP but a label volume's).
fn max_projection() -> bool {
    return params.mode == MODE_MIP && (params.flags & FLAG_LABELS) == 0u;
}

// Where in a sample step a pixel's samples sit, in [0, 1): a hash of the pixel (the same on
// every frame and in every renderer, so images stay comparable). Samples one step apart from
// the same entry plane would lie on the same shells for every pixel, and a thin band of
// opacity (CT's lung preset) shows them as rings (moiré); shifted per pixel they average out
// into fine noise, as other volume renderers do. Keep in sync with `pixel_jitter` in
// tests/support/reference.rs.
fn pixel_jitter(pixel: vec2<u32>) -> f32 {
    var h = (pixel.x * 0x8da6b343u) ^ (pixel.y * 0xd8163841u);
    h = (h ^ (h >> 16u)) * 0x7feb352du;
    h = (h ^ (h >> 15u)) * 0x846ca68bu;
    h = h ^ (h >> 16u);
    return f32(h >> 8u) * (1.0 / 16777216.0);
}
fn min_component(v: vec3<f32>) -> f32 { return min(v.x, min(v.y, v.z)); }

// Whether the values are labels (categories), drawn unblended and undithered: the `LABELS`
// pipelines (whose frames also set FLAG_LABELS).
fn labels() -> bool {
    return LABELS;
}

// Where in a sample step pixel `pixel`'s samples sit: `pixel_jitter`, but for labels, which are
// never dithered: the middle of the step for every pixel (a label's color does not depend on
// where in its voxel a ray samples it, and a jittered first sample made its surfaces speckle).
// Keep in sync with `ray_jitter` in tests/support/reference.rs.
fn ray_jitter(pixel: vec2<u32>) -> f32 {
    if labels() {
        return 0.5;
    }
    return pixel_jitter(pixel);
}

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

// Entry (clamped to the eye) and exit distances of a ray through the volume's box [0, dims]
// or, in a CLIP pipeline, through the crop box and the kept half-space of the clip plane. Every
// renderer starts and stops its rays here, so clipping costs a ray this and nothing per sample
// or node, and empty-space skipping is as before inside the interval; unclipped pipelines
// compile to the code they had before clipping existed.
fn volume_interval(origin: vec3<f32>, dir: vec3<f32>, inv: vec3<f32>) -> vec2<f32> {
    var low = vec3<f32>(0.0);
    var high = params.volume.xyz;
    if CLIP {
        low = params.clip_low.xyz;
        high = params.clip_high.xyz;
    }
    let t_low = (low - origin) * inv;
    let t_high = (high - origin) * inv;
    var t_enter = max(max_component(min(t_low, t_high)), 0.0);
    var t_leave = min_component(max(t_low, t_high));
    if CLIP {
        // (Without a plane, clip_plane keeps everything: 0 · p >= -1.)
        // dot(n, origin + t·dir) >= w  ⇔  t·facing >= -height.
        let facing = dot(params.clip_plane.xyz, dir);
        let height = dot(params.clip_plane.xyz, origin) - params.clip_plane.w;
        if facing > 0.0 {
            t_enter = max(t_enter, -height / facing);
        } else if facing < 0.0 {
            t_leave = min(t_leave, -height / facing);
        } else if height < 0.0 {
            t_leave = -1.0; // parallel to the plane, on the clipped side
        }
    }
    return vec2<f32>(t_enter, t_leave);
}

// Samples are fetched in batches of four: their texture reads do not depend on each other, so
// a ray waits for one memory latency per batch instead of one per sample (the frame is bound by
// its longest rays' chains of dependent reads: docs/performance-log.md, attempt 7). The dense
// march and the bricks' grid walk fetch two batches per loop iteration (attempt 17).
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
    // PROBE: the ray distance where alpha reached PROBE_ALPHA, or of the sample or node that
    // last raised the MIP maximum; negative until then.
    probe_t: f32,
}

fn new_accumulation() -> Accumulation {
    return Accumulation(vec3<f32>(0.0), 0.0, 0u, false, -1.0);
}

// Where a batch's samples are in the texture they come from, for the gradient (SHADING): sample
// j at ray distance t is at `select(next, here, t < split) + t · dir` in normalized texture
// coordinates (the grid walk's batches may cross into the next brick). `half_texel` is half a
// voxel along each axis there; `light` the ray's direction scaled for `shade`.
struct SampleFrame {
    here: vec3<f32>,
    next: vec3<f32>,
    split: f32,
    dir: vec3<f32>,
    half_texel: vec3<f32>,
    light: vec3<f32>,
    // The ray distance where the ray enters the (clipped) volume: a label volume's first
    // sample looks back to there, not outside it (`label_entry`).
    t_enter: f32,
}

// The headlight of a ray of voxel-space direction `dir`: |n · l| of a world-space normal n
// whose voxel-space gradient is g is |dot(g, light)| / |g ⊙ s|, s = shading_scale.xyz
// (world = voxel ⊘ spacing for gradients and ⊙ spacing for directions; the smallest spacing
// cancels).
fn headlight(dir: vec3<f32>) -> vec3<f32> {
    return dir / length(dir / params.shading_scale.xyz);
}

// A color under the headlight, the surface's |n · l| being `cosine` and its weight `weight`
// (0: homogeneous, plain color; 1: an edge, fully lit).
fn shade_with(rgb: vec3<f32>, cosine: f32, weight: f32) -> vec3<f32> {
    let k = params.shading;
    let lit = rgb * (k.x + k.y * cosine) + k.z * pow(max(cosine, 1e-6), k.w);
    return mix(rgb, lit, weight);
}

// A sample's color shaded by the volume's gradient there (`level_gradient`, in value levels
// per voxel, central differences half a voxel either side), weighted by its magnitude in
// transfer-window widths per voxel of the smallest spacing.
fn shade_sample(rgb: vec3<f32>, gradient: vec3<f32>, light: vec3<f32>) -> vec3<f32> {
    let magnitude = length(gradient * params.shading_scale.xyz);
    let weight = min(magnitude * params.shading_scale.w, 1.0);
    let cosine = min(abs(dot(gradient, light)) / max(magnitude, 1e-20), 1.0);
    return shade_with(rgb, cosine, weight);
}

// A composite's channel color `rgb` lit by the channel's own gradient (as `shade_sample`),
// weighted by its magnitude times `full` (1 / the channel's full-shading gradient). The
// highlight is in the channel's hue, not white: in an additive composite white says that
// every channel is there.
fn shade_tinted(rgb: vec3<f32>, gradient: vec3<f32>, light: vec3<f32>, full: f32) -> vec3<f32> {
    let magnitude = length(gradient * params.shading_scale.xyz);
    let weight = min(magnitude * full, 1.0);
    let cosine = min(abs(dot(gradient, light)) / max(magnitude, 1e-20), 1.0);
    let k = params.shading;
    let hue = rgb / max(max(rgb.r, max(rgb.g, rgb.b)), 1e-6);
    let lit = rgb * (k.x + k.y * cosine) + k.z * pow(max(cosine, 1e-6), k.w) * hue;
    return mix(rgb, lit, weight);
}

// No label known (`label_entry`'s sample before).
const NO_LABEL: u32 = 0xffffffffu;

// What a label volume's sample meets (`label_entry`).
struct LabelEntry {
    // The label: the first voxel the transfer function shows that the ray entered since the
    // sample before, else the sample's own.
    level: u32,
    // The axis of the face it was entered by (the normal it is lit by); zero inside one label.
    face: vec3<f32>,
    // The ray distance just inside it (the sample's own where nothing was entered).
    t: f32,
}

// A label volume's sample of label `level` at normalized texture coordinates `coords`, ray
// distance `t`, samples `step` apart. Labels are voxel cubes, as the octree draws them: the
// ray meets a label where it enters its voxel, not up to a step later where a sample happens
// to fall (zoomed in, that moved the cubes' edges by up to a voxel, and a gradient of
// nearest-sampled labels lit their faces as noise). So the voxels the ray crossed since the
// sample before (at most one voxel back along each axis; a voxel is a texel,
// `2 · frame.half_texel`; `before` is that sample's label where known, else NO_LABEL) are
// walked in order, and the first one entered from another label that the transfer function
// shows is what this sample stands for, lit by the face it was entered by (docs/octree.md,
// "Shading"). Where the sample before was in the same label and the ray crossed one voxel
// plane at most since, there is nothing to walk.
fn label_entry(level: u32, before: u32, coords: vec3<f32>, t: f32, step: f32,
               frame: SampleFrame) -> LabelEntry {
    var entry = LabelEntry(level, vec3<f32>(0.0), t);
    let texel = 2.0 * frame.half_texel;
    // Back to the sample before, or to where the ray entered the volume (just inside it).
    let back_t = max(t - step, frame.t_enter + 0.001 * step);
    let back = coords - frame.dir * (t - back_t);
    let start = floor(back / texel);
    // The sample before's label where it is known (`before`), else read.
    var previous = before;
    if previous == NO_LABEL || back_t > t - step {
        previous = label_level_at((start + 0.5) * texel);
    }
    if back_t > t - step && previous != level && (lookup_table[previous] >> 24u) != 0u {
        // The ray's first voxel is shown: met where the ray enters the volume, unlit (no
        // voxel before it, as the octree's first node).
        entry.level = previous;
        entry.t = back_t;
        return entry;
    }
    let delta = clamp(floor(coords / texel) - start, vec3<f32>(-1.0), vec3<f32>(1.0));
    let crossed = delta != vec3<f32>(0.0);
    // From a voxel of the same label straight into this one (one plane crossed, or none):
    // nothing in between to meet.
    if previous == level && dot(abs(delta), vec3<f32>(1.0)) < 2.0 {
        return entry;
    }
    // Where along back → coords each crossed axis's voxel plane lies (0…1); 2: not crossed.
    let planes = (start + max(delta, vec3<f32>(0.0))) * texel;
    var at = select(vec3<f32>(2.0), (planes - back) / select(vec3<f32>(1.0), coords - back, crossed),
                    crossed);
    var voxel = start;
    for (var i = 0u; i < 3u; i++) {
        let next = min_component(at);
        if next > 1.5 {
            break;
        }
        var axis = vec3<f32>(0.0, 0.0, 1.0);
        if at.x <= next {
            axis = vec3<f32>(1.0, 0.0, 0.0);
        } else if at.y <= next {
            axis = vec3<f32>(0.0, 1.0, 0.0);
        }
        voxel += axis * delta;
        at = select(at, vec3<f32>(2.0), axis > vec3<f32>(0.5));
        let here = label_level_at((voxel + 0.5) * texel);
        if here != previous && (lookup_table[here] >> 24u) != 0u {
            entry.level = here;
            entry.face = axis;
            // Just inside the voxel (a thousandth of a step past its plane).
            entry.t = min(back_t + (t - back_t) * next + 0.001 * step, t);
            return entry;
        }
        previous = here;
    }
    return entry;
}

// `accumulate` for a label volume (DVR, and MIP's first label): each sample stands for the
// label it meets (`label_entry`), composited unblended with its neighbours' values and lit by
// the face it was entered by (SHADING); `exponent` is a step's opacity-correction exponent.
fn accumulate_labels(acc: ptr<function, Accumulation>, levels: vec4<u32>, count: u32,
                     ts: vec4<f32>, frame: SampleFrame, exponent: f32) -> u32 {
    let step = ts.y - ts.x;
    for (var j = 0u; j < count; j++) {
        let coords = select(frame.next, frame.here, ts[j] < frame.split) + ts[j] * frame.dir;
        let before = select(NO_LABEL, levels[max(j, 1u) - 1u], j > 0u);
        let entry = label_entry(levels[j], before, coords, ts[j], step, frame);
        if first_label() {
            if take_label(acc, entry.level, entry.t) {
                return j + 1u;
            }
            continue;
        }
        let rgba = unpack4x8unorm(lookup_table[entry.level]);
        var a = min(rgba.a * params.density, 1.0);
        if exponent != 1.0 && a > 0.0 && a < 1.0 {
            a = 1.0 - pow(1.0 - a, exponent);
        }
        var rgb = rgba.rgb;
        if SHADING && a > 0.0 && dot(entry.face, entry.face) > 0.0 {
            let cosine = min(abs(dot(frame.light / params.shading_scale.xyz, entry.face)), 1.0);
            rgb = shade_with(rgb, cosine, 1.0);
        }
        (*acc).color += (1.0 - (*acc).alpha) * a * rgb;
        (*acc).alpha += (1.0 - (*acc).alpha) * a;
        if PROBE && (*acc).probe_t < 0.0 && (*acc).alpha >= PROBE_ALPHA {
            (*acc).probe_t = entry.t;
        }
        if (*acc).alpha >= EARLY_TERMINATION_ALPHA {
            (*acc).done = true;
            return j + 1u;
        }
    }
    return count;
}

// Takes the first `count` of four value levels in order along the ray, as one-voxel samples at
// distances `ts`, and returns how many it took before the ray was done. The four lookups are
// issued before any is blended, for the same reason as the batched fetches. `frame` places the
// samples for SHADING's gradient (unused, and compiled out, elsewhere).
fn accumulate(acc: ptr<function, Accumulation>, levels: vec4<u32>, count: u32, ts: vec4<f32>,
              frame: SampleFrame) -> u32 {
    // Labels, DVR and MIP (the first label shown): voxel cubes, never blended.
    if labels() {
        return accumulate_labels(acc, levels, count, ts, frame, select(1.0, sample_exponent(), COARSE));
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
    let exponent = sample_exponent();
    for (var j = 0u; j < count; j++) {
        let rgba = unpack4x8unorm(colors[j]);
        var a = min(rgba.a * params.density, 1.0);
        // A step is one voxel of the level sampled; opacity correction to it (at full detail a
        // step is one voxel, and alpha stays as it is).
        if COARSE && a < 1.0 {
            a = 1.0 - pow(1.0 - a, exponent);
        }
        var rgb = rgba.rgb;
        if SHADING && a > 0.0 {
            let coords = select(frame.next, frame.here, ts[j] < frame.split) + ts[j] * frame.dir;
            rgb = shade_sample(rgb, level_gradient(coords, frame.half_texel), frame.light);
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

// `first_label`: takes value level `level` at ray distance `t` if the transfer function shows
// it, as the pixel's color, opaque; returns whether it did (the ray is then done).
fn take_label(acc: ptr<function, Accumulation>, level: u32, t: f32) -> bool {
    let rgba = unpack4x8unorm(lookup_table[level]);
    if rgba.a <= 0.0 {
        return false;
    }
    (*acc).color = rgba.rgb;
    (*acc).alpha = 1.0;
    (*acc).running_max = level;
    (*acc).done = true;
    if PROBE {
        (*acc).probe_t = t;
    }
    return true;
}

// The opacity-correction exponent of one sample step: its length in level-0 voxels where
// opacity correction is on (a sample of a coarser level stands for that many voxels), else 1.
fn sample_exponent() -> f32 {
    return select(1.0, sample_voxels(), (params.flags & FLAG_OPACITY_CORRECTION) != 0u);
}

// Level-0 voxels per voxel of the level sampled and per sample step (`params.sample_voxels`);
// 1 outside COARSE pipelines.
fn sample_voxels() -> f32 {
    return select(1.0, params.sample_voxels, COARSE);
}

// `accumulate` for two batches fetched together (distances `ts`, `ts2`): the first `count` of
// their eight levels.
fn accumulate_pair(acc: ptr<function, Accumulation>, first: vec4<u32>, second: vec4<u32>, count: u32,
                   ts: vec4<f32>, ts2: vec4<f32>, frame: SampleFrame) -> u32 {
    var taken = accumulate(acc, first, min(count, BATCH), ts, frame);
    if !(*acc).done && count > BATCH {
        taken += accumulate(acc, second, count - BATCH, ts2, frame);
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

// The pixel's color once the ray is finished: blended over black (and a first label's, black
// where none was met), or the MIP's color.
fn final_color(acc: Accumulation) -> vec3<f32> {
    if max_projection() {
        return unpack4x8unorm(lookup_table[acc.running_max]).rgb;
    }
    return acc.color;
}

// The pixel an invocation traces: its own in the frame's tile, or in a PROBE pipeline (one
// workgroup) the probed pixel for invocation 0; the others (past the tile, or a probe's other
// invocations) get one past the image, which they leave at once.
fn ray_pixel(id: vec2<u32>) -> vec2<u32> {
    if PROBE {
        return select(params.image_size, params.probe_pixel, all(id == vec2<u32>(0u)));
    }
    let pixel = id + params.tile.xy;
    return select(params.image_size, pixel, all(pixel < params.tile.zw));
}

// A PROBE pipeline's answer: the point at `probe_t` on the ray, if it got there.
fn write_probe(origin: vec3<f32>, dir: vec3<f32>, probe_t: f32) {
    probe_out = ProbeResult(origin + max(probe_t, 0.0) * dir, select(0u, 1u, probe_t >= 0.0));
}

// Writes a pixel: the color, or the heat map of `work` (nodes or samples) when asked.
fn write_pixel(id: vec2<u32>, color: vec3<f32>, work: u32) {
    var rgb = color;
    if (params.flags & FLAG_HEATMAP) != 0u {
        rgb = heat(clamp(log2(1.0 + f32(work)) / 10.0, 0.0, 1.0));
    }
    let texel = id - params.placement.xy;
    textureStore(output, vec2<i32>(texel), vec4<f32>(rgb, 1.0));
    visits[texel.y * params.placement.z + texel.x] = work;
}
