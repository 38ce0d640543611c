//! A saved view (`render --save-view`, `render --view`, `movie --keyframes`, the app's File ▸
//! Save view…): the options that open and draw it — [`OpenOptions`] and [`DrawOptions`], the
//! model every front end maps into — as RON, with what only the app shows (rulers, its
//! layout). A colleague opens the same picture again. Paths are stored as given (a URL without
//! its user name, password or query); a field a file lacks takes its default, and a file of
//! version 1 (before the model) opens as what it held ([`crate::view_v1`]).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use voxscope_octree::TransferFunction;
use voxscope_render::RenderSettings;

use std::borrow::Borrow;

use voxscope_render::GpuContext;
use voxscope_volume::MAX_CHANNELS;

use crate::{DrawOptions, Drawable, OpenOptions, SavedTransfer, TransferOptions};

/// The version [`SavedView::write`] writes; [`SavedView::read`] reads this and earlier ones.
pub const VIEW_VERSION: u32 = 2;

/// Everything a view shows: what is opened, how it is drawn, and the app's rulers and layout.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SavedView {
    /// The file format's version ([`VIEW_VERSION`] when written).
    pub version: u32,
    /// The data: a path (as given), a URL (without user name, password or query),
    /// `synthetic:KIND:SIZE`, or none for the built-in sample; its channel, time point, raw
    /// layout and spacing. An HCS plate's field and a bioformats2raw container's series are
    /// part of the path, as they are opened (`plate.ome.zarr/B/3/0`), so one path names the
    /// image in every front end.
    pub open: OpenOptions,
    /// The camera and image size, the transfer function (as drawn, in `transfer.saved`), the
    /// render settings, clipping, the composite's channels, label overlays, the renderer and
    /// its budgets.
    pub draw: DrawOptions,
    /// Measured distances (voxel space) shown with the view.
    pub rulers: Vec<ViewRuler>,
    /// The app's layout of panes (`single`, `level-grid`, `transfer-pair`, `slices`).
    pub layout: Option<String>,
}

impl Default for SavedView {
    fn default() -> Self {
        Self {
            version: VIEW_VERSION,
            open: OpenOptions::default(),
            draw: DrawOptions::default(),
            rulers: Vec::new(),
            layout: None,
        }
    }
}

/// A measured distance between two points in voxel space.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewRuler {
    pub from: [f64; 3],
    pub to: [f64; 3],
}

/// What is wrong with a view file's text.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewProblem {
    #[error("not a voxscope view file: {0}")]
    NotAView(String),
    #[error(
        "view file version {0} is not one this voxscope reads (1 to {VIEW_VERSION}); a newer voxscope wrote it"
    )]
    Version(u32),
    /// A value out of its range (the words say which).
    #[error("{0}")]
    Invalid(String),
}

/// A view file that could not be read or written: the file, and why.
#[derive(Debug, thiserror::Error)]
pub enum ViewFileError {
    #[error("{}: {problem}", path.display())]
    Content { path: PathBuf, problem: ViewProblem },
    #[error("{}: {error}", path.display())]
    Read {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}: {bytes} bytes is too large for a view file", path.display())]
    TooLarge { path: PathBuf, bytes: u64 },
    #[error("{}: cannot encode the view: {error}", path.display())]
    Encode { path: PathBuf, error: ron::Error },
    #[error("{}: cannot write: {error}", path.display())]
    Write {
        path: PathBuf,
        error: std::io::Error,
    },
}

impl SavedView {
    /// Largest file accepted as a view.
    const MAX_BYTES: u64 = 1 << 20;

    /// The view of what `drawing` drew of `open` with `draw`: the options as given (sources
    /// stored as [`OpenOptions::stored`] keeps them), with the transfer function and render
    /// settings it drew, and every channel's color, window and visibility.
    pub fn of<G: Borrow<GpuContext>>(
        open: &OpenOptions,
        draw: &DrawOptions,
        drawing: &Drawable<G>,
    ) -> Self {
        let settings = drawing.render_settings(draw);
        let asked_level = draw.transfer.level;
        let mut draw = draw.clone();
        draw.transfer = TransferOptions::drawn(
            Some(SavedTransfer {
                transfer: drawing.transfer(),
                density: settings.density,
                mode: settings.mode,
            }),
            &settings,
        );
        draw.clip = settings.clip;
        if let Some(channels) = drawing.channels() {
            draw.channels = match drawing.channel_indices() {
                Some(indices) => crate::ChannelRequest::of_chosen(channels, &indices),
                None => crate::ChannelRequest::of_states(channels),
            };
            // The composite marches the voxels: the level is the one asked for, for a
            // renderer of one channel that opens the view.
            draw.transfer.level = asked_level;
        }
        // The renderer asked for where the data chose it (streamed beyond the octree, or the
        // composite), else the one that drew.
        if !(drawing.is_streamed() || drawing.channels().is_some()) {
            draw.renderer = Some(drawing.renderer().kind());
        }
        Self {
            version: VIEW_VERSION,
            open: open.stored(),
            draw,
            rulers: Vec::new(),
            layout: None,
        }
    }

