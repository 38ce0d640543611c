//! Pictures of the data on screen drawn away from the window, on a job thread: a movie's
//! frames and a screenshot at a scale. An [`OffscreenDrawer`] has a renderer of its own,
//! uploaded from the data on screen onto the app's offscreen device ([`super::OffscreenDevice`]:
//! the window's device and the panes' renderers and render targets are the UI thread's), draws a frame of any camera, settings and transfer function,
//! waits for it and reads it back on its thread; an image larger than one render target of
//! the device is drawn in tiles, each the whole image's rays through its pixels, as `render`
//! draws it.

use std::sync::Arc;
use std::time::Duration;

use image::{GenericImage, RgbaImage};
use voxscope_octree::TransferFunction;
use voxscope_render::{GpuContext, RenderTarget, RendererKind, RendererOptions, read_image};
use voxscope_scene::{
    ChannelState, CompositeScene, Progress, Scene, SceneError, Shot, VolumeData, refine,
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
}

impl OffscreenSource {
    /// What `scene` shows: its composite's channels, or its volume with its renderer's
    /// options.
    pub fn of_scene(scene: &Scene) -> Self {
        match &scene.composite {
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

/// A renderer of its own for pictures drawn on a job thread.
pub struct OffscreenDrawer {
    context: Arc<GpuContext>,
    volume: Option<Scene>,
    composite: Option<CompositeScene>,
    /// The transfer function the renderer holds now.
    transfer: TransferFunction,
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
        let (volume, composite) = match source {
            OffscreenSource::Volume { data, options } => (
                Some(voxscope_scene::upload(
                    data, &context, options, transfer, progress,
                )?),
                None,
            ),
            OffscreenSource::Composite { channels: data } => (
                None,
                Some(
                    CompositeScene::new(&context, data, channels)
                        .map_err(|e| SceneError::failed(format!("the composite: {e}")))?,
                ),
            ),
        };
        Ok(Self {
            context,
            volume,
            composite,
            transfer,
            target: None,
        })
    }

    /// Draws `shot` (and, for the composite, `channels`) as an image of `size`, in tiles of
    /// `tile` pixels where asked, else where the device needs them.
    pub fn draw(
        &mut self,
        shot: &Shot,
        channels: &[ChannelState],
        size: [u32; 2],
        tile: Option<u32>,
    ) -> Result<RgbaImage, SceneError> {
        self.follow(shot, channels)?;
        let context = Arc::clone(&self.context);
        let Some(side) = tile.or_else(|| context.tile_side(size)) else {
            let target = match self.target.take() {
                Some(target) if [target.width, target.height] == size => target,
                _ => RenderTarget::new(&context, size[0], size[1]),
            };
            self.draw_into(&target, shot)?;
            let image = read_image(&context, &target)
                .map_err(|e| SceneError::failed(format!("reading the frame back: {e}")))?;
            self.target = Some(target);
            return Ok(image);
        };
        let [width, height] = size;
        let side = side.max(16);
        let mut image = RgbaImage::new(width, height);
        for y in (0..height).step_by(side as usize) {
            for x in (0..width).step_by(side as usize) {
                let part = [side.min(width - x), side.min(height - y)];
                let target = RenderTarget::tile(&context, part, [x, y], size);
                self.draw_into(&target, shot)?;
                let tile = read_image(&context, &target)
                    .map_err(|e| SceneError::failed(format!("reading a tile back: {e}")))?;
                image
                    .copy_from(&tile, x, y)
                    .map_err(|e| SceneError::failed(format!("a tile does not fit: {e}")))?;
            }
        }
        Ok(image)
    }

    /// Gives the renderer `shot`'s transfer function, or the composite `channels`.
    fn follow(&mut self, shot: &Shot, channels: &[ChannelState]) -> Result<(), SceneError> {
        if let Some(composite) = &mut self.composite {
            composite.apply(&self.context, channels);
        }
        if let Some(scene) = &mut self.volume
            && shot.transfer != self.transfer
        {
            let mut encoder =
                self.context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::offscreen_transfer"),
                    });
            scene
                .renderer
                .set_transfer(&self.context, &mut encoder, &shot.transfer, None)
                .map_err(|e| SceneError::render(&scene.data.volume.name, e))?;
            self.context.queue.submit([encoder.finish()]);
            self.transfer = shot.transfer;
        }
        Ok(())
    }

    /// Draws `shot` into `target` (a whole image or a tile of one), complete when it returns.
    fn draw_into(&mut self, target: &RenderTarget, shot: &Shot) -> Result<(), SceneError> {
        let context = &self.context;
        if let Some(scene) = &mut self.volume {
            if scene.options.kind == RendererKind::Stream {
                refine(
                    context,
                    &mut scene.renderer,
                    target,
                    &shot.camera,
                    &shot.settings,
                    STREAMED_FRAME_WAIT,
                )?;
                return Ok(());
            }
            scene
                .renderer
                .render(context, target, &shot.camera, &shot.settings);
        }
        if let Some(composite) = &self.composite {
            composite
                .renderer
                .render(context, target, &shot.camera, &shot.settings);
        }
        Ok(())
    }
}
