//! Planar slices of the volume a renderer already holds, drawn on the GPU: each pixel is one
//! point of voxel space, its value read from the dense texture, the brick atlas or the octree's
//! value bounds, colored through the value window and colormap (opacity plays no part).
//! Nothing is copied to the CPU per frame.
//!
//! Two halves, as for the ray casters: [`SliceFrame`] and [`SliceSettings`] say what one slice
//! shows (the per-frame half, built on the CPU; [`SliceFrame::axis_aligned`] builds the frame
//! of an axis-aligned view as the app shows it, [`SliceFrame::voxel_grid`] the one pixel per
//! voxel frame of `voxscope slice`); [`Slicer`] is the pipeline, built once per device
//! ([`GpuContext::slicer`]). [`super::VolumeRenderer::encode_slice`] joins them.
//!
//! **Voxel space** is the ray casters': voxel `(i, j, k)` is the unit cube `[i, i + 1) × [j, j +
//! 1) × [k, k + 1)`, its center at `(i + ½, j + ½, k + ½)`. **Pixel positions** are those of a
//! view's pixels, `[0, width) × [0, height)` from the top-left corner: pixel `(c, r)` covers
//! `[c, c + 1) × [r, r + 1)`, its center at `(c + ½, r + ½)`.
//!
//! **Orientation.** Volumes with a known patient orientation are reordered to RAS on load
//! (`volume::Orientation`): +x points to the patient's right, +y to anterior, +z to superior.
//! Their views follow radiology viewers (3D Slicer, ITK-SNAP): see
//! [`SliceConvention::Radiological`]. Other volumes (microscopy, simulations) are shown as
//! image stacks: [`SliceConvention::Image`].

use std::sync::Mutex;

use wgpu::util::DeviceExt;

use super::gpu_data::SliceParams;
use super::pipeline::{
    compute_pipeline, dispatch_per_pixel, numbered_bind_group, output_image_entry, storage_entry,
    uniform_entry,
};
use super::raycaster::{OctreeOnGpu, VolumeShape};
use super::{DenseVolume, GpuBricks, GpuContext, GpuVolume, RenderTarget};
use voxscope_octree::{Colormap, pack_rgba};
use voxscope_volume::{LEVELS, Orientation, Quantization, ValueWindow, Volume};

/// Where a slice's pixels are in voxel space: the point at the center of pixel (0, 0), and the
/// step per pixel to the right and per pixel down. The point at pixel position `(u, v)` is
/// `origin + (u − ½) · step_x + (v − ½) · step_y` ([`Self::point_at`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliceFrame {
    /// Voxel-space point at the center of pixel (0, 0).
    pub origin: [f64; 3],
    /// Voxel-space step per pixel to the right.
    pub step_x: [f64; 3],
    /// Voxel-space step per pixel down.
    pub step_y: [f64; 3],
}

/// How the views across x, y and z lay the volume's other two axes on the screen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SliceConvention {
    /// Patient data in RAS order, as radiology viewers show it (3D Slicer, ITK-SNAP), the
    /// patient seen from the feet (axial) and from the front (coronal):
    /// - axial (across z): the patient's right on the screen's left (screen right is −x),
    ///   anterior up (screen down is −y);
    /// - coronal (across y): right on the left (screen right is −x), superior up (screen down
    ///   is −z);
    /// - sagittal (across x): anterior on the left (screen right is −y, posterior), superior
    ///   up (screen down is −z).
    Radiological,
    /// Image stacks (microscopy, simulations): across z as Fiji and napari show a plane, the
    /// first voxel in the top-left corner; the side views with +z up, as the 3D view stands
    /// the volume (each view a true view from one side, none mirrored):
    /// - across z: +x to the right, +y down (a TIFF page as stored; seen from −z);
    /// - across y: +x to the right, +z up (seen from −y);
    /// - across x: +y to the right, +z up (seen from +x).
    Image,
}

