//! Rendering on the GPU with wgpu: the device, the octree's buffers, the ray-casting, recolor
//! and slice compute pipelines, the camera. Knows nothing about the UI: the app and the command
//! line both drive it.

mod atlas_scatter;
mod bricks;
mod camera;
mod ceilings;
mod composite;
mod context;
mod copy_timer;
mod dense;
mod frame_probe;
mod gpu_data;
mod gpu_volume;
mod level_texture;
mod pipeline;
mod pipeline_cache;
mod probe;
mod raycaster;
mod readback;
mod recolor;
mod region;
mod renderer;
mod settings;
pub mod shaders;
mod slice;
mod staging_ring;
mod stream;
mod timer;
mod transfer_table;
mod uncleared_texture;
mod volume_renderer;

pub use bricks::{GpuBrickRecolor, GpuBricks};
pub use camera::{Camera, ViewFrame};
pub use ceilings::{CeilingSizes, Ceilings, measure_ceilings};
pub use composite::{ChannelLayer, CompositeRaycaster, CompositeVolume, tinted_lookup_table};
pub use context::{GpuContext, HeadlessStart, RenderError};
pub use dense::{DenseRaycaster, DenseVolume};
pub use frame_probe::{FrameProbe, FrameReport};
pub use gpu_volume::GpuVolume;
pub use probe::{GpuProbe, PROBE_ALPHA, ProbeHit, ProbeOutcome, ProbeRequest, probe_pixel};
pub use raycaster::{Frame, OctreeOnGpu, ProbeTarget, Raycaster, RenderTarget, VolumeShape};
pub use readback::{read_buffer, read_image, read_visits};
pub use recolor::GpuRecolor;
pub use region::ImageRegion;
pub use renderer::{FramePass, Renderer, StreamPaths};
pub use settings::{
    EARLY_TERMINATION_ALPHA, GRADIENT_FOR_FULL_SHADING, HEATMAP_SATURATION, RenderMode,
    RenderSettings, Shading, heatmap_color,
};
pub use slice::{
    EdgeLabels, SliceConvention, SliceFrame, SliceSettings, SliceSource, SliceView, Slicer,
};
pub use stream::{BUDGET_STEPS, StreamCompositeRaycaster, StreamRaycaster, StreamVolume};
pub use timer::{GpuTimer, WarmUp, time_passes, timing_name, warm_up};
pub use transfer_table::GpuTransferTable;
pub use volume_renderer::{
    DEFAULT_BRICK_SIZE, LevelDetail, RendererKind, RendererOptions, VolumeRenderer,
};

/// Renders one frame of an octree with the device's [`Raycaster`] and submits it.
pub fn render_frame(context: &GpuContext, frame: &Frame<'_>) {
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::frame"),
        });
    raycaster::encode_frame(context.raycaster(), context, &mut encoder, frame, None);
    context.queue.submit([encoder.finish()]);
}
