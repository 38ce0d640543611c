//! What a `Renderer` keeps on the GPU, made as `voxscope render` makes it (`src/cli/render.rs`):
//! one volume (octree, dense or bricks; bricks said where the octree does not fit), the
//! composite of 2 to 8 channels (the dense march), or a pyramid streamed into a fixed budget
//! (`renderer="stream"`, a volume longer than the octree holds, or an OME-Zarr store larger
//! than 512³, as the app streams it). Each frame then applies its transfer function and
//! channel settings where they changed (a GPU recolor or table write, nothing uploaded again).

use std::time::{Duration, Instant};

use voxscope::cli::{RenderOptions, RendererArg};
use voxscope_octree::{self as octree, DataKind, TransferFunction};
use voxscope_render::{
    Camera, ChannelLayer, GpuContext, RenderSettings, RenderTarget, RendererKind, RendererOptions,
    VolumeRenderer,
};
use voxscope_scene::{
    ChannelState, OpenedStream, Progress, SavedTransfer, StreamedVolume, VolumeData, VolumeSource,
    beyond_octree, opening_transfer, refine, renderer_for_octree,
};
use voxscope_volume::{QuantizedVolume, Volume};

use crate::errors::Failure;

/// One channel ready to draw: its values, quantized, and the volume that describes them (its
/// voxels dropped or never copied).
pub struct Channel {
    pub volume: Volume,
    pub quantized: QuantizedVolume,
}

impl Channel {
    /// `volume` quantized, described without its voxels (which stay with the caller).
    pub fn of_volume(volume: &Volume) -> Self {
        Self {
            quantized: QuantizedVolume::new(volume),
            volume: Volume {
                name: volume.name.clone(),
                format: volume.format,
                dims: volume.dims,
                spacing: volume.spacing,
                data: volume.data.emptied(),
                value_scale: volume.value_scale,
                orientation: volume.orientation.clone(),
                metadata: volume.metadata.clone(),
                default_window: volume.default_window,
                series: volume.series.clone(),
            },
        }
    }
}

/// A composite's channel: its values, kind and the state its tables were last written from.
pub struct CompositeChannel {
    pub channel: Channel,
    pub kind: DataKind,
}

/// What a Renderer draws.
pub enum Drawn {
    /// One volume in memory.
    Volume {
        data: VolumeData,
        renderer: VolumeRenderer,
        applied: TransferFunction,
        /// The octree's nodes are uploaded through this level (deeper frames draw it).
        upload_level: u32,
    },
    /// Several channels drawn together.
    Composite {
        channels: Vec<CompositeChannel>,
        renderer: VolumeRenderer,
        applied: Vec<ChannelState>,
    },
    /// A pyramid streamed into the GPU budget.
    Stream {
        streamed: StreamedVolume,
        renderer: VolumeRenderer,
        applied: TransferFunction,
    },
}

/// How a frame is drawn ([`Drawn::frame`]): its settings, camera, size and patience.
pub struct Frame {
    pub settings: RenderSettings,
    pub camera: Camera,
    pub size: (u32, u32),
    pub max_wait: Duration,
}

/// A one-line remark for the user (the octree did not fit and bricks draw instead).
pub type Notice = Option<String>;

/// What a frame drawn to completion has to say ([`Drawn::draw_complete`]): what went wrong or
/// stayed coarse (each frame it happens), and, apart, where the GPU budget limited the view:
/// the line to say, and the limit alone (the same frame after frame while the view is), so
/// that a Renderer says it once until it changes.
#[derive(Debug, Default)]
pub struct CompleteNotice {
    pub lines: Vec<String>,
    pub budget: Option<(String, String)>,
}

impl Drawn {
    /// The channels given (quantized already) drawn as `options` ask: one volume, or the
    /// composite of several.
    pub fn of_channels(
        context: &GpuContext,
        source: &VolumeSource,
        mut channels: Vec<Channel>,
        options: &RenderOptions,
    ) -> Result<(Self, Notice), Failure> {
        if channels.len() > 1 {
            return Self::composite(context, channels, options).map(|d| (d, None));
        }
        let channel = channels
            .pop()
            .ok_or_else(|| Failure::Value("no channel to draw".into()))?;
        Self::single(context, source, channel, options)
    }

