//! Frames of a [`Drawable`]: its settings for a frame's options, its transfer function and
//! channels changed in place (a GPU recolor or a table write, nothing uploaded again), and a
//! frame drawn whole, in tiles, or refined until complete, with the label overlays over it.

use std::borrow::Borrow;
use std::time::Duration;

use image::{GenericImage, RgbaImage};
use voxscope_octree::{MAX_DEPTH, TransferFunction};
use voxscope_render::{
    Camera, GpuContext, RenderSettings, RenderTarget, RendererKind, RendererOptions,
    VolumeRenderer, read_image,
};

use super::{CompositeChannel, Drawable, Drawn, StreamComposite, channel_states};
use crate::channels::write_states;
use crate::{
    ChannelState, DrawOptions, Refinement, SavedTransfer, SceneError, UploadedLabels,
    opening_transfer, refine,
};

impl<G: Borrow<GpuContext>> Drawable<G> {
    /// The device it is drawn on.
    pub fn context(&self) -> &GpuContext {
        self.gpu.borrow()
    }

    /// The renderer drawing it.
    pub fn renderer(&self) -> &VolumeRenderer {
        match &self.drawn {
            Drawn::Volume { renderer, .. }
            | Drawn::Composite { renderer, .. }
            | Drawn::Stream { renderer, .. } => renderer,
        }
    }

    /// Its name (the file, URL or array's).
    pub fn name(&self) -> String {
        match &self.drawn {
            Drawn::Volume { data, .. } => data.volume.name.clone(),
            Drawn::Composite { channels, .. } => channels[0].volume().name.clone(),
            Drawn::Stream { streamed, .. } => streamed.source.name().to_owned(),
        }
    }

    /// The deepest max level: the octree's or the pyramid's depth (0 for the composite).
    pub fn depth(&self) -> u32 {
        match &self.drawn {
            Drawn::Volume { data, .. } => data.octree.depth,
            Drawn::Composite { .. } => 0,
            Drawn::Stream { streamed, .. } => streamed.depth(),
        }
    }

    /// Whether a pyramid is streamed into the GPU budget.
    pub fn is_streamed(&self) -> bool {
        self.renderer().streamer().is_some()
    }

    /// The composite's channels as they are drawn; `None` for one volume.
    pub fn channels(&self) -> Option<&[ChannelState]> {
        match &self.drawn {
            Drawn::Composite { applied, .. } => Some(applied),
            Drawn::Stream {
                composite: Some(composite),
                ..
            } => Some(&composite.applied),
            _ => None,
        }
    }

    /// The file's channels a composite draws, in order, where they are not simply its
    /// channels in order (`None`): a streamed composite's, and an in-memory one's of chosen
    /// channels or of a file of more than it draws.
    pub fn channel_indices(&self) -> Option<Vec<usize>> {
        match &self.drawn {
            Drawn::Stream {
                composite: Some(composite),
                ..
            } => Some(composite.channels.iter().map(|c| c.index).collect()),
            Drawn::Composite {
                channels,
                alone: None,
                ..
            } if super::of_one_file(channels) => {
                let numbers = super::channel_numbers(channels, None);
                let every = channels[0].volume().series.channel_count();
                (!numbers.iter().copied().eq(0..every)).then_some(numbers)
            }
            _ => None,
        }
    }

    /// The transfer function drawn now (the composite's first channel's).
    pub fn transfer(&self) -> TransferFunction {
        match &self.drawn {
            Drawn::Stream {
                composite: Some(composite),
                ..
            } => composite.applied[0].transfer,
            Drawn::Volume { applied, .. } | Drawn::Stream { applied, .. } => *applied,
            Drawn::Composite { applied, .. } => applied[0].transfer,
        }
    }

    /// The label overlays drawn over each image.
    pub fn labels(&self) -> &[UploadedLabels] {
        &self.labels
    }

    /// The saved transfer function (a `tf` file's or a view's) the settings follow.
    pub fn saved(&self) -> Option<&SavedTransfer> {
        self.saved.as_ref()
    }

    /// The settings of a frame drawn with `options`: theirs over this volume's depth (an
    /// octree drawn no deeper than its nodes were uploaded), with their clip.
    pub fn render_settings(&self, options: &DrawOptions) -> RenderSettings {
        let mut settings = options.render_settings(self.depth(), self.saved.as_ref());
        if let Drawn::Volume {
            renderer,
            upload_level,
            ..
        } = &self.drawn
            && renderer.kind() == RendererKind::Octree
        {
            settings.max_level = settings.max_level.min(*upload_level);
        }
        settings
    }

    pub(super) fn data_spacing(&self) -> [f64; 3] {
        match &self.drawn {
            Drawn::Volume { data, .. } => data.volume.spacing,
            Drawn::Composite { channels, .. } => channels[0].volume().spacing,
            Drawn::Stream { streamed, .. } => streamed.source.spacing(),
        }
    }

