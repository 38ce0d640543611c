// The half-float atlas for `atlas_scatter.wgsl`: two texels a word.

@group(0) @binding(2) var atlas: texture_storage_3d<r16float, write>;

const TEXELS_PER_WORD: u32 = 2u;

// Texel `k` of `word`: a half float, exact as a 32-bit one.
fn texel(word: u32, k: u32) -> f32 {
    return unpack2x16float(word)[k];
}

