//! What a frame hands the streamer (where the camera is, what its rays asked for and used)
//! and what it gets back to copy into the atlas.

use std::sync::Arc;

/// Where the camera is, in level-0 voxel space, for "near the view's center first".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPoint {
    pub eye: [f64; 3],
    /// Unit direction of the image's center.
    pub forward: [f64; 3],
}

impl ViewPoint {
    /// 1 − cos of the angle between the view's center and `point`: 0 straight ahead.
    pub fn off_center(&self, point: [f64; 3]) -> f32 {
        let d: [f64; 3] = std::array::from_fn(|a| point[a] - self.eye[a]);
        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
        let cos =
            (d[0] * self.forward[0] + d[1] * self.forward[1] + d[2] * self.forward[2]) / length;
        (1.0 - cos) as f32
    }
}

/// What one drawn frame reported: the bricks its rays asked for and each slot's last use.
#[derive(Debug, Clone, Copy)]
pub struct Feedback<'a> {
    /// The frame's number ([`Streamer::frame`] when it was drawn).
    pub frame: u32,
    /// Keys the rays asked for (deduplicated on the GPU where cheap; repeats are fine).
    pub requests: &'a [u32],
    /// Asks in all, including those beyond the buffer's capacity.
    pub asked: u32,
    /// Per atlas slot, the last frame a ray used it as `2·frame + 1` where the ray wanted the
    /// brick's level, `2·frame` where it drew it in place of a missing finer brick (0: never).
    pub usage: &'a [u32],
}

/// A brick to copy into the atlas this frame.
#[derive(Debug, Clone)]
pub struct Upload {
    pub slot: u32,
    /// The padded brick's texels ([`AtlasTexels`]).
    pub texels: Arc<[u8]>,
}
