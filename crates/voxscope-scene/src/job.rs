//! Long work on a thread of its own, reporting through a [`Progress`] and ending in one typed
//! result: what the app's background jobs are made of, and what a caller that may wait uses
//! too ([`Job::wait`]).

use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, TryRecvError};

use voxscope_volume::progress::Progress;

use crate::SceneError;

/// Work running on another thread, reporting through a [`Progress`], ending in one result.
pub struct Job<T> {
    pub progress: Arc<Progress>,
    receiver: Receiver<Result<T, SceneError>>,
    /// What the job does, for a progress bar (`opening head.nii.gz`).
    pub title: String,
}

impl<T: Send + 'static> Job<T> {
    /// Runs `work` on a new thread; `wake` is called when it ends (to repaint a UI).
    pub fn spawn(
        title: String,
        wake: impl Fn() + Send + 'static,
        work: impl FnOnce(&Progress) -> Result<T, SceneError> + Send + 'static,
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
    pub fn try_take(&self) -> Option<Result<T, SceneError>> {
        match self.receiver.try_recv() {
            Ok(result) => Some(result),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err(self.stopped())),
        }
    }

    /// Waits for the result (tests, the command line; never a UI thread).
    pub fn wait(self) -> Result<T, SceneError> {
        self.receiver.recv().unwrap_or_else(|_| Err(self.stopped()))
    }

    fn stopped(&self) -> SceneError {
        SceneError::failed(format!("{}: the job stopped unexpectedly", self.title))
    }
}
