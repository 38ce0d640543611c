//! The compute pipeline that ray-casts a [`GpuVolume`] into a texture.

use glam::DVec3;

use super::gpu_data::{
    FLAG_HEATMAP, FLAG_LABELS, FLAG_OPACITY_CORRECTION, FLAG_PIXEL_LOD, MODE_DVR, MODE_MIP,
    ProbeResult, RaycastParams,
};
use super::pipeline::{
    Variant, VariantPipelines, atlas_entry, atlas_sampler_entry, clamped_sampler, dispatch_probe,
    dispatch_region, numbered_bind_group, output_image_entry, storage_entry, uniform_entry,
};
use super::settings::GRADIENT_FOR_FULL_SHADING;
use super::{Camera, GpuContext, GpuVolume, ImageRegion, RenderMode, RenderSettings, Shading};

/// Where a frame goes: an RGBA8 storage texture and the per-pixel count of nodes visited.
pub struct RenderTarget {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    /// One `u32` per pixel: nodes its ray visited.
    pub visits: wgpu::Buffer,
    pub width: u32,
    pub height: u32,
    /// Where it lies in the image it is part of: its first pixel (`[0, 0]` but for a tile).
    pub origin: [u32; 2],
    /// The whole image's size (its own but for a tile).
    pub image: [u32; 2],
}

impl RenderTarget {
    /// The texture format the ray caster writes.
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

    /// A target of `width`×`height` pixels (each at least 1).
    pub fn new(context: &GpuContext, width: u32, height: u32) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let texture = context.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("voxscope::raycast_target"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: Self::FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let visits = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::raycast_visits"),
            size: (width as u64 * height as u64 * 4).max(4),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Self {
            texture,
            view,
            visits,
            width,
            height,
            origin: [0, 0],
            image: [width, height],
        }
    }

    /// A target of `size` pixels that holds the part at `origin` of an image of `image`
    /// pixels: its rays are those of the whole image's pixels, so tiles drawn one by one make
    /// the image a target of the whole size would (a still larger than the device's largest
    /// texture or storage buffer).
    pub fn tile(context: &GpuContext, size: [u32; 2], origin: [u32; 2], image: [u32; 2]) -> Self {
        Self {
            origin,
            image,
            ..Self::new(context, size[0], size[1])
        }
    }

    /// Bytes on the GPU.
    pub fn gpu_bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * 4 + self.visits.size()
    }
}

/// What one frame draws, where, and how: the per-frame half of rendering (the pipelines live
/// in [`Raycaster`] and [`super::DenseRaycaster`]).
pub struct Frame<'a, V = GpuVolume> {
    pub volume: &'a V,
    pub target: &'a RenderTarget,
    pub camera: &'a Camera,
    pub settings: &'a RenderSettings,
}

impl<V> Clone for Frame<'_, V> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<V> Copy for Frame<'_, V> {}

/// What the ray casters' shared parameters need to know of a volume on the GPU.
pub trait VolumeShape {
    /// Voxels along x, y, z.
    fn dims(&self) -> [usize; 3];
    /// Physical voxel size along x, y, z.
    fn spacing(&self) -> [f64; 3];
    /// Octree depth (0 where there is no octree).
    fn depth(&self) -> u32;
    /// Deepest level a ray may descend to.
    fn level_cap(&self) -> u32;
    /// Value level at which a MIP ray may stop.
    fn mip_saturation(&self) -> u16;
    /// The transfer window's width in value levels (shading measures gradients against it).
    fn window_levels(&self) -> f32;
    /// Whether the values are labels (categories): sampled at the nearest voxel whatever the
    /// settings' filtering (a value between two labels is a third, unrelated one), and MIP
    /// draws the first visible label along a ray.
    fn labels(&self) -> bool {
        false
    }
    /// Whether frames sample with trilinear filtering under `settings`: where asked, and never
    /// for labels.
    fn filters(&self, settings: &RenderSettings) -> bool {
        settings.trilinear && !self.labels()
    }
    /// Where brick leaves are, if any.
    fn bricks(&self) -> Option<BrickShape> {
        None
    }
    /// Texel value × this = value level, for the volume's level texture (if it has one).
    fn level_scale(&self) -> f32 {
        self.bricks().map_or(1.0, |b| b.atlas_scale)
    }
    /// The pyramid level that frames of max level `max_level` sample (each of its voxels
    /// 2^level level-0 voxels a side): `depth − max_level` where the renderer draws a level
    /// finer than its nodes from a pyramid of its own (dense, and bricks below the brick
    /// level), 0 for full detail or where the octree's nodes are drawn.
    fn sampled_level(&self, _max_level: u32) -> u32 {
        0
    }
    /// The size in texels of the texture of values bound for pyramid level `level` (the dense
    /// volume's texture of that level, the bricks' atlas of it), if the volume has one.
    fn level_texels(&self, level: u32) -> Option<[usize; 3]> {
        let bricks = self.bricks().filter(|_| level == 0)?;
        Some(
            bricks
                .atlas_grid
                .map(|g| g as usize * (bricks.size as usize + 2)),
        )
    }
}

