//! The long-lived half of rendering: compute pipelines, their bind group layouts, samplers and
//! stand-in resources, built once per device and shared by every volume, renderer and pane
//! drawn with it (re_renderer's `ctx.renderer::<T>()`, egui's custom 3D demo). Each family is
//! built on first use, so a device that never draws `dense` never compiles it; volumes hold
//! only their buffers and textures, and opening a file or switching renderers compiles nothing
//! that was compiled before.
//!
//! Owned by [`GpuContext`], so the app's context (from egui-wgpu's device) and the command
//! line's headless one both have it. Nothing here changes per frame: each frame's parameters
//! go in a buffer of that frame's own ([`super::Raycaster::encode`]), so frames of several
//! panes and volumes can be recorded into one encoder.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::atlas_scatter::{self, AtlasScatter};
use super::{
    CompositeRaycaster, DenseRaycaster, GpuBrickRecolor, GpuContext, GpuRecolor, Raycaster,
    RendererKind, Slicer, StreamCompositeRaycaster, StreamRaycaster,
};

/// The pipeline families of one device, each built on first use.
#[derive(Default)]
pub(crate) struct PipelineCache {
    raycaster: OnceLock<Raycaster>,
    dense_raycaster: OnceLock<DenseRaycaster>,
    recolor: OnceLock<GpuRecolor>,
    brick_recolor: OnceLock<GpuBrickRecolor>,
    slicer: OnceLock<Slicer>,
    stream_raycaster: OnceLock<StreamRaycaster>,
    stream_composite_raycaster: OnceLock<StreamCompositeRaycaster>,
    composite_raycaster: OnceLock<CompositeRaycaster>,
    /// Per format of [`atlas_scatter::FORMATS`].
    atlas_scatter: [OnceLock<AtlasScatter>; atlas_scatter::FORMATS.len()],
    /// Compute pipelines built with this device so far.
    built: AtomicUsize,
}

impl PipelineCache {
    /// Counts `count` more compute pipelines built (`pipeline::compute_pipelines` and
    /// `pipeline::VariantPipelines`).
    pub(crate) fn count_built(&self, count: usize) {
        self.built.fetch_add(count, Ordering::Relaxed);
    }
}

impl GpuContext {
    /// The octree and bricks ray caster of this device, built on first use.
    pub fn raycaster(&self) -> &Raycaster {
        self.pipelines
            .raycaster
            .get_or_init(|| Raycaster::new(self))
    }

    /// The dense ray caster of this device, built on first use.
    pub fn dense_raycaster(&self) -> &DenseRaycaster {
        self.pipelines
            .dense_raycaster
            .get_or_init(|| DenseRaycaster::new(self))
    }

    /// The octree recolor of this device, built on first use.
    pub fn recolor(&self) -> &GpuRecolor {
        self.pipelines.recolor.get_or_init(|| GpuRecolor::new(self))
    }

    /// The bricks recolor of this device (which also runs [`Self::recolor`]), built on first
    /// use.
    pub fn brick_recolor(&self) -> &GpuBrickRecolor {
        self.pipelines
            .brick_recolor
            .get_or_init(|| GpuBrickRecolor::new(self))
    }

    /// The streaming ray caster of this device, built on first use.
    pub fn stream_raycaster(&self) -> &StreamRaycaster {
        self.pipelines
            .stream_raycaster
            .get_or_init(|| StreamRaycaster::new(self))
    }

    /// The streamed composite's ray caster of this device, built on first use.
    pub fn stream_composite_raycaster(&self) -> &StreamCompositeRaycaster {
        self.pipelines
            .stream_composite_raycaster
            .get_or_init(|| StreamCompositeRaycaster::new(self))
    }

    /// The composite-of-channels ray caster of this device, built on first use.
    pub fn composite_raycaster(&self) -> &CompositeRaycaster {
        self.pipelines
            .composite_raycaster
            .get_or_init(|| CompositeRaycaster::new(self))
    }

    /// Builds the pipelines that a renderer of `kind` draws, recolors and (streaming) uploads
    /// with on this device, where not built yet: each renderer calls it when it is made, and
    /// a thread may call it while the volume is read ([`super::HeadlessStart::begin_for`]),
    /// so that the first image waits for no compile.
    pub fn build_pipelines(&self, kind: RendererKind) {
        match kind {
            RendererKind::Octree => {
                self.raycaster();
                self.recolor();
            }
            RendererKind::Dense => {
                self.dense_raycaster();
            }
            RendererKind::Bricks => {
                self.raycaster();
                self.recolor();
                self.brick_recolor();
            }
            RendererKind::Stream => {
                self.stream_raycaster();
                // Both atlas formats (a byte's, two bytes'): the source's values choose.
                for format in super::stream::atlas_formats(self) {
                    self.atlas_scatter(format);
                }
            }
            RendererKind::Composite => {
                self.composite_raycaster();
            }
        }
    }

    /// The pipeline writing staged bricks into a streaming atlas of `format`, built on first
    /// use; `None` where this device cannot write `format` from a shader.
    pub(crate) fn atlas_scatter(&self, format: wgpu::TextureFormat) -> Option<&AtlasScatter> {
        if !self.atlas_storage_formats.contains(&format) {
            return None;
        }
        let index = atlas_scatter::FORMATS.iter().position(|&f| f == format)?;
        Some(self.pipelines.atlas_scatter[index].get_or_init(|| AtlasScatter::new(self, format)))
    }

    /// The slice pipeline of this device (every renderer's slices), built on first use.
    pub fn slicer(&self) -> &Slicer {
        self.pipelines.slicer.get_or_init(|| Slicer::new(self))
    }

    /// How many compute pipelines this context has built: each family's once, however many
    /// volumes, renderers and panes use it (and `ceilings`' at each measurement).
    pub fn pipelines_built(&self) -> usize {
        self.pipelines.built.load(Ordering::Relaxed)
    }
}