impl SliceConvention {
    /// The convention for `volume`: radiological where the file gave a patient orientation
    /// (its axes reordered to RAS on load, or NIfTI, NRRD and DICOM, whose axes are patient
    /// axes even when stored as RAS already; the app's axis gizmo has the same rule but for
    /// DICOM), image otherwise.
    pub fn of_volume(volume: &Volume) -> Self {
        let patient = matches!(volume.orientation, Orientation::Reoriented { .. })
            || matches!(volume.format, "NIfTI-1" | "NRRD" | "DICOM");
        if patient {
            Self::Radiological
        } else {
            Self::Image
        }
    }

    /// For the view across `axis` (0, 1, 2 for x, y, z): the volume axis that runs to the
    /// screen's right and its sign, then the one that runs down and its sign.
    pub fn screen_axes(self, axis: usize) -> [(usize, f64); 2] {
        match (self, axis) {
            (Self::Radiological, 0) => [(1, -1.0), (2, -1.0)],
            (Self::Radiological, 1) => [(0, -1.0), (2, -1.0)],
            (Self::Radiological, _) => [(0, -1.0), (1, -1.0)],
            (Self::Image, 0) => [(1, 1.0), (2, -1.0)],
            (Self::Image, 1) => [(0, 1.0), (2, -1.0)],
            (Self::Image, _) => [(0, 1.0), (1, 1.0)],
        }
    }

    /// The name of the view across `axis`: `sagittal`, `coronal`, `axial` for patient data,
    /// else `x`, `y`, `z`.
    pub fn view_name(self, axis: usize) -> &'static str {
        match (self, axis) {
            (Self::Radiological, 0) => "sagittal",
            (Self::Radiological, 1) => "coronal",
            (Self::Radiological, _) => "axial",
            (Self::Image, 0) => "x",
            (Self::Image, 1) => "y",
            (Self::Image, _) => "z",
        }
    }

    /// The name of the direction along `axis`, increasing (`positive`) or decreasing: `R`/`L`,
    /// `A`/`P`, `S`/`I` for patient data, else `+x`/`−x`…
    pub fn direction_name(self, axis: usize, positive: bool) -> &'static str {
        const PATIENT: [[&str; 2]; 3] = [["L", "R"], ["P", "A"], ["I", "S"]];
        const IMAGE: [[&str; 2]; 3] = [["−x", "+x"], ["−y", "+y"], ["−z", "+z"]];
        let names = match self {
            Self::Radiological => PATIENT,
            Self::Image => IMAGE,
        };
        names[axis.min(2)][positive as usize]
    }
}

/// The names of the directions toward each edge of a slice view (`R` on the left of an axial
/// view of patient data).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeLabels {
    pub left: &'static str,
    pub right: &'static str,
    pub top: &'static str,
    pub bottom: &'static str,
}

/// What an axis-aligned slice view shows: which slice, how magnified, where (the app keeps
/// one per view).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliceView {
    /// The axis the view looks along: 0, 1, 2 for x, y, z (sagittal, coronal, axial).
    pub axis: usize,
    /// The slice: a voxel index along `axis` (displayed, RAS-reordered order).
    pub index: usize,
    /// Magnification: 1 fits the whole slice in the view, 2 shows it twice as large.
    pub zoom: f64,
    /// The slice's center moved right and down by this many pixels from the view's center.
    pub pan: [f64; 2],
}

impl SliceView {
    /// Slice `index` across `axis`, fitted and centered.
    pub fn new(axis: usize, index: usize) -> Self {
        Self {
            axis,
            index,
            zoom: 1.0,
            pan: [0.0; 2],
        }
    }
}

/// Smallest and largest [`SliceView::zoom`] a frame takes (beyond, it is clamped).
const ZOOM_RANGE: [f64; 2] = [1e-3, 1e4];

