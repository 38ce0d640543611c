//! The compute pipeline that writes a frame's staged bricks into their cells of the streaming
//! atlas (`atlas_scatter.wgsl`), one per atlas texel format and device, where the device can
//! write that format from a shader ([`GpuContext::atlas_scatter`]). The staging ring lays the
//! bricks out for it and records its dispatch (`staging_ring.rs`).
//!
//! A normalized texel `n` is stored as `n / 255` (or `/ 65535`), which the store converts back
//! to `n` where it rounds to nearest (Vulkan says it should). A half-float texel goes through
//! 32 bits exactly; a device that flushed half subnormals would store those below 2⁻¹⁴ as 0.
//! lavapipe and the H200 keep every texel: the staging ring's test compares the atlas byte for
//! byte in all three formats, subnormals included.

use super::GpuContext;
use super::pipeline::{compute_pipelines, storage_entry};

/// Threads per workgroup; keep in sync with `@workgroup_size` in `atlas_scatter.wgsl` (both
/// entry points).
pub(crate) const WORKGROUP: u32 = 64;

/// The scatter pipeline of one atlas format, and the pass that zeroes an atlas made without
/// wgpu's zero fill (`zero`), with one bind group layout.
pub(crate) struct AtlasScatter {
    pub pipeline: wgpu::ComputePipeline,
    pub zero: wgpu::ComputePipeline,
    pub layout: wgpu::BindGroupLayout,
}

impl AtlasScatter {
    /// Builds the pipeline for an atlas of `format` (8- or 16-bit normalized, or half float);
    /// [`GpuContext::atlas_scatter`] does, once per device and format.
    pub(crate) fn new(context: &GpuContext, format: wgpu::TextureFormat) -> Self {
        let (label, source) = match format {
            wgpu::TextureFormat::R8Unorm => (
                "atlas_scatter_r8unorm",
                super::shaders::ATLAS_SCATTER_R8UNORM,
            ),
            wgpu::TextureFormat::R16Unorm => (
                "atlas_scatter_r16unorm",
                super::shaders::ATLAS_SCATTER_R16UNORM,
            ),
            wgpu::TextureFormat::R16Float => (
                "atlas_scatter_r16float",
                super::shaders::ATLAS_SCATTER_R16FLOAT,
            ),
            other => unreachable!("no scatter shader for {other:?}: FORMATS lists those with one"),
        };
        let (mut pipelines, layout) = compute_pipelines(
            context,
            label,
            source,
            &["main", "zero"],
            &[
                storage_entry(0, true),
                storage_entry(1, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format,
                        view_dimension: wgpu::TextureViewDimension::D3,
                    },
                    count: None,
                },
            ],
        );
        let zero = pipelines.remove(1);
        let pipeline = pipelines.remove(0);
        Self {
            pipeline,
            zero,
            layout,
        }
    }
}

/// The atlas formats with a scatter shader, in the order of [`GpuContext::atlas_scatter`]'s
/// cache.
pub(crate) const FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::R8Unorm,
    wgpu::TextureFormat::R16Unorm,
    wgpu::TextureFormat::R16Float,
];
