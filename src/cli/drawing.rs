//! What `render` and `movie` draw: the volume the options name, uploaded once for its renderer
//! (one volume, the composite of its channels, or a streamed pyramid), and a frame of it for
//! any camera, settings and transfer function, complete before it is read back (a streamed
//! view is refined until nothing visible is missing, or `--max-wait`).

use std::time::{Duration, Instant};

use image::{GenericImage, RgbaImage};
use voxscope_octree::{MAX_DEPTH, TransferFunction};
use voxscope_render::{
    Camera, ChannelLayer, GpuContext, HeadlessStart, RenderSettings, RenderTarget, RendererKind,
    RendererOptions, VolumeRenderer, read_image,
};
use voxscope_scene::{
    ChannelState, OpenedStream, Refinement, StreamedVolume, UploadedLabels, beyond_octree, refine,
};
use voxscope_volume::{QuantizedVolume, Volume, format_dims};

use super::args::{ChannelArg, RendererArg};
use super::composite::PreparedChannel;
use super::labels::{open_overlays, open_streamed_overlays};
use super::prepare::default_renderer;
use super::stream::open_streamed_with_renderer;
use super::{Prepared, RenderOptions, VolumeArgs};

/// One volume on the GPU, ready to draw frames of.
pub struct Drawing {
    pub context: GpuContext,
    pub renderer: VolumeRenderer,
    /// The settings the options ask for (the first frame's).
    pub settings: RenderSettings,
    /// The transfer function the renderer holds now.
    pub transfer: TransferFunction,
    pub content: Content,
    /// The volume's name, for messages.
    pub name: String,
    /// The label overlays drawn over each image (`--labels`), in order.
    pub labels: Vec<UploadedLabels>,
    max_wait: Duration,
    /// The composite's channels' values (what its tables are rewritten over when the
    /// channels' colors or windows change); empty for one volume.
    composite_values: Vec<QuantizedVolume>,
}

/// What a [`Drawing`] holds.
pub enum Content {
    /// One volume in memory, its octree `depth` deep.
    Volume { depth: u32 },
    /// The composite of these channels (the dense renderer).
    Composite { channels: Vec<ChannelState> },
    /// A pyramid streamed through the GPU budget, `depth` levels deep.
    Streamed { depth: u32 },
}

