//! GPU-side structs: `#[repr(C)]`, Pod, sizes checked at compile time, and field offsets and
//! sizes checked against the WGSL by a naga test.

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
    /// The crop box's low corner in voxel space (w unused); `[0, 0, 0]` without a box. Read
    /// by the clipping pipelines (`CLIP`) alone, as are the next two.
    pub clip_low: [f32; 4],
    /// The crop box's high corner in voxel space (w unused); the volume's dims without a box.
    pub clip_high: [f32; 4],
    /// The clip plane in voxel space: xyz the normal (the normalized one divided by the dims),
    /// w the distance; kept where `xyz · p ≥ w`. `[0, 0, 0, -1]` (everything) without a plane.
    pub clip_plane: [f32; 4],
    /// Ambient, diffuse, specular, shininess (the shaded pipelines read it).
    pub shading: [f32; 4],
    /// xyz: the smallest spacing ÷ each axis's spacing (voxel-space gradients to world ones);
    /// w: 1 ÷ (the transfer window's width in value levels × `GRADIENT_FOR_FULL_SHADING`).
    pub shading_scale: [f32; 4],
    /// The pixel the probe pipelines trace (`GpuProbe`); unused by the others.
    pub probe_pixel: [u32; 2],
    /// Level-0 voxels per voxel of the data sampled, and per sample step: 2^(depth − max
    /// level) where the dense or bricks renderer draws a pyramid level finer than the octree's
    /// nodes but coarser than full detail (the texture bound is that level's), else 1.
    pub sample_voxels: f32,
    pub _sample_pad: u32,
    /// The pixels the frame draws, `[x0, y0, x1, y1)`: the whole image, or a band of it where
    /// a slow device draws a frame in parts ([`crate::ImageRegion`]).
    pub tile: [u32; 4],
    /// Where the target lies in the image: xy its first pixel, z its width (w unused). The
    /// whole image at `[0, 0, width]`; a tile of a still larger than the device's textures
    /// elsewhere ([`crate::RenderTarget::tile`]), its rays those of the whole image's pixels.
    pub placement: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<RaycastParams>() == 304);

/// What a probe pipeline writes for its one pixel (`GpuProbe`). Keep in sync with
/// `struct ProbeResult` in `ray_common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ProbeResult {
    /// The probed point in voxel space (voxel (i, j, k) is the cube [i, i + 1) × …).
    pub point: [f32; 3],
    /// 1 when the ray reached the probed opacity (DVR) or took a sample (MIP), else 0.
    pub found: u32,
}

const _: () = assert!(std::mem::size_of::<ProbeResult>() == 16);

/// One cell of the bricks renderer's grid: a copy of the node covering it and its value
/// bounds (refreshed by `brick_grid.wgsl` after a recolor), and its brick's atlas cell.
/// Keep in sync with `struct GridCell` in `grid_cell.wgsl` and the `CELL_*` names of its
/// fields as vector components there (the grid walk reads a cell as a `vec4<u32>`).
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

/// Where `atlas_scatter.wgsl` writes one staged brick: the atlas texel of its cell's corner.
/// Keep in sync with `struct BrickPlacement` there.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct BrickPlacement {
    pub origin: [u32; 3],
    pub _pad: u32,
}

const _: () = assert!(std::mem::size_of::<BrickPlacement>() == 16);

/// Uniforms of one level's dispatch of `recolor.wgsl` and of `brick_grid.wgsl`. Keep in sync
/// with `struct LevelParams` in `node_common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct RecolorParams {
    pub level_start: u32,
    pub level_count: u32,
    pub groups_x: u32,
    /// 1 where the values are labels: a parent takes its children's most frequent visible
    /// color (`mode_color`), else their average. Unused by `brick_grid.wgsl`.
    pub labels: u32,
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
    /// 1 where the values are labels: a brick takes the color most of its visible voxels show
    /// (by majority vote), not their average.
    pub labels: u32,
    pub _pad: [u32; 2],
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