    /// One volume: streamed from a pyramid in memory when asked or longer than the octree
    /// holds, else uploaded for the renderer asked for (by default the octree, or bricks
    /// where it does not fit).
    fn single(
        context: &GpuContext,
        source: &VolumeSource,
        channel: Channel,
        options: &RenderOptions,
    ) -> Result<(Self, Notice), Failure> {
        let started = Instant::now();
        let saved = options.transfer.saved().map_err(Failure::Load)?;
        let request = options.transfer.request(saved.as_ref());
        let streams = options.renderer == Some(RendererArg::Stream)
            || (beyond_octree(channel.volume.dims)
                && matches!(options.renderer, None | Some(RendererArg::Bricks)));
        if streams {
            let streamed = StreamedVolume::from_quantized(
                &channel.volume,
                channel.quantized,
                &request,
                started,
            )?;
            let opened = streamed.with_renderer(context, options.stream.options())?;
            return Ok((Self::stream(opened), None));
        }
        let mut data = VolumeData::from_quantized(
            source,
            channel.volume,
            channel.quantized,
            started,
            &Progress::new(),
        )?;
        let transfer = opening_transfer(&data.quantized, data.kind, data.default_window, &request);
        octree::recolor(&mut data.octree, &transfer);
        let settings = options
            .transfer
            .render_settings(data.octree.depth, saved.as_ref());
        let mut notice = None;
        let kind = match options.renderer {
            Some(renderer) => renderer.into(),
            None => renderer_for_octree(context, &data.octree, settings.max_level).unwrap_or_else(
                |(kind, reason)| {
                    notice = Some(format!("{reason}; rendering with bricks"));
                    kind
                },
            ),
        };
        let renderer = VolumeRenderer::new(
            context,
            RendererOptions {
                kind,
                brick_size: options.brick_size,
                gpu_memory: options.stream.gpu_memory,
            },
            &data.octree,
            &data.quantized,
            data.volume.spacing,
            settings.max_level,
            &transfer,
        )
        .map_err(|e| Failure::Render(format!("{}: {e}", data.volume.name)))?;
        Ok((
            Self::Volume {
                data,
                renderer,
                applied: transfer,
                upload_level: settings.max_level,
            },
            notice,
        ))
    }

    /// The composite of `channels` (the dense renderer's), each channel's color and window
    /// as `options` ask.
    fn composite(
        context: &GpuContext,
        channels: Vec<Channel>,
        options: &RenderOptions,
    ) -> Result<Self, Failure> {
        if let Some(renderer) = options.renderer
            && renderer != RendererArg::Dense
        {
            return Err(Failure::Value(format!(
                "the composite of {} channels is drawn by the dense renderer; renderer=\"{}\" draws one channel (channel=N)",
                channels.len(),
                RendererKind::from(renderer).name()
            )));
        }
        let channels: Vec<CompositeChannel> = channels
            .into_iter()
            .map(|channel| CompositeChannel {
                kind: DataKind::of_volume(&channel.volume, &channel.quantized),
                channel,
            })
            .collect();
        let saved = options.transfer.saved().map_err(Failure::Load)?;
        let states = channel_states(&channels, options, saved.as_ref())?;
        let spacing = channels[0].channel.volume.spacing;
        let renderer = VolumeRenderer::new_composite(context, &layers(&channels, &states), spacing)
            .map_err(|e| Failure::Render(format!("{}: {e}", channels[0].channel.volume.name)))?;
        Ok(Self::Composite {
            channels,
            renderer,
            applied: states,
        })
    }

    /// A streamed volume with its renderer.
    pub fn stream<G>(opened: OpenedStream<G>) -> Self {
        let OpenedStream {
            volume, renderer, ..
        } = opened;
        Self::Stream {
            applied: volume.transfer,
            streamed: volume,
            renderer,
        }
    }

    /// The renderer drawing it.
    pub fn renderer(&self) -> &VolumeRenderer {
        match self {
            Self::Volume { renderer, .. }
            | Self::Composite { renderer, .. }
            | Self::Stream { renderer, .. } => renderer,
        }
    }

    /// Its name (the file, URL or the array's).
    pub fn name(&self) -> String {
        match self {
            Self::Volume { data, .. } => data.volume.name.clone(),
            Self::Composite { channels, .. } => channels[0].channel.volume.name.clone(),
            Self::Stream { streamed, .. } => streamed.source.name().to_owned(),
        }
    }

    /// The deepest max level: the octree's or the pyramid's depth (0 for the composite).
    pub fn depth(&self) -> u32 {
        match self {
            Self::Volume { data, .. } => data.octree.depth,
            Self::Composite { .. } => 0,
            Self::Stream { streamed, .. } => streamed.depth(),
        }
    }

    /// Applies what `options` ask of the transfer function and channels, where it changed (a
    /// GPU recolor or a table write); `saved` is their `tf` file, read already.
    pub fn apply_transfer(
        &mut self,
        context: &GpuContext,
        options: &RenderOptions,
        saved: Option<&SavedTransfer>,
    ) -> Result<(), Failure> {
        let request = options.transfer.request(saved);
        match self {
            Self::Volume {
                data,
                renderer,
                applied,
                ..
            } => {
                let transfer =
                    opening_transfer(&data.quantized, data.kind, data.default_window, &request);
                apply_transfer(context, renderer, applied, transfer, &data.volume.name)
            }
            Self::Composite {
                channels,
                renderer,
                applied,
            } => {
                let states = channel_states(channels, options, saved)?;
                if states != *applied
                    && let Some(volume) = renderer.composite()
                {
                    let shown: Vec<bool> = states.iter().map(|s| s.visible).collect();
                    volume.set_shown_layers(context, &layers(channels, &states), &shown);
                    *applied = states;
                }
                Ok(())
            }
            Self::Stream {
                streamed,
                renderer,
                applied,
            } => {
                let transfer = streamed.transfer_for(&request);
                let name = streamed.source.name().to_owned();
                apply_transfer(context, renderer, applied, transfer, &name)
            }
        }
    }