    /// The transfer function the view draws, where it holds one (else the data's own): its
    /// saved function with the window and colormap asked over it.
    pub fn transfer(&self) -> Option<TransferFunction> {
        self.draw.transfer.saved_function()
    }

    /// The render settings of the view for data `depth` deep.
    pub fn render_settings(&self, depth: u32) -> RenderSettings {
        self.draw
            .render_settings(depth, self.draw.transfer.saved.as_ref())
    }

    /// Writes it as RON.
    pub fn write(&self, path: &Path) -> Result<(), ViewFileError> {
        let text = ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default()).map_err(
            |error| ViewFileError::Encode {
                path: path.to_owned(),
                error,
            },
        )?;
        std::fs::write(path, text).map_err(|error| ViewFileError::Write {
            path: path.to_owned(),
            error,
        })
    }

    /// Reads a view file of any version; every error is one line naming the file.
    pub fn read(path: &Path) -> Result<Self, ViewFileError> {
        let read = |error| ViewFileError::Read {
            path: path.to_owned(),
            error,
        };
        let bytes = std::fs::metadata(path).map_err(read)?.len();
        if bytes > Self::MAX_BYTES {
            return Err(ViewFileError::TooLarge {
                path: path.to_owned(),
                bytes,
            });
        }
        let text = std::fs::read_to_string(path).map_err(read)?;
        Self::parse(&text).map_err(|problem| ViewFileError::Content {
            path: path.to_owned(),
            problem,
        })
    }

    /// Parses and checks a view file's text (version 1 files as what they held).
    pub fn parse(text: &str) -> Result<Self, ViewProblem> {
        let not_a_view = |e: ron::error::SpannedError| {
            ViewProblem::NotAView(e.to_string().lines().next().unwrap_or_default().to_owned())
        };
        let version = ron::from_str::<FileVersion>(text)
            .map_err(not_a_view)?
            .version;
        let view = match version {
            1 => crate::view_v1::parse(text).map_err(not_a_view)??,
            VIEW_VERSION => ron::from_str::<Self>(text).map_err(not_a_view)?,
            other => return Err(ViewProblem::Version(other)),
        };
        view.check()?;
        Ok(view)
    }

    /// Whether its values are in their ranges.
    fn check(&self) -> Result<(), ViewProblem> {
        let invalid = |words: String| Err(ViewProblem::Invalid(words));
        let draw = &self.draw;
        let (width, height) = draw.size;
        if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
            return invalid(format!(
                "the size {width}x{height} is not from 1x1 to 16384x16384"
            ));
        }
        let camera = draw.camera;
        let finite = [
            camera.azimuth_deg,
            camera.elevation_deg,
            camera.distance,
            camera.fov_y_deg,
        ]
        .iter()
        .chain(&camera.pan)
        .all(|v| v.is_finite());
        if !finite || camera.distance <= 0.0 {
            return invalid(
                "the camera has a value that is not a finite number (or a distance ≤ 0)".into(),
            );
        }
        let transfer = &draw.transfer;
        let windows = transfer
            .saved
            .iter()
            .map(|saved| saved.transfer.window)
            .chain(transfer.window)
            .chain(draw.channels.windows.iter().map(|(_, window)| *window));
        let thresholds = transfer
            .saved
            .iter()
            .map(|saved| saved.transfer.threshold)
            .chain([transfer.threshold]);
        let windows_valid = windows
            .into_iter()
            .all(|w| w.low.is_finite() && w.high.is_finite() && w.high > w.low);
        if !windows_valid || !thresholds.into_iter().all(|t| (0.0..=1.0).contains(&t)) {
            return invalid("a transfer function's window or threshold is out of range".into());
        }
        for density in transfer
            .saved
            .map(|s| s.density)
            .into_iter()
            .chain(transfer.density)
        {
            if !(density.is_finite() && density > 0.0) {
                return invalid(format!(
                    "the opacity scale (density) {density} is not a positive number"
                ));
            }
        }
        let channels = draw.channels.colors.len().max(
            draw.channels
                .windows
                .iter()
                .map(|(index, _)| index + 1)
                .max()
                .unwrap_or(0),
        );
        // Colors and windows are by channel number in the file (a store of more channels than
        // are drawn together names the ones it draws in `chosen`).
        if channels > voxscope_volume::MAX_AXIS {
            return invalid(format!(
                "{channels} channels: a channel axis has at most {}",
                voxscope_volume::MAX_AXIS
            ));
        }
        if draw.channels.chosen.len() > MAX_CHANNELS {
            return invalid(format!(
                "{} channels chosen: a composite draws at most {MAX_CHANNELS}",
                draw.channels.chosen.len()
            ));
        }
        Ok(())
    }

    /// Whether `other` shows the same data (source, channels, time, layout of a raw file).
    pub fn same_data(&self, other: &Self) -> bool {
        self.open == other.open
    }
}

/// The one field every version of a view file has (a file without it is of version 1).
#[derive(Deserialize)]
struct FileVersion {
    #[serde(default = "first_version")]
    version: u32,
}

fn first_version() -> u32 {
    1
}

#[cfg(test)]
mod tests;
