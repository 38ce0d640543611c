//! The composite of up to [`MAX_CHANNELS`] channels on one grid, drawn by the dense renderer's
//! march (`shaders/composite.wgsl`; docs/octree.md, "Composite of channels").
//!
//! Each channel has its own transfer function (window, opacity curve) and a color: its table
//! is the transfer function's, its color channels multiplied by the channel's color (napari's
//! additive colormaps: black to the color over the window). DVR sums the channels'
//! premultiplied colors at each sample and takes 1 − Π(1 − αc) as the sample's opacity; MIP
//! adds the colors of the channels' maxima. DVR skips blocks of 8³ voxels where every channel
//! is transparent (the union of the channels' visible ranges). Shaded, each channel is lit by
//! its own gradient (VTK's independent components do the same): its color at a sample under
//! the headlight of its own surface, weighted by its gradient in widths of its own window. Its
//! probe finds, in DVR, where the composite's opacity reaches [`super::PROBE_ALPHA`]; in MIP,
//! the sample of the maximum of the channel drawn brightest there (what the pixel shows most).

use std::sync::atomic::{AtomicUsize, Ordering};

use wgpu::util::DeviceExt;

use super::gpu_data::RaycastParams;
use super::pipeline::{
    Variant, VariantPipelines, atlas_entry, atlas_sampler_entry, clamped_sampler,
    numbered_bind_group, output_image_entry, storage_entry, uniform_entry,
};
use super::raycaster::{
    ProbeTarget, RayPass, StandIns, VolumeShape, encode_probe_ray, frame_params_buffer,
};
use super::renderer::{FramePass, Renderer};
use super::settings::{GRADIENT_FOR_FULL_SHADING, Shading};
use super::transfer_table::window_levels;
use super::{GpuContext, LevelDetail, RenderError, RenderSettings, RenderTarget, RendererKind};
use voxscope_octree::{TransferFunction, pack_rgba, unpack_rgba};
use voxscope_volume::{MAX_CHANNELS, Quantization, QuantizedVolume};

mod skipping;
use skipping::{block_ranges, visible_blocks};

/// One channel of a composite: its value levels, transfer function and color.
#[derive(Debug, Clone, Copy)]
pub struct ChannelLayer<'a> {
    pub quantized: &'a QuantizedVolume,
    pub transfer: &'a TransferFunction,
    /// RGB, 0…1.
    pub color: [f32; 3],
}

/// `transfer`'s lookup table over `quantization` with its colors multiplied by `color`
/// (opacity as it is): a channel's table in the composite.
pub fn tinted_lookup_table(
    transfer: &TransferFunction,
    quantization: Quantization,
    color: [f32; 3],
) -> Vec<u32> {
    transfer
        .lookup_table(quantization)
        .into_iter()
        .map(|packed| {
            let [r, g, b, a] = unpack_rgba(packed);
            let tint =
                |value: u8, factor: f32| (value as f32 * factor.clamp(0.0, 1.0)).round() as u8;
            pack_rgba([tint(r, color[0]), tint(g, color[1]), tint(b, color[2]), a])
        })
        .collect()
}

