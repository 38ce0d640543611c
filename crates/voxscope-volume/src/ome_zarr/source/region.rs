//! Reading a box of the input (`convert`'s slabs, a conversion part's columns), in the data's
//! units: raw files by offset (a row at a time where the box is narrower than the plane),
//! pyramids by region, folders of slices plane by plane, tiles and interpolated grids computed
//! for the box alone.

use std::io::{Read, Seek, SeekFrom};

use rayon::prelude::*;

use super::super::super::error::Problem;
use super::super::super::io::io_reason;
use super::super::super::{
    LoadError, Scalar, ValueScale, VoxelData, format_dims, with_voxel_slice,
};
use super::{Input, SlabSource, bands};

/// Where output voxel `i` of an axis `factor` times finer than `n` voxels samples the input:
/// its two neighbours and the weight of the second (voxel centres aligned, edges clamped).
fn interpolation_weights(
    n: usize,
    factor: usize,
    range: std::ops::Range<usize>,
) -> Vec<(usize, usize, f64)> {
    range
        .map(|i| {
            let at = ((i as f64 + 0.5) / factor as f64 - 0.5).clamp(0.0, (n - 1) as f64);
            let low = at.floor() as usize;
            (low, (low + 1).min(n - 1), at - low as f64)
        })
        .collect()
}

/// `size[2]` planes of `size[0] * size[1]` voxels, plane `i` filled by `fill(i, plane)`, in
/// parallel (a 4096² slab is gigabytes, which one thread wrote, and faulted in, while the
/// others waited).
fn planes_in_parallel<T: Default + Clone + Send>(
    size: [usize; 3],
    fill: impl Fn(usize, &mut [T]) + Sync,
) -> Vec<T> {
    let plane = size[0] * size[1];
    let mut out = vec![T::default(); plane * size[2]];
    out.par_chunks_mut(plane)
        .enumerate()
        .for_each(|(i, slice)| fill(i, slice));
    out
}

