//! The strips above the panes (the level grid's pane count, the transfer pair's B) and the
//! label at the top of each pane (its level and node count, or A and B).

use egui::{Align2, Color32, Rect, RichText, Ui, UiBuilder, vec2};

use super::numbers::group_digits;
use super::settings::{AppSettings, Layout};
use super::view_state::{MAX_GRID_PANES, ViewState};
use voxscope_octree::OpacityMode;
use voxscope_render::{LevelDetail, RenderMode, RendererKind};
use voxscope_scene::Scene;
use voxscope_scene::TransferChoice;
use voxscope_volume::{ValueWindow, format_value};

use super::transfer_panel::threshold_slider;

/// The level grid's strip: how many panes (at most one per level of an octree of `depth`).
/// A new count keeps the levels shown and adds levels not shown yet
/// ([`ViewState::resize_grid`]).
pub fn grid_strip(ui: &mut Ui, settings: &mut AppSettings, view: &mut ViewState, depth: u32) {
    let label = ui.label("Panes");
    let most = (depth as usize + 1).clamp(2, MAX_GRID_PANES);
    let before = settings.grid_panes.clamp(2, MAX_GRID_PANES);
    // Clamped where the user drags, not on showing: a shallow volume (or none yet) must not
    // lower the pane count kept for the next.
    let changed = ui
        .add(
            egui::Slider::new(&mut settings.grid_panes, 2..=most)
                .clamping(egui::SliderClamping::Edits),
        )
        .labelled_by(label.id)
        .changed();
    if changed && settings.grid_panes != before {
        view.resize_grid(before, settings.grid_panes, depth);
    }
    ui.label("· each pane: its own max level, one linked camera");
}

/// The transfer pair's strip: pane B's transfer function (over the volume's `window`).
pub fn pair_strip(ui: &mut Ui, settings: &mut AppSettings, window: ValueWindow) {
    ui.label("B:");
    let b = &mut settings.compare_transfer;
    ui.selectable_value(&mut b.opacity, OpacityMode::Gray, "Gray");
    ui.selectable_value(&mut b.opacity, OpacityMode::Binary, "Binary");
    if b.opacity == OpacityMode::Binary {
        let label = ui.label("threshold");
        threshold_slider(ui, &mut b.threshold, window).labelled_by(label.id);
    }
    let colormap_label = ui.label("colormap");
    egui::ComboBox::from_id_salt("compare_colormap")
        .selected_text(b.colormap.name())
        .show_ui(ui, |ui| {
            for colormap in voxscope_octree::Colormap::ALL {
                ui.selectable_value(&mut b.colormap, colormap, colormap.name());
            }
        })
        .response
        .labelled_by(colormap_label.id);
    if ui.button("Swap A and B").clicked() {
        std::mem::swap(&mut settings.transfer, &mut settings.compare_transfer);
    }
}

/// The label at the top of pane `index` of `count`: its level and node count (the level
/// grid's level is editable there), or the transfer pair's A or B.
pub fn pane_label(
    ui: &mut Ui,
    scene: &Scene,
    settings: &AppSettings,
    view: &mut ViewState,
    index: usize,
    count: usize,
    rect: Rect,
) {
    let octree = &scene.data.octree;
    let depth = scene.depth();
    let header = Rect::from_min_size(rect.min + vec2(6.0, 4.0), vec2(rect.width() - 12.0, 22.0));
    // What a level draws: the octree's nodes through it, or a pyramid level's voxels (max level
    // m is pyramid level depth − m: the streamed one's, or dense's and bricks' own below their
    // nodes).
    let nodes = |level: u32| match scene.renderer.streamer() {
        Some(streamer) => {
            let shape = streamer.shape();
            let pyramid_level = (depth - level.min(depth)) as usize;
            format!(
                "{} voxels",
                voxscope_volume::format_dims(shape.levels[pyramid_level].dims)
            )
        }
        None => match scene.renderer.level_detail(level) {
            LevelDetail::Pyramid { dims, .. } => {
                format!("{} voxels", voxscope_volume::format_dims(dims))
            }
            LevelDetail::Full if scene.renderer.kind() == RendererKind::Dense => {
                format!("{} voxels", voxscope_volume::format_dims(octree.dims))
            }
            LevelDetail::Nodes { .. } | LevelDetail::Full => format!(
                "{} nodes",
                group_digits(octree.nodes_through_level(level) as u64)
            ),
        },
    };
    let paint = |ui: &Ui, text: String| {
        ui.painter().text(
            header.left_top(),
            Align2::LEFT_TOP,
            text,
            egui::FontId::proportional(13.0),
            Color32::from_gray(220),
        );
    };
    if let Some(composite) = &scene.composite {
        // The composite has neither levels nor a second transfer function: every 3D pane
        // shows the same.
        paint(
            ui,
            format!(
                "composite of {} channels · {}, {}",
                composite.channels.len(),
                if composite.is_streamed() {
                    "streamed"
                } else {
                    "dense march"
                },
                if settings.shading.enabled && settings.mode == RenderMode::Dvr {
                    "lit"
                } else {
                    "unlit"
                }
            ),
        );
        return;
    }
    match settings.layout {
        Layout::Single | Layout::Slices => {
            let level = view.max_level.min(depth);
            paint(ui, format!("level {level} · {}", nodes(level)));
        }
        Layout::LevelGrid => {
            let nodes = nodes(view.grid_level(index, count, depth));
            let Some(level) = view.grid_level_mut(index, count) else {
                return;
            };
            ui.scope_builder(UiBuilder::new().max_rect(header), |ui| {
                ui.horizontal(|ui| {
                    let label = ui.label(RichText::new("level").color(Color32::from_gray(220)));
                    ui.add(egui::DragValue::new(level).range(0..=depth))
                        .labelled_by(label.id);
                    ui.label(RichText::new(nodes).color(Color32::from_gray(220)));
                });
            });
        }
        Layout::TransferPair => {
            let choice = if index == 0 {
                settings.transfer
            } else {
                settings.compare_transfer
            };
            let name = if index == 0 { "A" } else { "B" };
            paint(
                ui,
                format!("{name} · {}", describe_choice(choice, view.window)),
            );
        }
    }
}

/// `alpha = gray, grays`, `binary at 120, viridis` (the threshold in data units over
/// `window`).
fn describe_choice(choice: TransferChoice, window: ValueWindow) -> String {
    match choice.opacity {
        OpacityMode::Gray => format!("alpha = gray, {}", choice.colormap.name()),
        OpacityMode::Binary => format!(
            "binary at {}, {}",
            format_value(window.low + choice.threshold as f64 * (window.high - window.low)),
            choice.colormap.name()
        ),
        OpacityMode::Points(curve) => format!(
            "curve of {} points, {}",
            curve.points().len(),
            if curve.has_colors() {
                "its own colors"
            } else {
                choice.colormap.name()
            }
        ),
    }
}
