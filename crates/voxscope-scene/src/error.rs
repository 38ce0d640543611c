//! Why opening or preparing a scene ended without one: typed, so callers branch on the
//! variant (a cancel is not a failure; an octree that does not fit falls back to bricks),
//! never on message text. Each displays as the one line the user reads.

use voxscope_octree::BuildError;
use voxscope_render::RenderError;
use voxscope_stream::BrickError;
use voxscope_stream::SourceError;
use voxscope_volume::LoadError;
use voxscope_volume::progress::Cancelled;
use voxscope_volume::{LoadErrorKind, format_dims};

use crate::label_overlay::MAX_LABEL_VALUES;
use crate::saved_transfer::TransferFileError;

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
    /// A brick source could not be made of the volume or store (its dimensions, its chunks,
    /// its values' range).
    #[error(transparent)]
    Source(#[from] SourceError),
    /// A saved transfer function (`--tf`, `tf=`) could not be read: one line naming the file.
    #[error(transparent)]
    TransferFile(TransferFileError),
    /// A label overlay could not be opened or drawn: one line naming the label or file.
    #[error(transparent)]
    Labels(#[from] LabelError),
    /// A channel's window asked for a channel that the file does not have.
    #[error("--channel-window {channel}: there are {count} channels (0 to {})", count.saturating_sub(1))]
    NoSuchChannel { channel: usize, count: usize },
    /// A channel chosen to draw that the file does not have.
    #[error("--channels {channel}: there are {count} channels (0 to {})", count.saturating_sub(1))]
    NoChosenChannel { channel: usize, count: usize },
    /// More channel colors given than the file has channels.
    #[error("--channel-colors gives {colors} colors for {count} channels")]
    TooManyColors { colors: usize, count: usize },
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

/// Why a label overlay could not be opened, checked against its image or drawn: displays as
/// one line naming the label, its file or store.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LabelError {
    /// The labels lie on another grid than the image's.
    #[error(
        "{name}: its grid ({}) is not the image's ({}); labels must lie on the image's grid",
        format_dims(*dims),
        format_dims(*image_dims)
    )]
    OffGrid {
        name: String,
        dims: [usize; 3],
        image_dims: [usize; 3],
    },
    /// More distinct values than a label volume holds.
    #[error("{0}: more than {MAX_LABEL_VALUES} distinct labels; is it a label volume?")]
    TooManyLabels(String),
    /// A label image's pyramid without levels.
    #[error("{0}: has no levels")]
    NoLevels(String),
    /// A label image without a level on the grid of the image's volume in memory.
    #[error("{spec}: no level of {} voxels, the image's level in memory", format_dims(*dims))]
    NoLevelOf { spec: String, dims: [usize; 3] },
    /// The labels' file or store could not be read.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// A file that no format recognized, asked for as labels.
    #[error("{0} (a label file: NIfTI, NRRD, TIFF, …)")]
    NotLabelFile(LoadError),
    /// A label image's pyramid cannot be streamed.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// The labels' octree could not be built.
    #[error("{name}: {error}")]
    Build { name: String, error: BuildError },
    /// The labels could not be put on or drawn by the GPU.
    #[error("{name}: {error}")]
    Render { name: String, error: RenderError },
    /// Streamed labels could not be drawn.
    #[error("{name}: {error}")]
    Streamed {
        name: String,
        error: Box<SceneError>,
    },
    /// The GPU failed while the labels were drawn or read back.
    #[error(transparent)]
    Gpu(#[from] RenderError),
    /// More visible colors than streamed labels draw.
    #[error("{0}: more than 255 label colors; streamed labels draw at most 255")]
    TooManyColors(String),
    /// A name that is neither a file nor a label image of the image; `known` lists the
    /// image's label images.
    #[error(
        "--labels {name}: no such file, and no label image of {image} by that name ({})",
        if known.is_empty() { "it has no label images".to_owned() } else { format!("its label images are {}", known.join(", ")) }
    )]
    NotFound {
        name: String,
        image: String,
        known: Vec<String>,
    },
    /// A label that is not a label image of the streamed image.
    #[error(
        "--labels {name}: over a streamed image, labels are label images of {image} (info lists them); a label file is drawn over the image in memory (without --renderer stream)"
    )]
    NotStreamable { name: String, image: String },
}

impl LabelError {
    /// The error of reading a label file: one that no format recognized says that labels
    /// were asked for.
    pub fn of_label_file(error: LoadError) -> Self {
        match error.kind {
            LoadErrorKind::Unrecognized => Self::NotLabelFile(error),
            _ => Self::Load(error),
        }
    }
}
