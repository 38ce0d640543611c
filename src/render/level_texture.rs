//! Value levels in a 3D texture (the dense volume, the brick atlas): 8-bit when every level
//! fits (≤ 255, exact), otherwise 16-bit float (exact up to 2048, then 11 significant bits).

use super::{GpuContext, RenderError};

/// A 3D texture of value levels and how to read them back: `level = texel × scale`.
pub(crate) struct LevelTexture {
    /// The texture's view (it keeps the texture alive).
    pub view: wgpu::TextureView,
    /// Texel value × this = value level (255 for 8-bit, 1 for 16-bit float).
    pub scale: f32,
    /// Bytes on the GPU.
    pub bytes: u64,
}

impl LevelTexture {
    /// Uploads `levels` (x fastest) as a `dims` texture; checks the device's 3D size limit and
    /// reports running out of memory as an error.
    pub fn upload(
        context: &GpuContext,
        label: &str,
        dims: [usize; 3],
        levels: &[u16],
    ) -> Result<Self, RenderError> {
        let limit = context.limits.max_texture_dimension_3d as usize;
        if dims.iter().any(|&d| d > limit) {
            return Err(RenderError(format!(
                "the {label} needs a {}x{}x{} 3D texture but this GPU allows {limit} per side",
                dims[0], dims[1], dims[2]
            )));
        }
        let eight_bit = levels.iter().all(|&level| level <= 255);
        let (format, texel_bytes, scale) = if eight_bit {
            (wgpu::TextureFormat::R8Unorm, 1, 255.0)
        } else {
            (wgpu::TextureFormat::R16Float, 2, 1.0)
        };
        let data: Vec<u8> = if eight_bit {
            levels.iter().map(|&level| level as u8).collect()
        } else {
            let halves: Vec<half::f16> = levels
                .iter()
                .map(|&level| half::f16::from_f32(level as f32))
                .collect();
            bytemuck::cast_slice(&halves).to_vec()
        };
        let size = wgpu::Extent3d {
            width: dims[0] as u32,
            height: dims[1] as u32,
            depth_or_array_layers: dims[2] as u32,
        };
        let out_of_memory = context
            .device
            .push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let texture = context.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(&format!("voxscope::{label}")),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        context.queue.write_texture(
            texture.as_image_copy(),
            &data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size.width * texel_bytes),
                rows_per_image: Some(size.height),
            },
            size,
        );
        if let Some(error) = pollster::block_on(out_of_memory.pop()) {
            return Err(RenderError(format!(
                "the GPU has no room for the {label}: {error}"
            )));
        }
        Ok(Self {
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            scale,
            bytes: data.len() as u64,
        })
    }
}
