//! The right panel: level of detail, renderer, heat map, and the numbers: per-level node
//! statistics (table and chart), build and upload time, GPU memory, per-frame cost.

use egui::Ui;
use egui_plot::{Bar, BarChart, Legend, Plot};

use super::central::FrameFacts;
use super::clip_panel::{self, ClipContext};
use super::numbers::{format_bytes, group_digits};
use super::settings::{AppSettings, Layout};
use super::stream_panel;
use super::view_state::{MAX_GRID_PANES, ViewState};
use voxscope_octree::{DataKind, LevelStatistics};
use voxscope_render::{HEATMAP_SATURATION, LevelDetail, RendererKind, heatmap_color};
use voxscope_scene::CompositeScene;
use voxscope_scene::Scene;

/// What the panel shows besides the settings it edits.
pub struct OctreeFacts<'a> {
    pub scene: Option<&'a Scene>,
    pub statistics: &'a [LevelStatistics],
    /// True while the statistics are being recounted for a new transfer function.
    pub statistics_pending: bool,
    /// The last frame measured, and the pane it was measured on.
    pub frame: Option<FrameFacts>,
    /// Frames per second over the last second of continuous drawing.
    pub fps: Option<f64>,
    pub adapter: &'a str,
    /// Bytes of the panes' render targets.
    pub target_bytes: u64,
}

/// Draws the panel; edits `settings` and the view state (max level, clipping).
pub fn show(
    ui: &mut Ui,
    settings: &mut AppSettings,
    view: &mut ViewState,
    facts: &OctreeFacts<'_>,
) {
    ui.heading("Octree");
    ui.add_space(4.0);
    let composite = facts.scene.and_then(|s| s.composite.as_ref());
    egui::Grid::new("octree_grid")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            level_rows(ui, settings, view, facts);
            renderer_rows(ui, settings, view, facts);
        });
    match composite {
        Some(composite) if composite.is_streamed() => {
            ui.small("The channels are streamed together by the renderer above; the slices show the first channel.");
        }
        Some(_) => {
            ui.small("The composite is drawn by the dense march; the renderer above draws one channel (choose it under Channels and time) and the slices.");
        }
        None => {}
    }
    march_options(ui, settings, view, facts);
    if let Some(scene) = facts.scene {
        let volume = &scene.data.volume;
        let context = ClipContext {
            dims: volume.dims,
            extent: volume.extent(),
            cursor: view.cursor,
            camera: settings.camera,
        };
        clip_panel::show(ui, &mut view.clipping, &context);
        measurements(ui, view, volume);
    }

    ui.separator();
    frame_numbers(ui, facts);

    let Some(scene) = facts.scene else { return };
    if scene.stream_status.is_some() {
        ui.separator();
        stream_panel::show(ui, scene);
    }
    ui.separator();
    if let Some(composite) = composite {
        composite_facts(ui, composite);
        return;
    }
    node_statistics(ui, scene, facts);
}

/// The grid's level rows: the max level (the level grid's per pane), and what each level
/// shown draws with this renderer.
fn level_rows(ui: &mut Ui, settings: &AppSettings, view: &mut ViewState, facts: &OctreeFacts<'_>) {
    let depth = facts.scene.map_or(0, Scene::depth);
    let grid_levels = view.grid_levels_shown(settings.grid_panes.clamp(2, MAX_GRID_PANES), depth);
    let max_level = &mut view.max_level;
    let composite = facts.scene.and_then(|s| s.composite.as_ref());
    let grid = (settings.layout == Layout::LevelGrid && composite.is_none()).then_some(grid_levels);
    let label = ui.label("Max level");
    if let Some(levels) = &grid {
        let shown: Vec<String> = levels.iter().map(u32::to_string).collect();
        ui.label(format!("per pane: {}", shown.join(", ")))
            .labelled_by(label.id)
            .on_hover_text("The level grid draws each pane at its own max level: set it at the top of the pane. The single view's max level is kept for the other layouts");
    } else {
        ui.add_enabled(
            depth > 0 && composite.is_none(),
            egui::Slider::new(max_level, 0..=depth),
        )
        .labelled_by(label.id)
        .on_hover_text(
            "Deepest level rays descend to: 0 is the root alone, the last level the voxels",
        )
        .on_disabled_hover_text(
            "The composite is marched through the voxels by the dense renderer: it has no levels",
        );
    }
    ui.end_row();

    if let Some(scene) = facts.scene {
        const DRAWN_HOVER: &str = "What this max level draws with this renderer: the octree's nodes (one color each, as in the paper), or a level of the volume's pyramid (the volume averaged 2× per level), filtered, one sample per voxel of that level";
        ui.label("Drawn");
        match &grid {
            Some(levels) => {
                ui.vertical(|ui| {
                    for &level in levels {
                        let detail = level_detail_text(scene.renderer.level_detail(level));
                        ui.label(format!("{level}: {detail}"))
                            .on_hover_text(DRAWN_HOVER);
                    }
                });
            }
            None => {
                ui.label(level_detail_text(scene.renderer.level_detail(*max_level)))
                    .on_hover_text(DRAWN_HOVER);
            }
        }
        ui.end_row();
    }
}

