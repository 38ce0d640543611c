//! The dense baseline renderer: the volume's value levels in one 3D texture, marched at fixed
//! one-voxel steps with hardware filtering. What napari/vispy, pygfx and ParaView do; voxscope
//! keeps it to measure the octree against, and as a cross-check. Below full detail, a max
//! level draws its own pyramid level (the volume reduced 2× per level by the mean, or a label
//! volume's by the mode, a texture each, as the streaming renderer's pyramid), one step per
//! voxel of that level. A label volume is always sampled at the nearest voxel.

use super::gpu_data::RaycastParams;
use super::level_texture::LevelTexture;
use super::pipeline::{
    Variant, VariantPipelines, atlas_entry, atlas_sampler_entry, clamped_sampler,
    numbered_bind_group, output_image_entry, storage_entry, uniform_entry,
};
use super::raycaster::{
    ProbeTarget, RayPass, StandIns, VolumeShape, encode_probe_ray, frame_params_buffer,
};
use super::renderer::{FramePass, Renderer, level_detail, pipeline_variants};
use super::slice::SliceSource;
use super::{
    GpuContext, GpuTransferTable, LevelDetail, RenderError, RenderSettings, RenderTarget,
    RendererKind,
};
use voxscope_octree::TransferFunction;
use voxscope_stream::{Downsampling, coarser_levels};
use voxscope_volume::QuantizedVolume;

/// A volume as one 3D texture of value levels (8 or 16 bits, `LevelTexture`), and one per
/// coarser pyramid level.
pub struct DenseVolume {
    /// The value levels (read by the slices too).
    pub(crate) levels: LevelTexture,
    /// Entry `k − 1`: pyramid level `k` and its dims, down to one voxel.
    coarser: Vec<(LevelTexture, [usize; 3])>,
    pub transfer: GpuTransferTable,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    /// The values are labels: nearest samples, levels reduced by the mode.
    pub labels: bool,
}

impl DenseVolume {
    /// Uploads `volume`'s value levels and its coarser pyramid levels (reduced by the mode
    /// where `labels`); fails when a side exceeds the device's 3D texture limit.
    pub fn upload(
        context: &GpuContext,
        volume: &QuantizedVolume,
        spacing: [f64; 3],
        transfer: &TransferFunction,
        labels: bool,
    ) -> Result<Self, RenderError> {
        let levels = LevelTexture::upload(context, "dense_texture", volume.dims, &volume.levels)?;
        let coarser = coarser_levels(
            &volume.levels,
            volume.dims,
            Downsampling::of_values(labels),
            depth_of(volume.dims) as usize,
        )
        .iter()
        .map(|(coarse, dims)| {
            LevelTexture::upload_as(context, "dense_level", *dims, coarse, levels.format)
                .map(|texture| (texture, *dims))
        })
        .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            levels,
            coarser,
            transfer: GpuTransferTable::new(context, volume.quantization, transfer),
            dims: volume.dims,
            spacing,
            labels,
        })
    }

    /// The texture of pyramid level `level` (0: full detail).
    fn level_view(&self, level: u32) -> &wgpu::TextureView {
        match level {
            0 => &self.levels.view,
            _ => &self.coarser[level as usize - 1].0.view,
        }
    }
}

/// The octree depth of `dims` (`ceil(log2(largest side))`): the levels of the max-level slider
/// below full detail, each a pyramid level here.
fn depth_of(dims: [usize; 3]) -> u32 {
    let largest = dims.into_iter().max().unwrap_or(1).max(1);
    largest.next_power_of_two().trailing_zeros()
}

impl VolumeShape for DenseVolume {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }
    fn spacing(&self) -> [f64; 3] {
        self.spacing
    }
    fn depth(&self) -> u32 {
        self.coarser.len() as u32
    }
    fn level_cap(&self) -> u32 {
        self.coarser.len() as u32
    }
    fn mip_saturation(&self) -> u16 {
        self.transfer.mip_saturation()
    }
    fn level_scale(&self) -> f32 {
        self.levels.scale
    }
    fn window_levels(&self) -> f32 {
        self.transfer.window_levels()
    }
    fn labels(&self) -> bool {
        self.labels
    }
    fn sampled_level(&self, max_level: u32) -> u32 {
        (self.coarser.len() as u32).saturating_sub(max_level)
    }
    fn level_texels(&self, level: u32) -> Option<[usize; 3]> {
        match level {
            0 => Some(self.dims),
            _ => self.coarser.get(level as usize - 1).map(|(_, dims)| *dims),
        }
    }
}

