//! The streaming ray caster: its pipelines and bind groups, and the level walk or segment
//! walk each frame takes.

use super::*;

/// The streaming ray caster's pipelines (plain, shaded, probe, clipped variants), one per
/// device ([`GpuContext::stream_raycaster`]).
pub struct StreamRaycaster {
    pipelines: VariantPipelines,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// For labels, or with trilinear filtering off.
    nearest: wgpu::Sampler,
    stand_ins: StandIns,
}

impl StreamRaycaster {
    /// Builds the plain pipeline; [`GpuContext::stream_raycaster`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let (pipelines, layout) = VariantPipelines::new(
            context,
            "stream",
            crate::shaders::STREAM,
            &["main", "main_level", "main_levels"],
            &layout_entries(),
        );
        Self {
            pipelines,
            layout,
            sampler: clamped_sampler(
                &context.device,
                wgpu::FilterMode::Linear,
                "voxscope::stream_sampler",
            ),
            nearest: clamped_sampler(
                &context.device,
                wgpu::FilterMode::Nearest,
                "voxscope::stream_nearest",
            ),
            stand_ins: StandIns::new(context),
        }
    }

    /// Builds, where not built yet, the pipelines of `variant`: the segment loop's, and the
    /// level walk's where frames of `variant` may walk (not probes; `level_walk` on).
    pub(crate) fn prepare(&self, context: &GpuContext, variant: Variant, level_walk: bool) {
        self.pipelines.get(context, SEGMENTS, variant);
        if level_walk && !variant.probe {
            self.pipelines.get(context, LEVEL_WALK, variant);
            self.pipelines.get(context, LEVELS_WALK, variant);
        }
    }
}

impl RayPass<StreamVolume> for StreamRaycaster {
    const NAME: &'static str = "stream";

    fn pipelines(&self) -> &VariantPipelines {
        &self.pipelines
    }

    fn stand_ins(&self) -> &StandIns {
        &self.stand_ins
    }

    /// The level walk where every ray wants one level and the table can show that the walk
    /// takes each of its bricks ([`StreamVolume::walked_level`]), else segment by segment.
    fn entry_point(&self, volume: &StreamVolume, params: &RaycastParams) -> usize {
        match volume.walked_level(params) {
            Some(walk) if walk.two => LEVELS_WALK,
            Some(_) => LEVEL_WALK,
            None => SEGMENTS,
        }
    }

    /// Segment by segment: the level walk draws frames only.
    fn probe_entry_point(&self, _volume: &StreamVolume, _params: &RaycastParams) -> usize {
        SEGMENTS
    }

    /// Each segment picks its own level from the page table: no coarse variant; the `LABELS`
    /// one for a label volume.
    fn variant(&self, base: Variant, params: &RaycastParams) -> Variant {
        Variant {
            labels: params.flags & FLAG_LABELS != 0,
            ..base
        }
    }

    /// Notes the camera (the load order follows it) and that a frame was drawn (its requests
    /// are read back). Probes ask for nothing.
    fn before_frame(&self, volume: &StreamVolume, params: &RaycastParams) {
        note_view(volume, params);
        // Panes of different max levels on one volume want different levels: two adjacent
        // ones are copied together, else none (copying each in turn would rebuild the copy at
        // every step).
        let wanted = volume.walk_level(params).map_or(NO_LEVEL, WalkLevels::code);
        let _ = volume
            .walk_wanted
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |drawn| match drawn {
                NOT_DRAWN => Some(wanted),
                same if same == wanted => None,
                NO_LEVEL => None,
                _ if wanted == NO_LEVEL => Some(NO_LEVEL),
                other => Some(
                    WalkLevels::from_code(other)
                        .union(WalkLevels::from_code(wanted))
                        .map_or(NO_LEVEL, WalkLevels::code),
                ),
            });
        if volume.walked_level(params).is_some() {
            volume.walked_frames.fetch_add(1, Ordering::Relaxed);
            volume
                .walk_drew
                .store(volume.streamer.frame(), Ordering::Release);
        }
        volume.drawn.store(true, Ordering::Release);
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &StreamVolume,
        params: &RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let sampler = if volume.filters(settings) {
            &self.sampler
        } else {
            &self.nearest
        };
        let bound = Bound {
            layout: &self.layout,
            sampler,
            lookup_table: &volume.transfer.buffer,
        };
        bind_group(context, bound, volume, params, target, probe)
    }
}

/// Notes the camera of a frame of `params` (the load order follows it), whether it takes the
/// maximum, and that a frame was drawn (its requests are read back).
pub(super) fn note_view(volume: &StreamVolume, params: &RaycastParams) {
    let forward = glam::Vec3::from_slice(&params.forward[..3]);
    // The image's half width and height (`params.right` and `params.up`: voxel space,
    // against the forward direction there), to the unit forward direction: its frustum.
    let scale = 1.0 / f64::from(forward.length()).max(1e-12);
    let extent =
        [&params.right, &params.up].map(|v| [v[0], v[1], v[2]].map(|c| f64::from(c) * scale));
    let forward = forward.normalize_or_zero();
    *volume.view.lock().unwrap_or_else(|p| p.into_inner()) = Some(ViewPoint {
        eye: [params.eye[0], params.eye[1], params.eye[2]].map(f64::from),
        forward: forward.to_array().map(f64::from),
        extent: Some(extent),
    });
    volume
        .max_projection
        .store(max_projection(params), Ordering::Release);
}

/// What differs between the streaming passes' bind groups: the layout, the sampler, and the
/// lookup tables (one transfer function's, or the composite's channels').
pub(super) struct Bound<'a> {
    pub layout: &'a wgpu::BindGroupLayout,
    pub sampler: &'a wgpu::Sampler,
    pub lookup_table: &'a wgpu::Buffer,
}

/// The streaming passes' bind group layout (`stream_common.wgsl`'s bindings).
pub(super) fn layout_entries() -> [wgpu::BindGroupLayoutEntry; 12] {
    [
        uniform_entry(0, false),
        uniform_entry(1, false),
        storage_entry(2, true),
        output_image_entry(3),
        storage_entry(4, false),
        atlas_entry(5),
        atlas_sampler_entry(6),
        storage_entry(7, true),
        storage_entry(8, false),
        storage_entry(9, false),
        storage_entry(10, false),
        storage_entry(11, true),
    ]
}

/// The bind group of one streaming pass over `volume`.
pub(super) fn bind_group(
    context: &GpuContext,
    bound: Bound<'_>,
    volume: &StreamVolume,
    params: &RaycastParams,
    target: &RenderTarget,
    probe: &wgpu::Buffer,
) -> wgpu::BindGroup {
    let device = &context.device;
    let Bound {
        layout,
        sampler,
        lookup_table,
    } = bound;
    let params_buffer = frame_params_buffer(context, "voxscope::stream_params", params);
    let stream_params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("voxscope::stream_level_params"),
        contents: bytemuck::bytes_of(&volume.stream_params(params)),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    numbered_bind_group(
        device,
        "voxscope::stream_bind_group",
        layout,
        &[
            params_buffer.as_entire_binding(),
            stream_params.as_entire_binding(),
            lookup_table.as_entire_binding(),
            wgpu::BindingResource::TextureView(&target.view),
            target.visits.as_entire_binding(),
            wgpu::BindingResource::TextureView(&volume.atlas_view),
            wgpu::BindingResource::Sampler(sampler),
            volume.table.as_entire_binding(),
            volume.requests.as_entire_binding(),
            volume.usage.as_entire_binding(),
            probe.as_entire_binding(),
            volume.level_cells.as_entire_binding(),
        ],
    )
}
