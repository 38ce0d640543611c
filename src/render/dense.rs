//! The dense baseline renderer: the volume's value levels in one 3D texture, marched at fixed
//! one-voxel steps with hardware filtering. What napari/vispy, pygfx and ParaView do; voxscope
//! keeps it to measure the octree against, and as a cross-check.

use super::level_texture::LevelTexture;
use super::pipeline::{
    atlas_entry, atlas_sampler_entry, clamped_sampler, compute_pipeline, dispatch_per_pixel,
    numbered_bind_group, output_image_entry, storage_entry, uniform_entry,
};
use super::raycaster::{VolumeShape, frame_params_buffer, raycast_params};
use super::{Frame, GpuContext, GpuTransferTable, RenderError};
use crate::octree::TransferFunction;
use crate::volume::QuantizedVolume;

/// A volume as one 3D texture of value levels (8 or 16 bits, `LevelTexture`).
pub struct DenseVolume {
    /// The value levels (read by the slices too).
    pub(crate) levels: LevelTexture,
    pub transfer: GpuTransferTable,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
}

impl DenseVolume {
    /// Uploads `volume`'s value levels; fails when a side exceeds the device's 3D texture limit.
    pub fn upload(
        context: &GpuContext,
        volume: &QuantizedVolume,
        spacing: [f64; 3],
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        Ok(Self {
            levels: LevelTexture::upload(context, "dense_texture", volume.dims, &volume.levels)?,
            transfer: GpuTransferTable::new(context, volume.quantization, transfer),
            dims: volume.dims,
            spacing,
        })
    }

    /// Writes a new transfer function (no other work: the texture holds values, not colors).
    pub fn set_transfer(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        self.transfer.write(context, transfer);
    }

    /// Bytes on the GPU: the texture and the lookup table.
    pub fn gpu_bytes(&self) -> u64 {
        self.levels.bytes + self.transfer.size()
    }
}

impl VolumeShape for DenseVolume {
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
        self.transfer.mip_saturation()
    }
    fn level_scale(&self) -> f32 {
        self.levels.scale
    }
}

/// The fixed-step ray-marching pipeline and its samplers, one per device
/// ([`GpuContext::dense_raycaster`]).
pub struct DenseRaycaster {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    trilinear: wgpu::Sampler,
    nearest: wgpu::Sampler,
}

impl DenseRaycaster {
    /// Builds the pipeline; [`GpuContext::dense_raycaster`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let device = &context.device;
        let (pipeline, layout) = compute_pipeline(
            context,
            "dense",
            super::shaders::DENSE,
            &[
                uniform_entry(0, false),
                atlas_entry(1),
                atlas_sampler_entry(2),
                storage_entry(3, true),
                output_image_entry(4),
                storage_entry(5, false),
            ],
        );
        Self {
            pipeline,
            layout,
            trilinear: clamped_sampler(
                device,
                wgpu::FilterMode::Linear,
                "voxscope::dense_trilinear",
            ),
            nearest: clamped_sampler(device, wgpu::FilterMode::Nearest, "voxscope::dense_nearest"),
        }
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
        let params = frame_params_buffer(
            context,
            "voxscope::dense_params",
            &raycast_params(frame.volume, frame.target, frame.camera, frame.settings),
        );
        let sampler = if frame.settings.trilinear {
            &self.trilinear
        } else {
            &self.nearest
        };
        let bind_group = numbered_bind_group(
            &context.device,
            "voxscope::dense_bind_group",
            &self.layout,
            &[
                params.as_entire_binding(),
                wgpu::BindingResource::TextureView(&frame.volume.levels.view),
                wgpu::BindingResource::Sampler(sampler),
                frame.volume.transfer.buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&frame.target.view),
                frame.target.visits.as_entire_binding(),
            ],
        );
        dispatch_per_pixel(
            encoder,
            "dense",
            &self.pipeline,
            &bind_group,
            frame.target,
            timestamp_writes,
        );
    }
}
