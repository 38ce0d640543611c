//! Reordering a volume's axes to RAS (x → patient right, y → anterior, z → superior), the
//! nearest axis-aligned version of the orientation its header gives.

use super::Volume;

/// What loading did to the stored axis order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Orientation {
    /// Axes as stored in the file (no orientation known, or already RAS).
    AsStored,
    /// The stored axes pointed to these directions (e.g. `LIA`) and were reordered to RAS.
    Reoriented { stored: String },
}

impl Orientation {
    /// A short description for `info`.
    pub fn describe(&self) -> String {
        match self {
            Self::AsStored => "as stored".to_owned(),
            Self::Reoriented { stored } => format!("stored {stored}, shown RAS"),
        }
    }
}

/// Reorders `volume` so its index axes run along RAS. `directions[i]` is the RAS direction of
/// increasing index `i` (a column of the NIfTI affine, or an NRRD space direction in RAS).
/// Oblique directions snap to the nearest axis; a degenerate matrix leaves the volume as is.
pub(crate) fn reorient_to_ras(volume: Volume, directions: [[f64; 3]; 3]) -> Volume {
    let Some(axes) = nearest_axes(directions) else {
        return volume;
    };
    let stored: String = axes
        .iter()
        .map(|&(world, positive)| match (world, positive) {
            (0, true) => 'R',
            (0, false) => 'L',
            (1, true) => 'A',
            (1, false) => 'P',
            (2, true) => 'S',
            _ => 'I',
        })
        .collect();
    if stored == "RAS" {
        return volume;
    }
    // For each new (world) axis: which stored axis feeds it and whether it runs backwards.
    let mut source_axis = [0usize; 3];
    let mut flipped = [false; 3];
    for (stored_axis, &(world, positive)) in axes.iter().enumerate() {
        source_axis[world] = stored_axis;
        flipped[world] = !positive;
    }
    let old_dims = volume.dims;
    let dims: [usize; 3] = std::array::from_fn(|w| old_dims[source_axis[w]]);
    let spacing: [f64; 3] = std::array::from_fn(|w| volume.spacing[source_axis[w]]);
    let old_strides = [1, old_dims[0], old_dims[0] * old_dims[1]];
    let count = volume.voxel_count();
    let data = volume.data.gather(count, |n| {
        let new = [
            n % dims[0],
            (n / dims[0]) % dims[1],
            n / (dims[0] * dims[1]),
        ];
        (0..3)
            .map(|w| {
                let coord = if flipped[w] {
                    dims[w] - 1 - new[w]
                } else {
                    new[w]
                };
                coord * old_strides[source_axis[w]]
            })
            .sum()
    });
    Volume {
        dims,
        spacing,
        data,
        orientation: Orientation::Reoriented { stored },
        ..volume
    }
}

/// Whether [`reorient_to_ras`] leaves a volume of these `directions` as stored (already RAS,
/// or degenerate), so its voxels can be read in place.
pub(crate) fn keeps_stored_order(directions: [[f64; 3]; 3]) -> bool {
    nearest_axes(directions).is_none_or(|axes| axes == [(0, true), (1, true), (2, true)])
}

/// For each stored axis, the world axis it runs along most and whether in the positive sense;
/// `None` when two stored axes would share one world axis (degenerate input).
fn nearest_axes(directions: [[f64; 3]; 3]) -> Option<[(usize, bool); 3]> {
    let mut taken = [false; 3];
    let mut result = [(0, true); 3];
    // Assign the strongest components first so oblique matrices still give a permutation.
    let mut candidates: Vec<(f64, usize, usize)> = (0..3)
        .flat_map(|i| (0..3).map(move |w| (i, w)))
        .map(|(i, w)| (directions[i][w].abs(), i, w))
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut assigned = [false; 3];
    for (magnitude, i, w) in candidates {
        if assigned[i] || taken[w] || magnitude.is_nan() || magnitude <= 0.0 {
            continue;
        }
        assigned[i] = true;
        taken[w] = true;
        result[i] = (w, directions[i][w] > 0.0);
    }
    assigned.iter().all(|&a| a).then_some(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::VoxelData;

    #[test]
    fn lia_volume_becomes_ras() {
        // 2x3x4 volume whose value encodes its stored coordinates.
        let dims = [2, 3, 4];
        let data: Vec<u16> = (0..24).collect();
        let volume = Volume::new("t", "test", dims, [1.0, 2.0, 3.0], VoxelData::U16(data)).unwrap();
        // Stored x runs to the left, y inferior, z anterior (FreeSurfer's LIA).
        let lia = [[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
        let ras = reorient_to_ras(volume.clone(), lia);
        assert_eq!(ras.dims, [2, 4, 3]);
        assert_eq!(ras.spacing, [1.0, 3.0, 2.0]);
        assert_eq!(
            ras.orientation,
            Orientation::Reoriented {
                stored: "LIA".into()
            }
        );
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..2 {
                    // new x = flipped stored x; new y (anterior) = stored z; new z (superior) = flipped stored y.
                    let expected = volume.value(1 - x, 2 - z, y).unwrap();
                    assert_eq!(ras.value(x, y, z).unwrap(), expected);
                }
            }
        }
    }

    #[test]
    fn ras_and_degenerate_stay_as_stored() {
        let volume =
            Volume::new("t", "test", [2, 2, 2], [1.0; 3], VoxelData::U8(vec![0; 8])).unwrap();
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(
            reorient_to_ras(volume.clone(), identity).orientation,
            Orientation::AsStored
        );
        assert_eq!(
            reorient_to_ras(volume, [[0.0; 3]; 3]).orientation,
            Orientation::AsStored
        );
    }
}