/// Uniforms of `slice.wgsl`. Keep in sync with `struct SliceParams` there.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SliceParams {
    /// Voxel-space point at the center of pixel (0, 0) (w unused).
    pub origin: [f32; 4],
    /// Voxel-space step per pixel to the right (w unused).
    pub step_x: [f32; 4],
    /// Voxel-space step per pixel down (w unused).
    pub step_y: [f32; 4],
    /// Voxels along x, y, z; w: the octree's depth.
    pub dims: [u32; 4],
    /// Brick cells along x, y, z (w unused).
    pub brick_grid: [u32; 4],
    pub image_size: [u32; 2],
    /// Which volume the slice reads (`SOURCE_*` in slice.rs).
    pub source: u32,
    /// 1: the nearest voxel; 0: trilinear.
    pub nearest: u32,
    /// Texel value × this = value level.
    pub level_scale: f32,
    /// The deepest octree level on the GPU.
    pub deepest_level: u32,
    pub brick_size: u32,
    pub _pad: u32,
}

const _: () = assert!(std::mem::size_of::<SliceParams>() == 112);

/// Levels a [`StreamParams`] describes at most (the WGSL arrays' length; a pyramid has at most
/// `stream::MAX_LEVELS`).
pub(crate) const STREAM_LEVELS: usize = 16;

/// The streaming renderer's own uniforms, beside [`RaycastParams`]. Keep in sync with
/// `struct StreamParams` in `stream.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct StreamParams {
    /// Per level: bricks along x, y, z (w unused).
    pub level_grid: [[u32; 4]; STREAM_LEVELS],
    /// Per level: its voxel's size in level-0 voxels along x, y, z; w their minimum.
    pub level_scale: [[f32; 4]; STREAM_LEVELS],
    pub level_count: u32,
    /// The level the max-level slider allows at finest (depth − max level).
    pub finest_level: u32,
    /// The frame number rays mark the slots they use with.
    pub frame: u32,
    /// Page table entries − 1.
    pub table_mask: u32,
    /// Keys the request buffer holds.
    pub request_capacity: u32,
    /// Entries of the request buffer's deduplicating set − 1.
    pub request_set_mask: u32,
    /// The pixel footprint's multiplier (0: always the finest allowed level).
    pub lod_scale: f32,
    /// The level whose page-table entries the level walk reads flat (`main_level`).
    pub walk_level: u32,
    /// Where the next coarser level's entries begin in the flat copy, where the walk takes it
    /// too (`main_levels`): the walked level's brick count; else 0.
    pub walk_next: u32,
    /// Channels streamed together (1: one volume; the composite's otherwise).
    pub channel_count: u32,
    /// Bit `c`: channel `c` is drawn (the composite's).
    pub shown_channels: u32,
    pub _pad2: u32,
    /// Channel `c`'s 1 / the gradient that shades it fully (at `[c / 4][c % 4]`; the
    /// composite's, as the in-memory composite's `channel_shading`).
    pub channel_shading: [[f32; 4]; 2],
}

const _: () = assert!(std::mem::size_of::<StreamParams>() == 592);

pub(crate) const FLAG_OPACITY_CORRECTION: u32 = 1;
pub(crate) const FLAG_PIXEL_LOD: u32 = 2;
pub(crate) const FLAG_HEATMAP: u32 = 4;
/// The values are labels: MIP draws the first visible label (`first_label`, ray_common.wgsl).
pub(crate) const FLAG_LABELS: u32 = 8;
/// [`RaycastParams::mode`] of DVR and of MIP (keep in sync with `ray_common.wgsl`).
pub(crate) const MODE_DVR: u32 = 0;
pub(crate) const MODE_MIP: u32 = 1;

#[cfg(test)]
mod tests {
    //! Every struct a shader binds (a uniform, or the element of a storage array) has a Rust
    //! mirror here, and every mirror has the same fields at the same byte offsets and sizes as
    //! naga lays the WGSL struct out in each shader that declares it (raycast.wgsl declares
    //! `GridCell` but binds its grid as vectors). Fields named `_…` are padding: not compared by
    //! name (WGSL spells a `[u32; 3]` as three scalars), but the struct sizes catch them.
    use std::collections::BTreeMap;
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::shaders;
    use voxscope_octree::Node;

    /// A struct as one side lays it out.
    struct Layout {
        name: String,
        size: u32,
        /// In declaration order.
        fields: Vec<Field>,
    }