/// Brick leaves of a volume on the GPU, as the shader needs them.
#[derive(Debug, Clone, Copy)]
pub struct BrickShape {
    pub level: u32,
    pub size: u32,
    /// Atlas texel value × this = value level.
    pub atlas_scale: f32,
    pub atlas_grid: [u32; 3],
    /// Brick cells along x, y, z of the volume.
    pub grid: [u32; 3],
}

/// An octree on the GPU that [`Raycaster`] can draw: plain ([`GpuVolume`]) or with brick
/// leaves ([`super::GpuBricks`]).
pub trait OctreeOnGpu: VolumeShape {
    fn nodes(&self) -> &wgpu::Buffer;
    fn bounds(&self) -> &wgpu::Buffer;
    fn lookup_table(&self) -> &wgpu::Buffer;
    /// The brick atlas, if there are bricks.
    fn atlas(&self) -> Option<&wgpu::TextureView>;
    /// The texture that frames sampling pyramid level `level` bind
    /// ([`VolumeShape::sampled_level`]): the brick atlas at full detail, the level's own
    /// texture below the bricks.
    fn sampled_texture(&self, level: u32) -> Option<&wgpu::TextureView> {
        self.atlas().filter(|_| level == 0)
    }
    /// The grid of brick cells (`GridCell`s), if there are bricks.
    fn brick_grid(&self) -> Option<&wgpu::Buffer> {
        None
    }
}

impl OctreeOnGpu for GpuVolume {
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
        None
    }
}

impl VolumeShape for GpuVolume {
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
        self.uploaded_level
    }
    fn mip_saturation(&self) -> u16 {
        self.transfer.mip_saturation()
    }
    fn window_levels(&self) -> f32 {
        self.transfer.window_levels()
    }
    fn labels(&self) -> bool {
        self.labels
    }
}

/// The entry points of `raycast.wgsl`, in the order [`VariantPipelines`] numbers them.
const TREE_WALK: usize = 0;
const GRID_WALK: usize = 1;

/// The ray-casting compute pipelines: `main` descends the tree (plain octrees, and bricks when a
/// level cut or the pixel LOD may stop above them); `main_bricks` walks the brick grid. Each in
/// variants ([`Variant`]: shaded, probe, clipped), the plain ones built with the ray caster and
/// the others on first use. One per device ([`GpuContext::raycaster`]), shared by the octree
/// and bricks renderers of every volume.
pub struct Raycaster {
    pipelines: VariantPipelines,
    layout: wgpu::BindGroupLayout,
    /// Bound where a volume has no brick atlas.
    no_atlas: wgpu::TextureView,
    /// Bound where a volume has no brick grid.
    no_grid: wgpu::Buffer,
    atlas_sampler: wgpu::Sampler,
    /// The bricks of a label volume, or with trilinear filtering off.
    nearest_sampler: wgpu::Sampler,
    /// Bound where nothing is probed, and bound as the image of a probe (which draws nothing).
    stand_ins: StandIns,
}

/// Small resources bound where a pass does not use a binding: a probe result where a frame is
/// drawn, an image where a probe is traced.
pub(crate) struct StandIns {
    pub probe: wgpu::Buffer,
    pub target: RenderTarget,
}

impl StandIns {
    pub(crate) fn new(context: &GpuContext) -> Self {
        Self {
            probe: context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("voxscope::no_probe"),
                size: std::mem::size_of::<ProbeResult>() as u64,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }),
            target: RenderTarget::new(context, 1, 1),
        }
    }
}

/// The variant that draws a frame with `settings`.
pub(crate) fn frame_variant(settings: &RenderSettings) -> Variant {
    Variant {
        shaded: Shading::applies(settings),
        clipped: settings.clip.is_active(),
        ..Variant::PLAIN
    }
}

/// `variant` for a frame of `params`: the `COARSE` one where it samples a coarser pyramid
/// level (so a full-detail frame runs the code of before levels had pyramids, pow for pow),
/// the `LABELS` one for a label volume.
pub(crate) fn level_variant(variant: Variant, params: &RaycastParams) -> Variant {
    Variant {
        coarse: params.sample_voxels > 1.0,
        labels: params.flags & FLAG_LABELS != 0,
        ..variant
    }
}

