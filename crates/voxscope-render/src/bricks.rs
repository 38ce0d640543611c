//! The bricks renderer's GPU side: the octree prefix with brick leaves, the 3D brick atlas,
//! and the recolor of the brick level. Drawn by the same [`super::Raycaster`] as the octree.
//!
//! Max levels between the brick level and full detail draw pyramid levels of their own: each
//! level of the volume reduced 2× per level by the mean (the mode for labels: the streaming
//! renderer's pyramid) in a texture of its own, sampled where the cell grid says a ray must look
//! (bricks, and uniform regions, which a coarser level blurs into their neighbours), so each
//! level shows its own resolution, filtered (nearest for labels), at one sample per voxel of the
//! level.

use wgpu::util::DeviceExt;

use super::gpu_data::{BrickRecolorParams, GridCell, RecolorParams};
use super::level_texture::LevelTexture;
use super::pipeline::{
    atlas_entry, compute_pipeline, numbered_bind_group, storage_entry, uniform_entry,
};
use super::raycaster::{BrickShape, OctreeOnGpu, ProbeTarget, VolumeShape, encode_probe_ray};
use super::recolor::RecolorLevels;
use super::renderer::{FramePass, Renderer, level_detail, pipeline_variants};
use super::slice::SliceSource;
use super::{GpuContext, GpuTransferTable, LevelDetail, RenderError, RenderSettings, RendererKind};
use voxscope_octree::{BRICK_FLAG, BrickLayout, TransferFunction, ValueBounds};
use voxscope_stream::{Downsampling, coarser_levels};
use voxscope_volume::QuantizedVolume;

/// An octree with brick leaves on the GPU.
pub struct GpuBricks {
    nodes: wgpu::Buffer,
    bounds: wgpu::Buffer,
    transfer: GpuTransferTable,
    atlas: LevelTexture,
    /// Entry `k − 1`: pyramid level `k` and its dims, for every level between the brick level
    /// and full detail.
    levels: Vec<(LevelTexture, [usize; 3])>,
    brick_origins: wgpu::Buffer,
    /// Per brick cell: the index of the node covering it (static).
    grid_leaves: wgpu::Buffer,
    /// Per brick cell: a [`GridCell`], refreshed after each recolor.
    grid: wgpu::Buffer,
    grid_cells: u32,
    level_starts: Vec<usize>,
    shape: BrickShape,
    dims: [usize; 3],
    spacing: [f64; 3],
    depth: u32,
    /// The values are labels ([`BrickLayout::labels`]).
    labels: bool,
}

impl GpuBricks {
    /// Writes a new transfer function's lookup table (recolor afterwards: the
    /// [`Renderer::set_transfer`] of the bricks does both).
    pub fn write_lookup_table(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        self.transfer.write(context, transfer);
    }

    /// Uploads `layout` (nodes colored as they are), cut from `volume` (whose octree has
    /// `depth` levels), and the atlases of the levels between its brick level and full detail.
    /// The atlases are 8-bit when every value level fits (≤ 255), 16-bit otherwise
    /// (`LevelTexture`).
    pub fn upload(
        context: &GpuContext,
        layout: &BrickLayout,
        volume: &QuantizedVolume,
        spacing: [f64; 3],
        depth: u32,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let device = &context.device;
        let (dims, quantization) = (volume.dims, volume.quantization);
        let atlas =
            LevelTexture::upload(context, "brick_atlas", layout.atlas_dims(), &layout.atlas)?;
        let atlas_scale = atlas.scale;
        let sub_brick_levels = depth
            .saturating_sub(layout.brick_level + 1)
            .min(layout.brick_size.trailing_zeros().saturating_sub(1));
        let levels = coarser_levels(
            &volume.levels,
            dims,
            Downsampling::of_values(layout.labels),
            sub_brick_levels as usize,
        )
        .iter()
        .map(|(coarse, level_dims)| {
            LevelTexture::upload_as(context, "brick_level", *level_dims, coarse, atlas.format)
                .map(|texture| (texture, *level_dims))
        })
        .collect::<Result<Vec<_>, _>>()?;
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let buffer = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let nodes = buffer(
            "voxscope::brick_octree_nodes",
            bytemuck::cast_slice(&layout.nodes),
            storage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        );
        let bounds = buffer(
            "voxscope::brick_octree_bounds",
            bytemuck::cast_slice::<ValueBounds, u8>(&layout.bounds),
            storage,
        );
        let transfer = GpuTransferTable::new(context, quantization, transfer);
        let origins: Vec<[u32; 4]> = layout
            .brick_origins
            .iter()
            .map(|o| [o[0] as u32, o[1] as u32, o[2] as u32, 0])
            .chain(std::iter::once([0; 4])) // never empty
            .collect();
        let brick_origins = buffer(
            "voxscope::brick_origins",
            bytemuck::cast_slice(&origins),
            storage,
        );
        // Never empty: a binding needs at least one element.
        let leaves: Vec<u32> = if layout.grid_leaves.is_empty() {
            vec![0]
        } else {
            layout.grid_leaves.clone()
        };
        let cells: Vec<GridCell> = leaves
            .iter()
            .map(|&index| {
                let node = layout.nodes[index as usize];
                // Ten bits per axis, x lowest (`brick_to_atlas` in raycast.wgsl).
                let atlas_cell = if node.is_leaf() {
                    0
                } else {
                    let [x, y, z] = layout.atlas_cell((node.first_child & !BRICK_FLAG) as usize);
                    (x | (y << 10) | (z << 20)) as u32
                };
                GridCell {
                    color: node.color,
                    first_child: node.first_child,
                    bounds: layout.bounds[index as usize].0,
                    atlas_cell,
                }
            })
            .collect();
        let grid_leaves = buffer(
            "voxscope::brick_grid_leaves",
            bytemuck::cast_slice(&leaves),
            storage,
        );
        let grid = buffer(
            "voxscope::brick_grid",
            bytemuck::cast_slice(&cells),
            storage,
        );
        if let Some(error) = pollster::block_on(out_of_memory.pop()) {
            return Err(RenderError::DoesNotFit(format!(
                "the GPU has no room for the bricks: {error}"
            )));
        }
        Ok(Self {
            atlas,
            levels,
            nodes,
            bounds,
            transfer,
            brick_origins,
            grid_leaves,
            grid,
            grid_cells: layout.grid_leaves.len() as u32,
            level_starts: layout.level_starts.clone(),
            shape: BrickShape {
                level: layout.brick_level,
                size: layout.brick_size as u32,
                grid: layout.grid_dims.map(|g| g as u32),
                atlas_scale,
                atlas_grid: layout.atlas_grid.map(|g| g as u32),
            },
            dims,
            spacing,
            depth,
            labels: layout.labels,
        })
    }
}

