// The 16-bit normalized atlas for `atlas_scatter.wgsl`: two texels a word.

@group(0) @binding(2) var atlas: texture_storage_3d<r16unorm, write>;

const TEXELS_PER_WORD: u32 = 2u;

// Texel `k` of `word` as the value the texture stores it as (n / 65535 is stored as n).
fn texel(word: u32, k: u32) -> f32 {
    return f32((word >> (16u * k)) & 0xffffu) / 65535.0;
}

