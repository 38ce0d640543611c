//! The scalar types a volume file can store, and the typed voxel storage.

use rayon::prelude::*;

/// The voxel type stored in the file (kept as is in memory; no widening on load).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VoxelType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl VoxelType {
    /// Every supported type, for tests and help texts.
    pub const ALL: [VoxelType; 8] = [
        Self::U8,
        Self::I8,
        Self::U16,
        Self::I16,
        Self::U32,
        Self::I32,
        Self::F32,
        Self::F64,
    ];

    /// Bytes per voxel.
    pub fn size(self) -> usize {
        match self {
            Self::U8 | Self::I8 => 1,
            Self::U16 | Self::I16 => 2,
            Self::U32 | Self::I32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    /// The short name used on the command line and in `info --json` (`u8`, `i16`, `f32`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::U8 => "u8",
            Self::I8 => "i8",
            Self::U16 => "u16",
            Self::I16 => "i16",
            Self::U32 => "u32",
            Self::I32 => "i32",
            Self::F32 => "f32",
            Self::F64 => "f64",
        }
    }

    /// Parses a short name (`u8`, `i16`, …) as printed by [`Self::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// True for integer types: their values are exact in the octree's 16-bit statistics
    /// when the value range spans at most 65 536 values.
    pub fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
}

/// Byte order of stored multi-byte voxels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Endian {
    Little,
    Big,
}

/// The voxels of a volume in their stored type, x fastest, then y, then z.
#[derive(Debug, Clone, PartialEq)]
pub enum VoxelData {
    U8(Vec<u8>),
    I8(Vec<i8>),
    U16(Vec<u16>),
    I16(Vec<i16>),
    U32(Vec<u32>),
    I32(Vec<i32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

/// Runs `$body` with `$values` bound to the typed slice inside a [`VoxelData`].
#[macro_export]
macro_rules! with_voxel_slice {
    ($data:expr, $values:ident => $body:expr) => {
        match $data {
            $crate::VoxelData::U8($values) => $body,
            $crate::VoxelData::I8($values) => $body,
            $crate::VoxelData::U16($values) => $body,
            $crate::VoxelData::I16($values) => $body,
            $crate::VoxelData::U32($values) => $body,
            $crate::VoxelData::I32($values) => $body,
            $crate::VoxelData::F32($values) => $body,
            $crate::VoxelData::F64($values) => $body,
        }
    };
}

/// A stored scalar: converts to `f64` and decodes from bytes of either order.
pub trait Scalar: Copy + Send + Sync + 'static {
    /// Its [`VoxelType`].
    const TYPE: VoxelType;
    /// The value as `f64` (exact for every type but `u64`-sized ones, which we do not have).
    fn to_f64(self) -> f64;
    /// Decodes one value from exactly `size_of::<Self>()` bytes.
    fn decode(bytes: &[u8], endian: Endian) -> Self;
    /// Converts from `f64`, saturating (used by synthetic volumes and tests).
    fn from_f64(value: f64) -> Self;
    /// Encodes into bytes (used by tests that write files).
    fn encode(self, endian: Endian) -> Vec<u8>;
    /// Wraps a vector of this type.
    fn wrap(values: Vec<Self>) -> VoxelData;
}

macro_rules! impl_scalar {
    ($t:ty, $variant:ident) => {
        impl Scalar for $t {
            const TYPE: VoxelType = VoxelType::$variant;
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn decode(bytes: &[u8], endian: Endian) -> Self {
                let array = bytes
                    .try_into()
                    .expect("caller passes exactly one value's bytes");
                match endian {
                    Endian::Little => <$t>::from_le_bytes(array),
                    Endian::Big => <$t>::from_be_bytes(array),
                }
            }
            #[inline]
            fn from_f64(value: f64) -> Self {
                value as $t
            }
            fn encode(self, endian: Endian) -> Vec<u8> {
                match endian {
                    Endian::Little => self.to_le_bytes().to_vec(),
                    Endian::Big => self.to_be_bytes().to_vec(),
                }
            }
            fn wrap(values: Vec<Self>) -> VoxelData {
                VoxelData::$variant(values)
            }
        }
    };
}
impl_scalar!(u8, U8);
impl_scalar!(i8, I8);
impl_scalar!(u16, U16);
impl_scalar!(i16, I16);
impl_scalar!(u32, U32);
impl_scalar!(i32, I32);
impl_scalar!(f32, F32);
impl_scalar!(f64, F64);

impl VoxelData {
    /// Decodes `bytes` (exactly `count * type.size()` of them) into typed voxels.
    pub fn decode(voxel_type: VoxelType, bytes: &[u8], endian: Endian) -> Self {
        fn decode_as<T: Scalar>(bytes: &[u8], endian: Endian) -> VoxelData {
            let size = std::mem::size_of::<T>();
            T::wrap(
                bytes
                    .par_chunks_exact(size)
                    .map(|chunk| T::decode(chunk, endian))
                    .collect(),
            )
        }
        match voxel_type {
            VoxelType::U8 => VoxelData::U8(bytes.to_vec()),
            VoxelType::I8 => decode_as::<i8>(bytes, endian),
            VoxelType::U16 => decode_as::<u16>(bytes, endian),
            VoxelType::I16 => decode_as::<i16>(bytes, endian),
            VoxelType::U32 => decode_as::<u32>(bytes, endian),
            VoxelType::I32 => decode_as::<i32>(bytes, endian),
            VoxelType::F32 => decode_as::<f32>(bytes, endian),
            VoxelType::F64 => decode_as::<f64>(bytes, endian),
        }
    }