/// The variant that probes a pixel of a frame with `settings`.
pub(crate) fn probe_variant(settings: &RenderSettings) -> Variant {
    Variant {
        probe: true,
        clipped: settings.clip.is_active(),
        ..Variant::PLAIN
    }
}

impl Raycaster {
    /// Builds the plain pipelines; [`GpuContext::raycaster`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let device = &context.device;
        let (pipelines, layout) = VariantPipelines::new(
            context,
            "raycast",
            super::shaders::RAYCAST,
            &["main", "main_bricks"],
            &[
                uniform_entry(0, false),
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, true),
                output_image_entry(4),
                storage_entry(5, false),
                atlas_entry(6),
                atlas_sampler_entry(7),
                storage_entry(8, true),
                storage_entry(9, false),
            ],
        );
        let no_grid = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::no_brick_grid"),
            size: std::mem::size_of::<super::gpu_data::GridCell>() as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let no_atlas = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("voxscope::no_atlas"),
                size: wgpu::Extent3d {
                    width: 1,
                    height: 1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R16Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&wgpu::TextureViewDescriptor::default());
        let atlas_sampler =
            clamped_sampler(device, wgpu::FilterMode::Linear, "voxscope::atlas_sampler");
        let nearest_sampler =
            clamped_sampler(device, wgpu::FilterMode::Nearest, "voxscope::atlas_nearest");
        Self {
            pipelines,
            layout,
            no_atlas,
            no_grid,
            atlas_sampler,
            nearest_sampler,
            stand_ins: StandIns::new(context),
        }
    }

    /// Builds, where not built yet, the pipelines of `variant` (both entry points), so that a
    /// caller can compile them off the frame path (the app's loading thread).
    pub(crate) fn prepare(&self, context: &GpuContext, variant: Variant) {
        for entry in [TREE_WALK, GRID_WALK] {
            self.pipelines.get(context, entry, variant);
        }
    }
}

impl<V: OctreeOnGpu> RayPass<V> for Raycaster {
    const NAME: &'static str = "raycast";

    fn pipelines(&self) -> &VariantPipelines {
        &self.pipelines
    }

    fn stand_ins(&self) -> &StandIns {
        &self.stand_ins
    }

    /// The grid walk for bricks when nothing may stop above them (it holds the brick level
    /// alone; at the brick level itself the bricks' nodes are drawn, a voxel a brick), else
    /// the tree walk.
    fn entry_point(&self, volume: &V, params: &RaycastParams) -> usize {
        let walk_bricks = volume.bricks().is_some_and(|b| params.max_level > b.level)
            && params.flags & FLAG_PIXEL_LOD == 0;
        if walk_bricks { GRID_WALK } else { TREE_WALK }
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &V,
        params: &RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let params_buffer = frame_params_buffer(context, "voxscope::raycast_params", params);
        let sampler = if volume.filters(settings) {
            &self.atlas_sampler
        } else {
            &self.nearest_sampler
        };
        numbered_bind_group(
            &context.device,
            "voxscope::raycast_bind_group",
            &self.layout,
            &[
                params_buffer.as_entire_binding(),
                volume.nodes().as_entire_binding(),
                volume.bounds().as_entire_binding(),
                volume.lookup_table().as_entire_binding(),
                wgpu::BindingResource::TextureView(&target.view),
                target.visits.as_entire_binding(),
                wgpu::BindingResource::TextureView(
                    volume
                        .sampled_texture(volume.sampled_level(params.max_level))
                        .unwrap_or(&self.no_atlas),
                ),
                wgpu::BindingResource::Sampler(sampler),
                volume
                    .brick_grid()
                    .unwrap_or(&self.no_grid)
                    .as_entire_binding(),
                probe.as_entire_binding(),
            ],
        )
    }
}

/// What differs between the ray casters (octree and bricks, dense, streaming, composite): the
/// pipelines, the entry point and variant a frame runs, how a volume binds. [`encode_frame`]
/// and [`encode_probe_ray`] record the rest, the same for every one.
pub(crate) trait RayPass<V: VolumeShape> {
    /// The pass's name in labels (`raycast`).
    const NAME: &'static str;

    fn pipelines(&self) -> &VariantPipelines;

    /// What is bound where a pass does not use a binding.
    fn stand_ins(&self) -> &StandIns;

    /// The entry point that draws `volume` with `params`.
    fn entry_point(&self, _volume: &V, _params: &RaycastParams) -> usize {
        0
    }