    /// How to draw a frame with `options` (`saved`: their `tf` file): settings, camera, size.
    pub fn frame(&self, options: &RenderOptions, saved: Option<&SavedTransfer>) -> Frame {
        let mut settings = match self {
            Self::Volume {
                data,
                renderer,
                upload_level,
                ..
            } => {
                let mut settings = options.transfer.render_settings(data.octree.depth, saved);
                if renderer.kind() == RendererKind::Octree {
                    settings.max_level = settings.max_level.min(*upload_level);
                }
                settings
            }
            Self::Composite { .. } => options.transfer.render_settings(0, saved),
            Self::Stream { streamed, .. } => {
                options.transfer.render_settings(streamed.depth(), saved)
            }
        };
        settings.clip = options.clip.clip();
        Frame {
            settings,
            camera: options.camera(),
            size: options.size,
            max_wait: Duration::from_secs_f64(options.max_wait),
        }
    }

    /// Records and submits `frame` into `target` without waiting (the streaming renderer
    /// takes its per-frame step first: what earlier frames asked for is loaded and uploaded).
    pub fn draw(&mut self, context: &GpuContext, target: &RenderTarget, frame: &Frame) {
        if let Self::Stream { renderer, .. } = self {
            renderer.update(context);
        }
        self.renderer()
            .render(context, target, &frame.camera, &frame.settings);
    }

    /// Draws `frame` until it is complete: once, or for the streaming renderer frame after
    /// frame until nothing visible is missing or `frame.max_wait` passed (then what was still
    /// coarse is returned, as `render` says it).
    pub fn draw_complete(
        &mut self,
        context: &GpuContext,
        target: &RenderTarget,
        frame: &Frame,
    ) -> Result<CompleteNotice, Failure> {
        match self {
            Self::Stream { renderer, .. } => {
                let refinement = refine(
                    context,
                    renderer,
                    target,
                    &frame.camera,
                    &frame.settings,
                    frame.max_wait,
                )?;
                let mut lines = refinement.errors.clone();
                if !refinement.complete {
                    lines.push(format!(
                        "still coarse after {:.1} s (max_wait): {}",
                        refinement.seconds,
                        voxscope_scene::describe_missing(&refinement.status)
                    ));
                }
                // Complete, but coarser than full detail where the budget left bricks out.
                let budget = refinement
                    .completed_at_budget()
                    .zip(voxscope_scene::describe_budget_limit(&refinement.status));
                Ok(CompleteNotice { lines, budget })
            }
            _ => {
                self.draw(context, target, frame);
                Ok(CompleteNotice::default())
            }
        }
    }
}

/// Writes `transfer` to the GPU where it differs from `applied`.
fn apply_transfer(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    applied: &mut TransferFunction,
    transfer: TransferFunction,
    name: &str,
) -> Result<(), Failure> {
    if transfer == *applied {
        return Ok(());
    }
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::python_recolor"),
        });
    renderer
        .set_transfer(context, &mut encoder, &transfer, None)
        .map_err(|e| Failure::Render(format!("{name}: {e}")))?;
    context.queue.submit([encoder.finish()]);
    *applied = transfer;
    Ok(())
}

/// Each channel's state as `options` ask (`render`'s composite rule,
/// [`ChannelState::opening_of`]).
fn channel_states(
    channels: &[CompositeChannel],
    options: &RenderOptions,
    saved: Option<&SavedTransfer>,
) -> Result<Vec<ChannelState>, Failure> {
    let request = options.channels.request();
    request.check(channels.len()).map_err(Failure::Value)?;
    let transfer_request = options.transfer.request(saved);
    Ok(channels
        .iter()
        .enumerate()
        .map(|(index, c)| {
            ChannelState::opening_of(
                &c.channel.volume,
                &c.channel.quantized,
                c.kind,
                index,
                &transfer_request,
                &request,
            )
        })
        .collect())
}

/// The renderer's layers: each channel's levels under its state's transfer function and color.
fn layers<'a>(
    channels: &'a [CompositeChannel],
    states: &'a [ChannelState],
) -> Vec<ChannelLayer<'a>> {
    channels
        .iter()
        .zip(states)
        .map(|(c, state)| ChannelLayer {
            quantized: &c.channel.quantized,
            transfer: &state.transfer,
            color: state.color.map(|v| v as f32 / 255.0),
        })
        .collect()
}
