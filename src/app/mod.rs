//! The desktop app (eframe/egui): the ray caster's image in the central panel, the transfer
//! function on the left, the octree and its numbers on the right, level and transfer
//! comparisons, background loading. Builds on [`voxscope_render`]; nothing below imports egui.
//!
//! How it is put together (docs/architecture.md has the whole picture):
//! - [`VoxscopeApp`] holds [`AppSettings`] (persisted), the volume on screen ([`Scene`]) and
//!   its [`ViewState`], the background [`jobs`] and the [`central`] view;
//! - every action is a [`Command`], sent by menus, toolbar, shortcuts, drops and tests and
//!   run in one place;
//! - background work ends in typed [`jobs::JobEvent`]s, polled once per frame.

mod annotate;
mod central;
mod channel_list;
mod clip_panel;
mod command;
mod command_handling;
mod dialogs;
mod file_browser;
mod frame_controls;
mod jobs;
mod label_list;
mod menu;
mod movie_export;
mod movie_panel;
mod numbers;
mod octree_panel;
mod offscreen;
mod overlays;
mod pane_header;
mod picking;
mod prefetch;
mod saved_view;
mod screenshot;
mod settings;
mod slice_pane;
mod stream_panel;
mod transfer_editor;
mod transfer_panel;
mod url_dialog;
mod view_file;
mod view_state;
mod viewport;
mod voxscope_app;
mod wheel;

use std::sync::{Arc, Mutex, PoisonError};

pub use command::{Command, ViewPreset};
pub use dialogs::DialogKind;
pub use movie_panel::MoviePlan;
pub use settings::{AppSettings, Layout, Panel, STORAGE_KEY};
pub use view_state::{Ruler, ViewState};
pub use voxscope_app::VoxscopeApp;

use voxscope_render::GpuContext;
use voxscope_scene::VolumeSource;

/// The GPU as the app shares it with egui-wgpu: the ray casters' context on egui's device,
/// and egui-wgpu's renderer, which shows the render targets as textures; and the device of
/// the pictures job threads draw.
pub struct AppGpu {
    pub context: Arc<GpuContext>,
    pub render_state: egui_wgpu::RenderState,
    pub offscreen: OffscreenDevice,
}

/// A second device of the window's adapter, for what job threads draw and read back
/// (screenshots at a scale, movies, label overlays), made by the first job that needs it and
/// kept for the next. The window's device takes submissions from the UI thread alone: a job's
/// submission while egui-wgpu configures the window's surface (at start, on a resize) fails the
/// configuration, since wgpu waits for that device's queue to empty first.
#[derive(Clone)]
pub struct OffscreenDevice {
    adapter: wgpu::Adapter,
    context: Arc<Mutex<Option<Arc<GpuContext>>>>,
}

impl OffscreenDevice {
    pub fn new(adapter: wgpu::Adapter) -> Self {
        Self {
            adapter,
            context: Arc::default(),
        }
    }

    /// The device's context, made on first use (on a job thread: it waits for the driver); a
    /// device the driver refused is asked for again by the next job.
    pub fn context(&self) -> Result<Arc<GpuContext>, String> {
        let mut context = self.context.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(context) = context.as_ref() {
            return Ok(Arc::clone(context));
        }
        let made = GpuContext::from_adapter(&self.adapter)
            .map(Arc::new)
            .map_err(|e| format!("a device for drawing away from the window: {e}"))?;
        *context = Some(Arc::clone(&made));
        Ok(made)
    }
}

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

/// What the window opens on.
#[derive(Debug, Clone, PartialEq)]
pub enum Start {
    /// A volume (the sample when `None`): `voxscope [FILE]`.
    Open(Option<VolumeSource>),
    /// A view file: `voxscope --view V.ron`.
    View(std::path::PathBuf),
}

/// Opens the window on `start`, clipped by `clip`, and runs until it is closed.
pub fn run(start: Start, clip: voxscope_octree::Clip) -> Result<(), String> {
    eframe::run_native(
        "voxscope",
        native_options(),
        Box::new(move |cc| {
            let mut app = match start {
                Start::Open(source) => VoxscopeApp::new(cc, source),
                Start::View(view) => VoxscopeApp::with_view(cc, view),
            };
            app.clip_first_volume(clip);
            Ok(Box::new(app))
        }),
    )
    .map_err(|e| format!("cannot open the window: {e}"))
}
