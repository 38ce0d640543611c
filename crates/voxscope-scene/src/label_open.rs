//! Which label overlays a drawing asks for ([`crate::LabelOptions`]), read and checked against
//! the image's grid: label images of the opened OME-Zarr image by name, or label files. How
//! they are drawn is `label_overlay.rs`.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use voxscope_render::GpuContext;
use voxscope_stream::StreamOptions;
use voxscope_volume::ome_zarr::{LabelImage, Pyramid};
use voxscope_volume::remote::RemoteOptions;

use crate::label_overlay::open_label_pyramid;
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

/// The least GPU memory and RAM cache a streamed label image has, whatever its image's budgets:
/// below it an overlay's atlas holds too few bricks to follow the image's view.
pub const LABEL_BUDGET_FLOOR: u64 = 16 << 20;

/// The budgets of a label image streamed over an image streamed with `image`: a quarter of each
/// of the image's GPU memory and RAM cache, at least [`LABEL_BUDGET_FLOOR`].
pub fn label_stream_options(image: StreamOptions) -> StreamOptions {
    StreamOptions {
        gpu_memory: (image.gpu_memory / 4).max(LABEL_BUDGET_FLOOR),
        ram_cache: (image.ram_cache / 4).max(LABEL_BUDGET_FLOOR),
        ..image
    }
}

/// What a streamed label image is drawn with: its values hidden, its opacity, and the budgets
/// and wait of the image it is drawn over.
#[derive(Debug, Clone, Copy)]
pub struct StreamedLabelLook<'a> {
    pub hidden: &'a [f64],
    pub opacity: f32,
    /// The image's streaming options ([`label_stream_options`] takes the label's share).
    pub image_options: StreamOptions,
    pub max_wait: Duration,
}

/// The label image `label` of the image pyramid `image` (opened from `image_name`), read with
/// `remote` and streamed from its own pyramid with its share of the image's budgets: refused
/// where its grid is not the image's. The app's Labels list and `render --labels` over a
/// streamed image both open overlays through it.
pub fn open_streamed_label(
    context: &GpuContext,
    (image, image_name): (&Pyramid, &str),
    label: &LabelImage,
    remote: RemoteOptions,
    look: StreamedLabelLook<'_>,
) -> Result<UploadedLabels, LabelError> {
    let (_, pyramid) = open_label_pyramid(image, image_name, label, remote)?;
    UploadedLabels::streamed(
        context,
        &label.name,
        Arc::new(pyramid),
        &label.colors,
        look.hidden,
        look.opacity,
        label_stream_options(look.image_options),
        look.max_wait,
    )
}

/// The label images `labels` names, streamed over the streamed image `open` names from their
/// own pyramids, each with its share of the image's GPU and RAM
/// budgets (`options`; [`label_stream_options`]). Only label images of the store: a label file
/// is drawn over an image in memory.
pub fn open_streamed_overlays(
    labels: &LabelOptions,
    open: &OpenOptions,
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
    let look = StreamedLabelLook {
        hidden: &labels.hide,
        opacity: labels.opacity,
        image_options: options,
        max_wait,
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
            open_streamed_label(context, (image, image_name), label, remote, look)
        })
        .collect::<Result<_, LabelError>>()
        .map_err(SceneError::from)
}
