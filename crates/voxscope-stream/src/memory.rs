//! A volume already in memory (any loader's) as a brick source: level 0 is its quantized
//! voxels, the coarser levels are computed here (2× mean, or max for label volumes). So a
//! volume larger than the GPU budget streams like any other pyramid, and the octree's 1024 per
//! axis does not bound it.

use super::pyramid::{Downsampling, PyramidShape, coarser_levels, cut_brick};
use crate::{BrickData, BrickError, BrickId, BrickSource, SourceError};
use voxscope_volume::{Quantization, QuantizedVolume};

/// Every level of a pyramid, held whole in memory.
pub struct MemorySource {
    name: String,
    shape: PyramidShape,
    /// Each level's value levels, x fastest, finest first.
    levels: Vec<Vec<u16>>,
    spacing: [f64; 3],
    quantization: Quantization,
    max_value_level: u16,
    /// How the coarser levels were reduced ([`Downsampling::Mode`]: labels).
    how: Downsampling,
}

impl MemorySource {
    /// The pyramid of `quantized` (its levels are copied; see [`Self::from_levels`] to hand
    /// them over), each coarser level reduced by `how`.
    pub fn new(
        name: &str,
        quantized: &QuantizedVolume,
        spacing: [f64; 3],
        how: Downsampling,
    ) -> Result<Self, SourceError> {
        Self::from_levels(
            name,
            quantized.levels.clone(),
            quantized.dims,
            quantized.quantization,
            spacing,
            how,
        )
    }

    /// The pyramid whose level 0 is `levels` (`dims`, x fastest, in `quantization`).
    pub fn from_levels(
        name: &str,
        levels: Vec<u16>,
        dims: [usize; 3],
        quantization: Quantization,
        spacing: [f64; 3],
        how: Downsampling,
    ) -> Result<Self, SourceError> {
        let shape = PyramidShape::new(dims).map_err(SourceError::shape(name))?;
        if levels.len() != dims.iter().product::<usize>() {
            return Err(SourceError::LevelCount {
                name: name.to_owned(),
                count: levels.len(),
                dims,
            });
        }
        let max_value_level = levels.iter().copied().max().unwrap_or(0);
        let coarser = coarser_levels(&levels, dims, how, shape.levels.len() - 1);
        let mut all = vec![levels];
        for (level, (coarser, coarser_dims)) in coarser.into_iter().enumerate() {
            debug_assert_eq!(coarser_dims, shape.levels[level + 1].dims);
            all.push(coarser);
        }
        Ok(Self {
            name: name.to_owned(),
            shape,
            levels: all,
            spacing,
            quantization,
            max_value_level,
            how,
        })
    }

    /// The value levels of pyramid level `level`, x fastest (its dims are the shape's).
    pub fn level(&self, level: usize) -> Option<&[u16]> {
        self.levels.get(level).map(Vec::as_slice)
    }
}

impl BrickSource for MemorySource {
    fn name(&self) -> &str {
        &self.name
    }

    fn shape(&self) -> &PyramidShape {
        &self.shape
    }

    fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    fn quantization(&self) -> Quantization {
        self.quantization
    }

    fn max_value_level(&self) -> u16 {
        self.max_value_level
    }

    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        let (Some(levels), Some(_)) = (self.levels.get(id.level as usize), self.shape.key(id))
        else {
            return Err(BrickError::invalid(format!("{}: no {id}", self.name)));
        };
        Ok(cut_brick(
            levels,
            self.shape.levels[id.level as usize].dims,
            id.brick,
        ))
    }

    /// Labels where the levels were reduced by their mode.
    fn labels(&self) -> bool {
        self.how == Downsampling::Mode
    }
}