impl SliceFrame {
    /// The frame of `view` in a `target` of width × height pixels, for a volume of `dims`
    /// voxels of `spacing`, laid out by `convention`. Physical proportions are kept: a pixel
    /// spans as many millimetres (or the file's unit) across as down. At zoom 1 the slice's
    /// physical extent fits the target, centered; `view.pan` moves it. The slice's plane is
    /// at the centers of voxel layer `view.index`, so linear slices do not blend neighboring
    /// layers.
    pub fn axis_aligned(
        view: &SliceView,
        convention: SliceConvention,
        dims: [usize; 3],
        spacing: [f64; 3],
        target: [u32; 2],
    ) -> Self {
        let axis = view.axis.min(2);
        let [(right_axis, right_sign), (down_axis, down_sign)] = convention.screen_axes(axis);
        let [width, height] = target.map(|t| t.max(1) as f64);
        let extent = |a: usize| dims[a].max(1) as f64 * spacing[a];
        let zoom = if view.zoom.is_finite() {
            view.zoom.clamp(ZOOM_RANGE[0], ZOOM_RANGE[1])
        } else {
            1.0
        };
        let pixels_per_unit = (width / extent(right_axis)).min(height / extent(down_axis)) * zoom;
        let mut frame = Self {
            origin: [0.0; 3],
            step_x: [0.0; 3],
            step_y: [0.0; 3],
        };
        frame.step_x[right_axis] = right_sign / (pixels_per_unit * spacing[right_axis]);
        frame.step_y[down_axis] = down_sign / (pixels_per_unit * spacing[down_axis]);
        // The slice's center sits at the view's center moved by `pan`; pixel (0, 0)'s center
        // is half a pixel in from the corner.
        let from_center = [
            0.5 - width / 2.0 - view.pan[0],
            0.5 - height / 2.0 - view.pan[1],
        ];
        frame.origin[right_axis] =
            dims[right_axis] as f64 / 2.0 + from_center[0] * frame.step_x[right_axis];
        frame.origin[down_axis] =
            dims[down_axis] as f64 / 2.0 + from_center[1] * frame.step_y[down_axis];
        frame.origin[axis] = view.index as f64 + 0.5;
        frame
    }

    /// One pixel per voxel (what `voxscope slice` writes): the frame of slice `index` across
    /// `axis` and its size in pixels; pixel centers are voxel centers, laid out by
    /// `convention` (the voxels' spacing plays no part).
    pub fn voxel_grid(
        convention: SliceConvention,
        axis: usize,
        index: usize,
        dims: [usize; 3],
    ) -> (Self, [u32; 2]) {
        let axis = axis.min(2);
        let [(right_axis, _), (down_axis, _)] = convention.screen_axes(axis);
        let size =
            [dims[right_axis], dims[down_axis]].map(|d| d.clamp(1, u32::MAX as usize) as u32);
        let view = SliceView::new(axis, index);
        (
            Self::axis_aligned(&view, convention, dims, [1.0; 3], size),
            size,
        )
    }

    /// The voxel-space point at pixel position `pixel` (`[0.5, 0.5]`: the center of pixel
    /// (0, 0)).
    pub fn point_at(&self, pixel: [f64; 2]) -> [f64; 3] {
        std::array::from_fn(|a| {
            self.origin[a] + (pixel[0] - 0.5) * self.step_x[a] + (pixel[1] - 0.5) * self.step_y[a]
        })
    }

    /// The voxel under pixel position `pixel`, if it is inside a volume of `dims` voxels: the
    /// voxel a nearest slice draws there (for the cursor and the probe).
    pub fn voxel_at(&self, pixel: [f64; 2], dims: [usize; 3]) -> Option<[usize; 3]> {
        let point = self.point_at(pixel);
        let inside = (0..3).all(|a| point[a] >= 0.0 && point[a] < dims[a] as f64);
        inside.then(|| std::array::from_fn(|a| (point[a].floor() as usize).min(dims[a] - 1)))
    }

    /// The pixel position of voxel-space `point` projected onto the slice's plane (for the
    /// cursor's crosshair, rulers): the inverse of [`Self::point_at`] for points on the plane.
    /// Exact where `step_x` and `step_y` are perpendicular, as in every frame built here.
    pub fn pixel_of(&self, point: [f64; 3]) -> [f64; 2] {
        let offset: [f64; 3] = std::array::from_fn(|a| point[a] - self.origin[a]);
        let along = |step: &[f64; 3]| {
            let length_squared: f64 = step.iter().map(|s| s * s).sum();
            if length_squared == 0.0 {
                return 0.0;
            }
            offset.iter().zip(step).map(|(o, s)| o * s).sum::<f64>() / length_squared
        };
        [along(&self.step_x) + 0.5, along(&self.step_y) + 0.5]
    }

