//! Native file dialogs (rfd), each on its own thread so the UI keeps running while one is open.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What the user chose in a native file dialog, and how long it was open.
pub struct DialogAnswer {
    pub path: Option<PathBuf>,
    pub open_for: Duration,
}

/// The file dialogs the app shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DialogKind {
    /// File ▸ Open…: a volume file.
    Open,
    /// File ▸ Open folder…: a DICOM series, a folder of slices or a Zarr store.
    OpenFolder,
    /// File ▸ Save screenshot…
    SaveScreenshot,
    /// File ▸ Save transfer function…
    SaveTransfer,
    /// File ▸ Load transfer function…
    LoadTransfer,
    /// File ▸ Open labels…: a label volume on the image's grid, drawn over it.
    OpenLabels,
    /// File ▸ Save view… (and Ctrl+S before a view file was saved or opened).
    SaveView,
    /// File ▸ Open view…
    OpenView,
    /// The Movie panel's output: a movie file (or a folder, typed).
    MovieOutput,
}

/// The title of File ▸ Open folder…'s dialog: what a folder can be.
pub const OPEN_FOLDER_TITLE: &str = "Open a folder: a DICOM series, TIFF/PNG slices, an OME-Zarr store, an N5 container or a precomputed volume";

/// A dialog that closes faster than this was never shown: nobody cancels one so quickly.
pub const NOT_SHOWN_WITHIN: Duration = Duration::from_millis(300);

/// What a screenshot's save dialog is called: `Save screenshot`, or `Save screenshot at 2×`
/// (the 3D view drawn again at `scale` times its pixels).
pub fn screenshot_title(scale: u32) -> String {
    match scale {
        0 | 1 => "Save screenshot".to_owned(),
        scale => format!("Save screenshot at {scale}×"),
    }
}

/// The file name a screenshot's save dialog offers: `voxscope.png`, `voxscope-2x.png`.
pub fn screenshot_file_name(scale: u32) -> String {
    match scale {
        0 | 1 => "voxscope.png".to_owned(),
        scale => format!("voxscope-{scale}x.png"),
    }
}

/// Starts the dialog `kind` on its own thread, opening in `directory` when given; its answer
/// arrives on the returned receiver, and `wake` is called then (to repaint the UI).
/// `screenshot_scale` names a screenshot's scale in its title and file name.
pub fn spawn(
    kind: DialogKind,
    directory: Option<PathBuf>,
    screenshot_scale: u32,
    wake: impl Fn() + Send + 'static,
) -> mpsc::Receiver<DialogAnswer> {
    let (sender, receiver) = mpsc::channel();
    std::thread::spawn(move || {
        let started = Instant::now();
        let path = show(kind, directory.as_deref(), screenshot_scale);
        let _ = sender.send(DialogAnswer {
            path,
            open_for: started.elapsed(),
        });
        wake();
    });
    receiver
}

/// Shows the dialog and waits for the user's answer (on the dialog's thread).
fn show(kind: DialogKind, directory: Option<&Path>, screenshot_scale: u32) -> Option<PathBuf> {
    let mut dialog = rfd::FileDialog::new();
    if let Some(directory) = directory {
        dialog = dialog.set_directory(directory);
    }
    match kind {
        // Both from the format table, so the filter offers every format the loaders read.
        DialogKind::Open => dialog
            .set_title("Open a volume")
            .add_filter(
                voxscope_volume::dialog_filter_name(),
                &voxscope_volume::dialog_extensions(),
            )
            .add_filter("All files", &["*"])
            .pick_file(),
        DialogKind::OpenFolder => dialog.set_title(OPEN_FOLDER_TITLE).pick_folder(),
        DialogKind::SaveScreenshot => dialog
            .set_title(screenshot_title(screenshot_scale))
            .add_filter("PNG image", &["png"])
            .set_file_name(screenshot_file_name(screenshot_scale))
            .save_file(),
        DialogKind::SaveTransfer => dialog
            .set_title("Save transfer function")
            .add_filter("Transfer function (RON)", &["ron"])
            .set_file_name("transfer.ron")
            .save_file(),
        DialogKind::OpenLabels => dialog
            .set_title("Open labels on the image's grid")
            .add_filter(
                voxscope_volume::dialog_filter_name(),
                &voxscope_volume::dialog_extensions(),
            )
            .add_filter("All files", &["*"])
            .pick_file(),
        DialogKind::LoadTransfer => dialog
            .set_title("Load transfer function")
            .add_filter("Transfer function (RON)", &["ron"])
            .pick_file(),
        DialogKind::SaveView => dialog
            .set_title("Save view")
            .add_filter("voxscope view (RON)", &["ron"])
            .set_file_name("view.ron")
            .save_file(),
        DialogKind::OpenView => dialog
            .set_title("Open view")
            .add_filter("voxscope view (RON)", &["ron"])
            .pick_file(),
        DialogKind::MovieOutput => dialog
            .set_title("Write the movie to")
            .add_filter("Movie", &["webp", "gif", "png", "mp4"])
            .set_file_name("movie.webp")
            .save_file(),
    }
}
