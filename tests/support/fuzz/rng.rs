//! A small deterministic generator (SplitMix64): case `n` of a campaign seed is the same file
//! on every machine, so a failure is reproduced from its seed and number alone.

/// SplitMix64.
pub struct Rng(u64);

impl Rng {
    /// The generator of case `index` of `format` in the campaign `seed`.
    pub fn for_case(seed: u64, format: &str, index: u64) -> Self {
        let mut mixed = seed ^ 0x5851_f42d_4c95_7f2d;
        for byte in format.bytes() {
            mixed = (mixed ^ byte as u64).wrapping_mul(0x1000_0000_01b3);
        }
        let mut rng = Self(mixed ^ index.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        rng.next_u64();
        rng
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next_u64() % n as u64) as usize
        }
    }

    /// True `percent` times in a hundred.
    pub fn percent(&mut self, percent: usize) -> bool {
        self.below(100) < percent
    }

    /// One of `items` (which must not be empty).
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}
