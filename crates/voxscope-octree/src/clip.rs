//! Clipping: a crop box and one clip plane, in normalized volume coordinates (0…1 along each
//! axis, whatever the voxel counts and spacing), that the ray casters honor and the level
//! statistics count within.

use serde::{Deserialize, Serialize};

/// The part of a volume that is drawn: inside the crop box and on the kept side of the plane.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Clip {
    /// Per axis, the kept fraction `[low, high]` of the volume (0…1).
    pub bounds: Option<[[f32; 2]; 3]>,
    /// A plane; the side where `normal · p ≥ distance` is kept.
    pub plane: Option<ClipPlane>,
}

/// A clip plane in normalized volume coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClipPlane {
    /// Its normal (need not be unit length; never zero).
    pub normal: [f32; 3],
    /// `normal · p` on the plane.
    pub distance: f32,
}

impl Clip {
    /// Nothing clipped.
    pub const NONE: Self = Self {
        bounds: None,
        plane: None,
    };

    /// True when something is clipped away.
    pub fn is_active(&self) -> bool {
        self.bounds.is_some() || self.plane.is_some()
    }

    /// The crop box, `[low, high]` per axis, full where there is none.
    pub fn box_fractions(&self) -> [[f32; 2]; 3] {
        self.bounds.unwrap_or([[0.0, 1.0]; 3])
    }

    /// Whether the cell `[corner, corner + size]` (voxel units) of a volume of `dims` voxels
    /// has a part of positive volume inside the clip region (touching its boundary is not
    /// enough: a ray crosses none of such a cell).
    pub fn touches_cell(&self, corner: [f64; 3], size: f64, dims: [usize; 3]) -> bool {
        let fractions = self.box_fractions();
        let mut low = [0.0f64; 3];
        let mut high = [0.0f64; 3];
        for axis in 0..3 {
            let d = dims[axis] as f64;
            // The cell's extent in normalized coordinates, cut to the box.
            low[axis] = (corner[axis] / d).max(fractions[axis][0] as f64);
            high[axis] = ((corner[axis] + size) / d).min(fractions[axis][1] as f64);
            if low[axis] >= high[axis] {
                return false;
            }
        }
        match self.plane {
            None => true,
            Some(plane) => {
                // The largest n·p over the (cut) cell is at the corner the normal points to.
                let reach: f64 = (0..3)
                    .map(|a| {
                        let n = plane.normal[a] as f64;
                        n * if n >= 0.0 { high[a] } else { low[a] }
                    })
                    .sum();
                reach > plane.distance as f64
            }
        }
    }

    /// Parses the command line's crop box `X0:X1,Y0:Y1,Z0:Z1` (fractions 0…1).
    pub fn parse_box(text: &str) -> Result<[[f32; 2]; 3], ClipError> {
        let axes: Vec<&str> = text.split(',').collect();
        let [x, y, z] = axes[..] else {
            return Err(ClipError::NotBox(text.to_owned()));
        };
        let range = |part: &str| -> Result<[f32; 2], ClipError> {
            let (low, high) = part
                .split_once(':')
                .ok_or_else(|| ClipError::NotRange(part.to_owned()))?;
            let low: f32 = low
                .trim()
                .parse()
                .map_err(|_| ClipError::NotNumber(low.to_owned()))?;
            let high: f32 = high
                .trim()
                .parse()
                .map_err(|_| ClipError::NotNumber(high.to_owned()))?;
            if !(0.0..=1.0).contains(&low) || !(0.0..=1.0).contains(&high) || low >= high {
                return Err(ClipError::RangeOutside(part.to_owned()));
            }
            Ok([low, high])
        };
        Ok([range(x)?, range(y)?, range(z)?])
    }

    /// Parses the command line's plane `NX,NY,NZ,D` (normalized volume coordinates).
    pub fn parse_plane(text: &str) -> Result<ClipPlane, ClipError> {
        let values: Vec<f32> = text
            .split(',')
            .map(|v| v.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| ClipError::NotPlane(text.to_owned()))?;
        let [nx, ny, nz, d] = values[..] else {
            return Err(ClipError::NotPlane(text.to_owned()));
        };
        let normal = [nx, ny, nz];
        if normal.iter().chain([&d]).any(|v| !v.is_finite()) || normal == [0.0; 3] {
            return Err(ClipError::NoNormal(text.to_owned()));
        }
        Ok(ClipPlane {
            normal,
            distance: d,
        })
    }
}

/// Why the command line's crop box or clip plane text was refused: displays as the one line
/// shown after the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ClipError {
    /// A box that is not three comma-separated ranges.
    #[error("'{0}' is not X0:X1,Y0:Y1,Z0:Z1")]
    NotBox(String),
    /// One axis's range without its `:`.
    #[error("'{0}' is not LOW:HIGH")]
    NotRange(String),
    /// A bound that is not a number.
    #[error("'{0}' is not a number")]
    NotNumber(String),
    /// A range that is not within 0…1, low below high.
    #[error("'{0}' needs 0 ≤ LOW < HIGH ≤ 1 (fractions of the axis)")]
    RangeOutside(String),
    /// A plane that is not four numbers.
    #[error("'{0}' is not NX,NY,NZ,D (four numbers)")]
    NotPlane(String),
    /// A plane whose normal is zero or not finite.
    #[error("'{0}': the normal must be finite and not zero")]
    NoNormal(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_inside_and_outside_the_box_and_plane() {
        let dims = [100, 100, 100];
        let clip = Clip {
            bounds: Some([[0.5, 1.0], [0.0, 1.0], [0.0, 1.0]]),
            plane: None,
        };
        assert!(clip.touches_cell([60.0, 0.0, 0.0], 10.0, dims));
        assert!(
            clip.touches_cell([45.0, 0.0, 0.0], 10.0, dims),
            "straddles x = 0.5"
        );
        assert!(!clip.touches_cell([10.0, 0.0, 0.0], 10.0, dims));
        let plane = Clip {
            bounds: None,
            plane: Some(ClipPlane {
                normal: [0.0, 0.0, -1.0],
                distance: -0.25,
            }),
        };
        // Keeps z ≤ 0.25.
        assert!(plane.touches_cell([0.0, 0.0, 20.0], 5.0, dims));
        assert!(!plane.touches_cell([0.0, 0.0, 40.0], 5.0, dims));
        assert!(
            !plane.touches_cell([0.0, 0.0, 25.0], 5.0, dims),
            "touches z = 0.25 only"
        );
        assert!(Clip::NONE.touches_cell([500.0; 3], 1.0, [1000; 3]));
    }

    #[test]
    fn command_line_forms_parse_and_refuse_nonsense() {
        assert_eq!(
            Clip::parse_box("0:0.5, 0.25:1,0:1").expect("parses"),
            [[0.0, 0.5], [0.25, 1.0], [0.0, 1.0]]
        );
        for bad in ["0:1,0:1", "0:1,0:1,1:0", "0:2,0:1,0:1", "a:1,0:1,0:1"] {
            assert!(Clip::parse_box(bad).is_err(), "{bad}");
        }
        let plane = Clip::parse_plane("1,0,0,0.5").expect("parses");
        assert_eq!(plane.normal, [1.0, 0.0, 0.0]);
        for bad in ["1,0,0", "0,0,0,1", "1,0,0,x"] {
            assert!(Clip::parse_plane(bad).is_err(), "{bad}");
        }
    }
}