    /// The directions toward the view's left, right, top and bottom edges, named by
    /// `convention` (each step's largest component decides).
    pub fn edge_labels(&self, convention: SliceConvention) -> EdgeLabels {
        let name = |step: &[f64; 3], toward_positive: bool| {
            let axis = (0..3)
                .max_by(|&a, &b| step[a].abs().total_cmp(&step[b].abs()))
                .unwrap_or(0);
            convention.direction_name(axis, (step[axis] >= 0.0) == toward_positive)
        };
        EdgeLabels {
            left: name(&self.step_x, false),
            right: name(&self.step_x, true),
            top: name(&self.step_y, false),
            bottom: name(&self.step_y, true),
        }
    }
}

/// What one slice draws: where its pixels are, and the colors of the data's values there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliceSettings {
    pub frame: SliceFrame,
    /// Values at or below `low` take the colormap's first color, at or above `high` its last.
    pub window: ValueWindow,
    pub colormap: Colormap,
    /// The nearest voxel's value (exact); otherwise trilinear between voxel centers. A label
    /// volume, and the labels colormap, are always nearest: a label between two labels means
    /// nothing.
    pub nearest: bool,
}

/// The colors of a slice for all 65 536 value levels of `quantization`: the value's place in
/// `window` through `colormap`, opaque (packed RGBA8, red lowest).
pub(crate) fn slice_lookup_table(
    quantization: Quantization,
    window: ValueWindow,
    colormap: Colormap,
) -> Vec<u32> {
    (0..LEVELS)
        .map(|level| {
            let value = quantization.value(level as u16);
            let [r, g, b] = colormap.rgb_of(value, window.normalize(value));
            pack_rgba([r, g, b, 255])
        })
        .collect()
}

/// One color table on the GPU and the window and colormap it was made for.
pub(crate) struct SliceColors {
    window: ValueWindow,
    colormap: Colormap,
    buffer: wgpu::Buffer,
}

/// How many color tables a volume keeps: enough for views that each show their own window or
/// colormap without making tables every frame.
const KEPT_COLOR_TABLES: usize = 4;

/// A volume's slice color tables, the most recently used first, each made once for its window
/// and colormap. A new window or colormap makes a new buffer (rather than writing an old one),
/// so slices recorded earlier into a command encoder keep their own colors.
#[derive(Default)]
pub(crate) struct SliceColorCache(Mutex<Vec<SliceColors>>);

impl SliceColorCache {
    /// The color table of `window` and `colormap` for values of `quantization`.
    pub(crate) fn get(
        &self,
        context: &GpuContext,
        quantization: Quantization,
        window: ValueWindow,
        colormap: Colormap,
    ) -> wgpu::Buffer {
        // A poisoned lock only means a panic elsewhere while it was held; the tables in it are
        // still whole (each is made before it is added).
        let mut tables = self
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let found = tables
            .iter()
            .position(|t| t.window == window && t.colormap == colormap);
        let colors = match found {
            Some(index) => tables.remove(index),
            None => {
                let table = slice_lookup_table(quantization, window, colormap);
                let buffer = context
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("voxscope::slice_lookup_table"),
                        contents: bytemuck::cast_slice(&table),
                        usage: wgpu::BufferUsages::STORAGE,
                    });
                SliceColors {
                    window,
                    colormap,
                    buffer,
                }
            }
        };
        let buffer = colors.buffer.clone();
        tables.insert(0, colors);
        tables.truncate(KEPT_COLOR_TABLES);
        buffer
    }

    /// Bytes on the GPU (0 until the first slice).
    pub(crate) fn gpu_bytes(&self) -> u64 {
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .iter()
            .map(|colors| colors.buffer.size())
            .sum()
    }
}

