// What the GPU itself can do, measured the way the ray casters use it (`voxscope ceilings`,
// src/render/ceilings.rs): memory bandwidth, the rate of filtered 3D texture samples, the latency
// of a fetch that waits on the previous one (texture and storage buffer), the FMA rate, and the
// rate at which invocations that only store a result run.
// docs/benchmarks.md lists them; docs/performance-log.md (run 38) sets the renderers' times
// against them.

// Keep in sync with `CeilingParams` in src/render/ceilings.rs.
struct CeilingParams {
    elements: u32,     // vec4<u32> elements streamed from `source` to `destination`
    iterations: u32,   // fetches or FMA rounds per invocation
    invocations: u32,  // invocations that work (the rest of the last workgroup return)
    chain_length: u32, // entries of `chain`
    fma_scale: f32,    // a ← a · fma_scale + fma_offset
    fma_offset: f32,
    _padding: vec2<u32>,
}

@group(0) @binding(0) var<uniform> params: CeilingParams;
@group(0) @binding(1) var<storage, read> source: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> destination: array<vec4<u32>>;
@group(0) @binding(3) var levels: texture_3d<f32>;
@group(0) @binding(4) var level_sampler: sampler;
@group(0) @binding(5) var<storage, read> chain: array<u32>;
@group(0) @binding(6) var<storage, read_write> results: array<f32>;

const WORKGROUP: u32 = 256u;

// Bandwidth: every element read once and written once, in a grid-stride loop.
@compute @workgroup_size(256, 1, 1)
fn stream(@builtin(global_invocation_id) id: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>) {
    let stride = groups.x * WORKGROUP;
    for (var i = id.x; i < params.elements; i += stride) {
        destination[i] = source[i];
    }
}

// The fixed cost of a frame: invocations that only write their result, as a ray caster's
// invocations that miss the volume do.
@compute @workgroup_size(256, 1, 1)
fn store_only(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.invocations {
        return;
    }
    results[id.x] = f32(id.x);
}

// Where invocation `index` starts in the texture (normalized): neighbours start a texel apart,
// as neighbouring rays do.
fn start_point(index: u32, size: vec3<f32>) -> vec3<f32> {
    let texel = vec3<u32>(index % 61u, (index / 61u) % 59u, (index / 3599u) % 53u);
    return (vec3<f32>(texel) + 0.5) / size;
}

// Filtered sample rate: each invocation takes `iterations` trilinear samples along its own line,
// one texel apart, none waiting on another (as a ray's batch of samples).
@compute @workgroup_size(256, 1, 1)
fn filtered(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.invocations {
        return;
    }
    let size = vec3<f32>(textureDimensions(levels));
    let start = start_point(id.x, size);
    let step = vec3<f32>(1.0, 0.5, 0.25) / size;
    var sum = 0.0;
    for (var k = 0u; k < params.iterations; k++) {
        let p = fract(start + f32(k) * step);
        sum += textureSampleLevel(levels, level_sampler, p, 0.0).r;
    }
    results[id.x] = sum;
}

// Texture latency: each sample's position depends on the previous sample's value.
@compute @workgroup_size(256, 1, 1)
fn texture_chain(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.invocations {
        return;
    }
    let size = vec3<f32>(textureDimensions(levels));
    var p = start_point(id.x, size);
    var value = 0.0;
    for (var k = 0u; k < params.iterations; k++) {
        value = textureSampleLevel(levels, level_sampler, p, 0.0).r;
        p = fract(p + (vec3<f32>(0.37, 0.23, 0.11) + value) / size);
    }
    results[id.x] = value;
}

// Storage-buffer latency: each read's index is the previous read's value (`chain` is one cycle).
@compute @workgroup_size(256, 1, 1)
fn buffer_chain(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.invocations {
        return;
    }
    var index = id.x % params.chain_length;
    for (var k = 0u; k < params.iterations; k++) {
        index = chain[index];
    }
    results[id.x] = f32(index);
}

// FMA rate: eight independent vec4 chains per invocation (no chain waits on another).
@compute @workgroup_size(256, 1, 1)
fn fma_rate(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.invocations {
        return;
    }
    let scale = vec4<f32>(params.fma_scale);
    let offset = vec4<f32>(params.fma_offset);
    let first = f32(id.x & 7u);
    var a0 = vec4<f32>(first, first + 1.0, first + 2.0, first + 3.0);
    var a1 = a0 + 4.0;
    var a2 = a0 + 8.0;
    var a3 = a0 + 12.0;
    var a4 = a0 + 16.0;
    var a5 = a0 + 20.0;
    var a6 = a0 + 24.0;
    var a7 = a0 + 28.0;
    for (var k = 0u; k < params.iterations; k++) {
        a0 = fma(a0, scale, offset);
        a1 = fma(a1, scale, offset);
        a2 = fma(a2, scale, offset);
        a3 = fma(a3, scale, offset);
        a4 = fma(a4, scale, offset);
        a5 = fma(a5, scale, offset);
        a6 = fma(a6, scale, offset);
        a7 = fma(a7, scale, offset);
    }
    let total = a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7;
    results[id.x] = total.x + total.y + total.z + total.w;
}