    /// The stored type.
    pub fn voxel_type(&self) -> VoxelType {
        fn type_of<T: Scalar>(_: &[T]) -> VoxelType {
            T::TYPE
        }
        with_voxel_slice!(self, values => type_of(values))
    }

    /// `values` converted to `voxel_type` (saturating), e.g. from an ascii file.
    pub fn from_f64_values(voxel_type: VoxelType, values: &[f64]) -> Self {
        fn convert<T: Scalar>(values: &[f64]) -> VoxelData {
            T::wrap(values.iter().map(|&v| T::from_f64(v)).collect())
        }
        match voxel_type {
            VoxelType::U8 => convert::<u8>(values),
            VoxelType::I8 => convert::<i8>(values),
            VoxelType::U16 => convert::<u16>(values),
            VoxelType::I16 => convert::<i16>(values),
            VoxelType::U32 => convert::<u32>(values),
            VoxelType::I32 => convert::<i32>(values),
            VoxelType::F32 => convert::<f32>(values),
            VoxelType::F64 => convert::<f64>(values),
        }
    }

    /// Appends `other`'s voxels; `Err(other)` back when its type differs.
    pub fn append(&mut self, other: VoxelData) -> Result<(), VoxelData> {
        match (self, other) {
            (Self::U8(s), Self::U8(o)) => s.extend(o),
            (Self::I8(s), Self::I8(o)) => s.extend(o),
            (Self::U16(s), Self::U16(o)) => s.extend(o),
            (Self::I16(s), Self::I16(o)) => s.extend(o),
            (Self::U32(s), Self::U32(o)) => s.extend(o),
            (Self::I32(s), Self::I32(o)) => s.extend(o),
            (Self::F32(s), Self::F32(o)) => s.extend(o),
            (Self::F64(s), Self::F64(o)) => s.extend(o),
            (_, other) => return Err(other),
        }
        Ok(())
    }

    /// No voxels, same type: keeps a volume's description once its voxels are not needed.
    pub fn emptied(&self) -> Self {
        Self::decode(self.voxel_type(), &[], Endian::Little)
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        with_voxel_slice!(self, values => values.len())
    }

    /// True when there are no voxels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The stored value at linear index `index`, as `f64` (slow path: tests and probes).
    pub fn get(&self, index: usize) -> Option<f64> {
        with_voxel_slice!(self, values => values.get(index).map(|v| v.to_f64()))
    }

    /// A copy with voxels picked by `source_index` (used to reorient volumes).
    pub fn gather(&self, count: usize, source_index: impl Fn(usize) -> usize + Sync) -> Self {
        fn gather_as<T: Scalar>(
            values: &[T],
            count: usize,
            source_index: &(impl Fn(usize) -> usize + Sync),
        ) -> VoxelData {
            T::wrap(
                (0..count)
                    .into_par_iter()
                    .map(|i| values[source_index(i)])
                    .collect(),
            )
        }
        with_voxel_slice!(self, values => gather_as(values, count, &source_index))
    }
}
