//! Background work of the app and how the UI learns of its end. Every long task (opening a
//! volume, uploading it for another renderer, counting nodes under a new transfer function, a
//! native file dialog) runs on its own thread; [`Jobs::poll`], called once per frame, turns
//! what has finished into typed [`JobEvent`]s. The UI thread never waits on any of them.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::time::Duration;

use super::dialogs::DialogKind;
use super::scene::Scene;
use voxscope_octree::{BuildError, Clip, LevelStatistics, TransferFunction};
use voxscope_render::RendererOptions;
use voxscope_volume::progress::{Cancelled, Progress};

/// Why a job ended without a result. The UI branches on the variant, never on message text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum JobError {
    /// The user cancelled it (its [`Progress`] was cancelled); nothing went wrong.
    Cancelled,
    /// It failed; the message is one line that names the file or volume.
    Failed(String),
}

impl JobError {
    /// A failure with a one-line message.
    pub fn failed(message: impl Into<String>) -> Self {
        Self::Failed(message.into())
    }

    /// An octree build error about the volume called `name`: cancellation stays cancellation.
    pub fn from_build(name: &str, error: BuildError) -> Self {
        match error {
            BuildError::Cancelled => Self::Cancelled,
            error => Self::Failed(format!("{name}: {error}")),
        }
    }
}

impl From<Cancelled> for JobError {
    fn from(_: Cancelled) -> Self {
        Self::Cancelled
    }
}

impl std::fmt::Display for JobError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Cancelled => f.write_str("cancelled"),
            Self::Failed(message) => f.write_str(message),
        }
    }
}

/// Work running on another thread, reporting through a [`Progress`], ending in one result.
pub struct Job<T> {
    pub progress: Arc<Progress>,
    receiver: Receiver<Result<T, JobError>>,
    /// What the job does, for the progress bar (`opening head.nii.gz`).
    pub title: String,
}

impl<T: Send + 'static> Job<T> {
    /// Runs `work` on a new thread; `wake` is called when it ends (to repaint the UI).
    pub fn spawn(
        title: String,
        wake: impl Fn() + Send + 'static,
        work: impl FnOnce(&Progress) -> Result<T, JobError> + Send + 'static,
    ) -> Self {
        let progress = Arc::new(Progress::new());
        let (sender, receiver) = mpsc::channel();
        let job_progress = Arc::clone(&progress);
        std::thread::Builder::new()
            .name("voxscope-job".into())
            .spawn(move || {
                let result = work(&job_progress);
                let _ = sender.send(result);
                wake();
            })
            .expect("the OS lets a process start a thread");
        Self {
            progress,
            receiver,
            title,
        }
    }

    /// The result once the job has ended; `None` while it runs.
    pub fn try_take(&self) -> Option<Result<T, JobError>> {
        match self.receiver.try_recv() {
            Ok(result) => Some(result),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err(JobError::failed(format!(
                "{}: the job stopped unexpectedly",
                self.title
            )))),
        }
    }

    /// Waits for the result (tests and command-line use; never the UI thread).
    pub fn wait(self) -> Result<T, JobError> {
        self.receiver.recv().unwrap_or_else(|_| {
            Err(JobError::failed(format!(
                "{}: the job stopped unexpectedly",
                self.title
            )))
        })
    }
}

/// A volume opened in the background: the scene and its per-level statistics.
pub struct Opened {
    pub scene: Scene,
    pub statistics: Vec<LevelStatistics>,
    /// Another frame of the volume on screen: the view stays as it is.
    pub frame_change: bool,
    /// The composite's channel settings as the scene was drawn with them (empty for one
    /// channel): a new volume's defaults, or the ones the frame change carried.
    pub channels: Vec<super::channels::ChannelState>,
    /// What the user should know (the composite did not fit and one channel is shown).
    pub notice: Option<String>,
}

/// Per-level statistics counted under a transfer function, within a clip.
pub type Counted = (TransferFunction, Clip, Vec<LevelStatistics>);