/// The grid's renderer rows: the renderer this volume is drawn with, and the stream's budget
/// or the bricks' size where they apply.
fn renderer_rows(
    ui: &mut Ui,
    settings: &mut AppSettings,
    view: &mut ViewState,
    facts: &OctreeFacts<'_>,
) {
    // The renderer this volume is drawn with: the data's where it called for one (a
    // large store streams), else the user's. Choosing one is the user's choice, for
    // this volume and the next.
    let shown = view.data_renderer.unwrap_or(settings.renderer);
    let mut chosen = shown;
    let label = ui.label("Renderer");
    let combo = egui::ComboBox::from_id_salt("renderer")
        .selected_text(shown.name())
        .show_ui(ui, |ui| {
            for kind in RendererKind::ALL.into_iter().chain([RendererKind::Stream]) {
                ui.selectable_value(&mut chosen, kind, kind.name());
            }
        })
        .response
        .labelled_by(label.id)
        .on_hover_text("octree: the paper's voxel octree · dense: one 3D texture (the usual way) · bricks: octree down to bricks in a 3D atlas · stream: a pyramid of 32³ bricks streamed into a fixed GPU budget (OME-Zarr stores from the file, at full resolution)");
    if view.data_renderer.is_some() {
        combo.on_hover_text(format!(
            "This volume called for {}; the next opens with {}, the renderer chosen here",
            shown.name(),
            settings.renderer.name()
        ));
    }
    if chosen != shown {
        settings.renderer = chosen;
        view.data_renderer = None;
    }
    ui.end_row();

    if shown == RendererKind::Stream {
        stream_panel::budget_row(ui, settings, facts.scene);
    }

    if shown == RendererKind::Bricks {
        let label = ui.label("Brick size");
        egui::ComboBox::from_id_salt("brick_size")
            .selected_text(format!("{0}³", settings.brick_size))
            .show_ui(ui, |ui| {
                for size in [8, 16, 32] {
                    ui.selectable_value(&mut settings.brick_size, size, format!("{size}³"));
                }
            })
            .response
            .labelled_by(label.id);
        ui.end_row();
    }
}

