//! The dense baseline renderer: the volume's value levels in one 3D texture, marched at fixed
//! one-voxel steps with hardware filtering. What napari/vispy, pygfx and ParaView do; voxscope
//! keeps it to measure the octree against, and as a cross-check. Below full detail, a max
//! level draws its own pyramid level (the volume reduced 2× per level by the mean, a texture
//! each, as the streaming renderer's pyramid), one step per voxel of that level.

use super::level_texture::LevelTexture;
use super::pipeline::{
    Variant, VariantPipelines, atlas_entry, atlas_sampler_entry, clamped_sampler,
    dispatch_per_pixel, dispatch_probe, numbered_bind_group, output_image_entry, storage_entry,
    uniform_entry,
};
use super::raycaster::{
    ProbeTarget, StandIns, VolumeShape, frame_params_buffer, frame_variant, level_variant,
    probe_variant, raycast_params,
};
use super::{Frame, GpuContext, GpuTransferTable, RenderError, RenderSettings, RenderTarget};
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
}

impl DenseVolume {
    /// Uploads `volume`'s value levels and its coarser pyramid levels; fails when a side
    /// exceeds the device's 3D texture limit.
    pub fn upload(
        context: &GpuContext,
        volume: &QuantizedVolume,
        spacing: [f64; 3],
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let levels = LevelTexture::upload(context, "dense_texture", volume.dims, &volume.levels)?;
        let coarser = coarser_levels(
            &volume.levels,
            volume.dims,
            Downsampling::Mean,
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
        })
    }

    /// The texture of pyramid level `level` (0: full detail).
    fn level_view(&self, level: u32) -> &wgpu::TextureView {
        match level {
            0 => &self.levels.view,
            _ => &self.coarser[level as usize - 1].0.view,
        }
    }

    /// Writes a new transfer function (no other work: the texture holds values, not colors).
    pub fn set_transfer(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        self.transfer.write(context, transfer);
    }

    /// Bytes on the GPU: the textures and the lookup table.
    pub fn gpu_bytes(&self) -> u64 {
        let coarser: u64 = self.coarser.iter().map(|(texture, _)| texture.bytes).sum();
        self.levels.bytes + coarser + self.transfer.size()
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

    /// Records one frame into `encoder`, its parameters in a buffer of its own (so frames of
    /// several panes and volumes can share an encoder).
    pub fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        frame: &Frame<'_, DenseVolume>,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let target = frame.target;
        let params = raycast_params(
            frame.volume,
            [target.width, target.height],
            frame.camera,
            frame.settings,
        );
        let bind_group = self.bind_group(
            context,
            frame.volume,
            &params,
            frame.settings,
            target,
            &self.stand_ins.probe,
        );
        let pipeline = self.pipelines.get(
            context,
            0,
            level_variant(frame_variant(frame.settings), &params),
        );
        dispatch_per_pixel(
            encoder,
            "dense",
            pipeline,
            &bind_group,
            target,
            timestamp_writes,
        );
    }

    /// Records the probe of one pixel (see [`super::Raycaster`]'s): one ray, its answer in
    /// `probe.output`; draws nothing.
    pub(crate) fn encode_probe(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        volume: &DenseVolume,
        probe: &ProbeTarget<'_>,
    ) {
        let mut params = raycast_params(volume, probe.size, probe.camera, probe.settings);
        params.probe_pixel = probe.pixel;
        let bind_group = self.bind_group(
            context,
            volume,
            &params,
            probe.settings,
            &self.stand_ins.target,
            probe.output,
        );
        let pipeline = self.pipelines.get(
            context,
            0,
            level_variant(probe_variant(probe.settings), &params),
        );
        dispatch_probe(encoder, "dense_probe", pipeline, &bind_group);
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &DenseVolume,
        params: &super::gpu_data::RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let level = volume.level_view(volume.sampled_level(params.max_level));
        let params = frame_params_buffer(context, "voxscope::dense_params", params);
        let sampler = if settings.trilinear {
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
