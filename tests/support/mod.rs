//! Shared by the integration tests: paths to real data, the CPU reference renderer, file
//! writers for loader tests, and GPU helpers.
#![allow(dead_code)] // each test binary uses a different part

pub mod reference;
pub mod writers;

use std::path::PathBuf;

use voxscope::octree::{self, BuildOptions, Octree, TransferFunction};
use voxscope::render::{
    Camera, Frame, GpuContext, GpuVolume, Raycaster, RenderSettings, RenderTarget, read_image,
    render_frame,
};
use voxscope::volume::{QuantizedVolume, Volume};

/// A file of the shared real data set (`../shared/data`, beside the checkout).
pub fn shared_data(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(name);
    assert!(path.exists(), "test data {} is missing", path.display());
    path
}

/// A headless GPU; failing when there is none (GPU tests are never skipped).
pub fn gpu() -> GpuContext {
    GpuContext::new_headless().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// Quantizes, builds and colors `volume` with `transfer` (the robust window if `None`).
pub fn colored_octree(
    volume: &Volume,
    transfer: Option<TransferFunction>,
    options: BuildOptions,
) -> (Octree, TransferFunction) {
    let quantized = QuantizedVolume::new(volume);
    let mut octree = octree::build(&quantized, options).expect("octree builds");
    let transfer = transfer.unwrap_or_else(|| TransferFunction::gray(quantized.robust_window()));
    octree::recolor(&mut octree, &transfer);
    (octree, transfer)
}

/// Renders on the GPU and reads the image back.
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
    let raycaster = Raycaster::new(context);
    let target = RenderTarget::new(context, size.0, size.1);
    let frame = Frame {
        volume: &volume,
        target: &target,
        camera,
        settings,
    };
    render_frame(context, &raycaster, &frame);
    read_image(context, &target).expect("readback")
}

/// Where tests may write images worth looking at (target/test-images).
pub fn image_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-images");
    std::fs::create_dir_all(&dir).expect("create target/test-images");
    dir
}