/// How rays march and what the view shows of it: the pixel-footprint stop, opacity
/// correction, trilinear filtering, the heat map, previews of slow frames and drawing every
/// frame.
fn march_options(
    ui: &mut Ui,
    settings: &mut AppSettings,
    view: &ViewState,
    facts: &OctreeFacts<'_>,
) {
    let composite = facts.scene.and_then(|s| s.composite.as_ref());
    const NO_NODES: &str = "The composite samples the voxels one step apart: it has no nodes to stop at or to correct for";
    ui.add_enabled(
        composite.is_none(),
        egui::Checkbox::new(&mut settings.pixel_lod, "Pixel-footprint LOD"),
    )
    .on_hover_text("Also stop where a node projects to less than a pixel")
    .on_disabled_hover_text(NO_NODES);
    ui.add_enabled(
        composite.is_none(),
        egui::Checkbox::new(&mut settings.opacity_correction, "Opacity correction"),
    )
    .on_hover_text("Correct alpha for the distance a ray travels in a node; off is the paper's plain compositing")
    .on_disabled_hover_text(NO_NODES);
    let drawn_with = view.data_renderer.unwrap_or(settings.renderer);
    let labels = facts
        .scene
        .is_some_and(|s| composite.is_none() && matches!(s.data.kind, DataKind::Labels(_)));
    ui.add_enabled(
        !labels && (drawn_with != RendererKind::Octree || composite.is_some()),
        egui::Checkbox::new(&mut settings.trilinear, "Trilinear filtering"),
    )
    .on_hover_text("Dense, bricks, stream and the composite sample textures; the octree draws whole nodes")
    .on_disabled_hover_text(if labels {
        "A label volume's values are categories: a value between two labels is a third, unrelated label. Every renderer and the slices sample it at the nearest voxel, and its coarser levels keep each block's most frequent label."
    } else {
        "The octree draws whole nodes: there is nothing between voxels to filter"
    });
    ui.checkbox(&mut settings.heatmap, "Nodes-visited heat map")
        .on_hover_text("Show per pixel how many nodes its ray visited (the composite: how many samples it took)");
    if settings.heatmap {
        heatmap_legend(
            ui,
            if composite.is_some() {
                "samples"
            } else {
                "nodes"
            },
        );
    }
    ui.checkbox(&mut settings.fast_interaction, "Preview slow frames")
        .on_hover_text("When a frame would take the GPU over 40 ms, show it first at a resolution that fits, then at full resolution band by band; off: band by band alone (the window answers either way)");
    ui.checkbox(&mut settings.continuous, "Redraw every frame")
        .on_hover_text(
            "Measure sustained frame rate; otherwise the view is drawn only when something changes",
        );
}

/// The octree's nodes per level (table and chart, recounted for a new transfer function) and
/// how many it stores of the full tree's.
fn node_statistics(ui: &mut Ui, scene: &Scene, facts: &OctreeFacts<'_>) {
    ui.strong("Nodes per level");
    if facts.statistics_pending {
        ui.small("recounting for the new transfer function…");
    }
    statistics_table(ui, facts.statistics);
    statistics_chart(ui, facts.statistics);
    let octree = &scene.data.octree;
    ui.small(format!(
        "{} nodes stored of {} in the full tree (eq. 1){}",
        group_digits(octree.nodes.len() as u64),
        group_digits(voxscope_octree::full_tree_nodes(octree.depth)),
        if octree.collapsed {
            ", uniform subtrees collapsed"
        } else {
            ""
        }
    ));
}

/// What the statistics can honestly say of the composite: it is no octree, so the per-level
/// table does not apply; empty-space skipping's reach and the memory do.
fn composite_facts(ui: &mut Ui, composite: &CompositeScene) {
    ui.strong("Composite");
    let dims = composite.channels[0].volume.dims;
    egui::Grid::new("composite_facts")
        .num_columns(2)
        .spacing([8.0, 3.0])
        .show(ui, |ui| {
            ui.label("Channels");
            ui.label(format!(
                "{} of {}",
                composite.channels.len(),
                voxscope_volume::format_dims(dims)
            ));
            ui.end_row();
            if let Some((visible, total)) = composite.skipped_blocks() {
                ui.label("Visible blocks");
                ui.label(format!(
                    "{} of {} ({:.0} %)",
                    group_digits(visible as u64),
                    group_digits(total as u64),
                    100.0 * visible as f64 / total.max(1) as f64
                ))
                .on_hover_text("Blocks of 8³ voxels where some shown channel is visible under its transfer function: the rest are skipped");
                ui.end_row();
            }
            if composite.is_streamed() {
                ui.label("Streamed");
                ui.label("together, through one GPU budget")
                    .on_hover_text("The channels' bricks share one atlas, page table and RAM cache (the Streaming panel counts them); a hidden channel's bricks are never read");
                ui.end_row();
                return;
            }
            ui.label("Memory");
            ui.label(format!(
                "{} GPU, {} RAM",
                format_bytes(composite.gpu_bytes()),
                format_bytes(composite.cpu_bytes())
            ))
            .on_hover_text("GPU: the channels' levels in two RGBA 16-bit float 3D textures, their tables and the skipping blocks. RAM: every channel's levels and octree");
            ui.end_row();
        });
    ui.small("Per-level node counts describe one channel's octree and have no meaning for the composite: its rays march the voxels (samples per ray above, and in the heat map).");
}

