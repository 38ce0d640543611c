//! A transfer function saved to a file (the app's File ▸ Save transfer function…, the command
//! line's `--tf`), as RON.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use voxscope_octree::TransferFunction;
use voxscope_render::RenderMode;

/// A saved transfer function: the function, its opacity scale and its mode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SavedTransfer {
    pub transfer: TransferFunction,
    pub density: f32,
    pub mode: RenderMode,
}

/// Why a transfer function file could not be written or read: displays as one line naming
/// the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TransferFileError {
    /// RON could not encode it (the error's words).
    #[error("{}: cannot encode: {error}", path.display())]
    Encode { path: PathBuf, error: String },
    /// The file could not be written (the system's words).
    #[error("{}: cannot write: {error}", path.display())]
    Write { path: PathBuf, error: String },
    /// The file could not be read (the system's words).
    #[error("{}: {error}", path.display())]
    Read { path: PathBuf, error: String },
    /// Larger than a transfer function's file can be.
    #[error("{}: {bytes} bytes is too large for a transfer function", path.display())]
    TooLarge { path: PathBuf, bytes: u64 },
    /// Not a transfer function's RON (the first line of the parser's words).
    #[error("{}: not a voxscope transfer function: {error}", path.display())]
    NotTransfer { path: PathBuf, error: String },
    /// Its window, threshold or opacity scale is out of range.
    #[error("{}: the window, threshold or opacity scale is out of range", path.display())]
    OutOfRange { path: PathBuf },
}

impl SavedTransfer {
    /// Largest file accepted as a transfer function.
    const MAX_BYTES: u64 = 1 << 20;

    /// Writes it as RON (what File ▸ Save transfer function… saves).
    pub fn write(&self, path: &Path) -> Result<(), TransferFileError> {
        let path_buf = || path.to_path_buf();
        let text =
            ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default()).map_err(|e| {
                TransferFileError::Encode {
                    path: path_buf(),
                    error: e.to_string(),
                }
            })?;
        std::fs::write(path, text).map_err(|e| TransferFileError::Write {
            path: path_buf(),
            error: e.to_string(),
        })
    }

    /// Reads and validates a file written by File ▸ Save transfer function…; the error is
    /// one line naming the file.
    pub fn read(path: &Path) -> Result<Self, TransferFileError> {
        let path_buf = || path.to_path_buf();
        let unread = |e: std::io::Error| TransferFileError::Read {
            path: path_buf(),
            error: e.to_string(),
        };
        let metadata = std::fs::metadata(path).map_err(unread)?;
        if metadata.len() > Self::MAX_BYTES {
            return Err(TransferFileError::TooLarge {
                path: path_buf(),
                bytes: metadata.len(),
            });
        }
        let text = std::fs::read_to_string(path).map_err(unread)?;
        let saved: Self = ron::from_str(&text).map_err(|e| TransferFileError::NotTransfer {
            path: path_buf(),
            error: e.to_string().lines().next().unwrap_or_default().to_owned(),
        })?;
        let window = saved.transfer.window;
        let valid = window.low.is_finite()
            && window.high.is_finite()
            && window.high > window.low
            && (0.0..=1.0).contains(&saved.transfer.threshold)
            && saved.density > 0.0
            && saved.density <= 1.0;
        if !valid {
            return Err(TransferFileError::OutOfRange { path: path_buf() });
        }
        Ok(saved)
    }
}