/// The bricks renderer: drawn and probed by the device's [`super::Raycaster`] (the tree walk,
/// or the grid walk where nothing stops above the bricks), recolored by
/// [`GpuBrickRecolor`].
impl Renderer for GpuBricks {
    fn kind(&self) -> RendererKind {
        RendererKind::Bricks
    }

    fn level_detail(&self, max_level: u32) -> LevelDetail {
        level_detail(
            self.depth,
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

    /// Writes the lookup table and records the recolor of the brick level, the levels above
    /// it and the cell grid.
    fn set_transfer(
        &mut self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        self.write_lookup_table(context, transfer);
        context
            .brick_recolor()
            .encode(context, encoder, self, timestamp_writes);
        Ok(())
    }

    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        let coarse = matches!(
            self.level_detail(settings.max_level),
            LevelDetail::Pyramid { .. }
        );
        for variant in pipeline_variants(settings, probe, coarse, self.labels()) {
            context.raycaster().prepare(context, variant);
        }
    }

    fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        vec![
            ("atlas", self.atlas.bytes),
            (
                "pyramid_levels",
                self.levels.iter().map(|(texture, _)| texture.bytes).sum(),
            ),
            ("nodes", self.nodes.size()),
            ("bounds", self.bounds.size()),
            ("brick_origins", self.brick_origins.size()),
            ("brick_grid", self.grid.size() + self.grid_leaves.size()),
            ("lookup_table", self.transfer.size()),
        ]
    }

    fn slice_source(&self) -> Option<SliceSource<'_>> {
        Some(SliceSource::Bricks(self))
    }
}

impl VolumeShape for GpuBricks {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }
    fn spacing(&self) -> [f64; 3] {
        self.spacing
    }
    fn depth(&self) -> u32 {
        self.depth
    }
    fn level_cap(&self) -> u32 {
        self.depth
    }
    fn mip_saturation(&self) -> u16 {
        self.transfer.mip_saturation()
    }
    fn bricks(&self) -> Option<BrickShape> {
        Some(self.shape)
    }
    fn window_levels(&self) -> f32 {
        self.transfer.window_levels()
    }
    fn labels(&self) -> bool {
        self.labels
    }
    fn sampled_level(&self, max_level: u32) -> u32 {
        if max_level > self.shape.level && max_level < self.depth {
            (self.depth - max_level).min(self.levels.len() as u32)
        } else {
            0
        }
    }
    fn level_texels(&self, level: u32) -> Option<[usize; 3]> {
        match level {
            0 => Some(
                self.shape
                    .atlas_grid
                    .map(|g| g as usize * (self.shape.size as usize + 2)),
            ),
            _ => self.levels.get(level as usize - 1).map(|(_, dims)| *dims),
        }
    }
}

impl OctreeOnGpu for GpuBricks {
    fn nodes(&self) -> &wgpu::Buffer {
        &self.nodes
    }
    fn bounds(&self) -> &wgpu::Buffer {
        &self.bounds
    }
    fn lookup_table(&self) -> &wgpu::Buffer {
        &self.transfer.buffer
    }
    fn atlas(&self) -> Option<&wgpu::TextureView> {
        Some(&self.atlas.view)
    }
    fn sampled_texture(&self, level: u32) -> Option<&wgpu::TextureView> {
        match level {
            0 => Some(&self.atlas.view),
            _ => self
                .levels
                .get(level as usize - 1)
                .map(|(texture, _)| &texture.view),
        }
    }
    fn brick_grid(&self) -> Option<&wgpu::Buffer> {
        Some(&self.grid)
    }
}