/// Which of a renderer's volumes a slice reads its values from ([`super::Renderer::slice_source`]).
pub enum SliceSource<'a> {
    Dense(&'a DenseVolume),
    Bricks(&'a GpuBricks),
    Octree(&'a GpuVolume),
}

// Keep in sync with `SOURCE_*` in slice.wgsl.
const SOURCE_DENSE: u32 = 0;
const SOURCE_BRICKS: u32 = 1;
const SOURCE_OCTREE: u32 = 2;

impl SliceSource<'_> {
    /// Whether every voxel's level is on the GPU (the octree may be cut above the voxels).
    pub(crate) fn is_exact(&self) -> bool {
        match self {
            Self::Dense(_) | Self::Bricks(_) => true,
            Self::Octree(volume) => volume.is_complete(),
        }
    }

    /// Whether the values are labels: slices of them show the nearest voxel, whatever asked.
    pub(crate) fn labels(&self) -> bool {
        match self {
            Self::Dense(volume) => volume.labels(),
            Self::Bricks(bricks) => bricks.labels(),
            Self::Octree(volume) => volume.labels(),
        }
    }
}

/// The slice pipeline and the stand-ins bound where a source lacks a resource; one per device
/// ([`GpuContext::slicer`]).
pub struct Slicer {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    no_texture: wgpu::TextureView,
    /// One zeroed element, bound for the nodes, bounds or grid a source does not have.
    no_buffer: wgpu::Buffer,
}

impl Slicer {
    /// Builds the pipeline; [`GpuContext::slicer`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let device = &context.device;
        let (pipeline, layout) = compute_pipeline(
            context,
            "slice",
            super::shaders::SLICE,
            &[
                uniform_entry(0, false),
                level_texture_entry(1),
                storage_entry(2, true),
                storage_entry(3, true),
                storage_entry(4, true),
                storage_entry(5, true),
                output_image_entry(6),
            ],
        );
        let no_texture = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("voxscope::slice_no_texture"),
                size: wgpu::Extent3d {
                    width: 1,
                    height: 1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&wgpu::TextureViewDescriptor::default());
        let no_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::slice_no_buffer"),
            size: std::mem::size_of::<super::gpu_data::GridCell>() as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            layout,
            no_texture,
            no_buffer,
        }
    }

    /// Records one slice of `source` into `target`, colored by `lookup_table`, its parameters
    /// in a buffer of its own (so slices of several views and volumes can share an encoder).
    pub(crate) fn encode(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        source: &SliceSource<'_>,
        lookup_table: &wgpu::Buffer,
        target: &RenderTarget,
        settings: &SliceSettings,
    ) {
        let params = slice_params(source, target, settings);
        let params = context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::slice_params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let none = &self.no_buffer;
        let (texture, nodes, bounds, grid) = match source {
            SliceSource::Dense(volume) => (&volume.levels.view, none, none, none),
            SliceSource::Bricks(bricks) => (
                bricks.atlas().unwrap_or(&self.no_texture),
                bricks.nodes(),
                bricks.bounds(),
                bricks.brick_grid().unwrap_or(none),
            ),
            SliceSource::Octree(volume) => (&self.no_texture, &volume.nodes, &volume.bounds, none),
        };
        let bind_group = numbered_bind_group(
            &context.device,
            "voxscope::slice_bind_group",
            &self.layout,
            &[
                params.as_entire_binding(),
                wgpu::BindingResource::TextureView(texture),
                nodes.as_entire_binding(),
                bounds.as_entire_binding(),
                grid.as_entire_binding(),
                lookup_table.as_entire_binding(),
                wgpu::BindingResource::TextureView(&target.view),
            ],
        );
        dispatch_per_pixel(encoder, "slice", &self.pipeline, &bind_group, target, None);
    }
}

/// A 3D float texture read texel by texel (`textureLoad`, never filtered): the dense texture
/// or the brick atlas, whatever its format.
fn level_texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    }
}