/// The fixed-step ray-marching pipeline (in variants: [`Variant`]) and its samplers, one per
/// device ([`GpuContext::dense_raycaster`]).
pub struct DenseRaycaster {
    pipelines: VariantPipelines,
    layout: wgpu::BindGroupLayout,
    trilinear: wgpu::Sampler,
    nearest: wgpu::Sampler,
    stand_ins: StandIns,
}

impl DenseRaycaster {
    /// Builds the plain pipeline; [`GpuContext::dense_raycaster`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let device = &context.device;
        let (pipelines, layout) = VariantPipelines::new(
            context,
            "dense",
            super::shaders::DENSE,
            &["main"],
            &[
                uniform_entry(0, false),
                atlas_entry(1),
                atlas_sampler_entry(2),
                storage_entry(3, true),
                output_image_entry(4),
                storage_entry(5, false),
                storage_entry(6, false),
            ],
        );
        Self {
            pipelines,
            layout,
            trilinear: clamped_sampler(
                device,
                wgpu::FilterMode::Linear,
                "voxscope::dense_trilinear",
            ),
            nearest: clamped_sampler(device, wgpu::FilterMode::Nearest, "voxscope::dense_nearest"),
            stand_ins: StandIns::new(context),
        }
    }

    /// Builds the pipeline of `variant` where not built yet (off the frame path).
    pub(crate) fn prepare(&self, context: &GpuContext, variant: Variant) {
        self.pipelines.get(context, 0, variant);
    }
}

impl RayPass<DenseVolume> for DenseRaycaster {
    const NAME: &'static str = "dense";

    fn pipelines(&self) -> &VariantPipelines {
        &self.pipelines
    }

    fn stand_ins(&self) -> &StandIns {
        &self.stand_ins
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &DenseVolume,
        params: &RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let level = volume.level_view(volume.sampled_level(params.max_level));
        let params = frame_params_buffer(context, "voxscope::dense_params", params);
        let sampler = if volume.filters(settings) {
            &self.trilinear
        } else {
            &self.nearest
        };
        numbered_bind_group(
            &context.device,
            "voxscope::dense_bind_group",
            &self.layout,
            &[
                params.as_entire_binding(),
                wgpu::BindingResource::TextureView(level),
                wgpu::BindingResource::Sampler(sampler),
                volume.transfer.buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&target.view),
                target.visits.as_entire_binding(),
                probe.as_entire_binding(),
            ],
        )
    }
}

impl Renderer for DenseVolume {
    fn kind(&self) -> RendererKind {
        RendererKind::Dense
    }

    fn level_detail(&self, max_level: u32) -> LevelDetail {
        level_detail(
            self.depth(),
            self.dims,
            self.sampled_level(max_level),
            max_level,
        )
    }

    fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    ) {
        pass.encode_with(context.dense_raycaster(), context, encoder, self);
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
        encode_probe_ray(context.dense_raycaster(), context, encoder, self, probe);
        true
    }

    /// Writes the lookup table (no other work: the textures hold values, not colors).
    fn set_transfer(
        &mut self,
        context: &GpuContext,
        _encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        _timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        self.transfer.write(context, transfer);
        Ok(())
    }

    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        let coarse = matches!(
            self.level_detail(settings.max_level),
            LevelDetail::Pyramid { .. }
        );
        for variant in pipeline_variants(settings, probe, coarse, self.labels()) {
            context.dense_raycaster().prepare(context, variant);
        }
    }

    fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        let coarser: u64 = self.coarser.iter().map(|(texture, _)| texture.bytes).sum();
        vec![
            ("texture", self.levels.bytes + coarser),
            ("lookup_table", self.transfer.size()),
        ]
    }

    fn slice_source(&self) -> Option<SliceSource<'_>> {
        Some(SliceSource::Dense(self))
    }
}
