//! The streaming renderer as every front end draws it: the [`Renderer`] trait's methods.

use super::*;
use crate::Shading;

/// The streaming renderer: driven once a frame ([`Renderer::update`]), drawn and probed by the
/// device's [`StreamRaycaster`] with whatever is resident.
impl Renderer for StreamVolume {
    fn kind(&self) -> RendererKind {
        RendererKind::Stream
    }

    fn level_detail(&self, max_level: u32) -> LevelDetail {
        let depth = self.depth();
        level_detail(
            depth,
            self.dims(),
            depth.saturating_sub(max_level),
            max_level,
        )
    }

    /// The whole frame, whatever `region` asks: a frame's requests and usage marks are of all
    /// its rays ([`Renderer::draws_regions`] is false).
    fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    ) {
        let pass = pass.of_whole_target();
        if self.channels.is_some() {
            pass.encode_with(context.stream_composite_raycaster(), context, encoder, self);
        } else {
            pass.encode_with(context.stream_raycaster(), context, encoder, self);
        }
    }

    /// One channel's, or the composite's (as the in-memory composite probes).
    fn encode_probe(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        probe: &ProbeTarget<'_>,
    ) -> bool {
        if self.channels.is_some() {
            let raycaster = context.stream_composite_raycaster();
            encode_probe_ray(raycaster, context, encoder, self, probe);
        } else {
            encode_probe_ray(context.stream_raycaster(), context, encoder, self, probe);
        }
        true
    }

    fn set_transfer(
        &mut self,
        context: &GpuContext,
        _encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        _timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        self.apply_transfer(context, transfer);
        Ok(())
    }

    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        if self.channels.is_some() {
            let variant = Variant {
                clipped: settings.clip.is_active(),
                shaded: Shading::applies(settings),
                ..Variant::PLAIN
            };
            context
                .stream_composite_raycaster()
                .prepare(context, variant);
            if probe {
                let probing = Variant {
                    probe: true,
                    ..variant
                };
                context
                    .stream_composite_raycaster()
                    .prepare(context, probing);
            }
            return;
        }
        for variant in pipeline_variants(settings, probe, false, self.labels()) {
            context.stream_raycaster().prepare(
                context,
                variant,
                self.streamer.options().level_walk,
            );
        }
    }

    /// Together within the budget given.
    fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        vec![
            ("atlas", self.atlas_bytes),
            ("page_table", self.table.size()),
            ("requests", self.requests.size()),
            ("usage", self.usage.size()),
            (
                "readback",
                self.readbacks.iter().map(|r| r.buffer.size()).sum(),
            ),
            (
                "lookup_table",
                self.transfer.size() + self.channels.as_ref().map_or(0, StreamChannels::bytes),
            ),
            ("upload_staging", self.ring.gpu_bytes()),
            ("level_cells", self.level_cells.size()),
        ]
    }

    fn update(&mut self, context: &GpuContext) -> Option<StreamStatus> {
        Some(self.step(context))
    }

    fn streamer(&self) -> Option<&Streamer> {
        Some(&self.streamer)
    }

    fn streamer_mut(&mut self) -> Option<&mut Streamer> {
        Some(&mut self.streamer)
    }

    fn read_pinned(&mut self) -> Result<(), RenderError> {
        StreamVolume::read_pinned(self)
    }

    fn channel_count(&self) -> usize {
        self.channels.as_ref().map_or(1, StreamChannels::count)
    }

    fn set_channels(
        &self,
        context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        shown: &[bool],
    ) -> Result<(), RenderError> {
        match &self.channels {
            Some(channels) => channels.set(context, &**self.streamer.source(), layers, shown),
            None => Err(RenderError::Invalid(format!(
                "the stream renderer of one channel draws one channel, not {}",
                layers.len()
            ))),
        }
    }

    fn stream_paths(&self) -> Option<StreamPaths> {
        Some(StreamPaths {
            upload_path: self.upload_path(),
            atlas_zero: self.atlas_zero(),
            level_walk_frames: self.level_walk_frames(),
            walk_level: self.walk_level_state(),
        })
    }
}
