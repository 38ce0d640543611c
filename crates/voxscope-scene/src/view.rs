//! A saved view (`render --save-view`, `render --view`, `movie --keyframes`): what is shown and
//! how, as RON, so that a colleague opens the same picture again. Paths are stored as given
//! (a URL without its user name, password or query); a file from an older voxscope loads with
//! what it lacks at its defaults.

use std::path::Path;

use serde::{Deserialize, Serialize};
use voxscope_octree::TransferFunction;
use voxscope_render::{Camera, RenderSettings, RendererKind};

/// The version [`SavedView::write`] writes; [`SavedView::read`] reads this and earlier ones.
pub const VIEW_VERSION: u32 = 1;

/// Everything a view shows: the data, the camera, the transfer function(s) and the rendering
/// choices. Every field has a default, so that a file written before a field existed loads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SavedView {
    /// The file format's version ([`VIEW_VERSION`] when written).
    pub version: u32,
    /// What is shown.
    pub data: ViewData,
    /// The orbit camera (azimuth, elevation, distance, field of view, pan).
    pub camera: Camera,
    /// The image size, WxH pixels.
    pub size: [u32; 2],
    /// The transfer function drawn (for a composite, channel 0's opacity curve, which every
    /// channel shares; `channels` holds each channel's color and window). `None`: the one the
    /// data opens with.
    pub transfer: Option<TransferFunction>,
    /// The composite's channels, in order (empty for one channel).
    pub channels: Vec<ViewChannel>,
    /// Mode, level, density, opacity correction, shading, clip box and plane.
    pub settings: Option<RenderSettings>,
    /// The renderer that drew it (`None`: the default for the data).
    pub renderer: Option<RendererKind>,
    /// The bricks renderer's brick side.
    pub brick_size: Option<usize>,
    /// The streaming renderer's budgets.
    pub stream: Option<ViewStream>,
    /// Measured distances (voxel space) shown with the view.
    pub rulers: Vec<ViewRuler>,
    /// The app's layout of panes (`single`, `level-grid`, `transfer-pair`, `slices`).
    pub layout: Option<String>,
}

/// What a view shows: a source and which of its frames. An HCS plate's field and a
/// bioformats2raw container's series are part of the source's path, as they are opened
/// (`plate.ome.zarr/B/3/0`, `container.zarr/1`: the command line's `--field` and `--series`
/// append them before the view is written), so one path names the image in every front end.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewData {
    /// A path (as given), a URL (without user name, password or query), or
    /// `synthetic:KIND:SIZE`; `None`: the built-in sample.
    pub source: Option<String>,
    /// Files opened together as the channels of one volume (instead of `source`).
    pub channels_from: Vec<String>,
    /// `N`, or `all` for the composite; `None`: as the file opens.
    pub channel: Option<String>,
    /// The time point.
    pub time: usize,
    /// A headerless file's layout, `XxYxZ:TYPE:le|be`.
    pub raw: Option<String>,
    /// A voxel size that overrides the file's.
    pub spacing: Option<[f64; 3]>,
}

/// One channel of a composite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewChannel {
    /// RGB the channel is drawn in.
    pub color: [u8; 3],
    /// Its transfer function (its window; the opacity all channels share).
    pub transfer: TransferFunction,
    /// Drawn at all (the app's eye toggle); a file without it shows every channel.
    #[serde(default = "shown")]
    pub visible: bool,
}

/// A channel's visibility where a file does not say.
fn shown() -> bool {
    true
}

/// The streaming renderer's budgets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewStream {
    pub gpu_memory: u64,
    pub ram_cache: u64,
    pub upload_budget: u64,
    pub lod_scale: f32,
    /// Seconds a still may take to complete.
    pub max_wait: f64,
}

/// Seconds `render` waits at most for a streamed still to complete (`--max-wait`'s default).
pub const DEFAULT_MAX_WAIT_SECONDS: f64 = 30.0;

impl ViewStream {
    /// The budgets of a streaming renderer that holds `gpu_memory` and is otherwise as it
    /// opens by default (the app's: its GPU budget is the one it lets a user choose).
    pub fn with_gpu_memory(gpu_memory: u64) -> Self {
        let defaults = voxscope_stream::StreamOptions::default();
        Self {
            gpu_memory,
            ram_cache: defaults.ram_cache,
            upload_budget: defaults.upload_bytes_per_frame,
            lod_scale: defaults.lod_scale,
            max_wait: DEFAULT_MAX_WAIT_SECONDS,
        }
    }
}

/// A measured distance between two points in voxel space.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewRuler {
    pub from: [f64; 3],
    pub to: [f64; 3],
}

impl Default for SavedView {
    fn default() -> Self {
        Self {
            version: VIEW_VERSION,
            data: ViewData::default(),
            camera: Camera::default(),
            size: [1024, 768],
            transfer: None,
            channels: Vec::new(),
            settings: None,
            renderer: None,
            brick_size: None,
            stream: None,
            rulers: Vec::new(),
            layout: None,
        }
    }
}