    /// The entry point that probes a pixel of a frame of `volume` with `params` (one ray).
    fn probe_entry_point(&self, volume: &V, params: &RaycastParams) -> usize {
        self.entry_point(volume, params)
    }

    /// The variant of `base` that frames of `params` run: the `COARSE` one where they sample
    /// a coarser pyramid level ([`level_variant`]).
    fn variant(&self, base: Variant, params: &RaycastParams) -> Variant {
        level_variant(base, params)
    }

    /// What happens on the CPU as a frame of `volume` with `params` is recorded (the streaming
    /// renderer notes where the camera is).
    fn before_frame(&self, _volume: &V, _params: &RaycastParams) {}

    /// The bind group of one pass: `params` in a buffer of its own, `volume`, the image
    /// `target` and the probe's answer `probe`.
    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &V,
        params: &RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup;
}

/// Records one frame of `frame.volume` with `pass` into `encoder`, its parameters in a buffer
/// of its own.
pub(crate) fn encode_frame<V: VolumeShape, P: RayPass<V>>(
    pass: &P,
    context: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    frame: &Frame<'_, V>,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    let whole = ImageRegion::whole(frame.target.width, frame.target.height);
    encode_frame_region(pass, context, encoder, frame, whole, timestamp_writes);
}

/// Records the pixels `region` of one frame of `frame.volume` with `pass` into `encoder` (the
/// rest of the target keeps what it holds), its parameters in a buffer of its own.
pub(crate) fn encode_frame_region<V: VolumeShape, P: RayPass<V>>(
    pass: &P,
    context: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    frame: &Frame<'_, V>,
    region: ImageRegion,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    let Frame {
        volume,
        target,
        camera,
        settings,
    } = *frame;
    let mut params = raycast_params(volume, target.image, camera, settings);
    let [x0, y0, x1, y1] = region.bounds();
    let [ox, oy] = target.origin;
    params.tile = [x0 + ox, y0 + oy, x1 + ox, y1 + oy];
    params.placement = [ox, oy, target.width, 0];
    pass.before_frame(volume, &params);
    let bind_group = pass.bind_group(
        context,
        volume,
        &params,
        settings,
        target,
        &pass.stand_ins().probe,
    );
    let pipeline = pass.pipelines().get(
        context,
        pass.entry_point(volume, &params),
        pass.variant(frame_variant(settings), &params),
    );
    dispatch_region(
        encoder,
        P::NAME,
        pipeline,
        &bind_group,
        region,
        timestamp_writes,
    );
}

/// Records the probe of pixel `probe.pixel` of an image of `probe.size` (the frame that its
/// camera and settings would draw there) with `pass` into `encoder`: one ray, whose
/// [`ProbeResult`] goes to `probe.output` (STORAGE, 16 bytes). Draws nothing.
pub(crate) fn encode_probe_ray<V: VolumeShape, P: RayPass<V>>(
    pass: &P,
    context: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    volume: &V,
    probe: &ProbeTarget<'_>,
) {
    let mut params = raycast_params(volume, probe.size, probe.camera, probe.settings);
    params.probe_pixel = probe.pixel;
    let bind_group = pass.bind_group(
        context,
        volume,
        &params,
        probe.settings,
        &pass.stand_ins().target,
        probe.output,
    );
    let pipeline = pass.pipelines().get(
        context,
        pass.probe_entry_point(volume, &params),
        pass.variant(probe_variant(probe.settings), &params),
    );
    dispatch_probe(
        encoder,
        &format!("{}_probe", P::NAME),
        pipeline,
        &bind_group,
    );
}

/// Where and what a probe traces: pixel `pixel` of an image of `size` drawn with `camera` and
/// `settings`, its answer written to `output`.
pub struct ProbeTarget<'a> {
    pub size: [u32; 2],
    pub pixel: [u32; 2],
    pub camera: &'a Camera,
    pub settings: &'a RenderSettings,
    pub output: &'a wgpu::Buffer,
}

/// A uniform buffer holding one frame's `params`: one per recorded frame, so nothing shared is
/// written between frames. (272 bytes, created with its contents: no queue write to order.)
pub(crate) fn frame_params_buffer(
    context: &GpuContext,
    label: &str,
    params: &RaycastParams,
) -> wgpu::Buffer {
    wgpu::util::DeviceExt::create_buffer_init(
        &context.device,
        &wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        },
    )
}