fn frame_numbers(ui: &mut Ui, facts: &OctreeFacts<'_>) {
    let composite = facts.scene.is_some_and(|s| s.composite.is_some());
    egui::Grid::new("frame_grid")
        .num_columns(2)
        .spacing([8.0, 3.0])
        .show(ui, |ui| {
            ui.label("GPU");
            ui.label(facts.adapter);
            ui.end_row();
            if let Some(scene) = facts.scene {
                ui.label("Load + build");
                ui.label(format!(
                    "{:.2} s (octree {:.2} s), upload {:.2} s",
                    scene.data.load_seconds, scene.data.octree.build_seconds, scene.upload_seconds
                ));
                ui.end_row();
                let mut buffers = scene.renderer.gpu_bytes();
                if let Some(composite) = &scene.composite {
                    buffers.push(("composite", composite.gpu_bytes()));
                }
                let total: u64 = buffers.iter().map(|(_, b)| b).sum::<u64>() + facts.target_bytes;
                ui.label("GPU memory");
                ui.label(format_bytes(total)).on_hover_text(
                    buffers
                        .iter()
                        .map(|(name, bytes)| format!("{name}: {}", format_bytes(*bytes)))
                        .chain([format!(
                            "render targets: {}",
                            format_bytes(facts.target_bytes)
                        )])
                        .collect::<Vec<_>>()
                        .join("\n"),
                );
                ui.end_row();
            }
            if let Some(frame) = facts.frame {
                let measured = frame.measured;
                // Several panes: say which one the numbers are of.
                if measured.panes > 1 {
                    ui.label("Measured");
                    ui.label(match measured.level {
                        Some(level) => format!("pane {} (level {level})", measured.pane + 1),
                        None => format!("pane {}", measured.pane + 1),
                    })
                    .on_hover_text("The GPU time and the nodes per ray below are of this pane's last full image");
                    ui.end_row();
                }
                ui.label("GPU time");
                let time = match frame.frame_ms {
                    Some(ms) if frame.bands > 1 => {
                        format!("{ms:.1} ms per frame, in {} bands", frame.bands)
                    }
                    Some(ms) => format!("{ms:.3} ms per frame"),
                    None => "no timestamp queries on this GPU".to_owned(),
                };
                ui.label(time).on_hover_text(
                    "A frame that would keep the device busy longer than a UI frame's budget (40 ms) is drawn in bands, a preview shown meanwhile, so the window keeps answering",
                );
                ui.end_row();
                ui.label(if composite {
                    "Samples per ray"
                } else {
                    "Nodes per ray"
                });
                ui.label(format!(
                    "{:.1} average, {} max",
                    frame.report.nodes_per_ray_avg, frame.report.nodes_per_ray_max
                ));
                ui.end_row();
            }
            ui.label("Frame rate");
            ui.label(match facts.fps {
                Some(fps) => format!("{fps:.0} fps"),
                None => "idle (drawn on change)".to_owned(),
            });
            ui.end_row();
        });
}

fn heatmap_legend(ui: &mut Ui, what: &str) {
    let (rect, _) = ui.allocate_exact_size(
        egui::vec2(ui.available_width().min(220.0), 12.0),
        egui::Sense::hover(),
    );
    let steps = 48;
    for i in 0..steps {
        let x0 = rect.left() + rect.width() * i as f32 / steps as f32;
        let x1 = rect.left() + rect.width() * (i + 1) as f32 / steps as f32;
        // Evenly spaced in log2(1 + work), as the shader maps it.
        let work = (2f32.powf(10.0 * (i as f32 + 0.5) / steps as f32) - 1.0) as u32;
        let [r, g, b] = heatmap_color(work);
        ui.painter().rect_filled(
            egui::Rect::from_min_max(egui::pos2(x0, rect.top()), egui::pos2(x1, rect.bottom())),
            0.0,
            egui::Color32::from_rgb(r, g, b),
        );
    }
    ui.horizontal(|ui| {
        ui.small("0");
        ui.small("· 31 ·");
        ui.small(format!("{HEATMAP_SATURATION}+ {what} per ray (log scale)"));
    });
}