/// Each layer's `1 / (window width in levels × GRADIENT_FOR_FULL_SHADING)` (the shader's
/// `channel_shading`), as one volume's `shading_scale.w` is.
fn shading_scales(layers: &[ChannelLayer<'_>]) -> Vec<f32> {
    layers
        .iter()
        .map(|layer| {
            let width = window_levels(layer.quantized.quantization, layer.transfer);
            1.0 / (width * GRADIENT_FOR_FULL_SHADING)
        })
        .collect()
}

/// Up to 8 channels' value levels in two RGBA 3D textures (16-bit floats: exact up to level
/// 2048, 11 significant bits above) and their tinted tables one after another.
pub struct CompositeVolume {
    low: wgpu::TextureView,
    high: wgpu::TextureView,
    tables: wgpu::Buffer,
    /// Per channel, 1 / the gradient that shades it fully: its window's width in levels times
    /// [`GRADIENT_FOR_FULL_SHADING`] (each channel is lit by its own gradient).
    shading_scales: wgpu::Buffer,
    /// Each channel's level range per skipping block, and the blocks' visibility.
    block_ranges: Vec<Vec<[u16; 2]>>,
    visible: wgpu::Buffer,
    /// Blocks with something visible under the layers last written (the skipping's reach).
    visible_count: AtomicUsize,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub channels: usize,
    bytes: u64,
}

impl CompositeVolume {
    /// Uploads `layers` (1 to [`MAX_CHANNELS`], one grid) with the voxel size `spacing`.
    pub fn upload(
        context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        spacing: [f64; 3],
    ) -> Result<Self, RenderError> {
        let Some(first) = layers.first() else {
            return Err(RenderError::Invalid(
                "a composite needs at least one channel".into(),
            ));
        };
        if layers.len() > MAX_CHANNELS {
            return Err(RenderError::Invalid(format!(
                "{} channels; a composite shows at most {MAX_CHANNELS}",
                layers.len()
            )));
        }
        let dims = first.quantized.dims;
        if layers.iter().any(|layer| layer.quantized.dims != dims) {
            return Err(RenderError::Invalid(
                "the channels' dimensions differ".into(),
            ));
        }
        let limit = context.limits.max_texture_dimension_3d as usize;
        if dims.iter().any(|&d| d > limit) {
            return Err(RenderError::Invalid(format!(
                "the composite needs a {}x{}x{} 3D texture but this GPU allows {limit} per side",
                dims[0], dims[1], dims[2]
            )));
        }
        let out_of_memory = context
            .device
            .push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let (low, low_bytes) = Self::texture(
            context,
            "composite_low",
            dims,
            &layers[..layers.len().min(4)],
        );
        let (high, high_bytes) = if layers.len() > 4 {
            Self::texture(context, "composite_high", dims, &layers[4..])
        } else {
            // Bound but never read (the shader reads it only for channels 4–7).
            Self::texture(context, "composite_high_unused", [1, 1, 1], &[])
        };
        let block_ranges: Vec<Vec<[u16; 2]>> = layers
            .iter()
            .map(|layer| block_ranges(layer.quantized))
            .collect();
        let shown = vec![true; layers.len()];
        let flags = visible_blocks(layers, &block_ranges, &shown);
        let visible_count = AtomicUsize::new(flags.iter().filter(|&&f| f != 0).count());
        let visible = context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::composite_visible_blocks"),
                contents: bytemuck::cast_slice(&flags),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        let tables = Self::tables(layers, &shown);
        let tables = context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::composite_tables"),
                contents: bytemuck::cast_slice(&tables),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        let shading_scales = context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::composite_shading_scales"),
                contents: bytemuck::cast_slice(&shading_scales(layers)),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        if let Some(error) = pollster::block_on(out_of_memory.pop()) {
            return Err(RenderError::DoesNotFit(format!(
                "the GPU has no room for the composite: {error}"
            )));
        }
        Ok(Self {
            low,
            high,
            bytes: low_bytes + high_bytes + tables.size() + visible.size(),
            tables,
            shading_scales,
            block_ranges,
            visible,
            visible_count,
            dims,
            spacing,
            channels: layers.len(),
        })
    }

    /// Writes new transfer functions and colors (as many layers as at upload; their levels
    /// are not read again) and the blocks the ray may skip.
    pub fn set_layers(&self, context: &GpuContext, layers: &[ChannelLayer<'_>]) {
        self.set_shown_layers(context, layers, &vec![true; layers.len()]);
    }

    /// [`Self::set_layers`] with some layers hidden (`shown[i]` false): a hidden layer's
    /// table is transparent black, so it adds no color, hides nothing behind it and keeps
    /// no block from being skipped (the app's eye toggle).
    pub fn set_shown_layers(
        &self,
        context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        shown: &[bool],
    ) {
        debug_assert_eq!(layers.len(), self.channels);
        debug_assert_eq!(shown.len(), self.channels);
        context.queue.write_buffer(
            &self.tables,
            0,
            bytemuck::cast_slice(&Self::tables(layers, shown)),
        );
        context.queue.write_buffer(
            &self.shading_scales,
            0,
            bytemuck::cast_slice(&shading_scales(layers)),
        );
        let visible = visible_blocks(layers, &self.block_ranges, shown);
        self.visible_count.store(
            visible.iter().filter(|&&f| f != 0).count(),
            Ordering::Relaxed,
        );
        context
            .queue
            .write_buffer(&self.visible, 0, bytemuck::cast_slice(&visible));
    }

    /// Blocks of 8³ voxels where some shown channel is visible under the layers last
    /// written, and all blocks: what empty-space skipping leaves to march.
    pub fn block_counts(&self) -> (usize, usize) {
        (
            self.visible_count.load(Ordering::Relaxed),
            self.block_ranges.first().map_or(0, Vec::len),
        )
    }

    /// Bytes on the GPU: textures and tables.
    pub fn total_bytes(&self) -> u64 {
        self.bytes
    }

    fn tables(layers: &[ChannelLayer<'_>], shown: &[bool]) -> Vec<u32> {
        layers
            .iter()
            .zip(shown)
            .flat_map(|(layer, &shown)| {
                let table =
                    tinted_lookup_table(layer.transfer, layer.quantized.quantization, layer.color);
                if shown { table } else { vec![0; table.len()] }
            })
            .collect()
    }

    /// An RGBA16 float 3D texture of up to four channels' levels (unused components 0).
    fn texture(
        context: &GpuContext,
        label: &str,
        dims: [usize; 3],
        layers: &[ChannelLayer<'_>],
    ) -> (wgpu::TextureView, u64) {
        let voxels = dims.iter().product::<usize>();
        let mut texels = vec![half::f16::ZERO; voxels * 4];
        for (component, layer) in layers.iter().enumerate() {
            for (texel, &level) in texels[component..]
                .iter_mut()
                .step_by(4)
                .zip(&layer.quantized.levels)
            {
                *texel = half::f16::from_f32(level as f32);
            }
        }
        let size = wgpu::Extent3d {
            width: dims[0] as u32,
            height: dims[1] as u32,
            depth_or_array_layers: dims[2] as u32,
        };
        let texture = context.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(&format!("voxscope::{label}")),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let bytes: &[u8] = bytemuck::cast_slice(&texels);
        context.queue.write_texture(
            texture.as_image_copy(),
            bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size.width * 8),
                rows_per_image: Some(size.height),
            },
            size,
        );
        (
            texture.create_view(&wgpu::TextureViewDescriptor::default()),
            bytes.len() as u64,
        )
    }
}

impl VolumeShape for CompositeVolume {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }
    fn spacing(&self) -> [f64; 3] {
        self.spacing
    }
    fn depth(&self) -> u32 {
        0
    }
    fn level_cap(&self) -> u32 {
        0
    }
    fn mip_saturation(&self) -> u16 {
        // Each channel's maximum is needed to the end of the ray.
        u16::MAX
    }
    fn window_levels(&self) -> f32 {
        1.0
    }
    fn level_scale(&self) -> f32 {
        // 16-bit float texels hold the levels themselves.
        1.0
    }
}

/// The composite's pipeline and samplers.
pub struct CompositeRaycaster {
    pipelines: VariantPipelines,
    layout: wgpu::BindGroupLayout,
    trilinear: wgpu::Sampler,
    nearest: wgpu::Sampler,
    stand_ins: StandIns,
}

impl CompositeRaycaster {
    /// Builds the pipeline (its clipped variant on first use);
    /// [`GpuContext::composite_raycaster`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let device = &context.device;
        let (pipelines, layout) = VariantPipelines::new(
            context,
            "composite",
            super::shaders::COMPOSITE,
            &["main"],
            &[
                uniform_entry(0, false),
                atlas_entry(1),
                atlas_sampler_entry(2),
                storage_entry(3, true),
                output_image_entry(4),
                storage_entry(5, false),
                storage_entry(6, false),
                atlas_entry(7),
                storage_entry(8, true),
                storage_entry(9, true),
            ],
        );
        Self {
            pipelines,
            layout,
            trilinear: clamped_sampler(
                device,
                wgpu::FilterMode::Linear,
                "voxscope::composite_trilinear",
            ),
            nearest: clamped_sampler(
                device,
                wgpu::FilterMode::Nearest,
                "voxscope::composite_nearest",
            ),
            stand_ins: StandIns::new(context),
        }
    }

    /// Builds the pipeline of `variant` where not built yet (off the frame path).
    pub(crate) fn prepare(&self, context: &GpuContext, variant: Variant) {
        self.pipelines.get(context, 0, variant);
    }
}

