//! The GPU helpers of the integration tests: one adapter a test binary, the octree ray
//! caster's image of an octree, and a volume ready for every renderer. Shared by the render
//! crate's tests and the root package's (each names `colored_octree` in its support module).

use std::sync::LazyLock;

use voxscope_octree::{BuildOptions, Octree, TransferFunction};
use voxscope_render::{
    Camera, Frame, GpuContext, GpuVolume, RenderSettings, RenderTarget, read_image, render_frame,
};
use voxscope_volume::{QuantizedVolume, Volume};

use super::colored_octree;

/// The adapter every test of a test binary shares (as re_renderer's tests do): finding one
/// is the slow part, a device of it is cheap. An error, not a panic, so that every test
/// fails with the reason rather than with a poisoned lock.
static ADAPTER: LazyLock<Result<wgpu::Adapter, String>> =
    LazyLock::new(|| GpuContext::headless_adapter().map_err(|e| e.to_string()));

/// A fresh device of the shared adapter, for one test (its pipelines are built once, on first
/// use, as in the app); failing when there is no adapter (GPU tests are never skipped).
pub fn gpu() -> GpuContext {
    let adapter = ADAPTER
        .as_ref()
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    GpuContext::from_adapter(adapter).unwrap_or_else(|e| panic!("GPU tests need a device: {e}"))
}

/// Renders on the GPU (the device's octree ray caster) and reads the image back.
pub fn gpu_render(
    context: &GpuContext,
    octree: &Octree,
    spacing: [f64; 3],
    transfer: &TransferFunction,
    camera: &Camera,
    settings: &RenderSettings,
    size: (u32, u32),
) -> image::RgbaImage {
    let volume =
        GpuVolume::upload(context, octree, spacing, octree.depth, transfer).expect("upload");
    let target = RenderTarget::new(context, size.0, size.1);
    let frame = Frame {
        volume: &volume,
        target: &target,
        camera,
        settings,
    };
    render_frame(context, &frame);
    read_image(context, &target).expect("readback")
}

/// A volume ready for every renderer: quantized, its octree built and colored.
pub struct Prepared {
    pub volume: Volume,
    pub quantized: QuantizedVolume,
    pub octree: Octree,
    pub transfer: TransferFunction,
}

impl Prepared {
    /// Quantizes, builds and colors `volume` with `transfer` (the robust gray window if `None`).
    pub fn new(volume: Volume, transfer: Option<TransferFunction>) -> Self {
        let quantized = QuantizedVolume::new(&volume);
        let (octree, transfer) = colored_octree(&volume, transfer, BuildOptions::default());
        Self {
            volume,
            quantized,
            octree,
            transfer,
        }
    }

    /// Uploads this volume for `options` (the whole octree).
    pub fn renderer(
        &self,
        context: &GpuContext,
        options: impl Into<voxscope_render::RendererOptions>,
    ) -> voxscope_render::VolumeRenderer {
        voxscope_render::VolumeRenderer::new(
            context,
            options,
            &self.octree,
            &self.quantized,
            self.volume.spacing,
            self.octree.depth,
            &self.transfer,
        )
        .unwrap_or_else(|e| panic!("{}: {e}", self.volume.name))
    }
}

/// Draws one frame with `renderer` and reads it back.
pub fn draw(
    context: &GpuContext,
    renderer: &voxscope_render::VolumeRenderer,
    camera: &Camera,
    settings: &RenderSettings,
    size: (u32, u32),
) -> image::RgbaImage {
    let target = RenderTarget::new(context, size.0, size.1);
    renderer.render(context, &target, camera, settings);
    read_image(context, &target).expect("readback")
}
