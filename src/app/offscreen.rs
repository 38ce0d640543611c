//! Pictures of the data on screen drawn away from the window, on a job thread: a movie's
//! frames and a screenshot at a scale. An [`OffscreenDrawer`] is the scene layer's
//! [`Drawable`] (what `render` and `movie` draw with) of the data on screen, uploaded for a
//! renderer of its own onto the app's offscreen device ([`super::OffscreenDevice`]: the
//! window's device and the panes' renderers and render targets are the UI thread's); it draws
//! a frame of any camera, settings and transfer function, waits for it and reads it back on
//! its thread; an image larger than one render target of the device is drawn in tiles, each
//! the whole image's rays through its pixels, as `render` draws it.

use std::sync::Arc;
use std::time::Duration;

use image::RgbaImage;
use voxscope_octree::TransferFunction;
use voxscope_render::{GpuContext, RenderTarget, RendererOptions, read_image};
use voxscope_scene::{
    ChannelState, CompositeScene, Drawable, Progress, Scene, SceneError, Shot, VolumeData,
};

/// How long a streamed store's frame (or tile) may take to complete before it is read as it
/// is.
const STREAMED_FRAME_WAIT: Duration = Duration::from_secs(60);

/// What an offscreen picture is drawn from: the data on screen.
pub enum OffscreenSource {
    /// One volume, drawn by a renderer of these options (the streaming renderer refines each
    /// frame until nothing visible is missing).
    Volume {
        data: Arc<VolumeData>,
        options: RendererOptions,
    },
    /// The composite of these channels.
    Composite { channels: Vec<Arc<VolumeData>> },
    /// These channels of a store, streamed together from it.
    StreamedChannels {
        source: voxscope_scene::VolumeSource,
        select: voxscope_volume::Selection,
        chosen: Vec<usize>,
        options: RendererOptions,
    },
}

impl OffscreenSource {
    /// What `scene` shows: its composite's channels, or its volume with its renderer's
    /// options.
    pub fn of_scene(scene: &Scene) -> Self {
        match &scene.composite {
            Some(composite) if composite.is_streamed() => Self::StreamedChannels {
                source: scene.data.source.clone(),
                select: scene.data.volume.series.selected,
                chosen: composite
                    .channels
                    .iter()
                    .map(|data| data.volume.series.selected.channel)
                    .collect(),
                options: scene.options,
            },
            Some(composite) => Self::Composite {
                channels: composite.channels.clone(),
            },
            None => Self::Volume {
                data: Arc::clone(&scene.data),
                options: scene.options,
            },
        }
    }
}

/// A renderer of its own for pictures drawn on a job thread: the scene layer's [`Drawable`]
/// of the data on screen, on the offscreen device, and a target kept for the next frame.
pub struct OffscreenDrawer {
    drawable: Drawable<Arc<GpuContext>>,
    /// A target of the last whole-image size, kept for the next frame of that size.
    target: Option<RenderTarget>,
}

impl OffscreenDrawer {
    /// Uploads `source` for a renderer of its own, holding `transfer` (one volume) or drawing
    /// `channels` (the composite).
    pub fn new(
        context: Arc<GpuContext>,
        source: OffscreenSource,
        transfer: TransferFunction,
        channels: &[ChannelState],
        progress: &Progress,
    ) -> Result<Self, SceneError> {
        let drawable = match source {
            OffscreenSource::Volume { data, options } => {
                let scene = voxscope_scene::upload(data, &context, options, transfer, progress)?;
                Drawable::of_scene(context, scene)
            }
            OffscreenSource::Composite { channels: data } => {
                let composite = CompositeScene::new(&context, data, channels)
                    .map_err(|e| SceneError::failed(format!("the composite: {e}")))?;
                Drawable::of_composite(context, composite)?
            }
            OffscreenSource::StreamedChannels {
                source,
                select,
                chosen,
                options,
            } => {
                let stream = voxscope_stream::StreamOptions {
                    gpu_memory: options.gpu_memory,
                    ..voxscope_stream::StreamOptions::default()
                };
                Drawable::of_store_channels(context, &source, select, &chosen, stream)?
            }
        };
        Ok(Self {
            drawable,
            target: None,
        })
    }

    /// Draws `shot` (and, for the composite, `channels`) as an image of `size`, in tiles of
    /// `tile` pixels where asked, else where the device needs them; a streamed store's frame
    /// (or tile) is refined until complete, at most [`STREAMED_FRAME_WAIT`].
    pub fn draw(
        &mut self,
        shot: &Shot,
        channels: &[ChannelState],
        size: [u32; 2],
        tile: Option<u32>,
    ) -> Result<RgbaImage, SceneError> {
        self.drawable.set_transfer(&shot.transfer)?;
        self.drawable.set_channels(channels)?;
        let whole = (size[0], size[1]);
        if let Some(side) = self.drawable.tile_side(whole, tile) {
            let (image, _) = self.drawable.draw_tiled(
                whole,
                side.max(16),
                &shot.camera,
                &shot.settings,
                STREAMED_FRAME_WAIT,
            )?;
            return Ok(image);
        }
        let target = match self.target.take() {
            Some(target) if [target.width, target.height] == size => target,
            _ => RenderTarget::new(self.drawable.context(), size[0], size[1]),
        };
        self.drawable
            .draw_complete(&target, &shot.camera, &shot.settings, STREAMED_FRAME_WAIT)?;
        let image = read_image(self.drawable.context(), &target)
            .map_err(|e| SceneError::failed(format!("reading the frame back: {e}")))?;
        self.target = Some(target);
        Ok(image)
    }
}
