//! A transfer function saved to a file (the app's File ▸ Save transfer function…, the command
//! line's `--tf`), as RON.

use std::path::Path;

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

impl SavedTransfer {
    /// Largest file accepted as a transfer function.
    const MAX_BYTES: u64 = 1 << 20;

    /// Writes it as RON (what File ▸ Save transfer function… saves).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let text = ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default())
            .map_err(|e| format!("{}: cannot encode: {e}", path.display()))?;
        std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))
    }

    /// Reads and validates a file written by File ▸ Save transfer function…; the error is
    /// one line naming the file.
    pub fn read(path: &Path) -> Result<Self, String> {
        let metadata = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
        if metadata.len() > Self::MAX_BYTES {
            return Err(format!(
                "{}: {} bytes is too large for a transfer function",
                path.display(),
                metadata.len()
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let saved: Self = ron::from_str(&text).map_err(|e| {
            format!(
                "{}: not a voxscope transfer function: {}",
                path.display(),
                e.to_string().lines().next().unwrap_or_default()
            )
        })?;
        let window = saved.transfer.window;
        let valid = window.low.is_finite()
            && window.high.is_finite()
            && window.high > window.low
            && (0.0..=1.0).contains(&saved.transfer.threshold)
            && saved.density > 0.0
            && saved.density <= 1.0;
        if !valid {
            return Err(format!(
                "{}: the window, threshold or opacity scale is out of range",
                path.display()
            ));
        }
        Ok(saved)
    }
}
