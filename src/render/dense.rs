//! The dense baseline renderer: the volume's value levels in one 3D texture, marched at fixed
//! one-voxel steps with hardware filtering. What napari/vispy, pygfx and ParaView do; voxscope
//! keeps it to measure the octree against, and as a cross-check.

use half::f16;
use wgpu::util::DeviceExt;

use super::pipeline::{
    atlas_entry, atlas_sampler_entry, clamped_sampler, compute_pipeline, dispatch_per_pixel,
    output_image_entry, storage_entry, uniform_entry,
};
use super::raycaster::{VolumeShape, raycast_params};
use super::{Frame, GpuContext, RenderError};
use crate::octree::TransferFunction;
use crate::volume::{Quantization, QuantizedVolume};

/// A volume as one 3D texture of value levels (16-bit floats: integers up to 2048 are exact,
/// larger levels keep 11 significant bits).
pub struct DenseVolume {
    pub texture: wgpu::Texture,
    view: wgpu::TextureView,
    pub lookup_table: wgpu::Buffer,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    quantization: Quantization,
    mip_saturation: u16,
}

impl DenseVolume {
    /// Uploads `volume`'s value levels; fails when a side exceeds the device's 3D texture limit.
    pub fn upload(
        context: &GpuContext,
        volume: &QuantizedVolume,
        spacing: [f64; 3],
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let limit = context.limits.max_texture_dimension_3d as usize;
        if volume.dims.iter().any(|&d| d > limit) {
            return Err(RenderError(format!(
                "the dense renderer needs a {}x{}x{} 3D texture but this GPU allows {limit} per side",
                volume.dims[0], volume.dims[1], volume.dims[2]
            )));
        }
        let levels: Vec<f16> = volume
            .levels
            .iter()
            .map(|&l| f16::from_f32(l as f32))
            .collect();
        let size = wgpu::Extent3d {
            width: volume.dims[0] as u32,
            height: volume.dims[1] as u32,
            depth_or_array_layers: volume.dims[2] as u32,
        };
        let device = &context.device;
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("voxscope::dense_levels"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        context.queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&levels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size.width * 2),
                rows_per_image: Some(size.height),
            },
            size,
        );
        let table = transfer.lookup_table(volume.quantization);
        let lookup_table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::dense_lookup_table"),
            contents: bytemuck::cast_slice(&table),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        if let Some(error) = pollster::block_on(out_of_memory.pop()) {
            return Err(RenderError(format!(
                "the GPU has no room for the dense texture: {error}"
            )));
        }
        Ok(Self {
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            texture,
            lookup_table,
            dims: volume.dims,
            spacing,
            quantization: volume.quantization,
            mip_saturation: transfer.saturation_level(volume.quantization),
        })
    }

    /// Writes a new transfer function (no other work: the texture holds values, not colors).
    pub fn set_transfer(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        let table = transfer.lookup_table(self.quantization);
        context
            .queue
            .write_buffer(&self.lookup_table, 0, bytemuck::cast_slice(&table));
        self.mip_saturation = transfer.saturation_level(self.quantization);
    }

    /// Bytes on the GPU.
    pub fn gpu_bytes(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product::<u64>() * 2 + self.lookup_table.size()
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
        self.mip_saturation
    }
}

/// The fixed-step ray-marching pipeline.
pub struct DenseRaycaster {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    trilinear: wgpu::Sampler,
    nearest: wgpu::Sampler,
}

impl DenseRaycaster {
    pub fn new(context: &GpuContext) -> Self {
        let device = &context.device;
        let (pipeline, layout) = compute_pipeline(
            device,
            "dense",
            include_str!("../../shaders/dense.wgsl"),
            &[
                uniform_entry(0, false),
                atlas_entry(1),
                atlas_sampler_entry(2),
                storage_entry(3, true),
                output_image_entry(4),
                storage_entry(5, false),
            ],
        );
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::dense_params"),
            size: std::mem::size_of::<super::gpu_data::RaycastParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            layout,
            params,
            trilinear: clamped_sampler(
                device,
                wgpu::FilterMode::Linear,
                "voxscope::dense_trilinear",
            ),
            nearest: clamped_sampler(device, wgpu::FilterMode::Nearest, "voxscope::dense_nearest"),
        }
    }

    /// Records one frame into `encoder` (submit before recording another with other settings).
    pub fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        frame: &Frame<'_, DenseVolume>,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let params = raycast_params(frame.volume, frame.target, frame.camera, frame.settings);
        context
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let sampler = if frame.settings.trilinear {
            &self.trilinear
        } else {
            &self.nearest
        };
        let bind_group = context
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("voxscope::dense_bind_group"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&frame.volume.view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Sampler(sampler),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: frame.volume.lookup_table.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: wgpu::BindingResource::TextureView(&frame.target.view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: frame.target.visits.as_entire_binding(),
                    },
                ],
            });
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