impl RayPass<CompositeVolume> for CompositeRaycaster {
    const NAME: &'static str = "composite";

    fn pipelines(&self) -> &VariantPipelines {
        &self.pipelines
    }

    fn stand_ins(&self) -> &StandIns {
        &self.stand_ins
    }

    /// One level: the clipped, shaded and probe variants differ.
    fn variant(&self, base: Variant, _params: &RaycastParams) -> Variant {
        Variant {
            clipped: base.clipped,
            shaded: base.shaded,
            probe: base.probe,
            ..Variant::PLAIN
        }
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &CompositeVolume,
        params: &RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let params = frame_params_buffer(context, "voxscope::composite_params", params);
        let sampler = if settings.trilinear {
            &self.trilinear
        } else {
            &self.nearest
        };
        numbered_bind_group(
            &context.device,
            "voxscope::composite_bind_group",
            &self.layout,
            &[
                params.as_entire_binding(),
                wgpu::BindingResource::TextureView(&volume.low),
                wgpu::BindingResource::Sampler(sampler),
                volume.tables.as_entire_binding(),
                wgpu::BindingResource::TextureView(&target.view),
                target.visits.as_entire_binding(),
                probe.as_entire_binding(),
                wgpu::BindingResource::TextureView(&volume.high),
                volume.visible.as_entire_binding(),
                volume.shading_scales.as_entire_binding(),
            ],
        )
    }
}

