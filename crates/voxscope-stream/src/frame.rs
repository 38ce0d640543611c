//! What a frame hands the streamer (where the camera is, what its rays asked for and used)
//! and what it gets back to copy into the atlas.

use std::sync::Arc;

/// Where the camera is, in level-0 voxel space, for "near the view's center first".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPoint {
    pub eye: [f64; 3],
    /// Unit direction of the image's center.
    pub forward: [f64; 3],
    /// The image's half width and half height as directions: its rays go along `forward +
    /// x·extent[0] + y·extent[1]`, x and y in −1…1. `None` where unknown (every point counts
    /// as in view).
    pub extent: Option<[[f64; 3]; 2]>,
}

impl ViewPoint {
    /// Looking along `forward` from `eye`, the image's extent unknown.
    pub fn new(eye: [f64; 3], forward: [f64; 3]) -> Self {
        Self {
            eye,
            forward,
            extent: None,
        }
    }

    /// Whether the box from `low` to `high` may reach into the image's frustum: no side plane
    /// of the frustum (nor the plane through the eye across the view) has it wholly outside
    /// (always, where the extent is unknown).
    pub fn sees(&self, low: [f64; 3], high: [f64; 3]) -> bool {
        let Some([right, up]) = self.extent else {
            return true;
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let f = self.forward;
        let corner = |x: f64, y: f64| -> [f64; 3] {
            std::array::from_fn(|a| f[a] + x * right[a] + y * up[a])
        };
        // The four side planes through the eye, each spanned by two corner rays, their
        // normals turned inwards (towards the center ray); and the plane across the view.
        let mut normals = [
            (1.0, 1.0, 1.0, -1.0),
            (-1.0, -1.0, -1.0, 1.0),
            (-1.0, 1.0, 1.0, 1.0),
            (1.0, -1.0, -1.0, -1.0),
        ]
        .map(|(x0, y0, x1, y1)| {
            let normal = cross(corner(x0, y0), corner(x1, y1));
            if dot(normal, f) < 0.0 {
                normal.map(|c| -c)
            } else {
                normal
            }
        })
        .to_vec();
        normals.push(f);
        normals.iter().all(|&normal| {
            // The box's corner farthest along the normal.
            let far: [f64; 3] =
                std::array::from_fn(|a| if normal[a] >= 0.0 { high[a] } else { low[a] });
            dot(normal, std::array::from_fn(|a| far[a] - self.eye[a])) >= 0.0
        })
    }

    /// 1 − cos of the angle between the view's center and `point`: 0 straight ahead.
    pub fn off_center(&self, point: [f64; 3]) -> f32 {
        let d: [f64; 3] = std::array::from_fn(|a| point[a] - self.eye[a]);
        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
        let cos =
            (d[0] * self.forward[0] + d[1] * self.forward[1] + d[2] * self.forward[2]) / length;
        (1.0 - cos) as f32
    }
}

impl ViewPoint {
    /// How the view moved from `earlier` to this one, per frame (eye and direction deltas).
    pub fn since(&self, earlier: &ViewPoint) -> ViewPoint {
        ViewPoint::new(
            std::array::from_fn(|a| self.eye[a] - earlier.eye[a]),
            std::array::from_fn(|a| self.forward[a] - earlier.forward[a]),
        )
    }

    /// The view `frames` frames on at the per-frame `motion` ([`Self::since`]).
    pub fn ahead(&self, motion: ViewPoint, frames: f64) -> ViewPoint {
        let forward: [f64; 3] =
            std::array::from_fn(|a| self.forward[a] + motion.forward[a] * frames);
        let length = forward.iter().map(|f| f * f).sum::<f64>().sqrt();
        ViewPoint {
            eye: std::array::from_fn(|a| self.eye[a] + motion.eye[a] * frames),
            forward: if length > 1e-9 {
                forward.map(|f| f / length)
            } else {
                self.forward
            },
            extent: self.extent,
        }
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
    /// The frame's rays took the maximum (MIP): a ray needs a brick only where the brick's
    /// largest value is above the ray's so far.
    pub max_projection: bool,
}

/// A brick to copy into the atlas this frame.
#[derive(Debug, Clone)]
pub struct Upload {
    pub slot: u32,
    /// The padded brick's texels ([`AtlasTexels`]).
    pub texels: Arc<[u8]>,
}

#[cfg(test)]
mod tests {
    use super::ViewPoint;

    #[test]
    fn the_view_ahead_follows_the_camera_s_motion() {
        let earlier = ViewPoint::new([0.0, 0.0, -100.0], [0.0, 0.0, 1.0]);
        let now = ViewPoint::new([2.0, 0.0, -100.0], [0.0, 0.0, 1.0]);
        let motion = now.since(&earlier);
        let ahead = now.ahead(motion, 10.0);
        assert_eq!(ahead.eye, [22.0, 0.0, -100.0]);
        // A brick the camera moves toward is nearer the view ahead's center than now.
        let coming = [40.0, 0.0, 0.0];
        assert!(ahead.off_center(coming) < now.off_center(coming));
        // Standing still, ahead is now.
        assert_eq!(now.ahead(now.since(&now), 10.0), now);
        // A turning camera turns on: its direction stays a unit vector.
        let turned = ViewPoint {
            forward: [0.1, 0.0, 0.995],
            ..now
        };
        let ahead = turned.ahead(turned.since(&now), 5.0);
        let length = ahead.forward.iter().map(|f| f * f).sum::<f64>().sqrt();
        assert!((length - 1.0).abs() < 1e-9 && ahead.forward[0] > 0.1);
    }
}

#[cfg(test)]
mod frustum_tests {
    use super::ViewPoint;

    #[test]
    fn a_view_sees_what_its_frustum_reaches() {
        // From the origin along +z, 90° wide and about 53° high (tan 1 and tan 0.5).
        let view = ViewPoint {
            extent: Some([[1.0, 0.0, 0.0], [0.0, 0.5, 0.0]]),
            ..ViewPoint::new([0.0; 3], [0.0, 0.0, 1.0])
        };
        let cube =
            |center: [f64; 3], half: f64| (center.map(|c| c - half), center.map(|c| c + half));
        let sees = |(low, high): ([f64; 3], [f64; 3])| view.sees(low, high);
        assert!(sees(cube([0.0, 0.0, 10.0], 0.5)));
        assert!(sees(cube([9.0, 4.0, 10.0], 0.5)), "inside a corner");
        assert!(!sees(cube([0.0, 8.0, 10.0], 1.0)), "above the image");
        assert!(sees(cube([0.0, 8.0, 10.0], 3.0)), "a box reaching into it");
        assert!(!sees(cube([14.0, 0.0, 10.0], 1.0)), "right of it");
        assert!(!sees(cube([0.0, 0.0, -10.0], 1.0)), "behind the eye");
        // Its extent unknown, a view sees everything.
        let unknown = ViewPoint::new([0.0; 3], [0.0, 0.0, 1.0]);
        assert!(unknown.sees([0.0, 0.0, -11.0], [1.0, 1.0, -9.0]));
    }
}
