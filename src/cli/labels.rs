//! Label overlays on the command line (`render --labels NAME|FILE`, `probe`): which label
//! volumes to draw over the image, read and checked against the image's grid. How they are
//! drawn is voxscope-scene's `label_overlay.rs`.

use std::path::Path;

use clap::Args;
use std::sync::Arc;
use std::time::Duration;

use voxscope_render::GpuContext;
use voxscope_scene::{DEFAULT_LABEL_OPACITY, LabelOverlay, UploadedLabels};
use voxscope_stream::StreamOptions;
use voxscope_volume::ome_zarr::{LabelImage, Pyramid};
use voxscope_volume::{Selection, format_dims};

use super::VolumeArgs;

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

fn parse_opacity(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{text}' is not an opacity from 0 to 1")),
    }
}

/// The label images of the OME-Zarr image `volume` opens (none for other files), with the
/// pyramid they belong to.
pub fn label_images(volume: &VolumeArgs) -> Option<(Pyramid, Vec<LabelImage>)> {
    let file = volume.file.as_deref()?;
    if !voxscope_volume::ome_zarr::is_zarr_spec(file) {
        return None;
    }
    let options = volume.load_options();
    let pyramid = Pyramid::open_spec(file, options.select, options.remote).ok()?;
    let labels = pyramid.label_images();
    Some((pyramid, labels))
}

/// Reads each of `names` (a label image of the image `volume` opens, else a file) as a label
/// overlay on the grid of the image, whose volume in memory has `image_dims` voxels. Errors
/// are one line naming the label or file and the problem.
pub fn open_overlays(
    names: &[String],
    volume: &VolumeArgs,
    image_dims: [usize; 3],
) -> Result<Vec<LabelOverlay>, String> {
    if names.is_empty() {
        return Ok(Vec::new());
    }
    let listed = label_images(volume);
    names
        .iter()
        .map(|name| open_overlay(name, volume, listed.as_ref(), image_dims))
        .collect()
}

fn open_overlay(
    name: &str,
    volume: &VolumeArgs,
    listed: Option<&(Pyramid, Vec<LabelImage>)>,
    image_dims: [usize; 3],
) -> Result<LabelOverlay, String> {
    let image_name = volume
        .file
        .as_deref()
        .unwrap_or(voxscope_volume::SAMPLE_NAME);
    if let Some((image, labels)) = listed
        && let Some(label) = labels.iter().find(|label| label.name == name)
    {
        let remote = volume.load_options().remote;
        return LabelOverlay::open_label_image(image, image_name, label, image_dims, remote);
    }
    if voxscope_volume::remote::is_url(name) || Path::new(name).exists() {
        return LabelOverlay::open_file(name, image_dims);
    }
    let known = match listed {
        Some((_, labels)) if !labels.is_empty() => format!(
            "its label images are {}",
            labels
                .iter()
                .map(|l| l.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        _ => "it has no label images".to_owned(),
    };
    Err(format!(
        "--labels {name}: no such file, and no label image of {image_name} by that name ({known})"
    ))
}

/// The label images `args` names, streamed over a streamed image (`volume`, whose level 0 has
/// `image_dims` voxels) from their own pyramids, each with a quarter of the image's GPU and RAM
/// budgets (`options`). Only label images of the store: a label file is drawn over an image in
/// memory.
pub fn open_streamed_overlays(
    args: &LabelArgs,
    volume: &VolumeArgs,
    image_dims: [usize; 3],
    context: &GpuContext,
    options: StreamOptions,
    max_wait: Duration,
) -> Result<Vec<UploadedLabels>, String> {
    if args.labels.is_empty() {
        return Ok(Vec::new());
    }
    let listed = label_images(volume);
    let image_name = volume
        .file
        .as_deref()
        .unwrap_or(voxscope_volume::SAMPLE_NAME);
    let remote = volume.load_options().remote;
    let options = StreamOptions {
        gpu_memory: (options.gpu_memory / 4).max(1 << 20),
        ram_cache: (options.ram_cache / 4).max(1 << 20),
        ..options
    };
    args.labels
        .iter()
        .map(|name| {
            let Some((image, label)) = listed
                .as_ref()
                .and_then(|(image, labels)| Some((image, labels.iter().find(|l| &l.name == name)?)))
            else {
                return Err(format!(
                    "--labels {name}: over a streamed image, labels are label images of {image_name} (info lists them); a label file is drawn over the image in memory (without --renderer stream)"
                ));
            };
            let spec = image.label_spec(image_name, label);
            let pyramid =
                Pyramid::open_spec(&spec, Selection::default(), remote).map_err(|e| e.to_string())?;
            let dims = pyramid.levels.first().map(|level| level.dims);
            if dims != Some(image_dims) {
                return Err(format!(
                    "{spec}: its grid ({}) is not the image's ({}); labels must lie on the image's grid",
                    dims.map(format_dims).unwrap_or_default(),
                    format_dims(image_dims)
                ));
            }
            UploadedLabels::streamed(
                context,
                &label.name,
                Arc::new(pyramid),
                &label.colors,
                &args.labels_hide,
                args.labels_opacity,
                options,
                max_wait,
            )
        })
        .collect()
}
