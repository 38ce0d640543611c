//! The 8-byte node of the flat list, and its color packing.

/// `first_child` of a leaf: it has no children block.
pub const LEAF: u32 = u32::MAX;

/// One octree node: 4 bytes of RGBA color and the index of its first child.
///
/// The 8 children of a node are stored together, so `first_child..first_child + 8` are its
/// children. Keep in sync with `struct Node` in `shaders/node_common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Node {
    /// RGBA8, red in the lowest byte (WGSL `unpack4x8unorm` order); straight (not
    /// premultiplied) color.
    pub color: u32,
    /// Index of the first of the 8 children, or [`LEAF`].
    pub first_child: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 8);

impl Node {
    /// True when this node has no children block.
    #[inline]
    pub fn is_leaf(self) -> bool {
        self.first_child == LEAF
    }

    /// The alpha byte of the color.
    #[inline]
    pub fn alpha(self) -> u8 {
        (self.color >> 24) as u8
    }
}

/// Packs RGBA bytes, red lowest.
#[inline]
pub fn pack_rgba(rgba: [u8; 4]) -> u32 {
    u32::from_le_bytes(rgba)
}

/// Unpacks RGBA bytes, red lowest.
#[inline]
pub fn unpack_rgba(color: u32) -> [u8; 4] {
    color.to_le_bytes()
}

/// The color of a parent from its 8 children: the opacity-weighted average color (the average
/// of premultiplied colors, un-premultiplied), rounded; alpha is the plain average rounded up,
/// so a parent is transparent only when every child is. Keep in sync with `weighted_mean` in
/// `node_common.wgsl`.
#[inline]
pub fn average_color(children: [u32; 8]) -> u32 {
    let mut alpha_sum = 0u32;
    let mut weighted = [0u32; 3];
    for color in children {
        let [r, g, b, a] = unpack_rgba(color).map(u32::from);
        alpha_sum += a;
        weighted[0] += r * a;
        weighted[1] += g * a;
        weighted[2] += b * a;
    }
    if alpha_sum == 0 {
        return 0;
    }
    let channel = |w: u32| ((w + alpha_sum / 2) / alpha_sum) as u8;
    pack_rgba([
        channel(weighted[0]),
        channel(weighted[1]),
        channel(weighted[2]),
        alpha_sum.div_ceil(8) as u8,
    ])
}

/// The color of a parent of a label volume's nodes from its 8 children: the color most of
/// its visible children show (ties to the first child in order), never a mix of two labels'
/// colors; its alpha is [`average_color`]'s (transparent only when every child is, which the
/// ray casters' skipping relies on). Keep in sync with `mode_color` in `recolor.wgsl`.
#[inline]
pub fn mode_color(children: [u32; 8]) -> u32 {
    let alpha = average_color(children) >> 24;
    if alpha == 0 {
        return 0;
    }
    let visible = |color: u32| color >> 24 != 0;
    let mut best = 0u32;
    let mut best_count = 0;
    for (i, &color) in children.iter().enumerate() {
        if !visible(color) {
            continue;
        }
        let count = children[i..].iter().filter(|&&c| c == color).count();
        // The first child of a color sees every other of that color after it.
        let first = children[..i].iter().all(|&c| c != color);
        if first && count > best_count {
            best = color;
            best_count = count;
        }
    }
    (best & 0x00ff_ffff) | (alpha << 24)
}

/// The range of 16-bit value levels below a node: `min | max << 16`.
/// [`ValueBounds::EMPTY`] (min above max) marks padding outside the volume.
/// Keep in sync with the WGSL shaders, which read it as a plain `u32`.
#[repr(transparent)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ValueBounds(pub u32);

const _: () = assert!(std::mem::size_of::<ValueBounds>() == 4);

impl ValueBounds {
    /// No voxel at all (padding): the identity of [`Self::merge`].
    pub const EMPTY: Self = Self(0x0000_FFFF);

    /// A single voxel's level.
    #[inline]
    pub fn single(level: u16) -> Self {
        Self(level as u32 | (level as u32) << 16)
    }

    /// Smallest level below.
    #[inline]
    pub fn min(self) -> u16 {
        self.0 as u16
    }

    /// Largest level below (exact, so MIP can skip subtrees that cannot win).
    #[inline]
    pub fn max(self) -> u16 {
        (self.0 >> 16) as u16
    }

    /// True for padding only.
    #[inline]
    pub fn is_empty(self) -> bool {
        self.min() > self.max()
    }

    /// True when every voxel below has the same level.
    #[inline]
    pub fn is_uniform(self) -> bool {
        self.min() == self.max()
    }

    /// Bounds of the union.
    #[inline]
    pub fn merge(self, other: Self) -> Self {
        let min = self.min().min(other.min());
        let max = self.max().max(other.max());
        Self(min as u32 | (max as u32) << 16)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_label_parent_takes_its_most_shown_child_color_never_a_mix() {
        let red = pack_rgba([255, 0, 0, 255]);
        let blue = pack_rgba([0, 0, 255, 255]);
        let children = [0, red, blue, blue, 0, red, blue, 0];
        // Blue thrice, red twice: blue, with the alpha of the average (5 of 8 opaque).
        assert_eq!(
            unpack_rgba(mode_color(children)),
            [0, 0, 255, (5 * 255u32).div_ceil(8) as u8]
        );
        // A tie goes to the first child's color.
        let tie = [0, red, blue, 0, 0, 0, red, blue];
        assert_eq!(unpack_rgba(mode_color(tie))[..3], [255, 0, 0]);
        assert_eq!(mode_color([0; 8]), 0);
    }

    #[test]
    fn average_of_one_opaque_white_among_transparent_is_faint_white() {
        let mut children = [0u32; 8];
        children[3] = pack_rgba([255, 255, 255, 255]);
        assert_eq!(unpack_rgba(average_color(children)), [255, 255, 255, 32]);
    }

    #[test]
    fn alpha_rounds_up_so_any_visible_child_keeps_the_parent_visible() {
        let mut children = [0u32; 8];
        children[0] = pack_rgba([10, 20, 30, 1]);
        assert_eq!(unpack_rgba(average_color(children)), [10, 20, 30, 1]);
        assert_eq!(average_color([0; 8]), 0);
    }

    #[test]
    fn empty_bounds_are_the_merge_identity() {
        let b = ValueBounds::single(7).merge(ValueBounds::single(9));
        assert_eq!((b.min(), b.max()), (7, 9));
        assert_eq!(ValueBounds::EMPTY.merge(b), b);
        assert!(ValueBounds::EMPTY.is_empty());
        assert!(!b.is_empty() && !b.is_uniform());
    }
}
