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
    /// The GPU could not be opened or used (no device, lost).
    #[error(transparent)]
    Gpu(RenderError),
    /// A pyramid's bricks could not be read (a streamed source's preview).
    #[error(transparent)]
    Stream(#[from] BrickError),
    /// A saved transfer function (`--tf`, `tf=`) could not be read: one line naming the file.
    #[error("{0}")]
    TransferFile(String),
    /// What was asked cannot be drawn as asked (a channel's window for a channel that is not
    /// there, labels over a composite): one line naming the option.
    #[error("{0}")]
    Invalid(String),
    /// Label overlays were asked over what they cannot be drawn over (yet).
    #[error(
        "--labels {name}: label overlays are drawn over one volume in memory; not over {over} (yet)"
    )]
    LabelsRefused { name: String, over: &'static str },
    /// Another renderer than the dense one was asked for the composite of several channels.
    #[error("the composite of {channels} channels is drawn by the dense renderer; --renderer {} draws one channel (--channel N)", renderer.name())]
    CompositeNeedsDense {
        channels: usize,
        renderer: voxscope_render::RendererKind,
    },
    /// The volume is longer than the voxel octree holds (the streamed renderers draw it).
    #[error("{0}")]
    BeyondOctree(String),
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
            error @ BuildError::TooDeep { .. } => Self::BeyondOctree(format!("{name}: {error}")),
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