/// The composite of channels: drawn by the device's [`CompositeRaycaster`]. Its channels carry
/// their own transfer functions ([`CompositeVolume::set_shown_layers`]); it has no levels.
impl Renderer for CompositeVolume {
    fn kind(&self) -> RendererKind {
        RendererKind::Composite
    }

    fn level_detail(&self, _max_level: u32) -> LevelDetail {
        LevelDetail::Full
    }

    fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    ) {
        pass.encode_with(context.composite_raycaster(), context, encoder, self);
    }

    fn draws_regions(&self) -> bool {
        true
    }

    fn encode_probe(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        probe: &ProbeTarget<'_>,
    ) -> bool {
        encode_probe_ray(context.composite_raycaster(), context, encoder, self, probe);
        true
    }

    /// Nothing: each channel's transfer function is its own ([`Self::set_shown_layers`]).
    fn set_transfer(
        &mut self,
        _context: &GpuContext,
        _encoder: &mut wgpu::CommandEncoder,
        _transfer: &TransferFunction,
        _timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        Ok(())
    }

    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        let variant = Variant {
            clipped: settings.clip.is_active(),
            shaded: Shading::applies(settings),
            ..Variant::PLAIN
        };
        context.composite_raycaster().prepare(context, variant);
        if probe {
            let probing = Variant {
                probe: true,
                ..variant
            };
            context.composite_raycaster().prepare(context, probing);
        }
    }

    fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        vec![("textures_and_tables", self.bytes)]
    }

    fn channel_count(&self) -> usize {
        self.channels
    }

    fn set_channels(
        &self,
        context: &GpuContext,
        layers: &[ChannelLayer<'_>],
        shown: &[bool],
    ) -> Result<(), RenderError> {
        if layers.len() != self.channels || shown.len() != self.channels {
            return Err(RenderError::Invalid(format!(
                "{} channel layers and {} visibilities for a composite of {} channels",
                layers.len(),
                shown.len(),
                self.channels
            )));
        }
        self.set_shown_layers(context, layers, shown);
        Ok(())
    }

    fn skipped_blocks(&self) -> Option<(usize, usize)> {
        Some(self.block_counts())
    }
}
