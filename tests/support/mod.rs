//! Shared by the integration tests: paths to real data, the CPU reference renderer, file
//! writers for loader tests, and GPU helpers.
#![allow(dead_code)] // each test binary uses a different part

pub mod app_harness;
pub mod damage;
pub mod fault_server;
pub mod http_server;
pub mod reference;
pub mod writers;

use std::path::PathBuf;
use std::sync::LazyLock;

use voxscope_octree::{BuildOptions, Octree, TransferFunction};
use voxscope_render::{
    Camera, Frame, GpuContext, GpuVolume, RenderSettings, RenderTarget, read_image, render_frame,
};
use voxscope_volume::{QuantizedVolume, Volume};

/// A file of the shared real data set (`../shared/data`, beside the checkout).
pub fn shared_data(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(name);
    assert!(path.exists(), "test data {} is missing", path.display());
    path
}

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

/// Quantizes, builds and colors `volume` with `transfer` (the robust window if `None`).
pub fn colored_octree(
    volume: &Volume,
    transfer: Option<TransferFunction>,
    options: BuildOptions,
) -> (Octree, TransferFunction) {
    let quantized = QuantizedVolume::new(volume);
    let mut octree = voxscope_octree::build(&quantized, options).expect("octree builds");
    let transfer = transfer.unwrap_or_else(|| TransferFunction::gray(quantized.robust_window()));
    voxscope_octree::recolor(&mut octree, &transfer);
    (octree, transfer)
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

/// Where tests may write images worth looking at (target/test-images).
pub fn image_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-images");
    std::fs::create_dir_all(&dir).expect("create target/test-images");
    dir
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
