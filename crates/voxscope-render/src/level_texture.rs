//! Value levels in a 3D texture (the dense volume, the brick atlas): 8-bit when every level
//! fits (≤ 255), otherwise 16-bit normalized where the device has it
//! ([`GpuContext::has_norm16_textures`]); both are exact. Devices without it get 16-bit floats,
//! exact up to 2048 and rounded to 11 significant bits above (a CT's levels reach 4000 and more).

use super::{GpuContext, RenderError};

/// A 3D texture of value levels and how to read them back: `level = texel × scale`.
pub(crate) struct LevelTexture {
    /// The texture's view (it keeps the texture alive).
    pub view: wgpu::TextureView,
    /// Texel value × this = value level (255 for 8-bit, 65 535 for 16-bit normalized, 1 for
    /// 16-bit float), rounded.
    pub scale: f32,
    /// Bytes on the GPU.
    pub bytes: u64,
    /// How the levels are stored.
    pub format: LevelFormat,
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
        let format = LevelFormat::for_levels(context, levels);
        Self::upload_as(context, label, dims, levels, format)
    }

    /// [`Self::upload`] in a given format: a pyramid's coarser levels take their finest
    /// level's, so that one `scale` reads them all (their levels are that level's means).
    pub fn upload_as(
        context: &GpuContext,
        label: &str,
        dims: [usize; 3],
        levels: &[u16],
        format: LevelFormat,
    ) -> Result<Self, RenderError> {
        let limit = context.limits.max_texture_dimension_3d as usize;
        if dims.iter().any(|&d| d > limit) {
            return Err(RenderError::DoesNotFit(format!(
                "the {label} needs a {}x{}x{} 3D texture but this GPU allows {limit} per side",
                dims[0], dims[1], dims[2]
            )));
        }
        let data: Vec<u8> = match format {
            LevelFormat::Unorm8 => levels.iter().map(|&level| level as u8).collect(),
            LevelFormat::Unorm16 => bytemuck::cast_slice(levels).to_vec(),
            LevelFormat::Float16 => {
                let halves: Vec<half::f16> = levels
                    .iter()
                    .map(|&level| half::f16::from_f32(level as f32))
                    .collect();
                bytemuck::cast_slice(&halves).to_vec()
            }
        };
        let level_format = format;
        let texel_bytes = format.texel_bytes();
        let scale = format.scale();
        let format = format.texture_format();
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
            return Err(RenderError::DoesNotFit(format!(
                "the GPU has no room for the {label}: {error}"
            )));
        }
        Ok(Self {
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            scale,
            bytes: data.len() as u64,
            format: level_format,
        })
    }
}

/// The texture formats value levels are stored in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LevelFormat {
    /// Every level ≤ 255: one byte, exact.
    Unorm8,
    /// 16-bit normalized: exact for all 65 536 levels.
    Unorm16,
    /// 16-bit float, where the device has no 16-bit normalized textures: exact up to 2048.
    Float16,
}

impl LevelFormat {
    /// The format `levels` are stored in on `context`'s device.
    pub fn for_levels(context: &GpuContext, levels: &[u16]) -> Self {
        if levels.iter().all(|&level| level <= 255) {
            Self::Unorm8
        } else if context.has_norm16_textures {
            Self::Unorm16
        } else {
            Self::Float16
        }
    }

    fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            Self::Unorm8 => wgpu::TextureFormat::R8Unorm,
            Self::Unorm16 => wgpu::TextureFormat::R16Unorm,
            Self::Float16 => wgpu::TextureFormat::R16Float,
        }
    }

    fn texel_bytes(self) -> u32 {
        match self {
            Self::Unorm8 => 1,
            Self::Unorm16 | Self::Float16 => 2,
        }
    }

    /// Texel value × this = value level.
    fn scale(self) -> f32 {
        match self {
            Self::Unorm8 => 255.0,
            Self::Unorm16 => 65535.0,
            Self::Float16 => 1.0,
        }
    }
}
