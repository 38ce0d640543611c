//! Building blocks shared by the compute pipelines: layout entries and pipeline creation.

use std::sync::OnceLock;

use super::GpuContext;

/// A uniform buffer entry visible to compute shaders.
pub(crate) fn uniform_entry(binding: u32, has_dynamic_offset: bool) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(
        binding,
        wgpu::BufferBindingType::Uniform,
        has_dynamic_offset,
    )
}

/// A storage buffer entry visible to compute shaders.
pub(crate) fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(
        binding,
        wgpu::BufferBindingType::Storage { read_only },
        false,
    )
}

fn buffer_entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
    has_dynamic_offset: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The write-only RGBA8 image every ray caster draws into.
pub(crate) fn output_image_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: super::RenderTarget::FORMAT,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

/// A bind group of `layout` whose entries are `resources`, bound at 0, 1, 2… in order (every
/// layout here numbers its bindings that way).
pub(crate) fn numbered_bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource<'_>],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
        .iter()
        .enumerate()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: binding as u32,
            resource: resource.clone(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// A compute pipeline of `source`'s `main` with one bind group of `entries`.
pub(crate) fn compute_pipeline(
    context: &GpuContext,
    label: &str,
    source: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
    let (mut pipelines, layout) = compute_pipelines(context, label, source, &["main"], entries);
    (pipelines.remove(0), layout)
}

/// One compute pipeline per entry point of `source`, all with one bind group of `entries`
/// (counted in [`GpuContext::pipelines_built`]).
pub(crate) fn compute_pipelines(
    context: &GpuContext,
    label: &str,
    source: &str,
    entry_points: &[&str],
    entries: &[wgpu::BindGroupLayoutEntry],
) -> (Vec<wgpu::ComputePipeline>, wgpu::BindGroupLayout) {
    let device = &context.device;
    context.pipelines.count_built(entry_points.len());
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(&format!("voxscope::{label}.wgsl")),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("voxscope::{label}_layout")),
        entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(&format!("voxscope::{label}_pipeline_layout")),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipelines = entry_points
        .iter()
        .map(|entry_point| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&format!("voxscope::{label}_{entry_point}_pipeline")),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        })
        .collect();
    (pipelines, layout)
}

/// A variant of a ray caster's entry point, chosen by the WGSL `override` constants of
/// `ray_common.wgsl`: each is its own pipeline, so the code a variant does not use is compiled
/// out of the others. The plain variant (none of them) is the ray caster as it was before
/// shading, probing and clipping existed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Variant {
    /// DVR with headlight shading (`SHADING`).
    pub shaded: bool,
    /// One ray that reports its probed point instead of drawing (`PROBE`).
    pub probe: bool,
    /// Rays cut to the crop box and clip plane (`CLIP`).
    pub clipped: bool,
    /// A pyramid level coarser than full detail is sampled (`COARSE`: dense and bricks below
    /// full detail; `sample_voxels` > 1).
    pub coarse: bool,
    /// The values are labels (`LABELS`): samples meet the voxels the ray enters between them
    /// (`label_entry`), undithered. Its own pipeline, so that the other volumes' pipelines
    /// carry none of its code (carried in all of them, the bricks renderer's frames took 5–7 %
    /// longer on an H200, run 148).
    pub labels: bool,
}

impl Variant {
    /// Unshaded, drawing, unclipped.
    pub const PLAIN: Self = Self {
        shaded: false,
        probe: false,
        clipped: false,
        coarse: false,
        labels: false,
    };

    const COUNT: usize = 32;

    /// The override constants that select this variant (the others keep their defaults).
    fn constants(self) -> Vec<(&'static str, f64)> {
        [
            (self.shaded, "SHADING"),
            (self.probe, "PROBE"),
            (self.clipped, "CLIP"),
            (self.coarse, "COARSE"),
            (self.labels, "LABELS"),
        ]
        .into_iter()
        .filter(|&(on, _)| on)
        .map(|(_, name)| (name, 1.0))
        .collect()
    }

    fn index(self) -> usize {
        self.shaded as usize
            | (self.probe as usize) << 1
            | (self.clipped as usize) << 2
            | (self.coarse as usize) << 3
            | (self.labels as usize) << 4
    }