/// What the user chose in a native file dialog, and how long it was open.
pub struct DialogAnswer {
    pub path: Option<PathBuf>,
    pub open_for: Duration,
}

/// Something a background job finished, as [`Jobs::poll`] hands it to the app.
pub enum JobEvent {
    /// A volume is ready to be shown (it replaces the one on screen).
    Opened(Box<Opened>),
    /// Opening ended without a volume: cancelled, or failed.
    OpenEnded(JobError),
    /// The volume on screen was uploaded for another renderer.
    Uploaded(Box<Scene>),
    /// That upload failed; the renderer on screen stays.
    UploadFailed(JobError),
    /// Statistics under a transfer function were counted.
    Counted(Box<Counted>),
    /// A file dialog closed.
    DialogClosed(DialogKind, DialogAnswer),
}

/// The app's background jobs: at most one of each kind at a time.
#[derive(Default)]
pub struct Jobs {
    /// Opening a volume: read, quantize, build, color, upload.
    pub opening: Option<Job<Opened>>,
    /// Uploading the volume on screen for other renderer options.
    pub uploading: Option<(RendererOptions, Job<Scene>)>,
    /// Counting nodes per level under the live transfer function.
    pub counting: Option<Job<Counted>>,
    /// A native file dialog on its own thread.
    pub dialog: Option<(DialogKind, Receiver<DialogAnswer>)>,
}

impl Jobs {
    /// True while any job runs.
    pub fn is_busy(&self) -> bool {
        self.opening.is_some()
            || self.uploading.is_some()
            || self.counting.is_some()
            || self.dialog.is_some()
    }

    /// Starts opening a volume; an open still running is cancelled and its result dropped.
    pub fn open(&mut self, job: Job<Opened>) {
        if let Some(earlier) = self.opening.replace(job) {
            earlier.progress.cancel();
        }
    }

    /// Asks the open in progress, if any, to stop at its next check; its end arrives as
    /// [`JobEvent::OpenEnded`] with [`JobError::Cancelled`].
    pub fn cancel_open(&self) {
        if let Some(job) = &self.opening {
            eprintln!("voxscope: cancelling {}", job.title);
            job.progress.cancel();
        }
    }

    /// Takes every job that has finished since the last call.
    pub fn poll(&mut self) -> Vec<JobEvent> {
        let mut events = Vec::new();
        if let Some(result) = self.opening.as_ref().and_then(Job::try_take) {
            self.opening = None;
            events.push(match result {
                Ok(opened) => JobEvent::Opened(Box::new(opened)),
                Err(error) => JobEvent::OpenEnded(error),
            });
        }
        if let Some(result) = self.uploading.as_ref().and_then(|(_, job)| job.try_take()) {
            self.uploading = None;
            events.push(match result {
                Ok(scene) => JobEvent::Uploaded(Box::new(scene)),
                Err(error) => JobEvent::UploadFailed(error),
            });
        }
        if let Some(result) = self.counting.as_ref().and_then(Job::try_take) {
            self.counting = None;
            // Counting only fails if its thread died; the next frame starts it again.
            if let Ok(counted) = result {
                events.push(JobEvent::Counted(Box::new(counted)));
            }
        }
        if let Some((kind, receiver)) = &self.dialog {
            match receiver.try_recv() {
                Ok(answer) => {
                    events.push(JobEvent::DialogClosed(*kind, answer));
                    self.dialog = None;
                }
                Err(TryRecvError::Disconnected) => self.dialog = None,
                Err(TryRecvError::Empty) => {}
            }
        }
        events
    }

    /// The open in progress: its title, stage and fraction done.
    pub fn open_progress(&self) -> Option<(&str, &'static str, f32)> {
        self.opening.as_ref().map(|job| {
            let (stage, fraction) = job.progress.get();
            (job.title.as_str(), stage, fraction)
        })
    }
}
