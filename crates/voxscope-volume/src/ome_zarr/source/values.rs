//! The type `convert` writes an input's values as, where the input stores them with a scale.

use rayon::prelude::*;

use crate::{ValueScale, VoxelData, VoxelType};

/// The type `data`'s values take in their units through `scale`: the stored type where the
/// scale is the identity; an integer type where the scale maps integers to integers (integer
/// slope and intercept: a CT's Hounsfield units) and every mapped value fits it (the stored
/// type if it does, else the smallest of u8, i8, u16, i16, u32, i32 that does); else f32.
pub fn scaled_type(data: &VoxelData, scale: ValueScale) -> VoxelType {
    let stored = data.voxel_type();
    if scale == ValueScale::IDENTITY {
        return stored;
    }
    let integral = |v: f64| v.is_finite() && v.fract() == 0.0;
    if !stored.is_integer() || !integral(scale.slope) || !integral(scale.intercept) {
        return VoxelType::F32;
    }
    let (low, high) = (0..data.len())
        .into_par_iter()
        .map(|i| data.get(i).unwrap_or(0.0))
        .fold(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |(low, high), v| (low.min(v), high.max(v)),
        )
        .reduce(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    if low > high {
        return stored;
    }
    let (a, b) = (scale.apply(low), scale.apply(high));
    let (low, high) = (a.min(b), a.max(b));
    let fits = |t: VoxelType| {
        let (min, max) = match t {
            VoxelType::U8 => (0.0, u8::MAX as f64),
            VoxelType::I8 => (i8::MIN as f64, i8::MAX as f64),
            VoxelType::U16 => (0.0, u16::MAX as f64),
            VoxelType::I16 => (i16::MIN as f64, i16::MAX as f64),
            VoxelType::U32 => (0.0, u32::MAX as f64),
            VoxelType::I32 => (i32::MIN as f64, i32::MAX as f64),
            VoxelType::F32 | VoxelType::F64 => return false,
        };
        min <= low && high <= max
    };
    std::iter::once(stored)
        .chain([
            VoxelType::U8,
            VoxelType::I8,
            VoxelType::U16,
            VoxelType::I16,
            VoxelType::U32,
            VoxelType::I32,
        ])
        .find(|&t| fits(t))
        .unwrap_or(VoxelType::F32)
}
