// The 8-bit atlas for `atlas_scatter.wgsl`: four texels a word.

@group(0) @binding(2) var atlas: texture_storage_3d<r8unorm, write>;

const TEXELS_PER_WORD: u32 = 4u;

// Texel `k` of `word` as the value the texture stores it as (n / 255 is stored as n).
fn texel(word: u32, k: u32) -> f32 {
    return f32((word >> (8u * k)) & 0xffu) / 255.0;
}

