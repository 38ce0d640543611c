//! Which label overlays a drawing asks for ([`crate::LabelOptions`]), read and checked against
//! the image's grid: label images of the opened OME-Zarr image by name, or label files. How
//! they are drawn is `label_overlay.rs`.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use voxscope_render::GpuContext;
use voxscope_stream::StreamOptions;
use voxscope_volume::Selection;
use voxscope_volume::ome_zarr::{LabelImage, Pyramid};

use crate::{LabelError, LabelOptions, LabelOverlay, OpenOptions, SceneError, UploadedLabels};

/// Reads each of `names` (a label image of the image `open` names, else a file) as a label
/// overlay on the grid of the image, whose volume in memory has `image_dims` voxels. Errors
/// are one line naming the label or file and the problem.
pub fn open_overlays(
    names: &[String],
    open: &OpenOptions,
    image_dims: [usize; 3],
) -> Result<Vec<LabelOverlay>, SceneError> {
    if names.is_empty() {
        return Ok(Vec::new());
    }
    let listed = open.label_images();
    names
        .iter()
        .map(|name| open_overlay(name, open, listed.as_ref(), image_dims))
        .collect::<Result<_, LabelError>>()
        .map_err(SceneError::from)
}

fn open_overlay(
    name: &str,
    open: &OpenOptions,
    listed: Option<&(Pyramid, Vec<LabelImage>)>,
    image_dims: [usize; 3],
) -> Result<LabelOverlay, LabelError> {
    let image_name = open.name();
    if let Some((image, labels)) = listed
        && let Some(label) = labels.iter().find(|label| label.name == name)
    {
        let remote = open.load_options().remote;
        return LabelOverlay::open_label_image(image, image_name, label, image_dims, remote);
    }
    if voxscope_volume::remote::is_url(name) || Path::new(name).exists() {
        return LabelOverlay::open_file(name, image_dims);
    }
    let known = match listed {
        Some((_, labels)) => labels.iter().map(|l| l.name.clone()).collect(),
        None => Vec::new(),
    };
    Err(LabelError::NotFound {
        name: name.to_owned(),
        image: image_name.to_owned(),
        known,
    })
}

/// The label images `labels` names, streamed over a streamed image (`open`, whose level 0 has
/// `image_dims` voxels) from their own pyramids, each with a quarter of the image's GPU and RAM
/// budgets (`options`). Only label images of the store: a label file is drawn over an image in
/// memory.
pub fn open_streamed_overlays(
    labels: &LabelOptions,
    open: &OpenOptions,
    image_dims: [usize; 3],
    context: &GpuContext,
    options: StreamOptions,
    max_wait: Duration,
) -> Result<Vec<UploadedLabels>, SceneError> {
    if labels.names.is_empty() {
        return Ok(Vec::new());
    }
    let listed = open.label_images();
    let image_name = open.name();
    let remote = open.load_options().remote;
    let options = StreamOptions {
        gpu_memory: (options.gpu_memory / 4).max(1 << 20),
        ram_cache: (options.ram_cache / 4).max(1 << 20),
        ..options
    };
    labels
        .names
        .iter()
        .map(|name| {
            let Some((image, label)) = listed.as_ref().and_then(|(image, labels)| {
                Some((image, labels.iter().find(|l| &l.name == name)?))
            }) else {
                return Err(LabelError::NotStreamable {
                    name: name.clone(),
                    image: image_name.to_owned(),
                });
            };
            let spec = image.label_spec(image_name, label);
            let pyramid = Pyramid::open_spec(&spec, Selection::default(), remote)?;
            let dims = pyramid.levels.first().map(|level| level.dims);
            if dims != Some(image_dims) {
                return Err(LabelError::OffGrid {
                    name: spec,
                    dims: dims.unwrap_or_default(),
                    image_dims,
                });
            }
            UploadedLabels::streamed(
                context,
                &label.name,
                Arc::new(pyramid),
                &label.colors,
                &labels.hide,
                labels.opacity,
                options,
                max_wait,
            )
        })
        .collect::<Result<_, LabelError>>()
        .map_err(SceneError::from)
}