/// The shader's parameters for one slice of `source`.
fn slice_params(
    source: &SliceSource<'_>,
    target: &RenderTarget,
    settings: &SliceSettings,
) -> SliceParams {
    let vec4 = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
    let (kind, dims, depth, level_scale, deepest_level, brick_size, brick_grid) = match source {
        SliceSource::Dense(volume) => (
            SOURCE_DENSE,
            volume.dims,
            0,
            volume.level_scale(),
            0,
            1,
            [1; 3],
        ),
        SliceSource::Bricks(bricks) => {
            let shape = bricks.bricks().expect("a GpuBricks has bricks");
            (
                SOURCE_BRICKS,
                bricks.dims(),
                bricks.depth(),
                shape.atlas_scale,
                0,
                shape.size,
                shape.grid,
            )
        }
        SliceSource::Octree(volume) => (
            SOURCE_OCTREE,
            volume.dims,
            volume.depth,
            1.0,
            volume.uploaded_level,
            1,
            [1; 3],
        ),
    };
    let dims = dims.map(|d| d as u32);
    SliceParams {
        origin: vec4(settings.frame.origin),
        step_x: vec4(settings.frame.step_x),
        step_y: vec4(settings.frame.step_y),
        dims: [dims[0], dims[1], dims[2], depth],
        brick_grid: [brick_grid[0], brick_grid[1], brick_grid[2], 0],
        image_size: [target.width, target.height],
        source: kind,
        nearest: u32::from(
            settings.nearest || settings.colormap == Colormap::Labels || source.labels(),
        ),
        level_scale,
        deepest_level,
        brick_size,
        _pad: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn length(v: [f64; 3]) -> f64 {
        v.iter().map(|c| c * c).sum::<f64>().sqrt()
    }

    #[test]
    fn a_pixel_spans_as_many_millimetres_across_as_down() {
        let dims = [128, 128, 62];
        let spacing = [2.0, 2.0, 3.0];
        for convention in [SliceConvention::Radiological, SliceConvention::Image] {
            for axis in 0..3 {
                for target in [[300, 200], [120, 400], [1, 1]] {
                    let view = SliceView {
                        axis,
                        index: 10,
                        zoom: 1.7,
                        pan: [12.0, -5.0],
                    };
                    let frame = SliceFrame::axis_aligned(&view, convention, dims, spacing, target);
                    let mm = |step: [f64; 3]| length(std::array::from_fn(|a| step[a] * spacing[a]));
                    let (across, down) = (mm(frame.step_x), mm(frame.step_y));
                    assert!(
                        (across - down).abs() < 1e-12 * across,
                        "{convention:?} axis {axis} {target:?}: {across} mm across, {down} down"
                    );
                    assert_eq!(frame.step_x[axis], 0.0);
                    assert_eq!(frame.step_y[axis], 0.0);
                    assert_eq!(frame.origin[axis], 10.5, "the plane is at voxel centers");
                }
            }
        }
    }

    #[test]
    fn at_zoom_one_the_slice_fits_the_view_centered() {
        // Axial view of 2×2×3 mm voxels, 128×128 in plane (256 mm square), in 400×200 pixels:
        // the height limits it, 200 pixels for 256 mm.
        let dims = [128, 128, 62];
        let view = SliceView::new(2, 31);
        let frame = SliceFrame::axis_aligned(
            &view,
            SliceConvention::Radiological,
            dims,
            [2.0, 2.0, 3.0],
            [400, 200],
        );
        let center = frame.point_at([200.0, 100.0]);
        assert!((center[0] - 64.0).abs() < 1e-9 && (center[1] - 64.0).abs() < 1e-9);
        let top_edge = frame.point_at([200.0, 0.0]);
        assert!(
            (top_edge[1] - 128.0).abs() < 1e-9,
            "anterior edge at the top"
        );
        let left_edge = frame.point_at([100.0, 100.0]);
        assert!(
            (left_edge[0] - 128.0).abs() < 1e-9,
            "patient right at the left"
        );
    }

    #[test]
    fn radiological_views_put_right_left_anterior_and_superior_up() {
        let dims = [10, 20, 30];
        let labels = |axis| {
            let (frame, _) = SliceFrame::voxel_grid(SliceConvention::Radiological, axis, 0, dims);
            let l = frame.edge_labels(SliceConvention::Radiological);
            [l.left, l.right, l.top, l.bottom]
        };
        assert_eq!(labels(2), ["R", "L", "A", "P"], "axial");
        assert_eq!(labels(1), ["R", "L", "S", "I"], "coronal");
        assert_eq!(labels(0), ["A", "P", "S", "I"], "sagittal");
        let image = |axis| {
            let (frame, size) = SliceFrame::voxel_grid(SliceConvention::Image, axis, 0, dims);
            let l = frame.edge_labels(SliceConvention::Image);
            ([l.left, l.right, l.top, l.bottom], size)
        };
        assert_eq!(image(2), (["−x", "+x", "−y", "+y"], [10, 20]));
        // The side views stand +z up, as the 3D view does.
        assert_eq!(image(1), (["−x", "+x", "+z", "−z"], [10, 30]));
        assert_eq!(image(0), (["−y", "+y", "+z", "−z"], [20, 30]));
    }

    #[test]
    fn one_pixel_per_voxel_puts_voxel_centers_at_pixel_centers() {
        let dims = [7, 5, 3];
        let (frame, size) = SliceFrame::voxel_grid(SliceConvention::Radiological, 2, 1, dims);
        assert_eq!(size, [7, 5]);
        assert_eq!(frame.origin, [6.5, 4.5, 1.5]);
        assert_eq!(frame.step_x, [-1.0, 0.0, 0.0]);
        assert_eq!(frame.step_y, [0.0, -1.0, 0.0]);
        for row in 0..5 {
            for column in 0..7 {
                let pixel = [column as f64 + 0.5, row as f64 + 0.5];
                assert_eq!(
                    frame.voxel_at(pixel, dims),
                    Some([6 - column, 4 - row, 1]),
                    "pixel ({column}, {row})"
                );
                let corner = [column as f64 + 0.01, row as f64 + 0.99];
                assert_eq!(frame.voxel_at(corner, dims), Some([6 - column, 4 - row, 1]));
            }
        }
        assert_eq!(
            frame.voxel_at([-0.2, 2.0], dims),
            None,
            "left of the volume"
        );
        assert_eq!(frame.voxel_at([3.0, 5.1], dims), None, "below it");
    }

    #[test]
    fn pixel_of_inverts_point_at() {
        let view = SliceView {
            axis: 0,
            index: 3,
            zoom: 2.5,
            pan: [-7.0, 30.0],
        };
        let frame = SliceFrame::axis_aligned(
            &view,
            SliceConvention::Radiological,
            [40, 50, 60],
            [0.7, 1.1, 2.5],
            [320, 240],
        );
        for pixel in [[0.0, 0.0], [12.25, 200.5], [319.9, 3.0]] {
            let back = frame.pixel_of(frame.point_at(pixel));
            assert!(
                (back[0] - pixel[0]).abs() < 1e-9 && (back[1] - pixel[1]).abs() < 1e-9,
                "{pixel:?} → {back:?}"
            );
        }
        // A point off the plane projects onto it.
        let mut point = frame.point_at([100.0, 50.0]);
        point[0] += 4.0;
        let back = frame.pixel_of(point);
        assert!((back[0] - 100.0).abs() < 1e-9 && (back[1] - 50.0).abs() < 1e-9);
    }

    #[test]
    fn pan_moves_the_slice_with_the_pointer() {
        let dims = [64, 64, 64];
        let still = SliceView::new(2, 0);
        let moved = SliceView {
            pan: [10.0, -4.0],
            ..still
        };
        let conventions = [SliceConvention::Radiological, SliceConvention::Image];
        for convention in conventions {
            let a = SliceFrame::axis_aligned(&still, convention, dims, [1.0; 3], [100, 100]);
            let b = SliceFrame::axis_aligned(&moved, convention, dims, [1.0; 3], [100, 100]);
            let before = a.point_at([30.0, 40.0]);
            let after = b.point_at([40.0, 36.0]);
            for axis in 0..3 {
                assert!((before[axis] - after[axis]).abs() < 1e-9, "{convention:?}");
            }
        }
    }

    #[test]
    fn slice_colors_follow_the_window_and_are_opaque() {
        let quantization = Quantization {
            offset: -1024.0,
            step: 1.0,
        };
        let window = ValueWindow {
            low: -100.0,
            high: 300.0,
        };
        let table = slice_lookup_table(quantization, window, Colormap::Grays);
        let level = |value: f64| quantization.level(value) as usize;
        assert_eq!(table[level(-1024.0)], pack_rgba([0, 0, 0, 255]));
        assert_eq!(table[level(-100.0)], pack_rgba([0, 0, 0, 255]));
        assert_eq!(table[level(100.0)], pack_rgba([128, 128, 128, 255]));
        assert_eq!(table[level(300.0)], pack_rgba([255, 255, 255, 255]));
        assert_eq!(table[level(3000.0)], pack_rgba([255, 255, 255, 255]));
    }
}
