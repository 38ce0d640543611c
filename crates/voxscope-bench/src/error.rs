//! Why a benchmark ended without its report: typed, so the command line words each as the one
//! line its users read (a volume that does not open as it words every command's, with its
//! advice), never by parsing message text.

use voxscope_octree::BuildError;
use voxscope_render::RenderError;
use voxscope_scene::SceneError;
use voxscope_stream::{BrickError, BrickId};

/// Why a benchmark ended without its report.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// No frames to time.
    #[error("--frames must be at least 1")]
    NoFrames,
    /// The volume could not be opened or prepared (read, quantized, built, its transfer
    /// function file read): the front end words it as it words opening for every command.
    #[error(transparent)]
    Open(SceneError),
    /// A multi-channel file gave no channel.
    #[error("no channel was read")]
    NoChannel,
    /// Scene work on a volume already open failed (a streamed view refined).
    #[error(transparent)]
    Scene(SceneError),
    /// The GPU could not be opened or used (no device, a wait or readback failed).
    #[error(transparent)]
    Gpu(#[from] RenderError),
    /// The GPU could not hold or draw the volume called `volume`.
    #[error("{volume}: {error}")]
    Renderer { volume: String, error: RenderError },
    /// The pyramid called `volume` gave no preview level (no brick could be read).
    #[error("{volume}: {error}")]
    Preview { volume: String, error: BrickError },
    /// The octree of the volume called `volume` could not be built.
    #[error("{volume}: {error}")]
    Build { volume: String, error: BuildError },
    /// The resident comparison's pyramid could not be made of its level in memory (one line
    /// naming it).
    #[error("{0}")]
    Pyramid(String),
    /// A brick of the decode benchmark's block that the pyramid called `volume` does not hold.
    #[error("{volume}: no {id}")]
    NoBrick { volume: String, id: BrickId },
    /// The loaders did not read the decode benchmark's block in time.
    #[error("{volume}: the loaders read {received} of {total} bricks in {seconds} s")]
    LoadersTooSlow {
        volume: String,
        received: usize,
        total: usize,
        seconds: u64,
    },
    /// The resident comparison was given another renderer than the streaming one.
    #[error("the resident comparison needs the streaming renderer")]
    NotStreaming,
}

impl BenchError {
    /// The renderer's error about the volume called `volume`.
    pub fn renderer(volume: &str, error: RenderError) -> Self {
        Self::Renderer {
            volume: volume.to_owned(),
            error,
        }
    }
}
