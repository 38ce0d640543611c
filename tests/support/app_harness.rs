//! The app under egui_kittest on the software Vulkan device: a harness that waits for the
//! background work, snapshots with the measured times masked, and image helpers.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use voxscope::app::{VoxscopeApp, wgpu_setup};
use voxscope_scene::VolumeSource;

pub const SIZE: egui::Vec2 = egui::vec2(1280.0, 800.0);

pub fn harness_with(
    source: Option<VolumeSource>,
    size: egui::Vec2,
) -> Harness<'static, VoxscopeApp> {
    let mut harness = Harness::builder()
        .with_size(size)
        .wgpu_setup(wgpu_setup())
        .build_eframe(move |cc| VoxscopeApp::new(cc, source));
    settle(&mut harness);
    harness
}

pub fn harness() -> Harness<'static, VoxscopeApp> {
    harness_with(None, SIZE)
}

/// A fresh app (no settings stored: a new user's) opening `source`, settled.
pub fn fresh_app(source: &str) -> Harness<'static, VoxscopeApp> {
    harness_with(Some(VolumeSource::Spec(source.to_owned())), SIZE)
}

/// An app started with `storage` as its stored settings (a restart), opening `source` (the
/// sample when `None`), settled.
pub fn restarted_app(
    storage: MemoryStorage,
    source: Option<VolumeSource>,
) -> Harness<'static, VoxscopeApp> {
    let storage: &'static MemoryStorage = Box::leak(Box::new(storage));
    let mut harness = Harness::builder()
        .with_size(SIZE)
        .wgpu_setup(wgpu_setup())
        .build_eframe(move |cc| {
            cc.storage = Some(storage);
            VoxscopeApp::new(cc, source)
        });
    settle(&mut harness);
    harness
}

/// What eframe would store of `harness`'s app on quitting.
pub fn stored_settings(harness: &mut Harness<'_, VoxscopeApp>) -> MemoryStorage {
    let mut storage = MemoryStorage::default();
    eframe::App::save(harness.state_mut(), &mut storage);
    storage
}

/// Settings storage in memory, as eframe's file storage holds them.
#[derive(Default)]
pub struct MemoryStorage(std::collections::HashMap<String, String>);

impl eframe::Storage for MemoryStorage {
    fn get_string(&self, key: &str) -> Option<String> {
        self.0.get(key).cloned()
    }
    fn set_string(&mut self, key: &str, value: String) {
        self.0.insert(key.to_owned(), value);
    }
    fn remove_string(&mut self, key: &str) {
        self.0.remove(key);
    }
    fn flush(&mut self) {}
}

/// The app on Mesa's software Vulkan device (lavapipe), whatever GPU the machine has: where
/// a frame takes seconds, as the slow-frame tests need. Fails when the device is missing.
pub fn software_device_harness(source: &str) -> Harness<'static, VoxscopeApp> {
    let egui_wgpu::WgpuSetup::CreateNew(mut setup) = wgpu_setup() else {
        panic!("voxscope's setup creates its device");
    };
    setup.native_adapter_selector = Some(std::sync::Arc::new(|adapters, _| {
        adapters
            .iter()
            .find(|adapter| adapter.get_info().device_type == wgpu::DeviceType::Cpu)
            .cloned()
            .ok_or_else(|| {
                "the slow-frame tests need Mesa's software Vulkan device (mesa-vulkan-drivers)"
                    .to_owned()
            })
    }));
    let source = VolumeSource::Spec(source.to_owned());
    Harness::builder()
        .with_size(SIZE)
        .wgpu_setup(egui_wgpu::WgpuSetup::CreateNew(setup))
        .build_eframe(move |cc| VoxscopeApp::new(cc, Some(source)))
}

/// Steps until no background work is left and the view is drawn.
pub fn settle(harness: &mut Harness<'_, VoxscopeApp>) {
    let started = Instant::now();
    loop {
        harness.step();
        if !harness.state().is_busy() {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the app stayed busy for 2 minutes"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    // One more frame to draw what the last job delivered, and one to read its numbers.
    harness.run_steps(2);
    while harness.state().is_busy() {
        harness.step();
        std::thread::sleep(Duration::from_millis(5));
    }
    harness.run_steps(1);
}

/// A snapshot with the measured figures masked: times vary from run to run, and which frame
/// the nodes per ray were counted on depends on the machine's load.
pub fn snapshot(harness: &mut Harness<'_, VoxscopeApp>, name: &str) {
    let right = harness.ctx.content_rect().right();
    // The composite counts samples per ray where the renderers of one channel count nodes.
    let per_ray = ["Nodes per ray", "Samples per ray"]
        .into_iter()
        .find(|label| harness.query_by_label(label).is_some())
        .expect("the panel shows nodes or samples per ray");
    // Several panes: which one the numbers are of depends on which finished last.
    let measured = harness.query_by_label("Measured").map(|node| node.rect());
    let rows: Vec<egui::Rect> = ["Load + build", "GPU time", per_ray]
        .iter()
        .map(|label| harness.get_by_label(label).rect())
        .chain(measured)
        .collect();
    let values_left = harness.get_by_label(per_ray).rect().right() + 4.0;
    for row in rows {
        harness.mask(egui::Rect::from_min_max(
            egui::pos2(values_left, row.top()),
            egui::pos2(right, row.bottom()),
        ));
    }
    harness.snapshot(name);
}

/// The rendered view as an image (what File ▸ Save screenshot writes).
pub fn view(harness: &Harness<'_, VoxscopeApp>) -> image::RgbaImage {
    harness.state().view_image(1.0).expect("the view is drawn")
}

pub fn differing_pixels(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}

/// Pixels that are not the black background.
pub fn lit_pixels(image: &image::RgbaImage) -> usize {
    image
        .pixels()
        .filter(|p| p.0[0] > 8 || p.0[1] > 8 || p.0[2] > 8)
        .count()
}

/// A relative path under target/, so messages in snapshots do not depend on the checkout.
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new("target/app-test");
    std::fs::create_dir_all(dir).expect("create target/app-test");
    dir.join(name)
}

/// A primary-button click at `pos` (a place that is no widget of its own, like a spot on the
/// histogram).
pub fn click_at(harness: &Harness<'_, VoxscopeApp>, pos: egui::Pos2) {
    harness.hover_at(pos);
    for pressed in [true, false] {
        harness.event(egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::NONE,
        });
    }
}

/// Drags from `from` to `to` in a few steps, as a hand would.
pub fn drag(harness: &mut Harness<'_, VoxscopeApp>, from: egui::Pos2, to: egui::Pos2) {
    harness.hover_at(from);
    harness.step();
    harness.drag_at(from);
    harness.step();
    for f in [0.25, 0.5, 0.75, 1.0] {
        harness.hover_at(from.lerp(to, f));
        harness.step();
    }
    harness.drop_at(to);
    harness.step();
}

/// Switches the renderer through the Octree panel's combo box, and waits for the upload.
pub fn choose_renderer(harness: &mut Harness<'_, VoxscopeApp>, name: &str) {
    harness.get_by_label("Renderer").click();
    harness.run_steps(2);
    harness.get_by_label(name).click();
    settle(harness);
}