/// A value in [-1, 1) fixed by `index` (SplitMix64's finalizer).
fn unit_noise(index: u64) -> f64 {
    let mut z = index.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The box `origin .. origin + size` of a `dims` volume held as `values`, x fastest.
fn cropped<T: Scalar>(
    values: &[T],
    dims: [usize; 3],
    origin: [usize; 3],
    size: [usize; 3],
) -> VoxelData {
    let [x0, y0, z0] = origin;
    let [w, h, d] = size;
    if [w, h] == [dims[0], dims[1]] {
        let plane = w * h;
        return T::wrap(values[z0 * plane..(z0 + d) * plane].to_vec());
    }
    let mut out = Vec::with_capacity(w * h * d);
    for z in z0..z0 + d {
        for y in y0..y0 + h {
            let row = (z * dims[1] + y) * dims[0] + x0;
            out.extend_from_slice(&values[row..row + w]);
        }
    }
    T::wrap(out)
}

impl SlabSource {
    /// Slices `z0..z0 + count`, in the data's units ([`Self::value_scale`] applied), as
    /// [`Self::voxel_type`], x fastest.
    pub fn read(&mut self, z0: usize, count: usize) -> Result<VoxelData, LoadError> {
        self.read_box([0, 0, z0], [self.dims[0], self.dims[1], count])
    }

    /// The box `origin .. origin + size` (x, y, z; within the volume), in the data's units,
    /// as [`Self::voxel_type`], x fastest.
    pub fn read_box(
        &mut self,
        origin: [usize; 3],
        size: [usize; 3],
    ) -> Result<VoxelData, LoadError> {
        let stored = self
            .read_problem(origin, size)
            .map_err(|problem| LoadError::new(&self.name, problem))?;
        if self.value_scale == ValueScale::IDENTITY {
            return Ok(stored);
        }
        let scale = self.value_scale;
        let values: Vec<f64> = (0..stored.len())
            .into_par_iter()
            .map(|i| scale.apply(stored.get(i).unwrap_or(0.0)))
            .collect();
        Ok(VoxelData::from_f64_values(self.voxel_type, &values))
    }

    fn read_problem(&mut self, origin: [usize; 3], size: [usize; 3]) -> Result<VoxelData, Problem> {
        let dims = self.dims;
        if size.contains(&0) || (0..3).any(|a| origin[a] + size[a] > dims[a]) {
            return Err(format!(
                "the box {} at {} lies outside {}",
                format_dims(size),
                format_dims(origin),
                format_dims(dims)
            ));
        }
        let [x0, y0, z0] = origin;
        let [w, h, d] = size;
        match &mut self.input {
            Input::Memory(data) => {
                Ok(with_voxel_slice!(&*data, values => cropped(values, dims, origin, size)))
            }
            Input::Pyramid { pyramid, .. } => bands::read(pyramid, origin, size),
            Input::Raw {
                file,
                offset,
                endian,
            } => {
                let voxel = self.voxel_type.size();
                let mut bytes = vec![0u8; w * h * d * voxel];
                let failed = |e: std::io::Error| {
                    format!("cannot read slices {z0}..{}: {}", z0 + d, io_reason(&e))
                };
                let at = |x: usize, y: usize, z: usize| {
                    *offset + (((z * dims[1] + y) * dims[0] + x) * voxel) as u64
                };
                if [w, h] == [dims[0], dims[1]] {
                    file.seek(SeekFrom::Start(at(0, 0, z0)))
                        .and_then(|_| file.read_exact(&mut bytes))
                        .map_err(failed)?;
                } else if 2 * w >= dims[0] {
                    // A box at least half the plane wide: one read a plane of the span from
                    // its first row's start to its last row's end, the rows cut out of it
                    // (a system call a row cost more than the bytes between rows).
                    let span = ((h - 1) * dims[0] + w) * voxel;
                    let mut plane = vec![0u8; span];
                    for (i, rows) in bytes.chunks_exact_mut(w * h * voxel).enumerate() {
                        file.seek(SeekFrom::Start(at(x0, y0, z0 + i)))
                            .and_then(|_| file.read_exact(&mut plane))
                            .map_err(failed)?;
                        for (j, row) in rows.chunks_exact_mut(w * voxel).enumerate() {
                            let from = j * dims[0] * voxel;
                            row.copy_from_slice(&plane[from..from + w * voxel]);
                        }
                    }
                } else {
                    // One read per row (whole rows are one run: the branch above).
                    for (i, row) in bytes.chunks_exact_mut(w * voxel).enumerate() {
                        let (z, y) = (z0 + i / h, y0 + i % h);
                        file.seek(SeekFrom::Start(at(x0, y, z)))
                            .and_then(|_| file.read_exact(row))
                            .map_err(failed)?;
                    }
                }
                Ok(VoxelData::decode(self.voxel_type, &bytes, *endian))
            }
            Input::Tiled { data, tile } => {
                fn repeat<T: Scalar + Default + Send + Sync>(
                    values: &[T],
                    tile: [usize; 3],
                    origin: [usize; 3],
                    size: [usize; 3],
                ) -> VoxelData {
                    let [x0, y0, z0] = origin;
                    T::wrap(planes_in_parallel(size, |i, plane| {
                        let z = z0 + i;
                        for (j, line) in plane.chunks_exact_mut(size[0]).enumerate() {
                            let y = y0 + j;
                            let row = tile[0] * ((y % tile[1]) + tile[1] * (z % tile[2]));
                            let row = &values[row..row + tile[0]];
                            let mut x = x0;
                            let mut rest = line;
                            while !rest.is_empty() {
                                let from = x % tile[0];
                                let n = (tile[0] - from).min(rest.len());
                                let (head, tail) = rest.split_at_mut(n);
                                head.copy_from_slice(&row[from..from + n]);
                                rest = tail;
                                x += n;
                            }
                        }
                    }))
                }
                let tile = *tile;
                Ok(with_voxel_slice!(&*data, values => repeat(values, tile, origin, size)))
            }
            Input::Upsampled {
                data,
                from,
                factor,
                noise,
            } => {
                #[allow(clippy::too_many_arguments)]
                fn interpolate<T: Scalar + Default + Send + Sync>(
                    values: &[T],
                    from: [usize; 3],
                    factor: [usize; 3],
                    noise: f64,
                    dims: [usize; 3],
                    origin: [usize; 3],
                    size: [usize; 3],
                ) -> VoxelData {
                    let weights = |a: usize| {
                        interpolation_weights(from[a], factor[a], origin[a]..origin[a] + size[a])
                    };
                    let (xs, ys, zs) = (weights(0), weights(1), weights(2));
                    let integer = T::TYPE.is_integer();
                    let at = |x: usize, y: usize, z: usize| {
                        values[x + from[0] * (y + from[1] * z)].to_f64()
                    };
                    T::wrap(planes_in_parallel(size, |i, plane| {
                        let (z_low, z_high, wz) = zs[i];
                        for (j, line) in plane.chunks_exact_mut(size[0]).enumerate() {
                            let (y_low, y_high, wy) = ys[j];
                            for (k, voxel) in line.iter_mut().enumerate() {
                                let (x_low, x_high, wx) = xs[k];
                                let along_x =
                                    |y, z| at(x_low, y, z) * (1.0 - wx) + at(x_high, y, z) * wx;
                                let along_y =
                                    |z| along_x(y_low, z) * (1.0 - wy) + along_x(y_high, z) * wy;
                                let mut value = along_y(z_low) * (1.0 - wz) + along_y(z_high) * wz;
                                if noise > 0.0 {
                                    let [x, y, z] = [origin[0] + k, origin[1] + j, origin[2] + i];
                                    let index = x + dims[0] * (y + dims[1] * z);
                                    value += noise * unit_noise(index as u64);
                                }
                                *voxel = T::from_f64(if integer { value.round() } else { value });
                            }
                        }
                    }))
                }
                let (from, factor, noise) = (*from, *factor, *noise);
                Ok(
                    with_voxel_slice!(&*data, values => interpolate(values, from, factor, noise, dims, origin, size)),
                )
            }
            Input::Slices(files) => {
                let mut data: Option<VoxelData> = None;
                for file in &files[z0..z0 + d] {
                    let slice = super::super::super::slices::read_slice(file)
                        .map_err(|p| format!("slice {}: {p}", file.display()))?;
                    if slice.dims != [dims[0], dims[1], 1] {
                        return Err(format!(
                            "slice {} is {} but the first is {}x{}x1",
                            file.display(),
                            format_dims(slice.dims),
                            dims[0],
                            dims[1]
                        ));
                    }
                    if slice.data.voxel_type() != self.voxel_type {
                        return Err(format!(
                            "slice {} holds {} values but the first holds {}",
                            file.display(),
                            slice.data.voxel_type().name(),
                            self.voxel_type.name()
                        ));
                    }
                    let part = with_voxel_slice!(&slice.data, values => cropped(values, slice.dims, [x0, y0, 0], [w, h, 1]));
                    match &mut data {
                        None => data = Some(part),
                        Some(data) => data
                            .append(part)
                            .map_err(|_| "slices of two types".to_owned())?,
                    }
                }
                data.ok_or_else(|| "no slices".to_owned())
            }
        }
    }
}
