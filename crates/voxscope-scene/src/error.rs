//! Why opening or preparing a scene ended without one: typed, so callers branch on the
//! variant (a cancel is not a failure; an octree that does not fit falls back to bricks),
//! never on message text. Each displays as the one line the user reads.

use voxscope_octree::BuildError;
use voxscope_render::RenderError;
use voxscope_stream::BrickError;
use voxscope_volume::LoadError;
use voxscope_volume::progress::Cancelled;

/// Why scene work ended without a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// The user cancelled it (its [`voxscope_volume::progress::Progress`] was cancelled);
    /// nothing went wrong.
    #[error("cancelled")]
    Cancelled,
    /// The file or store could not be read.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The GPU could not hold or draw the volume called `volume`.
    #[error("{volume}: {error}")]
    Render { volume: String, error: RenderError },
    /// A pyramid's bricks could not be read (a streamed source's preview).
    #[error(transparent)]
    Stream(#[from] BrickError),
    /// Anything else, one line that names the file or volume.
    #[error("{0}")]
    Failed(String),
}

impl SceneError {
    /// A failure with a one-line message.
    pub fn failed(message: impl Into<String>) -> Self {
        Self::Failed(message.into())
    }

    /// A renderer's error about the volume called `volume`.
    pub fn render(volume: &str, error: RenderError) -> Self {
        Self::Render {
            volume: volume.to_owned(),
            error,
        }
    }

    /// An octree build error about the volume called `name`: cancellation stays cancellation.
    pub fn from_build(name: &str, error: BuildError) -> Self {
        match error {
            BuildError::Cancelled => Self::Cancelled,
            error => Self::Failed(format!("{name}: {error}")),
        }
    }

    /// Whether the renderer asked for does not fit the device (where another renderer might).
    pub fn does_not_fit(&self) -> bool {
        matches!(
            self,
            Self::Render {
                error: RenderError::DoesNotFit(_),
                ..
            }
        )
    }
}

impl From<Cancelled> for SceneError {
    fn from(_: Cancelled) -> Self {
        Self::Cancelled
    }
}