impl Drawing {
    /// Reads, prepares and uploads what `volume` and `options` name, as `render` draws it:
    /// `--renderer stream`, the composite of several channels, a volume beyond the octree
    /// streamed from memory, or one volume for its renderer.
    pub fn open(volume: &VolumeArgs, options: &RenderOptions) -> Result<Self, String> {
        // The GPU starts while the volume is read; for the streaming renderer, which is what
        // a store's `--renderer stream` always draws, it builds the renderer's pipelines too.
        let streams = options.renderer == Some(RendererArg::Stream);
        let gpu = HeadlessStart::begin_for(streams.then_some(RendererKind::Stream));
        let max_wait = Duration::from_secs_f64(options.max_wait);
        let refuse_labels = |what: &str| -> Result<(), String> {
            match options.labels.labels.first() {
                Some(name) => Err(format!(
                    "--labels {name}: label overlays are drawn over one volume in memory; not over {what} (yet)"
                )),
                None => Ok(()),
            }
        };
        if streams {
            // The renderer is made while the store's first chunks are on their way.
            let (opened, saved) = open_streamed_with_renderer(
                volume,
                &options.transfer,
                options.stream.options(),
                || gpu.finish().map_err(|e| e.to_string()),
            )?;
            let image_dims = opened.volume.source.shape().dims();
            let mut drawing = Self::streamed(opened, saved.as_ref(), options, max_wait);
            drawing.labels = open_streamed_overlays(
                &options.labels,
                volume,
                image_dims,
                &drawing.context,
                options.stream.options(),
                max_wait,
            )?;
            return Ok(drawing);
        }
        let loaded = match volume.composite_channels()? {
            Some(channels) if channels.len() > 1 => {
                refuse_labels("the composite of several channels (--channel N draws one)")?;
                return Self::composite(gpu, channels, options, max_wait);
            }
            Some(mut channels) => channels.pop().ok_or("no channel was read")?,
            None => volume.load()?,
        };
        // `--channel N` of a file of several channels: drawn as the composite draws it, in the
        // channel's color and window, where the options or the file give it a color and the
        // dense renderer can draw it; else in the channel's window, by the renderer asked for.
        let mut transfer_args = options.transfer.clone();
        if let Some(ChannelArg::Index(index)) = volume.channel {
            if options.channels.colors_channel(&loaded, index)? {
                if matches!(options.renderer, None | Some(RendererArg::Dense))
                    && !beyond_octree(loaded.dims)
                {
                    refuse_labels("a channel in its color (--renderer octree draws it)")?;
                    let channel = options
                        .channels
                        .prepare_one(loaded, index, &options.transfer)?;
                    return Self::composite_of(gpu, vec![channel], options, max_wait);
                }
                eprintln!(
                    "channel {index} is drawn in grays: its color needs the dense renderer (--renderer dense)"
                );
            }
            if let Some(window) = options.channels.window_of(index) {
                transfer_args.window = Some(window);
            }
        }
        let options = &RenderOptions {
            transfer: transfer_args,
            ..options.clone()
        };
        // Longer than the voxel octree holds: bricks are streamed from memory.
        if beyond_octree(loaded.dims)
            && matches!(options.renderer, None | Some(RendererArg::Bricks))
        {
            eprintln!(
                "{}: {} voxels are beyond the voxel octree's {} a side: drawn by the streaming renderer, from memory",
                loaded.name,
                format_dims(loaded.dims),
                1u32 << MAX_DEPTH
            );
            refuse_labels("a volume streamed from memory")?;
            let saved = options.transfer.saved()?;
            let streamed = StreamedVolume::from_volume(
                loaded,
                &options.transfer.request(saved.as_ref()),
                Instant::now(),
            )
            .map_err(|e| e.to_string())?;
            let context = gpu.finish().map_err(|e| e.to_string())?;
            let opened = streamed
                .with_renderer(context, options.stream.options())
                .map_err(|e| e.to_string())?;
            return Ok(Self::streamed(opened, saved.as_ref(), options, max_wait));
        }
        let prepared = Prepared::from_volume(loaded, &options.transfer)?;
        let depth = prepared.data.octree.depth;
        let mut settings = options
            .transfer
            .render_settings(depth, prepared.saved.as_ref());
        settings.clip = options.clip.clip();
        let context = gpu.finish().map_err(|e| e.to_string())?;
        let kind = match options.renderer {
            Some(renderer) => renderer.into(),
            None => default_renderer(
                &context,
                &prepared.data.octree,
                settings.max_level,
                "rendering",
            ),
        };
        let name = prepared.data.volume.name.clone();
        let renderer_options = RendererOptions {
            kind,
            brick_size: options.brick_size,
            ..Default::default()
        };
        let labels = open_overlays(&options.labels.labels, volume, prepared.data.volume.dims)?
            .into_iter()
            .map(|overlay| {
                overlay
                    .layer(
                        &options.labels.labels_hide,
                        options.labels.labels_opacity,
                        prepared.data.volume.spacing,
                    )?
                    .upload(&context, renderer_options, settings.max_level)
            })
            .collect::<Result<Vec<_>, String>>()?;
        let renderer = VolumeRenderer::new(
            &context,
            renderer_options,
            &prepared.data.octree,
            &prepared.data.quantized,
            prepared.data.volume.spacing,
            settings.max_level,
            &prepared.transfer,
        )
        .map_err(|e| format!("{name}: {e}"))?;
        Ok(Self {
            context,
            renderer,
            settings,
            transfer: prepared.transfer,
            content: Content::Volume { depth },
            name,
            labels,
            max_wait,
            composite_values: Vec::new(),
        })
    }