    pub(super) fn renderer_options(&self, options: &DrawOptions) -> RendererOptions {
        RendererOptions {
            kind: self.renderer().kind(),
            brick_size: options.brick_size,
            gpu_memory: options.stream.gpu_memory,
        }
    }

    pub(super) fn upload_level(&self) -> u32 {
        match &self.drawn {
            Drawn::Volume { upload_level, .. } => *upload_level,
            // The composite is drawn at full detail: so are the labels over it.
            Drawn::Composite { .. } => MAX_DEPTH,
            _ => self.depth(),
        }
    }

    /// Gives the renderer another transfer function (the composite keeps its channels' own).
    pub fn set_transfer(&mut self, transfer: &TransferFunction) -> Result<(), SceneError> {
        let name = self.name();
        let context = self.gpu.borrow();
        match &mut self.drawn {
            Drawn::Volume {
                renderer, applied, ..
            }
            | Drawn::Stream {
                renderer, applied, ..
            } => write_transfer(context, renderer, applied, *transfer, &name),
            Drawn::Composite { .. } => Ok(()),
        }
    }

    /// Applies what `options` ask of the transfer function and channels, where it changed (a
    /// GPU recolor or a table write); `saved` is their `tf` file, read already, which the
    /// settings follow from now on (once applied without error).
    pub fn apply_transfer(
        &mut self,
        options: &DrawOptions,
        saved: Option<SavedTransfer>,
    ) -> Result<(), SceneError> {
        let request = options.transfer.request(saved.as_ref());
        let name = self.name();
        let context = self.gpu.borrow();
        match &mut self.drawn {
            Drawn::Volume {
                data,
                renderer,
                applied,
                ..
            } => {
                let transfer =
                    opening_transfer(&data.quantized, data.kind, data.default_window, &request);
                write_transfer(context, renderer, applied, transfer, &name)?;
            }
            Drawn::Composite {
                channels,
                renderer,
                applied,
                alone,
            } => {
                let states = channel_states(channels, options, saved.as_ref(), *alone)?;
                if states != *applied {
                    let quantized = channels.iter().map(CompositeChannel::quantized);
                    write_states(context, renderer, quantized, &states)
                        .map_err(|e| SceneError::render(&name, e))?;
                    *applied = states;
                }
            }
            Drawn::Stream {
                renderer,
                composite: Some(composite),
                ..
            } => {
                let states = composite_states(composite, &request, options);
                composite.apply(context, renderer, states, &name)?;
            }
            Drawn::Stream {
                streamed,
                renderer,
                applied,
                composite: None,
            } => {
                let transfer = streamed.transfer_for(&request);
                write_transfer(context, renderer, applied, transfer, &name)?;
            }
        }
        // Only what was applied: a frame whose keywords failed leaves the last ones.
        self.saved = saved;
        Ok(())
    }

    /// Draws the composite's channels as `states` say (their colors, windows and transfer
    /// functions; as many as it has): a movie's frame between keyframes. One volume ignores
    /// them; states for another number of channels are refused.
    pub fn set_channels(&mut self, states: &[ChannelState]) -> Result<(), SceneError> {
        let name = self.name();
        let context = self.gpu.borrow();
        if let Drawn::Stream {
            renderer,
            composite: Some(composite),
            ..
        } = &mut self.drawn
        {
            if states.len() != composite.channels.len() {
                return Err(SceneError::failed(format!(
                    "{name}: {} channel settings for {} channels",
                    states.len(),
                    composite.channels.len()
                )));
            }
            return composite.apply(context, renderer, states.to_vec(), &name);
        }
        let Drawn::Composite {
            channels,
            renderer,
            applied,
            ..
        } = &mut self.drawn
        else {
            return Ok(());
        };
        if states == applied.as_slice() {
            return Ok(());
        }
        let quantized = channels.iter().map(CompositeChannel::quantized);
        write_states(context, renderer, quantized, states)
            .map_err(|e| SceneError::render(&channels[0].volume().name, e))?;
        *applied = states.to_vec();
        Ok(())
    }

    /// Records and submits a frame into `target` without waiting (the streaming renderer
    /// takes its per-frame step first: what earlier frames asked for is loaded and uploaded).
    pub fn draw(&mut self, target: &RenderTarget, camera: &Camera, settings: &RenderSettings) {
        let streamed = self.is_streamed();
        let (context, renderer) = self.parts();
        if streamed {
            renderer.update(context);
        }
        renderer.render(context, target, camera, settings);
    }

    /// Draws a frame until it is complete: submitted once (read it back to wait for it), or
    /// for a streamed pyramid frame after frame until nothing visible is missing or
    /// `max_wait` passed, whose refinement it returns.
    pub fn draw_complete(
        &mut self,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
        max_wait: Duration,
    ) -> Result<Option<Refinement>, SceneError> {
        if !self.is_streamed() {
            self.draw(target, camera, settings);
            return Ok(None);
        }
        let (context, renderer) = self.parts();
        refine(context, renderer, target, camera, settings, max_wait).map(Some)
    }

