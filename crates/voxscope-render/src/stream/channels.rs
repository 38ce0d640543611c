//! The streamed composite: a streaming renderer of several channels of one grid
//! (`voxscope_stream::ChannelSources`), drawn by `stream_composite.wgsl`. Each channel's
//! transfer function, tinted by its color, is a table of its own (hidden: transparent black);
//! the shown channels are a bit mask in the frame's uniforms; and the streamer's visibility per
//! channel follows the tables, so a hidden or transparent channel's bricks are never asked for.
//! A change of colors, windows or visibility writes tables and a mask, and reads nothing.

use super::*;
use crate::ChannelLayer;
use crate::composite::tinted_lookup_table;
use crate::settings::GRADIENT_FOR_FULL_SHADING;
use crate::transfer_table::window_levels;
use voxscope_stream::MAX_STREAMED_CHANNELS;
use voxscope_volume::Quantization;

/// A streaming renderer's channels, where its pyramid has several.
pub(super) struct StreamChannels {
    /// Each channel's tinted table, one after another (65 536 entries each).
    pub(super) tables: wgpu::Buffer,
    /// Bit `c`: channel `c` is drawn.
    shown: AtomicU32,
    /// Per channel, 1 / the gradient that shades it fully (f32 bits): its window's width in
    /// levels times [`GRADIENT_FOR_FULL_SHADING`].
    shading: [AtomicU32; MAX_STREAMED_CHANNELS as usize],
    /// The channels' visibility counts from the latest [`StreamChannels::set`], for the next
    /// [`StreamVolume::step`] to give the streamer (it needs the renderer mutably).
    pending: Mutex<Option<Vec<Vec<u32>>>>,
    count: usize,
}

impl StreamChannels {
    /// `count` channels, each drawn with `transfer` untinted until [`Self::set`] says
    /// otherwise, all shown.
    pub(super) fn new(
        context: &GpuContext,
        source: &dyn BrickSource,
        count: usize,
        transfer: &TransferFunction,
    ) -> Self {
        let tables: Vec<u32> = (0..count as u32)
            .flat_map(|c| transfer.lookup_table(source.channel_quantization(c)))
            .collect();
        let tables = context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::stream_channel_tables"),
                contents: bytemuck::cast_slice(&tables),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        let channels = Self {
            tables,
            shown: AtomicU32::new((1u32 << count) - 1),
            shading: Default::default(),
            pending: Mutex::new(None),
            count,
        };
        for c in 0..count {
            channels.set_shading(c, source.channel_quantization(c as u32), transfer);
        }
        channels
    }

    /// Channel `c`'s full-shading gradient from its window under `transfer`.
    fn set_shading(&self, c: usize, quantization: Quantization, transfer: &TransferFunction) {
        if let Some(slot) = self.shading.get(c) {
            let full = 1.0 / (window_levels(quantization, transfer) * GRADIENT_FOR_FULL_SHADING);
            slot.store(full.to_bits(), Ordering::Release);
        }
    }

    /// The channels' full-shading scales as the frame's uniforms hold them (`[c / 4][c % 4]`).
    pub(super) fn shading_scales(&self) -> [[f32; 4]; 2] {
        std::array::from_fn(|row| {
            std::array::from_fn(|column| {
                f32::from_bits(self.shading[row * 4 + column].load(Ordering::Acquire))
            })
        })
    }

    pub(super) fn count(&self) -> usize {
        self.count
    }

    /// The shown channels' bits.
    pub(super) fn shown_mask(&self) -> u32 {
        self.shown.load(Ordering::Acquire)
    }

    /// Gives each channel its transfer function and color (`layers`) and shows those `shown`
    /// marks: tables written, the mask set, the visibility left for the next step.
    pub(super) fn set(
        &self,
        context: &GpuContext,
        source: &dyn BrickSource,
        layers: &[ChannelLayer<'_>],
        shown: &[bool],
    ) -> Result<(), RenderError> {
        if layers.len() != self.count || shown.len() != self.count {
            return Err(RenderError::Invalid(format!(
                "{} channel layers and {} visibilities for a streamed composite of {} channels",
                layers.len(),
                shown.len(),
                self.count
            )));
        }
        let mut tables = Vec::with_capacity(self.count << 16);
        let mut visibility = Vec::with_capacity(self.count);
        let mut mask = 0u32;
        for (c, (layer, &shown)) in layers.iter().zip(shown).enumerate() {
            let quantization = source.channel_quantization(c as u32);
            self.set_shading(c, quantization, layer.transfer);
            let table = if shown {
                tinted_lookup_table(layer.transfer, quantization, layer.color)
            } else {
                vec![0; 1 << 16]
            };
            if shown {
                mask |= 1 << c;
            }
            visibility.push(visible_below(&table));
            tables.extend(table);
        }
        context
            .queue
            .write_buffer(&self.tables, 0, bytemuck::cast_slice(&tables));
        self.shown.store(mask, Ordering::Release);
        *self.pending.lock().unwrap_or_else(|p| p.into_inner()) = Some(visibility);
        Ok(())
    }

    /// The visibility the latest [`Self::set`] left, once.
    pub(super) fn take_visibility(&self) -> Option<Vec<Vec<u32>>> {
        self.pending
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
    }

    pub(super) fn bytes(&self) -> u64 {
        self.tables.size()
    }
}

/// The streamed composite's ray caster (`stream_composite.wgsl`), one per device
/// ([`GpuContext::stream_composite_raycaster`]): the streaming renderer's bindings, its
/// channels' tables in the lookup table's place.
pub struct StreamCompositeRaycaster {
    pipelines: VariantPipelines,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    stand_ins: StandIns,
}

impl StreamCompositeRaycaster {
    pub(crate) fn new(context: &GpuContext) -> Self {
        let (pipelines, layout) = VariantPipelines::new(
            context,
            "stream_composite",
            crate::shaders::STREAM_COMPOSITE,
            &["main"],
            &ray_pass::layout_entries(),
        );
        Self {
            pipelines,
            layout,
            sampler: clamped_sampler(
                &context.device,
                wgpu::FilterMode::Linear,
                "voxscope::stream_composite_sampler",
            ),
            stand_ins: StandIns::new(context),
        }
    }

    pub(crate) fn prepare(&self, context: &GpuContext, variant: Variant) {
        self.pipelines.get(context, 0, variant);
    }
}

impl RayPass<StreamVolume> for StreamCompositeRaycaster {
    const NAME: &'static str = "stream_composite";

    fn pipelines(&self) -> &VariantPipelines {
        &self.pipelines
    }

    fn stand_ins(&self) -> &StandIns {
        &self.stand_ins
    }

    /// Unlabelled: the clip's, the shading's and the probe's variants.
    fn variant(&self, base: Variant, _params: &RaycastParams) -> Variant {
        Variant {
            clipped: base.clipped,
            shaded: base.shaded,
            probe: base.probe,
            ..Variant::PLAIN
        }
    }

    fn before_frame(&self, volume: &StreamVolume, params: &RaycastParams) {
        ray_pass::note_view(volume, params);
        volume.drawn.store(true, Ordering::Release);
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &StreamVolume,
        params: &RaycastParams,
        _settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let lookup_table = volume
            .channels
            .as_ref()
            .map_or(&volume.transfer.buffer, |channels| &channels.tables);
        let bound = ray_pass::Bound {
            layout: &self.layout,
            sampler: &self.sampler,
            lookup_table,
        };
        ray_pass::bind_group(context, bound, volume, params, target, probe)
    }
}
