//! The sample volume built into the binary, shown when no file is given.

use super::{LoadError, Volume};

/// Name under which the sample appears in `info` and the app.
pub const SAMPLE_NAME: &str = "sample:mri-head-128x128x62";

/// T1 MRI of a head from the Insight Toolkit's examples (Apache-2.0; see assets/README.md).
const SAMPLE_NIFTI: &[u8] = include_bytes!("../../../assets/mri-head-128x128x62.nii.gz");

/// Decodes the embedded sample volume.
pub fn sample() -> Result<Volume, LoadError> {
    super::nifti::decode(SAMPLE_NAME, SAMPLE_NIFTI, None)
        .map_err(|p| LoadError::new(SAMPLE_NAME, p))
}
