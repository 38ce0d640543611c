//! Label overlays on the command line (`render --labels NAME|FILE`, `probe`): which label
//! volumes to draw over the image. They are read and checked against the image's grid by
//! voxscope-scene's `label_open.rs`, and drawn by its `label_overlay.rs`.

use clap::Args;

use voxscope_scene::option_text::parse_opacity;
use voxscope_scene::{DEFAULT_LABEL_OPACITY, LabelOptions};

/// The label layers drawn over the image.
#[derive(Debug, Clone, Default, Args)]
pub struct LabelArgs {
    /// Draw labels over the image: a label image of the opened OME-Zarr image by name (its
    /// `labels/` group; `info` lists them), or a label file on the image's grid (NIfTI, NRRD,
    /// TIFF, …). Repeatable, or a comma list.
    #[arg(long, value_name = "NAME|FILE", value_delimiter = ',')]
    pub labels: Vec<String>,
    /// The labels' opacity over the image, 0…1 (times each label color's alpha).
    #[arg(long, value_name = "F", default_value_t = DEFAULT_LABEL_OPACITY, value_parser = parse_opacity)]
    pub labels_opacity: f32,
    /// Label values not drawn: a ray passes them and shows the next visible label.
    #[arg(
        long,
        value_name = "V,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub labels_hide: Vec<f64>,
}

impl LabelArgs {
    /// The overlays these options ask for, as the scene layer takes them.
    pub fn options(&self) -> LabelOptions {
        LabelOptions {
            names: self.labels.clone(),
            opacity: self.labels_opacity,
            hide: self.labels_hide.clone(),
        }
    }
}
