//! The orbit camera: it looks at the volume's center (plus a pan offset) from a direction given
//! by azimuth and elevation, at a distance measured in bounding-sphere radii.
//!
//! World space is the volume's physical space (spacing applied), centered on the volume, with
//! +z up. For RAS volumes (NIfTI, NRRD with a space) azimuth 0 looks at the face from the front
//! (anterior), azimuth 90 from the patient's right, and the head stands upright.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// An orbit camera around the volume.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Rotation around +z in degrees; 0 puts the eye on +y.
    pub azimuth_deg: f64,
    /// Angle above the xy plane in degrees (clamped short of the poles).
    pub elevation_deg: f64,
    /// Distance from the look-at point in bounding-sphere radii.
    pub distance: f64,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f64,
    /// Offset of the look-at point from the volume center, in world units (panning).
    pub pan: [f64; 3],
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            azimuth_deg: 30.0,
            elevation_deg: 20.0,
            distance: 3.0,
            fov_y_deg: 45.0,
            pan: [0.0; 3],
        }
    }
}

/// A camera resolved for one volume and image shape: eye and orthonormal basis in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewFrame {
    pub eye: DVec3,
    /// Unit view direction at the image center.
    pub forward: DVec3,
    /// Unit vector to the image's right.
    pub right: DVec3,
    /// Unit vector to the image's top.
    pub up: DVec3,
    /// `tan(fov_y / 2)`.
    pub tan_half_fov_y: f64,
    /// Width / height.
    pub aspect: f64,
}

impl ViewFrame {
    /// World direction (not unit length; `forward` has length 1) of the ray through normalized
    /// device coordinates `ndc` (x right, y up, both −1…1).
    pub fn ray_direction(&self, ndc_x: f64, ndc_y: f64) -> DVec3 {
        self.forward
            + self.right * (ndc_x * self.tan_half_fov_y * self.aspect)
            + self.up * (ndc_y * self.tan_half_fov_y)
    }

    /// NDC of the center of pixel (`x`, `y`) in an image `width`×`height`, row 0 at the top.
    pub fn pixel_ndc(x: u32, y: u32, width: u32, height: u32) -> (f64, f64) {
        (
            2.0 * (x as f64 + 0.5) / width as f64 - 1.0,
            1.0 - 2.0 * (y as f64 + 0.5) / height as f64,
        )
    }
}

impl Camera {
    /// The view of a volume whose physical size is `extent`, for an image of `aspect`.
    pub fn frame(&self, extent: [f64; 3], aspect: f64) -> ViewFrame {
        let radius = 0.5 * DVec3::from(extent).length();
        let azimuth = self.azimuth_deg.to_radians();
        let elevation = self.elevation_deg.clamp(-89.9, 89.9).to_radians();
        let target = DVec3::from(self.pan);
        let toward_eye = DVec3::new(
            azimuth.sin() * elevation.cos(),
            azimuth.cos() * elevation.cos(),
            elevation.sin(),
        );
        let eye = target + toward_eye * (self.distance * radius);
        let forward = -toward_eye;
        let right = forward.cross(DVec3::Z).normalize();
        let up = right.cross(forward);
        ViewFrame {
            eye,
            forward,
            right,
            up,
            tan_half_fov_y: (self.fov_y_deg.clamp(1.0, 170.0).to_radians() * 0.5).tan(),
            aspect,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn azimuth_zero_looks_from_the_front_with_patient_left_on_the_right() {
        let frame = Camera {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            ..Camera::default()
        }
        .frame([2.0, 2.0, 2.0], 1.0);
        assert!((frame.eye - DVec3::new(0.0, 3.0 * 3f64.sqrt(), 0.0)).length() < 1e-9);
        assert!((frame.forward - DVec3::NEG_Y).length() < 1e-12);
        // Screen right is −x: the patient's left, as when facing a person.
        assert!((frame.right - DVec3::NEG_X).length() < 1e-12);
        assert!((frame.up - DVec3::Z).length() < 1e-12);
    }
}