    struct Field {
        name: String,
        offset: u32,
        size: u32,
    }

    /// The size of the field `field` selects, without a value of `T`.
    fn size_of_field<T, F>(_field: fn(&T) -> &F) -> u32 {
        size_of::<F>() as u32
    }

    /// The layout of `$ty`, whose every field must be listed: the pattern in
    /// `every_field_listed` does not compile when one is missing.
    macro_rules! rust_layout {
        ($ty:ident { $($field:ident),+ $(,)? }) => {{
            #[allow(dead_code)]
            fn every_field_listed(value: $ty) {
                let $ty { $($field: _),+ } = value;
            }
            Layout {
                name: stringify!($ty).to_owned(),
                size: size_of::<$ty>() as u32,
                fields: vec![$(Field {
                    name: stringify!($field).to_owned(),
                    offset: offset_of!($ty, $field) as u32,
                    size: size_of_field(|value: &$ty| &value.$field),
                }),+],
            }
        }};
    }

    fn raycast_params() -> Layout {
        rust_layout!(RaycastParams {
            eye,
            forward,
            right,
            up,
            volume,
            image_size,
            depth,
            max_level,
            mode,
            flags,
            density,
            lod_factor,
            mip_saturation,
            brick_level,
            brick_size,
            atlas_scale,
            atlas_grid,
            brick_grid,
            atlas_texel,
            clip_low,
            clip_high,
            clip_plane,
            shading,
            shading_scale,
            probe_pixel,
            sample_voxels,
            _sample_pad,
            tile,
            placement,
        })
    }

    fn stream_params() -> Layout {
        rust_layout!(StreamParams {
            level_grid,
            level_scale,
            level_count,
            finest_level,
            frame,
            table_mask,
            request_capacity,
            request_set_mask,
            lod_scale,
            walk_level,
            walk_next,
            channel_count,
            shown_channels,
            _pad2,
            channel_shading,
        })
    }

    fn brick_placement() -> Layout {
        rust_layout!(BrickPlacement { origin, _pad })
    }

    fn probe_result() -> Layout {
        rust_layout!(ProbeResult { point, found })
    }

    fn node() -> Layout {
        rust_layout!(Node { color, first_child })
    }

    fn grid_cell() -> Layout {
        rust_layout!(GridCell {
            color,
            first_child,
            bounds,
            atlas_cell,
        })
    }

    fn recolor_params() -> Layout {
        rust_layout!(RecolorParams {
            level_start,
            level_count,
            groups_x,
            labels,
        })
    }

    fn brick_recolor_params() -> Layout {
        rust_layout!(BrickRecolorParams {
            level_start,
            level_count,
            groups_x,
            brick_size,
            atlas_grid,
            dims,
            atlas_scale,
            labels,
            _pad,
        })
    }

    fn ceiling_params() -> Layout {
        rust_layout!(CeilingParams {
            elements,
            iterations,
            invocations,
            chain_length,
            fma_scale,
            fma_offset,
            _padding,
        })
    }

    fn slice_params() -> Layout {
        rust_layout!(SliceParams {
            origin,
            step_x,
            step_y,
            dims,
            brick_grid,
            image_size,
            source,
            nearest,
            level_scale,
            deepest_level,
            brick_size,
            _pad,
        })
    }

    /// For each shader, the Rust mirror of each WGSL struct it binds or reads, by WGSL name.
    fn mirrors(shader: &str) -> Vec<(&'static str, Layout)> {
        match shader {
            "raycast" => vec![
                ("Params", raycast_params()),
                ("Node", node()),
                ("GridCell", grid_cell()),
                ("ProbeResult", probe_result()),
            ],
            "dense" | "composite" => vec![
                ("Params", raycast_params()),
                ("ProbeResult", probe_result()),
            ],
            "stream" | "stream_composite" => vec![
                ("Params", raycast_params()),
                ("StreamParams", stream_params()),
                ("ProbeResult", probe_result()),
            ],
            "recolor" => vec![("LevelParams", recolor_params()), ("Node", node())],
            "brick_recolor" => vec![("Params", brick_recolor_params()), ("Node", node())],
            "brick_grid" => vec![
                ("LevelParams", recolor_params()),
                ("Node", node()),
                ("GridCell", grid_cell()),
            ],
            "ceilings" => vec![("CeilingParams", ceiling_params())],
            "atlas_scatter_r8unorm" | "atlas_scatter_r16unorm" | "atlas_scatter_r16float" => {
                vec![("BrickPlacement", brick_placement())]
            }
            "slice" => vec![
                ("SliceParams", slice_params()),
                ("Node", node()),
                ("GridCell", grid_cell()),
            ],
            other => panic!("no mirrors listed for the shader {other}"),
        }
    }

