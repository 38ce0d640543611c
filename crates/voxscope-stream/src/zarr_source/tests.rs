use super::*;

#[test]
fn copied_rows_are_the_reduction_of_one_voxel_each() {
    // A level of 70 × 70 × 67 voxels stored as 69 × 70 × 67 (a floored level): bricks at
    // the start, inside and past the end along each axis, whose aprons and clamped voxels
    // repeat edge ones, and one inside the level along every axis.
    let level = [70, 70, 67];
    let stored_dims = [69, 70, 67];
    let voxel_count: usize = stored_dims.iter().product();
    let values: Vec<u16> = (0..voxel_count)
        .map(|i| (i as u32).wrapping_mul(2_654_435_761).rotate_right(7) as u16)
        .collect();
    for brick in [
        [0, 0, 0],
        [1, 0, 0],
        [2, 1, 1],
        [1, 1, 0],
        [1, 1, 1],
        [2, 2, 2],
    ] {
        let first = brick.map(|c: usize| c * BRICK_SIZE);
        let voxels = padded_voxels(first, level);
        let (origin, size) = stored_region(&voxels, [1; 3], stored_dims);
        let mut region = Vec::with_capacity(size.iter().product());
        for z in origin[2]..origin[2] + size[2] {
            for y in origin[1]..origin[1] + size[1] {
                let row = stored_dims[0] * (y + stored_dims[1] * z);
                region.extend_from_slice(&values[row + origin[0]..row + origin[0] + size[0]]);
            }
        }
        let copied = gather_padded(region.clone(), origin, size, &voxels, stored_dims);
        for how in [Downsampling::Mean, Downsampling::Max, Downsampling::Mode] {
            let reduced = reduce_padded(&region, origin, size, &voxels, [1; 3], stored_dims, how);
            assert_eq!(copied, reduced, "brick {brick:?}, {how:?}");
        }
    }
}

#[test]
fn integer_levels_are_the_rounded_levels() {
    let cases = [
        (VoxelData::I16((i16::MIN..=i16::MAX).collect()), -32768.0),
        (VoxelData::I16((i16::MIN..=i16::MAX).collect()), -1024.0),
        (VoxelData::U16((0..=u16::MAX).collect()), 0.0),
        (VoxelData::U16((0..=u16::MAX).collect()), 100.0),
        (VoxelData::U8((0..=u8::MAX).collect()), 3.0),
        (VoxelData::I8((i8::MIN..=i8::MAX).collect()), -128.0),
        (
            VoxelData::I32(vec![i32::MIN, -70_000, -5, 0, 65_530, 65_541, i32::MAX]),
            -5.0,
        ),
        (VoxelData::U32(vec![0, 7, 65_535, 65_536, u32::MAX]), 0.0),
    ];
    for (data, offset) in cases {
        let quantization = Quantization { offset, step: 1.0 };
        let rounded: Vec<u16> = with_voxel_slice!(&data, values => values
            .iter()
            .map(|v| quantization.level(v.to_f64()))
            .collect());
        let described = format!("{data:?} at {offset}");
        assert_eq!(to_levels(data, quantization), rounded, "{described}");
    }
}

#[test]
fn covered_voxels_stay_inside_the_stored_level() {
    assert_eq!(covered(0, 0, 1, 10), (0, 0));
    assert_eq!(covered(2, 3, 4, 100), (8, 15));
    // A pyramid voxel past a floored stored level's end repeats its last voxel.
    assert_eq!(covered(5, 5, 2, 10), (9, 9));
    assert_eq!(covered(4, 4, 2, 9), (8, 8));
}

#[test]
fn thin_chunks_keep_no_faces() {
    for cube in [8, 16, 64] {
        assert!(keeps_faces([cube; 3]), "{cube}³");
    }
    assert!(keeps_faces([512, 512, 4]));
    assert!(!keeps_faces([512, 512, 2]));
    assert!(!keeps_faces([1024, 1024, 1]));
    assert!(!keeps_faces([1, 1, 1]));
}

#[test]
fn one_to_four_plane_chunks_are_thin() {
    assert!(thin_chunk([1024, 1024, 1]));
    assert!(thin_chunk([512, 512, 4]));
    assert!(!thin_chunk([512, 512, 8]));
    assert!(!thin_chunk([64, 64, 64]));
}
