//! Recoloring on the GPU after a transfer-function edit: one dispatch per level, deepest
//! first, all in one submission. The topology never changes.

use super::gpu_data::RecolorParams;
use super::pipeline::{compute_pipeline, numbered_bind_group, storage_entry, uniform_entry};
use super::{GpuContext, GpuVolume, RenderError};

/// Threads per workgroup; keep in sync with `@workgroup_size` in `recolor.wgsl`.
const WORKGROUP: u32 = 256;

/// The recolor compute pipeline, one per device ([`GpuContext::recolor`]).
pub struct GpuRecolor {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

impl GpuRecolor {
    /// Builds the pipeline; [`GpuContext::recolor`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let (pipeline, layout) = compute_pipeline(
            context,
            "recolor",
            super::shaders::RECOLOR,
            &[
                uniform_entry(0, true),
                storage_entry(1, false),
                storage_entry(2, true),
                storage_entry(3, true),
            ],
        );
        Self { pipeline, layout }
    }

    /// Records the recolor of every level of `volume` from its lookup table into `encoder`.
    /// Fails when only a prefix of the octree is on the GPU (recolor on the CPU then).
    pub fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        volume: &GpuVolume,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        if !volume.is_complete() {
            return Err(RenderError::Invalid(format!(
                "only levels 0..={} of {} are on the GPU; recolor on the CPU",
                volume.uploaded_level, volume.depth
            )));
        }
        let levels = RecolorLevels {
            nodes: &volume.nodes,
            bounds: &volume.bounds,
            lookup_table: &volume.transfer.buffer,
            level_starts: &volume.level_starts,
            deepest: volume.depth,
            labels: volume.labels,
        };
        self.encode_levels(context, encoder, &levels, timestamp_writes);
        Ok(())
    }

    /// Records the recolor of levels `deepest..=0`, deepest first: leaves from the lookup
    /// table, inner nodes from their children (which must be final before).
    pub(crate) fn encode_levels(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        levels: &RecolorLevels<'_>,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let device = &context.device;
        let max_groups = context.limits.max_compute_workgroups_per_dimension.max(1);
        let stride = context.limits.min_uniform_buffer_offset_alignment.max(16) as usize;
        let count_levels = levels.deepest as usize + 1;
        // One parameter block per level, deepest first, at aligned offsets.
        let mut blocks = vec![0u8; stride * count_levels];
        let mut dispatches = Vec::with_capacity(count_levels);
        for (slot, level) in (0..count_levels).rev().enumerate() {
            let start = levels.level_starts[level] as u32;
            let count = (levels.level_starts[level + 1] - levels.level_starts[level]) as u32;
            let groups = count.div_ceil(WORKGROUP);
            let groups_x = groups.min(max_groups);
            let groups_y = groups.div_ceil(groups_x.max(1));
            let params = RecolorParams {
                level_start: start,
                level_count: count,
                groups_x,
                labels: u32::from(levels.labels),
            };
            blocks[slot * stride..slot * stride + 16].copy_from_slice(bytemuck::bytes_of(&params));
            dispatches.push(((slot * stride) as u32, groups_x, groups_y));
        }
        let params = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::recolor_params"),
                contents: &blocks,
                usage: wgpu::BufferUsages::UNIFORM,
            },
        );
        let bind_group = numbered_bind_group(
            device,
            "voxscope::recolor_bind_group",
            &self.layout,
            &[
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &params,
                    offset: 0,
                    size: wgpu::BufferSize::new(16),
                }),
                levels.nodes.as_entire_binding(),
                levels.bounds.as_entire_binding(),
                levels.lookup_table.as_entire_binding(),
            ],
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxscope::recolor_pass"),
            timestamp_writes,
        });
        pass.set_pipeline(&self.pipeline);
        for (offset, groups_x, groups_y) in dispatches {
            if groups_x == 0 {
                continue;
            }
            pass.set_bind_group(0, &bind_group, &[offset]);
            pass.dispatch_workgroups(groups_x, groups_y, 1);
        }
    }
}

/// The buffers and levels one recolor covers.
pub(crate) struct RecolorLevels<'a> {
    pub nodes: &'a wgpu::Buffer,
    pub bounds: &'a wgpu::Buffer,
    pub lookup_table: &'a wgpu::Buffer,
    pub level_starts: &'a [usize],
    /// Levels `deepest..=0` are recolored.
    pub deepest: u32,
    /// The values are labels: parents take their children's most shown color.
    pub labels: bool,
}