impl ViewData {
    /// `source` as a view stores it: a URL without user name, password, query or fragment
    /// (credentials and tokens stay out of files that are shared), anything else as given.
    pub fn stored_source(spec: &str) -> String {
        if spec.contains("://") {
            voxscope_volume::remote::redact_url(spec)
        } else {
            spec.to_owned()
        }
    }

    /// The first path the data names that does not exist (URLs, `synthetic:` and the sample
    /// are not checked: they are not files).
    pub fn missing_path(&self) -> Option<&str> {
        self.source
            .iter()
            .chain(&self.channels_from)
            .map(String::as_str)
            .find(|spec| {
                !spec.contains("://")
                    && !spec.starts_with("synthetic:")
                    && !Path::new(spec).exists()
            })
    }
}

impl SavedView {
    /// Largest file accepted as a view.
    const MAX_BYTES: u64 = 1 << 20;

    /// Writes it as RON.
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let text = ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default())
            .map_err(|e| format!("{}: cannot encode the view: {e}", path.display()))?;
        std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))
    }

    /// Reads a view file; every error is one line naming the file.
    pub fn read(path: &Path) -> Result<Self, String> {
        let metadata = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
        if metadata.len() > Self::MAX_BYTES {
            return Err(format!(
                "{}: {} bytes is too large for a view file",
                path.display(),
                metadata.len()
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Parses and checks a view file's text.
    pub fn parse(text: &str) -> Result<Self, String> {
        let view: Self = ron::from_str(text).map_err(|e| {
            format!(
                "not a voxscope view file: {}",
                e.to_string().lines().next().unwrap_or_default()
            )
        })?;
        if view.version == 0 || view.version > VIEW_VERSION {
            return Err(format!(
                "view file version {} is not one this voxscope reads (1 to {VIEW_VERSION}); a newer voxscope wrote it",
                view.version
            ));
        }
        let [width, height] = view.size;
        if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
            return Err(format!(
                "the size {width}x{height} is not from 1x1 to 16384x16384"
            ));
        }
        let camera = view.camera;
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
            return Err(
                "the camera has a value that is not a finite number (or a distance ≤ 0)".into(),
            );
        }
        let transfers = view
            .transfer
            .iter()
            .chain(view.channels.iter().map(|c| &c.transfer));
        for transfer in transfers {
            let window = transfer.window;
            let valid = window.low.is_finite()
                && window.high.is_finite()
                && window.high > window.low
                && (0.0..=1.0).contains(&transfer.threshold);
            if !valid {
                return Err("a transfer function's window or threshold is out of range".into());
            }
        }
        if let Some(settings) = view.settings
            && !(settings.density.is_finite() && settings.density > 0.0)
        {
            return Err(format!(
                "the opacity scale (density) {} is not a positive number",
                settings.density
            ));
        }
        if view.channels.len() > 8 {
            return Err(format!(
                "{} channels: a composite has at most 8",
                view.channels.len()
            ));
        }
        Ok(view)
    }

    /// Whether `other` shows the same data (source, channels, time, layout of a raw file).
    pub fn same_data(&self, other: &Self) -> bool {
        self.data == other.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_round_trips_and_an_older_file_loads_with_defaults() {
        let view = SavedView {
            data: ViewData {
                source: Some("head.nii.gz".into()),
                time: 2,
                ..ViewData::default()
            },
            camera: Camera {
                azimuth_deg: 75.5,
                ..Camera::default()
            },
            size: [64, 48],
            rulers: vec![ViewRuler {
                from: [1.0, 2.0, 3.0],
                to: [4.0, 5.0, 6.0],
            }],
            ..SavedView::default()
        };
        let text =
            ron::ser::to_string_pretty(&view, ron::ser::PrettyConfig::default()).expect("encodes");
        assert_eq!(SavedView::parse(&text), Ok(view));
        // A file of an earlier version with only a camera.
        let old = SavedView::parse("(version: 1, camera: (azimuth_deg: 10.0, elevation_deg: 5.0, distance: 2.0, fov_y_deg: 30.0, pan: (0.0, 0.0, 0.0)))")
            .expect("loads");
        assert_eq!(old.camera.azimuth_deg, 10.0);
        assert_eq!(old.size, [1024, 768]);
        assert_eq!(old.data.source, None);
    }

    #[test]
    fn bad_files_say_what_is_wrong_in_one_line() {
        for (text, expected) in [
            ("(version: 1, camera: (", "not a voxscope view file"),
            ("(version: 7)", "a newer voxscope wrote it"),
            ("(size: (0, 10))", "the size 0x10"),
            ("[1, 2, 3]", "not a voxscope view file"),
        ] {
            let error = SavedView::parse(text).expect_err(text);
            assert!(error.contains(expected), "{text}: {error}");
            assert_eq!(error.lines().count(), 1, "{error}");
        }
    }

    #[test]
    fn urls_are_stored_without_credentials_or_query() {
        assert_eq!(
            ViewData::stored_source("https://me:secret@example.org/a.ome.zarr?token=x"),
            "https://example.org/a.ome.zarr"
        );
        assert_eq!(
            ViewData::stored_source("../data/head.nii.gz"),
            "../data/head.nii.gz"
        );
    }
}