    fn composite(
        gpu: HeadlessStart,
        channels: Vec<Volume>,
        options: &RenderOptions,
        max_wait: Duration,
    ) -> Result<Self, String> {
        if let Some(renderer) = options.renderer
            && renderer != RendererArg::Dense
        {
            return Err(format!(
                "the composite of {} channels is drawn by the dense renderer; --renderer {} draws one channel (--channel N)",
                channels.len(),
                RendererKind::from(renderer).name()
            ));
        }
        let prepared = options.channels.prepare(channels, &options.transfer)?;
        Self::composite_of(gpu, prepared, options, max_wait)
    }

    /// `prepared` (one channel or several) drawn by the dense renderer's composite.
    fn composite_of(
        gpu: HeadlessStart,
        prepared: Vec<PreparedChannel>,
        options: &RenderOptions,
        max_wait: Duration,
    ) -> Result<Self, String> {
        let saved = options.transfer.saved()?;
        let mut settings = options.transfer.render_settings(0, saved.as_ref());
        settings.clip = options.clip.clip();
        let context = gpu.finish().map_err(|e| e.to_string())?;
        let layers: Vec<ChannelLayer<'_>> = prepared.iter().map(|c| c.layer()).collect();
        let name = prepared[0].volume.name.clone();
        let renderer = VolumeRenderer::new_composite(&context, &layers, prepared[0].volume.spacing)
            .map_err(|e| format!("{name}: {e}"))?;
        let transfer = prepared[0].state.transfer;
        let (channels, composite_values) =
            prepared.into_iter().map(|c| (c.state, c.quantized)).unzip();
        Ok(Self {
            context,
            renderer,
            settings,
            transfer,
            content: Content::Composite { channels },
            name,
            labels: Vec::new(),
            max_wait,
            composite_values,
        })
    }

    fn streamed(
        opened: OpenedStream<GpuContext>,
        saved: Option<&voxscope_scene::SavedTransfer>,
        options: &RenderOptions,
        max_wait: Duration,
    ) -> Self {
        let OpenedStream {
            volume,
            gpu: context,
            renderer,
            ..
        } = opened;
        let depth = volume.depth();
        let mut settings = options.transfer.render_settings(depth, saved);
        settings.clip = options.clip.clip();
        Self {
            context,
            renderer,
            settings,
            transfer: volume.transfer,
            content: Content::Streamed { depth },
            name: volume.source.name().to_owned(),
            labels: Vec::new(),
            max_wait,
            composite_values: Vec::new(),
        }
    }

    /// The octree's (or pyramid's) depth; 0 for the composite.
    pub fn depth(&self) -> u32 {
        match self.content {
            Content::Volume { depth } | Content::Streamed { depth } => depth,
            Content::Composite { .. } => 0,
        }
    }