    /// `plain`, or the constants set, in pipeline labels.
    fn name(self) -> String {
        let constants = self.constants();
        if constants.is_empty() {
            return "plain".into();
        }
        let names: Vec<String> = constants
            .iter()
            .map(|(name, _)| name.to_lowercase())
            .collect();
        names.join("_")
    }
}

/// The variants of a shader's entry points, sharing one module and layout; each pipeline is
/// built the first time it is asked for (counted in [`GpuContext::pipelines_built`]).
pub(crate) struct VariantPipelines {
    label: &'static str,
    module: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    entry_points: &'static [&'static str],
    /// Per entry point, per [`Variant`].
    pipelines: Vec<[OnceLock<wgpu::ComputePipeline>; Variant::COUNT]>,
}

impl VariantPipelines {
    /// The module of `source` and a layout of one bind group of `entries`; builds the plain
    /// variant of every entry point now (the others wait for their first use).
    pub(crate) fn new(
        context: &GpuContext,
        label: &'static str,
        source: &str,
        entry_points: &'static [&'static str],
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> (Self, wgpu::BindGroupLayout) {
        let device = &context.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&format!("voxscope::{label}.wgsl")),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(&format!("voxscope::{label}_layout")),
            entries,
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&format!("voxscope::{label}_pipeline_layout")),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let pipelines = entry_points
            .iter()
            .map(|_| std::array::from_fn(|_| OnceLock::new()))
            .collect();
        let variants = Self {
            label,
            module,
            layout,
            entry_points,
            pipelines,
        };
        for entry in 0..entry_points.len() {
            variants.get(context, entry, Variant::PLAIN);
        }
        (variants, bind_group_layout)
    }

    /// The pipeline of entry point number `entry` (in the list given to [`Self::new`]) in
    /// `variant`, built on first use.
    pub(crate) fn get(
        &self,
        context: &GpuContext,
        entry: usize,
        variant: Variant,
    ) -> &wgpu::ComputePipeline {
        self.pipelines[entry][variant.index()].get_or_init(|| {
            context.pipelines.count_built(1);
            let entry_point = self.entry_points[entry];
            let constants = variant.constants();
            context
                .device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(&format!(
                        "voxscope::{}_{entry_point}_{}_pipeline",
                        self.label,
                        variant.name()
                    )),
                    layout: Some(&self.layout),
                    module: &self.module,
                    entry_point: Some(entry_point),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        ..Default::default()
                    },
                    cache: None,
                })
        })
    }
}

/// Pixels per workgroup side; keep in sync with `@workgroup_size` in `raycast.wgsl` and
/// `dense.wgsl`.
const WORKGROUP_SIDE: u32 = 8;

/// Records one compute pass running `pipeline` once per pixel of `target`.
pub(crate) fn dispatch_per_pixel(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    target: &super::RenderTarget,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    dispatch(
        encoder,
        label,
        pipeline,
        bind_group,
        [
            target.width.div_ceil(WORKGROUP_SIDE),
            target.height.div_ceil(WORKGROUP_SIDE),
        ],
        timestamp_writes,
    );
}

/// Records one compute pass of a per-pixel pipeline over `region` of the image (its first
/// pixel is `params.tile`'s; `ray_pixel` in ray_common.wgsl adds it).
pub(crate) fn dispatch_region(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    region: super::ImageRegion,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    dispatch(
        encoder,
        label,
        pipeline,
        bind_group,
        [
            region.size[0].div_ceil(WORKGROUP_SIDE),
            region.size[1].div_ceil(WORKGROUP_SIDE),
        ],
        timestamp_writes,
    );
}

/// Records one compute pass of a probe pipeline: one workgroup, whose first invocation traces
/// the probed pixel (`ray_pixel` in `ray_common.wgsl`).
pub(crate) fn dispatch_probe(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
) {
    dispatch(encoder, label, pipeline, bind_group, [1, 1], None);
}

fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    workgroups: [u32; 2],
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(&format!("voxscope::{label}_pass")),
        timestamp_writes,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.dispatch_workgroups(workgroups[0], workgroups[1], 1);
}

/// A filterable 3D float texture (the dense volume, the brick atlas).
pub(crate) fn atlas_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    }
}

/// A filtering sampler entry.
pub(crate) fn atlas_sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// A sampler that clamps to the edge and filters with `filter`.
pub(crate) fn clamped_sampler(
    device: &wgpu::Device,
    filter: wgpu::FilterMode,
    label: &str,
) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: filter,
        min_filter: filter,
        ..Default::default()
    })
}
