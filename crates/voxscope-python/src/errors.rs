//! voxscope's exceptions: one class per kind of failure callers tell apart, each carrying the
//! one-line message the command line prints for it. Bad keyword values are `ValueError`s
//! and wrong types `TypeError`s, as in any Python library.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use voxscope_render::RenderError as GpuError;
use voxscope_scene::SceneError;

create_exception!(
    voxscope,
    VoxscopeError,
    PyException,
    "A voxscope operation failed; the message is the command line's one line for it."
);
create_exception!(
    voxscope,
    LoadError,
    VoxscopeError,
    "A file, folder, store or URL could not be read: the message names it and the problem."
);
create_exception!(
    voxscope,
    RenderError,
    VoxscopeError,
    "The GPU could not hold or draw the volume (no device, too large for it, lost)."
);

/// A renderer's error about `volume`.
pub fn gpu_error(volume: &str, error: GpuError) -> PyErr {
    match error {
        GpuError::NoDevice(message) => RenderError::new_err(message),
        error => RenderError::new_err(format!("{volume}: {error}")),
    }
}

/// A loader's error (one line naming the file).
pub fn load_error(error: voxscope_volume::LoadError) -> PyErr {
    LoadError::new_err(error.to_string())
}

/// Registers the exception classes in the module.
pub fn register(module: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = module.py();
    module.add("VoxscopeError", py.get_type::<VoxscopeError>())?;
    module.add("LoadError", py.get_type::<LoadError>())?;
    module.add("RenderError", py.get_type::<RenderError>())?;
    Ok(())
}

/// Why drawing could not start, by whose fault: the input (a file, store or `tf` file not
/// read), the GPU, or a value asked for; each a one-line message.
#[derive(Debug)]
pub enum Failure {
    Load(String),
    Render(String),
    Value(String),
}

impl From<SceneError> for Failure {
    fn from(error: SceneError) -> Self {
        match error {
            SceneError::Load(_) | SceneError::Stream(_) | SceneError::TransferFile(_) => {
                Self::Load(error.to_string())
            }
            SceneError::Render { .. } | SceneError::Gpu(_) => Self::Render(error.to_string()),
            // The command line's words name its options; these name the keywords.
            SceneError::CompositeNeedsDense { channels, renderer } => Self::Value(format!(
                "the composite of {channels} channels is drawn by the dense renderer; renderer=\"{}\" draws one channel (channel=N)",
                renderer.name()
            )),
            SceneError::NoChosenChannel { channel, count } => Self::Value(format!(
                "channels: the file has no channel {channel} ({count} channels, 0 to {})",
                count.saturating_sub(1)
            )),
            SceneError::Cancelled
            | SceneError::Invalid(_)
            | SceneError::NoSuchChannel { .. }
            | SceneError::TooManyColors { .. }
            | SceneError::Source(_)
            | SceneError::Labels(_)
            | SceneError::LabelsRefused { .. }
            | SceneError::BeyondOctree(_)
            | SceneError::Failed(_) => Self::Value(error.to_string()),
        }
    }
}

impl From<Failure> for PyErr {
    fn from(failure: Failure) -> Self {
        match failure {
            Failure::Load(message) => LoadError::new_err(message),
            Failure::Render(message) => RenderError::new_err(message),
            Failure::Value(message) => pyo3::exceptions::PyValueError::new_err(message),
        }
    }
}
