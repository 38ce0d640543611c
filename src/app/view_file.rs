//! The app's view files read and written on job threads (the UI thread never waits on disk):
//! File ▸ Save view… and Open view… (`saved_view.rs` turns the app's state into a view and
//! back).

use std::path::PathBuf;

use voxscope_scene::{Job, SavedView, SceneError};

/// A view file's job ended: what it did.
pub enum ViewFile {
    /// The view was written to this file.
    Written(PathBuf),
    /// This file was read and its data exists.
    Read(PathBuf, Box<SavedView>),
}

/// Writes `view` to `path` on a job thread (the UI thread never waits on disk).
pub fn write_job(
    view: SavedView,
    path: PathBuf,
    wake: impl Fn() + Send + 'static,
) -> Job<ViewFile> {
    Job::spawn(format!("saving {}", path.display()), wake, move |_| {
        view.write(&path)
            .map_err(|e| SceneError::failed(e.to_string()))?;
        Ok(ViewFile::Written(path))
    })
}

/// Reads the view file `path` on a job thread, and checks that the data it names exists: a
/// view whose data is missing is one line naming both.
pub fn read_job(path: PathBuf, wake: impl Fn() + Send + 'static) -> Job<ViewFile> {
    Job::spawn(format!("reading {}", path.display()), wake, move |_| {
        let view = SavedView::read(&path).map_err(|e| SceneError::failed(e.to_string()))?;
        if let Some(missing) = view.open.missing_path() {
            return Err(SceneError::failed(format!(
                "{}: its data {missing} does not exist",
                path.display()
            )));
        }
        Ok(ViewFile::Read(path, Box::new(view)))
    })
}
