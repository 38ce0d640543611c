//! GPU-side structs: `#[repr(C)]`, Pod, sizes checked at compile time and against the WGSL
//! by a naga test.

/// Uniforms of `raycast.wgsl`. Keep in sync with `struct Params` there.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct RaycastParams {
    pub eye: [f32; 4],
    pub forward: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub volume: [f32; 4],
    pub image_size: [u32; 2],
    pub depth: u32,
    pub max_level: u32,
    pub mode: u32,
    pub flags: u32,
    pub density: f32,
    pub lod_factor: f32,
    pub mip_saturation: u32,
    /// Level of brick leaves; beyond the depth when there are none.
    pub brick_level: u32,
    pub brick_size: u32,
    /// Atlas texel value × this = value level.
    pub atlas_scale: f32,
    /// Bricks along x, y, z of the atlas (w unused).
    pub atlas_grid: [u32; 4],
    /// Brick cells along x, y, z of the volume (w unused): the grid a full-detail ray walks.
    pub brick_grid: [u32; 4],
    /// 1 / the atlas's size in texels along x, y, z (w unused): texel to normalized coordinates,
    /// a uniform so that the grid walk keeps no registers for it.
    pub atlas_texel: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<RaycastParams>() == 176);

/// One cell of the bricks renderer's grid: a copy of the node covering it and its value
/// bounds (refreshed by `brick_grid.wgsl` after a recolor), and its brick's atlas cell.
/// Keep in sync with `struct GridCell` in `grid_cell.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GridCell {
    pub color: u32,
    pub first_child: u32,
    pub bounds: u32,
    /// Atlas cell of the brick, ten bits per axis (x lowest); 0 where the node is no brick.
    pub atlas_cell: u32,
}

const _: () = assert!(std::mem::size_of::<GridCell>() == 16);

/// Uniforms of one level's dispatch of `recolor.wgsl` and of `brick_grid.wgsl`. Keep in sync
/// with `struct LevelParams` in `node_common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct RecolorParams {
    pub level_start: u32,
    pub level_count: u32,
    pub groups_x: u32,
    pub _pad: u32,
}

const _: () = assert!(std::mem::size_of::<RecolorParams>() == 16);

/// Uniforms of `brick_recolor.wgsl`. Keep in sync with `struct Params` there.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct BrickRecolorParams {
    pub level_start: u32,
    pub level_count: u32,
    pub groups_x: u32,
    pub brick_size: u32,
    pub atlas_grid: [u32; 4],
    pub dims: [u32; 4],
    pub atlas_scale: f32,
    pub _pad: [u32; 3],
}

const _: () = assert!(std::mem::size_of::<BrickRecolorParams>() == 64);

/// Uniforms of `ceilings.wgsl`. Keep in sync with `struct CeilingParams` there.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct CeilingParams {
    /// `vec4<u32>` elements streamed from source to destination.
    pub elements: u32,
    /// Fetches or FMA rounds per invocation.
    pub iterations: u32,
    /// Invocations that work.
    pub invocations: u32,
    /// Entries of the index chain.
    pub chain_length: u32,
    /// `a ← a · fma_scale + fma_offset`.
    pub fma_scale: f32,
    pub fma_offset: f32,
    pub _padding: [u32; 2],
}

const _: () = assert!(std::mem::size_of::<CeilingParams>() == 32);

pub(crate) const FLAG_OPACITY_CORRECTION: u32 = 1;
pub(crate) const FLAG_PIXEL_LOD: u32 = 2;
pub(crate) const FLAG_HEATMAP: u32 = 4;

#[cfg(test)]
mod tests {
    use super::*;

    /// Size of the WGSL struct `name` in `source`, as naga lays it out.
    fn wgsl_struct_size(source: &str, name: &str) -> u32 {
        let module = naga::front::wgsl::parse_str(source).expect("shader parses");
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).expect("layout");
        let (handle, _) = module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some(name))
            .expect("struct exists");
        layouter[handle].size
    }

    #[test]
    fn rust_structs_mirror_wgsl() {
        let raycast = crate::render::shaders::RAYCAST;
        let recolor = crate::render::shaders::RECOLOR;
        let node = std::mem::size_of::<crate::octree::Node>() as u32;
        assert_eq!(
            wgsl_struct_size(raycast, "Params"),
            std::mem::size_of::<RaycastParams>() as u32
        );
        assert_eq!(wgsl_struct_size(raycast, "Node"), node);
        let dense = crate::render::shaders::DENSE;
        assert_eq!(
            wgsl_struct_size(dense, "Params"),
            std::mem::size_of::<RaycastParams>() as u32
        );
        assert_eq!(
            wgsl_struct_size(recolor, "LevelParams"),
            std::mem::size_of::<RecolorParams>() as u32
        );
        assert_eq!(wgsl_struct_size(recolor, "Node"), node);
        let bricks = crate::render::shaders::BRICK_RECOLOR;
        assert_eq!(
            wgsl_struct_size(bricks, "Params"),
            std::mem::size_of::<BrickRecolorParams>() as u32
        );
        assert_eq!(wgsl_struct_size(bricks, "Node"), node);
        let grid = crate::render::shaders::BRICK_GRID;
        assert_eq!(
            wgsl_struct_size(grid, "LevelParams"),
            std::mem::size_of::<RecolorParams>() as u32
        );
        assert_eq!(wgsl_struct_size(grid, "Node"), node);
        assert_eq!(
            wgsl_struct_size(crate::render::shaders::CEILINGS, "CeilingParams"),
            std::mem::size_of::<CeilingParams>() as u32
        );
    }
}