/// The camera and settings in the shader's voxel space, for an image of `size` pixels.
pub(crate) fn raycast_params(
    volume: &impl VolumeShape,
    size: [u32; 2],
    camera: &Camera,
    settings: &RenderSettings,
) -> RaycastParams {
    let [width, height] = size;
    let spacing = DVec3::from(volume.spacing());
    let dims = DVec3::new(
        volume.dims()[0] as f64,
        volume.dims()[1] as f64,
        volume.dims()[2] as f64,
    );
    let extent = dims * spacing;
    let frame = camera.frame(extent.to_array(), width as f64 / height as f64);
    // World (centered, physical) to voxel space: shift by half the extent, divide by spacing.
    let to_voxel_point = |p: DVec3| (p + extent * 0.5) / spacing;
    let to_voxel_vector = |v: DVec3| v / spacing;
    let tan_x = frame.tan_half_fov_y * frame.aspect;
    let tan_y = frame.tan_half_fov_y;
    let vec4 = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
    let smallest_spacing = spacing.min_element();
    let pixel_angle = 2.0 * tan_y / height as f64;
    let bricks = volume.bricks();
    let mut flags = 0;
    if settings.opacity_correction {
        flags |= FLAG_OPACITY_CORRECTION;
    }
    if settings.pixel_lod {
        flags |= FLAG_PIXEL_LOD;
    }
    if settings.heatmap {
        flags |= FLAG_HEATMAP;
    }
    if volume.labels() {
        flags |= FLAG_LABELS;
    }
    // Clipping, from normalized volume coordinates to voxel space (p_voxel = p · dims).
    let box_fractions = settings.clip.box_fractions();
    let corner = |side: usize| -> [f32; 4] {
        let at = |axis: usize| (box_fractions[axis][side] as f64 * dims[axis]) as f32;
        [at(0), at(1), at(2), 0.0]
    };
    let clip_plane = match settings.clip.plane {
        Some(plane) => {
            let n = plane.normal;
            [
                (n[0] as f64 / dims.x) as f32,
                (n[1] as f64 / dims.y) as f32,
                (n[2] as f64 / dims.z) as f32,
                plane.distance,
            ]
        }
        None => [0.0, 0.0, 0.0, -1.0],
    };
    let shading = settings.shading;
    let to_world = spacing.min_element() / spacing;
    let max_level = settings.max_level.min(volume.level_cap());
    let sampled_level = volume.sampled_level(max_level);
    let sample_voxels = (1u64 << sampled_level) as f32;
    RaycastParams {
        eye: vec4(to_voxel_point(frame.eye), 0.0),
        forward: vec4(to_voxel_vector(frame.forward), 0.0),
        right: vec4(to_voxel_vector(frame.right * tan_x), tan_x),
        up: vec4(to_voxel_vector(frame.up * tan_y), tan_y),
        volume: vec4(dims, (1u64 << volume.depth()) as f64),
        image_size: [width, height],
        depth: volume.depth(),
        max_level,
        mode: match settings.mode {
            RenderMode::Dvr => MODE_DVR,
            RenderMode::Mip => MODE_MIP,
        },
        flags,
        density: settings.density.max(0.0),
        lod_factor: (pixel_angle / smallest_spacing) as f32,
        mip_saturation: volume.mip_saturation() as u32,
        brick_level: bricks.map_or(u32::MAX, |b| b.level),
        brick_size: bricks.map_or(1, |b| b.size),
        atlas_scale: volume.level_scale(),
        atlas_grid: bricks.map_or([1; 4], |b| {
            [b.atlas_grid[0], b.atlas_grid[1], b.atlas_grid[2], 0]
        }),
        brick_grid: bricks.map_or([1, 1, 1, 0], |b| [b.grid[0], b.grid[1], b.grid[2], 0]),
        atlas_texel: volume
            .level_texels(sampled_level)
            .map_or([1.0, 1.0, 1.0, 0.0], |texels| {
                let texel = |axis: usize| 1.0 / (texels[axis] as f32 * sample_voxels);
                [texel(0), texel(1), texel(2), 0.0]
            }),
        clip_low: corner(0),
        clip_high: corner(1),
        clip_plane,
        shading: [
            shading.ambient,
            shading.diffuse,
            shading.specular,
            shading.shininess.max(0.0),
        ],
        shading_scale: [
            to_world.x as f32,
            to_world.y as f32,
            to_world.z as f32,
            1.0 / (volume.window_levels() * GRADIENT_FOR_FULL_SHADING),
        ],
        probe_pixel: [0, 0],
        sample_voxels,
        _sample_pad: 0,
        tile: [0, 0, width, height],
        placement: [0, 0, width, 0],
    }
}