    /// The layout of every named struct `module` declares, by name.
    fn declared_structs(module: &naga::Module) -> BTreeMap<String, Layout> {
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).expect("layout");
        let mut structs = BTreeMap::new();
        for (handle, ty) in module.types.iter() {
            let (naga::TypeInner::Struct { members, .. }, Some(name)) = (&ty.inner, &ty.name)
            else {
                continue;
            };
            let fields = members
                .iter()
                .map(|member| Field {
                    name: member.name.clone().unwrap_or_default(),
                    offset: member.offset,
                    size: layouter[member.ty].size,
                })
                .collect();
            let size = layouter[handle].size;
            structs.insert(
                name.clone(),
                Layout {
                    name: name.clone(),
                    size,
                    fields,
                },
            );
        }
        structs
    }

    /// The names of the structs `module` binds: a uniform or storage variable of that struct,
    /// or an array of it.
    fn bound_structs(module: &naga::Module) -> Vec<String> {
        let mut names = Vec::new();
        for (_, global) in module.global_variables.iter() {
            if global.binding.is_none() {
                continue;
            }
            let mut ty = global.ty;
            if let naga::TypeInner::Array { base, .. } = module.types[ty].inner {
                ty = base;
            }
            if let (naga::TypeInner::Struct { .. }, Some(name)) =
                (&module.types[ty].inner, &module.types[ty].name)
            {
                names.push(name.clone());
            }
        }
        names
    }

    /// How `wgsl` (a struct of `shader`, as [`declared_structs`] gives it) lays out `rust`'s
    /// fields otherwise than Rust does, naming the first field that differs; `None` where the
    /// two agree. A test's diagnosis, printed as it is.
    fn difference(shader: &str, wgsl: &Layout, rust: &Layout) -> Option<String> {
        fn named(layout: &Layout) -> Vec<&Field> {
            layout
                .fields
                .iter()
                .filter(|field| !field.name.starts_with('_'))
                .collect()
        }
        let (wgsl_fields, rust_fields) = (named(wgsl), named(rust));
        let here = format!("{shader}: WGSL {} and Rust {}", wgsl.name, rust.name);
        for index in 0..wgsl_fields.len().max(rust_fields.len()) {
            match (wgsl_fields.get(index), rust_fields.get(index)) {
                (Some(w), Some(r)) if w.name != r.name => {
                    return Some(format!(
                        "{here}: field {} is `{}` in WGSL, `{}` in Rust",
                        index + 1,
                        w.name,
                        r.name
                    ));
                }
                (Some(w), Some(r)) if w.offset != r.offset => {
                    return Some(format!(
                        "{here}: `{}` is at byte {} in WGSL, {} in Rust",
                        r.name, w.offset, r.offset
                    ));
                }
                (Some(w), Some(r)) if w.size != r.size => {
                    return Some(format!(
                        "{here}: `{}` takes {} bytes in WGSL, {} in Rust",
                        r.name, w.size, r.size
                    ));
                }
                (Some(w), None) => return Some(format!("{here}: `{}` is missing in Rust", w.name)),
                (None, Some(r)) => return Some(format!("{here}: `{}` is missing in WGSL", r.name)),
                _ => {}
            }
        }
        if wgsl.size != rust.size {
            return Some(format!(
                "{here}: {} bytes in WGSL, {} in Rust (padding)",
                wgsl.size, rust.size
            ));
        }
        None
    }

    #[test]
    fn rust_structs_mirror_wgsl_field_by_field() {
        for shader in shaders::ALL {
            let module = naga::front::wgsl::parse_str(shader.source).expect("shader parses");
            let declared = declared_structs(&module);
            let mirrors = mirrors(shader.name);
            for (wgsl_name, rust) in &mirrors {
                let wgsl = declared.get(*wgsl_name).unwrap_or_else(|| {
                    panic!(
                        "{}: declares no struct {wgsl_name} (mirror {})",
                        shader.name, rust.name
                    )
                });
                if let Some(problem) = difference(shader.name, wgsl, rust) {
                    panic!("{problem}");
                }
            }
            for bound in bound_structs(&module) {
                assert!(
                    mirrors.iter().any(|(wgsl_name, _)| *wgsl_name == bound),
                    "{}: binds {bound} with no Rust mirror listed in gpu_data's test",
                    shader.name
                );
            }
        }
    }

    /// The `CELL_*` constants of `source` (`const CELL_NAME = N;`), which name GridCell's fields
    /// as components of a vector. Abstract integers: naga keeps none of them in the module, so
    /// they are read from the text.
    fn cell_components(source: &str) -> Vec<(String, u32)> {
        source
            .lines()
            .filter_map(|line| line.strip_prefix("const CELL_"))
            .map(|rest| {
                let (name, value) = rest
                    .trim_end_matches(';')
                    .split_once(" = ")
                    .unwrap_or_else(|| panic!("`const CELL_{rest}` is not `const CELL_NAME = N;`"));
                let value = value
                    .parse()
                    .unwrap_or_else(|_| panic!("CELL_{name}: {value} is not a component index"));
                (format!("CELL_{name}"), value)
            })
            .collect()
    }

    #[test]
    fn grid_cell_components_are_named_after_its_fields_in_order() {
        for shader in shaders::ALL {
            let module = naga::front::wgsl::parse_str(shader.source).expect("shader parses");
            let Some(cell) = declared_structs(&module).remove("GridCell") else {
                continue;
            };
            let expected: Vec<(String, u32)> = cell
                .fields
                .iter()
                .enumerate()
                .map(|(index, field)| (format!("CELL_{}", field.name.to_uppercase()), index as u32))
                .collect();
            assert_eq!(
                cell_components(shader.source),
                expected,
                "{}: each GridCell field's CELL_ component, in order",
                shader.name
            );
        }
    }

    /// The comparison names what differs: a field moved, renamed, resized or missing.
    #[test]
    fn a_differing_field_is_named() {
        let rust = rust_layout!(RecolorParams {
            level_start,
            level_count,
            groups_x,
            labels,
        });
        let check = |wgsl: &str| {
            let source = format!("{wgsl}\n@group(0) @binding(0) var<uniform> params: LevelParams;");
            let module = naga::front::wgsl::parse_str(&source).expect("test WGSL parses");
            difference("test", &declared_structs(&module)["LevelParams"], &rust)
        };
        let same =
            "struct LevelParams { level_start: u32, level_count: u32, groups_x: u32, labels: u32 }";
        assert_eq!(check(same), None);
        let cases = [
            (
                "struct LevelParams { level_count: u32, level_start: u32, groups_x: u32, labels: u32 }",
                "field 1 is `level_count` in WGSL, `level_start` in Rust",
            ),
            (
                "struct LevelParams { level_start: u32, level_count: u32, _p: u32, groups_x: u32 }",
                "`groups_x` is at byte 12 in WGSL, 8 in Rust",
            ),
            (
                "struct LevelParams { level_start: u32, level_count: u32, groups_x: vec2<u32> }",
                "`groups_x` takes 8 bytes in WGSL, 4 in Rust",
            ),
            (
                "struct LevelParams { level_start: u32, level_count: u32, _p: vec2<u32> }",
                "`groups_x` is missing in WGSL",
            ),
            (
                "struct LevelParams { level_start: u32, level_count: u32, groups_x: u32 }",
                "`labels` is missing in WGSL",
            ),
            (
                "struct LevelParams { level_start: u32, level_count: u32, groups_x: u32, labels: u32, _p: u32 }",
                "20 bytes in WGSL, 16 in Rust",
            ),
        ];
        for (wgsl, expected) in cases {
            let problem = check(wgsl).expect(wgsl);
            assert!(problem.contains(expected), "{wgsl}: {problem}");
        }
    }
}
