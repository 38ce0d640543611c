//! An octree on the GPU: node list, value bounds and the transfer function's lookup table,
//! with the sizes checked against the device before anything is allocated there.

use wgpu::util::DeviceExt;

use super::raycaster::{ProbeTarget, encode_probe_ray};
use super::renderer::{FramePass, Renderer, level_detail, pipeline_variants};
use super::slice::SliceSource;
use super::{GpuContext, GpuTransferTable, LevelDetail, RenderError, RenderSettings, RendererKind};
use voxscope_octree::{Node, Octree, TransferFunction, ValueBounds};

/// GPU buffers of one octree, uploaded through `levels` (a prefix of the flat list).
pub struct GpuVolume {
    pub nodes: wgpu::Buffer,
    pub bounds: wgpu::Buffer,
    pub transfer: GpuTransferTable,
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Physical voxel size along x, y, z.
    pub spacing: [f64; 3],
    /// Depth of the whole octree.
    pub depth: u32,
    /// Deepest level on the GPU (`depth` unless a prefix was uploaded).
    pub uploaded_level: u32,
    /// `level_starts` of the octree, through `uploaded_level + 1`.
    pub level_starts: Vec<usize>,
    /// The values are labels ([`voxscope_octree::Octree::labels`]).
    pub labels: bool,
}

impl GpuVolume {
    /// Uploads `octree` (colors as they are) through level `max_level`. Fails with a message
    /// naming both sizes, and the deepest level that would fit, when the device cannot hold it.
    pub fn upload(
        context: &GpuContext,
        octree: &Octree,
        spacing: [f64; 3],
        max_level: u32,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let uploaded_level = max_level.min(octree.depth);
        let count = octree.nodes_through_level(uploaded_level);
        let limit = context.max_storage_bytes();
        let bytes = (count * std::mem::size_of::<Node>()) as u64;
        if bytes > limit {
            let fitting = (0..=octree.depth).rev().find(|&l| {
                (octree.nodes_through_level(l) * std::mem::size_of::<Node>()) as u64 <= limit
            });
            // Said as a max level, which both the command line (--level) and the app (Max
            // level) set.
            let advice = match fitting {
                Some(level) => format!("; it fits through max level {level}"),
                None => String::new(),
            };
            return Err(RenderError::DoesNotFit(format!(
                "the octree through level {uploaded_level} needs {} MiB of nodes but this GPU ({}) allows {} MiB per storage buffer{advice}",
                bytes.div_ceil(1 << 20),
                context.adapter_info.name,
                limit >> 20,
            )));
        }
        let device = &context.device;
        // Allocation failures become errors, not the default handler's panic.
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let nodes = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::octree_nodes"),
            contents: bytemuck::cast_slice(&octree.nodes[..count]),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        let bounds = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::octree_bounds"),
            contents: bytemuck::cast_slice::<ValueBounds, u8>(&octree.bounds[..count]),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let transfer = GpuTransferTable::new(context, octree.quantization, transfer);
        if let Some(error) = pollster::block_on(out_of_memory.pop()) {
            return Err(RenderError::DoesNotFit(format!(
                "the GPU ({}) has no room for the octree's {} MiB: {error}; a lower max level needs less",
                context.adapter_info.name,
                bytes.div_ceil(1 << 20)
            )));
        }
        Ok(Self {
            nodes,
            bounds,
            transfer,
            dims: octree.dims,
            spacing,
            depth: octree.depth,
            uploaded_level,
            level_starts: octree.level_starts[..uploaded_level as usize + 2].to_vec(),
            labels: octree.labels,
        })
    }

    /// True when every level is on the GPU, so [`super::GpuRecolor`] can recolor it.
    pub fn is_complete(&self) -> bool {
        self.uploaded_level == self.depth
    }

    /// Nodes on the GPU.
    pub fn node_count(&self) -> usize {
        self.level_starts[self.uploaded_level as usize + 1]
    }

    /// Writes a new transfer function's lookup table (recolor afterwards: the
    /// [`Renderer::set_transfer`] of the octree does both).
    pub fn write_lookup_table(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        self.transfer.write(context, transfer);
    }
}

/// The paper's octree: drawn and probed by the device's [`super::Raycaster`], recolored on the
/// GPU level by level ([`super::GpuRecolor`]).
impl Renderer for GpuVolume {
    fn kind(&self) -> RendererKind {
        RendererKind::Octree
    }

    fn level_detail(&self, max_level: u32) -> LevelDetail {
        level_detail(self.depth, self.dims, 0, max_level)
    }

    fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    ) {
        pass.encode_with(context.raycaster(), context, encoder, self);
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
        encode_probe_ray(context.raycaster(), context, encoder, self, probe);
        true
    }

    /// Writes the lookup table and records the recolor of every level (topology untouched).
    fn set_transfer(
        &mut self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        self.write_lookup_table(context, transfer);
        context
            .recolor()
            .encode(context, encoder, self, timestamp_writes)
    }

    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        for variant in pipeline_variants(settings, probe, false, self.labels) {
            context.raycaster().prepare(context, variant);
        }
    }

    fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        vec![
            ("nodes", self.nodes.size()),
            ("bounds", self.bounds.size()),
            ("lookup_table", self.transfer.size()),
        ]
    }

    fn slice_source(&self) -> Option<SliceSource<'_>> {
        Some(SliceSource::Octree(self))
    }
}
