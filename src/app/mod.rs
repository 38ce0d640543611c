//! The desktop app (eframe/egui): the ray caster's image in the central panel, the transfer
//! function on the left, the octree and its numbers on the right, level and transfer
//! comparisons, background loading. Builds on [`crate::render`]; nothing below imports egui.

mod octree_panel;
mod scene;
mod settings;
mod transfer_panel;
mod viewport;
mod voxscope_app;

use std::sync::Arc;

pub use scene::{Job, VolumeData, VolumeSource};
pub use settings::{AppSettings, Layout, STORAGE_KEY, TransferChoice, TransferPreset};
pub use voxscope_app::{OPEN_EXTENSIONS, VoxscopeApp};

use crate::render::GpuContext;

/// How the app (and its tests) ask egui-wgpu for a device: the adapter's own limits and the
/// features the ray caster wants, so storage buffers and 3D textures are as large as the GPU
/// allows and timestamp queries work where they exist.
pub fn wgpu_setup() -> egui_wgpu::WgpuSetup {
    let mut setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    setup.instance_descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    setup.power_preference =
        wgpu::PowerPreference::from_env().unwrap_or(wgpu::PowerPreference::HighPerformance);
    setup.device_descriptor = Arc::new(GpuContext::device_descriptor);
    egui_wgpu::WgpuSetup::CreateNew(setup)
}

/// The window: title, size, drops, the wgpu renderer set up by [`wgpu_setup`].
pub fn native_options() -> eframe::NativeOptions {
    eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("voxscope")
            .with_app_id("voxscope")
            .with_inner_size([1400.0, 860.0])
            .with_min_inner_size([640.0, 420.0])
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: wgpu_setup(),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Opens the window on `source` (the sample when `None`) and runs until it is closed.
pub fn run(source: Option<VolumeSource>) -> Result<(), String> {
    eframe::run_native(
        "voxscope",
        native_options(),
        Box::new(move |cc| Ok(Box::new(VoxscopeApp::new(cc, source)))),
    )
    .map_err(|e| format!("cannot open the window: {e}"))
}
