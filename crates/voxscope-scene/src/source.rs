//! What to open: the embedded sample, or a path, URL or synthetic spec.

use voxscope_volume::ome_zarr;
use voxscope_volume::{LoadOptions, Selection, Volume};

use crate::SceneError;

/// What to open: the embedded sample or a file path / URL / synthetic spec.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VolumeSource {
    Sample,
    Spec(String),
}

impl VolumeSource {
    /// The spec as the command line and the recent list write it (`sample` for the sample).
    pub fn spec(&self) -> &str {
        match self {
            Self::Sample => "sample",
            Self::Spec(spec) => spec,
        }
    }

    /// The inverse of [`Self::spec`].
    pub fn from_spec(spec: &str) -> Self {
        if spec == "sample" {
            Self::Sample
        } else {
            Self::Spec(spec.to_owned())
        }
    }

    /// The Zarr store this source names (a folder or a URL), if it names one.
    pub fn zarr_spec(&self) -> Option<&str> {
        match self {
            Self::Sample => None,
            Self::Spec(spec) => Some(spec.as_str()).filter(|s| ome_zarr::is_zarr_spec(s)),
        }
    }

    /// Reads the frame `select` names (the sample has one).
    pub fn load(&self, select: Selection) -> Result<Volume, SceneError> {
        self.load_with(&LoadOptions {
            select,
            ..LoadOptions::default()
        })
    }

    /// Reads the volume with `options` (a raw layout, a spacing, a remote store's limits).
    pub fn load_with(&self, options: &LoadOptions) -> Result<Volume, SceneError> {
        Ok(match self {
            Self::Sample => voxscope_volume::sample(),
            Self::Spec(spec) => voxscope_volume::load(spec, options),
        }?)
    }
}