    /// The device and the renderer, to draw with.
    fn parts(&mut self) -> (&GpuContext, &mut VolumeRenderer) {
        let renderer = match &mut self.drawn {
            Drawn::Volume { renderer, .. }
            | Drawn::Composite { renderer, .. }
            | Drawn::Stream { renderer, .. } => renderer,
        };
        (self.gpu.borrow(), renderer)
    }

    /// The side of the square tiles this device draws an image of `size` in, where the image
    /// exceeds what one target may be (its largest 2D texture, storage buffer or buffer), or
    /// `asked`; `None` where it is drawn whole.
    pub fn tile_side(&self, size: (u32, u32), asked: Option<u32>) -> Option<u32> {
        asked.or_else(|| self.context().tile_side([size.0, size.1]))
    }

    /// Draws an image of `size` in tiles of `side` pixels (see [`RenderTarget::tile`]), each
    /// drawn, waited for and read back before the next: the image one target of the whole
    /// size would hold. A streamed pyramid's tile is a target of its own to the streaming
    /// renderer: its rays' requests are the tile's, and it is refined until nothing it shows
    /// is missing (or `max_wait`) before it is read; the bricks it loaded stay cached for the
    /// tiles after it. Returns the image and the refinements of a streamed one's tiles.
    pub fn draw_tiled(
        &mut self,
        size: (u32, u32),
        side: u32,
        camera: &Camera,
        settings: &RenderSettings,
        max_wait: Duration,
    ) -> Result<(RgbaImage, Vec<Refinement>), SceneError> {
        let mut refinements = Vec::new();
        let (width, height) = size;
        let side = side.max(1);
        let mut image = RgbaImage::new(width, height);
        for y in (0..height).step_by(side as usize) {
            for x in (0..width).step_by(side as usize) {
                let part_size = [side.min(width - x), side.min(height - y)];
                let target = RenderTarget::tile(self.context(), part_size, [x, y], [width, height]);
                refinements.extend(self.draw_complete(&target, camera, settings, max_wait)?);
                let part = read_image(self.context(), &target).map_err(SceneError::Gpu)?;
                image.copy_from(&part, x, y).map_err(|e| {
                    SceneError::failed(format!("{}: a tile does not fit: {e}", self.name()))
                })?;
            }
        }
        Ok((image, refinements))
    }

    /// Draws the label overlays over `image`, the frame of `camera` and `settings` drawn
    /// whole (`side` None) or in tiles of `side` pixels, as the image was.
    pub fn draw_labels_over(
        &mut self,
        image: &mut RgbaImage,
        side: Option<u32>,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<(), SceneError> {
        let (width, height) = image.dimensions();
        let context = self.gpu.borrow();
        // The composite is drawn at full detail whatever the level asked: so are its labels.
        let settings = &match self.drawn {
            Drawn::Composite { .. } => RenderSettings {
                max_level: MAX_DEPTH,
                ..*settings
            },
            _ => *settings,
        };
        for labels in &mut self.labels {
            let slots = match side {
                None => {
                    let target = RenderTarget::new(context, width, height);
                    labels.draw_slots(context, &target, camera, settings)?
                }
                Some(side) => {
                    let side = side.max(1);
                    let mut slots = vec![0u16; (width * height) as usize];
                    for y in (0..height).step_by(side as usize) {
                        for x in (0..width).step_by(side as usize) {
                            let size = [side.min(width - x), side.min(height - y)];
                            let target = RenderTarget::tile(context, size, [x, y], [width, height]);
                            let part = labels.draw_slots(context, &target, camera, settings)?;
                            for row in 0..size[1] {
                                let from = (row * size[0]) as usize;
                                let to = ((y + row) * width + x) as usize;
                                slots[to..to + size[0] as usize]
                                    .copy_from_slice(&part[from..from + size[0] as usize]);
                            }
                        }
                    }
                    slots
                }
            };
            labels.blend(image, &slots);
        }
        Ok(())
    }
}

/// Writes `transfer` to the GPU where it differs from `applied`.
/// The states of a streamed composite's channels as `options` ask over `request` (a color or
/// window asked for file channel N goes to channel N).
fn composite_states(
    composite: &StreamComposite,
    request: &crate::TransferRequest,
    options: &crate::DrawOptions,
) -> Vec<crate::ChannelState> {
    composite
        .channels
        .iter()
        .map(|channel| channel.state(request, &options.channels))
        .collect()
}

fn write_transfer(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    applied: &mut TransferFunction,
    transfer: TransferFunction,
    name: &str,
) -> Result<(), SceneError> {
    if transfer == *applied {
        return Ok(());
    }
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::set_transfer"),
        });
    renderer
        .set_transfer(context, &mut encoder, &transfer, None)
        .map_err(|e| SceneError::render(name, e))?;
    context.queue.submit([encoder.finish()]);
    *applied = transfer;
    Ok(())
}
