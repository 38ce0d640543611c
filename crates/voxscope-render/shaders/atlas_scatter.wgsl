// Writes a frame's staged bricks into their cells of the streaming atlas. The staging holds
// each brick whole (34³ texels, x fastest, then y, then z), one after another, and for brick
// `i` its cell's corner `placements[i]`. One invocation takes one 32-bit word of a brick's
// texels: TEXELS_PER_WORD of them in order, low bits first. Prefixed by the atlas format's file
// (`atlas_r8unorm.wgsl`, …), which declares `atlas`, TEXELS_PER_WORD and `texel`.

// Where brick `i` goes: the atlas texel of its cell's corner. Mirrors `BrickPlacement` in
// gpu_data.rs.
struct BrickPlacement {
    origin: vec3<u32>,
    _pad: u32,
}

// A padded brick's side and texels (`PADDED_BRICK` in the stream crate).
const SIDE: u32 = 34u;
const BRICK_TEXELS: u32 = SIDE * SIDE * SIDE;
const WORDS_PER_BRICK: u32 = BRICK_TEXELS / TEXELS_PER_WORD;

@group(0) @binding(0) var<storage, read> placements: array<BrickPlacement>;
@group(0) @binding(1) var<storage, read> texels: array<u32>;

// One workgroup row per brick: x counts words of the brick, y is the brick.
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let word = id.x;
    let brick = id.y;
    if word >= WORDS_PER_BRICK || brick >= arrayLength(&placements) {
        return;
    }
    let value = texels[brick * WORDS_PER_BRICK + word];
    let origin = placements[brick].origin;
    for (var k = 0u; k < TEXELS_PER_WORD; k++) {
        let index = word * TEXELS_PER_WORD + k;
        let at = vec3<u32>(index % SIDE, (index / SIDE) % SIDE, index / (SIDE * SIDE));
        textureStore(atlas, origin + at, vec4<f32>(texel(value, k), 0.0, 0.0, 1.0));
    }
}

// Writes 0 into every texel of the atlas: its first use, where it was made without wgpu's zero
// fill (`uncleared_texture.rs`). One invocation per texel; x counts along a row, y and z are
// the row's.
@compute @workgroup_size(64)
fn zero(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= textureDimensions(atlas)) {
        return;
    }
    textureStore(atlas, id, vec4<f32>(0.0, 0.0, 0.0, 1.0));
}