    /// Draws one frame into `target` and waits for it: for a streamed pyramid, frame after
    /// frame until nothing visible is missing (or `--max-wait`), whose refinement it returns.
    pub fn draw(
        &mut self,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<Option<Refinement>, String> {
        if let Content::Streamed { .. } = self.content {
            return refine(
                &self.context,
                &mut self.renderer,
                target,
                camera,
                settings,
                self.max_wait,
            )
            .map(Some)
            .map_err(|e| e.to_string());
        }
        self.renderer
            .render(&self.context, target, camera, settings);
        self.context.wait_idle().map_err(|e| e.to_string())?;
        Ok(None)
    }

    /// The side of the square tiles this device draws an image of `size` in, where the image
    /// exceeds what one target may be (its largest 2D texture, storage buffer or buffer), or
    /// `asked` (`--tile-size`); `None` where it is drawn whole.
    pub fn tile_side(&self, size: (u32, u32), asked: Option<u32>) -> Option<u32> {
        asked.or_else(|| self.context.tile_side([size.0, size.1]))
    }

    /// Draws an image of `size` in tiles of `side` pixels (see [`RenderTarget::tile`]), each
    /// drawn, waited for and read back before the next: the image one target of the whole
    /// size would hold. A streamed pyramid's tile is a target of its own to the streaming
    /// renderer: its rays' requests are the tile's, and [`refine`] draws it until nothing it
    /// shows is missing (or `--max-wait`) before it is read; the bricks it loaded stay cached
    /// for the tiles after it. Returns the image and the refinements of a streamed one's
    /// tiles.
    pub fn draw_tiled(
        &mut self,
        size: (u32, u32),
        side: u32,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<(RgbaImage, Vec<Refinement>), String> {
        let mut refinements = Vec::new();
        let (width, height) = size;
        let side = side.max(1);
        let mut image = RgbaImage::new(width, height);
        for y in (0..height).step_by(side as usize) {
            for x in (0..width).step_by(side as usize) {
                let part_size = [side.min(width - x), side.min(height - y)];
                let target = RenderTarget::tile(&self.context, part_size, [x, y], [width, height]);
                refinements.extend(self.draw(&target, camera, settings)?);
                let part = read_image(&self.context, &target).map_err(|e| e.to_string())?;
                image
                    .copy_from(&part, x, y)
                    .map_err(|e| format!("{}: a tile does not fit: {e}", self.name))?;
            }
        }
        Ok((image, refinements))
    }

    /// Draws the composite's channels as `states` say (their colors, windows and transfer
    /// functions; as many as it has): a movie's frame between keyframes. One volume ignores
    /// them.
    pub fn set_channels(&mut self, states: &[ChannelState]) {
        let Content::Composite { channels } = &mut self.content else {
            return;
        };
        if states == channels.as_slice() || states.len() != self.composite_values.len() {
            return;
        }
        if let Some(composite) = self.renderer.composite() {
            let layers: Vec<ChannelLayer<'_>> = self
                .composite_values
                .iter()
                .zip(states)
                .map(|(quantized, state)| ChannelLayer {
                    quantized,
                    transfer: &state.transfer,
                    color: state.color.map(|c| c as f32 / 255.0),
                })
                .collect();
            let shown: Vec<bool> = states.iter().map(|s| s.visible).collect();
            composite.set_shown_layers(&self.context, &layers, &shown);
        }
        *channels = states.to_vec();
    }

    /// Draws the label overlays (`--labels`) over `image`, the frame of `camera` and
    /// `settings` drawn whole (`side` None) or in tiles of `side` pixels, as the image was.
    pub fn draw_labels_over(
        &mut self,
        image: &mut RgbaImage,
        side: Option<u32>,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<(), String> {
        let (width, height) = image.dimensions();
        for labels in &mut self.labels {
            let slots = match side {
                None => {
                    let target = RenderTarget::new(&self.context, width, height);
                    labels.draw_slots(&self.context, &target, camera, settings)?
                }
                Some(side) => {
                    let side = side.max(1);
                    let mut slots = vec![0u16; (width * height) as usize];
                    for y in (0..height).step_by(side as usize) {
                        for x in (0..width).step_by(side as usize) {
                            let size = [side.min(width - x), side.min(height - y)];
                            let target =
                                RenderTarget::tile(&self.context, size, [x, y], [width, height]);
                            let part =
                                labels.draw_slots(&self.context, &target, camera, settings)?;
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

    /// Gives the renderer another transfer function (the composite keeps its channels' own).
    pub fn set_transfer(&mut self, transfer: &TransferFunction) -> Result<(), String> {
        if *transfer == self.transfer || matches!(self.content, Content::Composite { .. }) {
            return Ok(());
        }
        let mut encoder =
            self.context
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("voxscope::movie_transfer"),
                });
        self.renderer
            .set_transfer(&self.context, &mut encoder, transfer, None)
            .map_err(|e| format!("{}: {e}", self.name))?;
        self.context.queue.submit([encoder.finish()]);
        self.transfer = *transfer;
        Ok(())
    }
}
