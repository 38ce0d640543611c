//! Background work of the app and how the UI learns of its end. Every long task (opening a
//! volume, uploading it for another renderer, counting nodes under a new transfer function,
//! reading or writing a view file, a native file dialog) runs on its own thread; [`Jobs::poll`], called once per frame, turns
//! what has finished into typed [`JobEvent`]s. The UI thread never waits on any of them.

use std::sync::mpsc::{Receiver, TryRecvError};

use super::dialogs::{DialogAnswer, DialogKind};
use super::movie_export::Exported;
use super::view_file::ViewFile;
use voxscope_render::RendererOptions;
use voxscope_scene::{Counted, Job, Opened, SavedView, Scene, SceneError};

/// Something a background job finished, as [`Jobs::poll`] hands it to the app.
pub enum JobEvent {
    /// A volume is ready to be shown (it replaces the one on screen).
    Opened(Box<Opened>),
    /// A view file's data is ready to be shown; the view is applied over it.
    ViewOpened(Box<Opened>, Box<SavedView>),
    /// Opening ended without a volume: cancelled, or failed.
    OpenEnded(SceneError),
    /// The volume on screen was uploaded for another renderer.
    Uploaded(Box<Scene>),
    /// That upload failed; the renderer on screen stays.
    UploadFailed(SceneError),
    /// Statistics under a transfer function were counted.
    Counted(Box<Counted>),
    /// A view file was read or written.
    ViewFile(ViewFile),
    /// Reading or writing a view file failed.
    ViewFileFailed(SceneError),
    /// A movie was written.
    MovieExported(Exported),
    /// Writing a movie was cancelled, or failed.
    MovieEnded(SceneError),
    /// A screenshot at a scale was written to this file.
    ScreenshotSaved(std::path::PathBuf),
    /// Drawing or writing a screenshot at a scale failed.
    ScreenshotFailed(SceneError),
    /// A file dialog closed.
    DialogClosed(DialogKind, DialogAnswer),
}

/// The app's background jobs: at most one of each kind at a time.
#[derive(Default)]
pub struct Jobs {
    /// Opening a volume: read, quantize, build, color, upload.
    pub opening: Option<Job<Opened>>,
    /// The view file whose data [`Self::opening`] opens, applied when it is shown.
    opening_view: Option<Box<SavedView>>,
    /// Reading or writing a view file.
    pub view_file: Option<Job<ViewFile>>,
    /// Drawing and writing a movie (the Movie panel's Export).
    pub exporting: Option<Job<Exported>>,
    /// Drawing and writing a screenshot at a scale (File ▸ Save screenshot at 2×, 4×).
    pub screenshot: Option<Job<std::path::PathBuf>>,
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
            || self.view_file.is_some()
            || self.exporting.is_some()
            || self.screenshot.is_some()
            || self.dialog.is_some()
    }

    /// Starts opening a volume; an open still running is cancelled and its result dropped
    /// (and a view waiting for it is forgotten).
    pub fn open(&mut self, job: Job<Opened>) {
        self.opening_view = None;
        if let Some(earlier) = self.opening.replace(job) {
            earlier.progress.cancel();
        }
    }

    /// Starts opening `view`'s data: [`Self::open`], ending in [`JobEvent::ViewOpened`].
    pub fn open_view(&mut self, job: Job<Opened>, view: SavedView) {
        self.open(job);
        self.opening_view = Some(Box::new(view));
    }

    /// Asks the open in progress, if any, to stop at its next check; its end arrives as
    /// [`JobEvent::OpenEnded`] with [`SceneError::Cancelled`].
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
            let view = self.opening_view.take();
            events.push(match (result, view) {
                (Ok(opened), Some(view)) => JobEvent::ViewOpened(Box::new(opened), view),
                (Ok(opened), None) => JobEvent::Opened(Box::new(opened)),
                (Err(error), _) => JobEvent::OpenEnded(error),
            });
        }
        if let Some(result) = self.view_file.as_ref().and_then(Job::try_take) {
            self.view_file = None;
            events.push(match result {
                Ok(done) => JobEvent::ViewFile(done),
                Err(error) => JobEvent::ViewFileFailed(error),
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
        if let Some(result) = self.exporting.as_ref().and_then(Job::try_take) {
            self.exporting = None;
            events.push(match result {
                Ok(exported) => JobEvent::MovieExported(exported),
                Err(error) => JobEvent::MovieEnded(error),
            });
        }
        if let Some(result) = self.screenshot.as_ref().and_then(Job::try_take) {
            self.screenshot = None;
            events.push(match result {
                Ok(path) => JobEvent::ScreenshotSaved(path),
                Err(error) => JobEvent::ScreenshotFailed(error),
            });
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

    /// The movie being written: its title, stage and fraction done.
    pub fn export_progress(&self) -> Option<(&str, &'static str, f32)> {
        self.exporting.as_ref().map(|job| {
            let (stage, fraction) = job.progress.get();
            (job.title.as_str(), stage, fraction)
        })
    }

    /// The open in progress: its title, stage and fraction done.
    pub fn open_progress(&self) -> Option<(&str, &'static str, f32)> {
        self.opening.as_ref().map(|job| {
            let (stage, fraction) = job.progress.get();
            (job.title.as_str(), stage, fraction)
        })
    }
}