/// The "Drawn" row: what a max level draws.
fn level_detail_text(detail: LevelDetail) -> String {
    match detail {
        LevelDetail::Full => "every voxel".to_owned(),
        LevelDetail::Nodes { level } => format!("nodes to level {level}, one color each"),
        LevelDetail::Pyramid { level, dims } => format!(
            "{}×{}×{} voxels of {}³, filtered",
            dims[0],
            dims[1],
            dims[2],
            1u64 << level
        ),
    }
}

fn statistics_table(ui: &mut Ui, statistics: &[LevelStatistics]) {
    // The panel's width, scrolling sideways where the columns need more: a table that grew
    // the panel's content past its edge clipped its last column and the chart below.
    egui::ScrollArea::horizontal()
        .id_salt("stats_scroll")
        .auto_shrink([false, true])
        .show(ui, |ui| {
            egui::Grid::new("stats_table")
                .striped(true)
                .num_columns(6)
                .spacing([6.0, 2.0])
                .show(ui, |ui| {
                    for header in ["level", "nodes", "leaves", "transp.", "opaque", "bytes"] {
                        ui.strong(header);
                    }
                    ui.end_row();
                    for level in statistics {
                        ui.label(level.level.to_string());
                        ui.monospace(group_digits(level.nodes));
                        ui.monospace(group_digits(level.leaves));
                        ui.monospace(group_digits(level.transparent));
                        ui.monospace(group_digits(level.opaque));
                        ui.monospace(format_bytes(level.bytes));
                        ui.end_row();
                    }
                });
        });
}

fn statistics_chart(ui: &mut Ui, statistics: &[LevelStatistics]) {
    let log = |n: u64| (1.0 + n as f64).log10();
    let series =
        |name: &str, offset: f64, color: egui::Color32, value: fn(&LevelStatistics) -> u64| {
            let bars = statistics
                .iter()
                .map(|s| Bar::new(s.level as f64 + offset, log(value(s))).width(0.26))
                .collect();
            BarChart::new(name, bars).color(color)
        };
    Plot::new("stats_chart")
        .height(150.0)
        .legend(Legend::default().position(egui_plot::Corner::LeftTop))
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show_grid([false, true])
        .x_axis_label("level")
        .y_axis_formatter(|mark, _| {
            if mark.value.fract() == 0.0 {
                format!("1e{:.0}", mark.value)
            } else {
                String::new()
            }
        })
        .show(ui, |plot| {
            plot.bar_chart(series(
                "nodes",
                -0.28,
                egui::Color32::from_rgb(110, 150, 230),
                |s| s.nodes,
            ));
            plot.bar_chart(series(
                "opaque",
                0.0,
                egui::Color32::from_rgb(240, 170, 60),
                |s| s.opaque,
            ));
            plot.bar_chart(series(
                "transparent",
                0.28,
                egui::Color32::from_rgb(150, 150, 150),
                |s| s.transparent,
            ));
        });
}

/// The rulers measured so far, each with its length and a button to remove it.
fn measurements(ui: &mut Ui, view: &mut ViewState, volume: &voxscope_volume::Volume) {
    let spacing = volume.spacing;
    let title = if view.rulers.is_empty() {
        "Measurements".to_owned()
    } else {
        format!("Measurements ({})", view.rulers.len())
    };
    egui::CollapsingHeader::new(title)
        .id_salt("measurements")
        .show(ui, |ui| {
            if view.rulers.is_empty() {
                ui.small("Choose the Ruler tool, then drag in a slice or click two points in the 3D view.");
                return;
            }
            let mut remove = None;
            egui::Grid::new("rulers").num_columns(3).striped(true).show(ui, |ui| {
                for (index, ruler) in view.rulers.iter().enumerate() {
                    ui.label(format!("{}", index + 1));
                    ui.monospace(volume.with_unit(format!("{:.2}", ruler.length(spacing))));
                    if ui.small_button("Remove").clicked() {
                        remove = Some(index);
                    }
                    ui.end_row();
                }
            });
            if let Some(index) = remove {
                view.rulers.remove(index);
            }
            if ui.small_button("Remove all").clicked() {
                view.rulers.clear();
            }
        });
}