/// Recolors a [`GpuBricks`]: the brick level from the atlas, the levels above from children
/// (with the device's [`super::GpuRecolor`]), then the cell grid from the nodes. One per
/// device ([`GpuContext::brick_recolor`]).
pub struct GpuBrickRecolor {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    grid_pipeline: wgpu::ComputePipeline,
    grid_layout: wgpu::BindGroupLayout,
}

/// Threads per workgroup of `brick_grid.wgsl`.
const GRID_WORKGROUP: u32 = 256;

impl GpuBrickRecolor {
    /// Builds the pipelines; [`GpuContext::brick_recolor`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let (pipeline, layout) = compute_pipeline(
            context,
            "brick_recolor",
            super::shaders::BRICK_RECOLOR,
            &[
                uniform_entry(0, false),
                storage_entry(1, false),
                storage_entry(2, true),
                storage_entry(3, true),
                atlas_entry(4),
                storage_entry(5, true),
            ],
        );
        let (grid_pipeline, grid_layout) = compute_pipeline(
            context,
            "brick_grid",
            super::shaders::BRICK_GRID,
            &[
                uniform_entry(0, false),
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, true),
                storage_entry(4, false),
            ],
        );
        Self {
            pipeline,
            layout,
            grid_pipeline,
            grid_layout,
        }
    }

    /// Records the recolor of every node of `bricks` from its lookup table.
    pub fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        bricks: &GpuBricks,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let level = bricks.shape.level as usize;
        let start = bricks.level_starts[level] as u32;
        let count = (bricks.level_starts[level + 1] - bricks.level_starts[level]) as u32;
        // One workgroup per node of the brick level.
        let groups = count.max(1);
        let groups_x = groups.min(context.limits.max_compute_workgroups_per_dimension.max(1));
        let dims = bricks.dims.map(|d| d as u32);
        let params = BrickRecolorParams {
            level_start: start,
            level_count: count,
            groups_x,
            brick_size: bricks.shape.size,
            atlas_grid: [
                bricks.shape.atlas_grid[0],
                bricks.shape.atlas_grid[1],
                bricks.shape.atlas_grid[2],
                0,
            ],
            dims: [dims[0], dims[1], dims[2], 0],
            atlas_scale: bricks.shape.atlas_scale,
            labels: u32::from(bricks.labels),
            _pad: [0; 2],
        };
        let device = &context.device;
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::brick_recolor_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = numbered_bind_group(
            device,
            "voxscope::brick_recolor_bind_group",
            &self.layout,
            &[
                params.as_entire_binding(),
                bricks.nodes.as_entire_binding(),
                bricks.bounds.as_entire_binding(),
                bricks.transfer.buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&bricks.atlas.view),
                bricks.brick_origins.as_entire_binding(),
            ],
        );
        // Time the whole recolor: the first pass starts the clock, the grid's stops it.
        let (first, last) = match &timestamp_writes {
            Some(w) => (
                Some(wgpu::ComputePassTimestampWrites {
                    query_set: w.query_set,
                    beginning_of_pass_write_index: w.beginning_of_pass_write_index,
                    end_of_pass_write_index: None,
                }),
                Some(wgpu::ComputePassTimestampWrites {
                    query_set: w.query_set,
                    beginning_of_pass_write_index: None,
                    end_of_pass_write_index: w.end_of_pass_write_index,
                }),
            ),
            None => (None, None),
        };
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("voxscope::brick_recolor_pass"),
                timestamp_writes: first,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(groups_x, groups.div_ceil(groups_x), 1);
        }
        if level > 0 {
            let levels = RecolorLevels {
                nodes: &bricks.nodes,
                bounds: &bricks.bounds,
                lookup_table: &bricks.transfer.buffer,
                level_starts: &bricks.level_starts,
                deepest: level as u32 - 1,
                labels: bricks.labels,
            };
            context
                .recolor()
                .encode_levels(context, encoder, &levels, None);
        }
        self.encode_grid(context, encoder, bricks, last);
    }

    /// Records the refresh of the cell grid from the (recolored) nodes.
    fn encode_grid(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        bricks: &GpuBricks,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let device = &context.device;
        let groups = bricks.grid_cells.div_ceil(GRID_WORKGROUP).max(1);
        let groups_x = groups.min(context.limits.max_compute_workgroups_per_dimension.max(1));
        let params = RecolorParams {
            level_start: 0,
            level_count: bricks.grid_cells,
            groups_x,
            labels: 0,
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::brick_grid_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = numbered_bind_group(
            device,
            "voxscope::brick_grid_bind_group",
            &self.grid_layout,
            &[
                params.as_entire_binding(),
                bricks.nodes.as_entire_binding(),
                bricks.bounds.as_entire_binding(),
                bricks.grid_leaves.as_entire_binding(),
                bricks.grid.as_entire_binding(),
            ],
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxscope::brick_grid_pass"),
            timestamp_writes,
        });
        pass.set_pipeline(&self.grid_pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(groups_x, groups.div_ceil(groups_x), 1);
    }
}
