//! The left panel: opacity mode, value window with presets, global opacity, colormap, DVR or
//! MIP, and the histogram with the transfer curve and draggable handles.

use egui::{Color32, CornerRadius, Rect, Sense, Shape, Stroke, Ui, pos2, vec2};

use super::scene::{HISTOGRAM_BINS, VolumeData};
use super::settings::AppSettings;
use crate::octree::{Colormap, OpacityMode};
use crate::render::RenderMode;
use crate::volume::ValueWindow;

/// Named windows for CT data (Hounsfield units), as level/width pairs radiologists use.
const CT_PRESETS: [(&str, f64, f64); 4] = [
    ("Brain", 40.0, 80.0),
    ("Soft tissue", 40.0, 400.0),
    ("Lung", -600.0, 1500.0),
    ("Bone", 400.0, 1800.0),
];

/// Draws the panel; edits `settings` and `window` in place.
pub fn show(
    ui: &mut Ui,
    settings: &mut AppSettings,
    window: &mut ValueWindow,
    data: Option<&VolumeData>,
) {
    ui.heading("Transfer function");
    ui.add_space(4.0);

    egui::Grid::new("transfer_grid")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            ui.label("Rendering");
            ui.horizontal(|ui| {
                ui.selectable_value(&mut settings.mode, RenderMode::Dvr, "DVR")
                    .on_hover_text("Direct volume rendering: front-to-back compositing");
                ui.selectable_value(&mut settings.mode, RenderMode::Mip, "MIP")
                    .on_hover_text("Maximum intensity projection");
            });
            ui.end_row();

            ui.label("Opacity");
            ui.horizontal(|ui| {
                ui.selectable_value(&mut settings.transfer.opacity, OpacityMode::Gray, "Gray")
                    .on_hover_text("Alpha equals the windowed gray value (the paper's default)");
                ui.selectable_value(
                    &mut settings.transfer.opacity,
                    OpacityMode::Binary,
                    "Binary",
                )
                .on_hover_text("Transparent below the threshold, opaque above");
            });
            ui.end_row();

            if settings.transfer.opacity == OpacityMode::Binary {
                let label = ui.label("Threshold");
                ui.add(
                    egui::Slider::new(&mut settings.transfer.threshold, 0.0..=1.0)
                        .fixed_decimals(3),
                )
                .labelled_by(label.id);
                ui.end_row();
            }

            let label = ui.label("Opacity scale");
            ui.add(egui::Slider::new(&mut settings.density, 0.01..=1.0).logarithmic(true))
                .labelled_by(label.id)
                .on_hover_text("Multiplies every alpha: below 1 makes dense volumes see-through");
            ui.end_row();

            let label = ui.label("Colormap");
            egui::ComboBox::from_id_salt("colormap")
                .selected_text(settings.transfer.colormap.name())
                .show_ui(ui, |ui| {
                    for colormap in Colormap::ALL {
                        ui.selectable_value(
                            &mut settings.transfer.colormap,
                            colormap,
                            colormap.name(),
                        );
                    }
                })
                .response
                .labelled_by(label.id);
            ui.end_row();
        });

    ui.separator();
    ui.label("Value window (data units)");
    let speed = data.map_or(1.0, |d| {
        let [low, high] = d.quantized.value_range;
        ((high - low) / 500.0).max(1e-6)
    });
    ui.horizontal(|ui| {
        let label = ui.label("low");
        ui.add(egui::DragValue::new(&mut window.low).speed(speed))
            .labelled_by(label.id);
        let label = ui.label("high");
        ui.add(egui::DragValue::new(&mut window.high).speed(speed))
            .labelled_by(label.id);
    });
    if window.high <= window.low {
        window.high = window.low + speed.max(f64::EPSILON * window.low.abs().max(1.0));
    }
    if let Some(data) = data {
        ui.horizontal_wrapped(|ui| {
            if ui
                .button("Auto")
                .on_hover_text("0.5–99.5 percentiles")
                .clicked()
            {
                *window = data.default_window;
            }
            if ui.button("Full range").clicked() {
                let [low, high] = data.quantized.value_range;
                if high > low {
                    *window = ValueWindow { low, high };
                }
            }
            if data.is_ct_like() {
                for (name, level, width) in CT_PRESETS {
                    if ui
                        .button(name)
                        .on_hover_text(format!("level {level} HU, width {width} HU"))
                        .clicked()
                    {
                        *window = ValueWindow {
                            low: level - width / 2.0,
                            high: level + width / 2.0,
                        };
                    }
                }
            }
        });
        if let Some(labels) = data.label_count() {
            ui.horizontal_wrapped(|ui| {
                ui.small(format!("Label volume: {labels} distinct values."));
                if ui
                    .button("Show labels")
                    .on_hover_text("Categorical colors per value, label 0 transparent")
                    .clicked()
                {
                    let [low, high] = data.quantized.value_range;
                    if high > low {
                        *window = ValueWindow { low, high };
                        settings.transfer.colormap = Colormap::Labels;
                        settings.transfer.opacity = OpacityMode::Binary;
                        // Just above 0: every label but the background is opaque.
                        settings.transfer.threshold = (window.normalize(0.5) as f32).max(1e-4);
                    }
                }
            });
        }
        ui.add_space(4.0);
        histogram(ui, settings, window, data);
    }
}

/// The volume's histogram (log counts) with the transfer curve over it, the colormap under
/// it, and handles: the window's low and high, and the binary threshold.
fn histogram(ui: &mut Ui, settings: &mut AppSettings, window: &mut ValueWindow, data: &VolumeData) {
    let width = ui.available_width().max(120.0);
    let (rect, _) = ui.allocate_exact_size(vec2(width, 130.0), Sense::hover());
    let bar_rect = Rect::from_min_max(rect.left_bottom() - vec2(0.0, 10.0), rect.right_bottom());
    let plot = Rect::from_min_max(rect.left_top(), pos2(rect.right(), bar_rect.top() - 2.0));
    let painter = ui.painter_at(rect);
    painter.rect_filled(plot, CornerRadius::same(2), ui.visuals().extreme_bg_color);

    let [value_low, value_high] = data.quantized.value_range;
    let span = (value_high - value_low).max(f64::MIN_POSITIVE);
    let x_of = |value: f64| plot.left() + ((value - value_low) / span) as f32 * plot.width();
    let value_of = |x: f32| value_low + ((x - plot.left()) / plot.width()) as f64 * span;

    // Bars: log10(1 + count), scaled to the tallest.
    let tallest = data
        .histogram
        .iter()
        .map(|&c| (1.0 + c as f64).log10())
        .fold(0.0, f64::max)
        .max(1e-9);
    let bar_width = plot.width() / HISTOGRAM_BINS as f32;
    let bar_color = ui
        .visuals()
        .widgets
        .inactive
        .fg_stroke
        .color
        .gamma_multiply(0.6);
    for (bin, &count) in data.histogram.iter().enumerate() {
        if count == 0 {
            continue;
        }
        let height = ((1.0 + count as f64).log10() / tallest) as f32 * plot.height();
        let x = plot.left() + bin as f32 * bar_width;
        painter.rect_filled(
            Rect::from_min_max(
                pos2(x, plot.bottom() - height),
                pos2(x + bar_width.max(1.0), plot.bottom()),
            ),
            CornerRadius::ZERO,
            bar_color,
        );
    }

    // Colormap under the window, as the transfer function colors it.
    let transfer = settings.transfer.with_window(*window);
    let steps = 64;
    for i in 0..steps {
        let x0 = bar_rect.left() + bar_rect.width() * i as f32 / steps as f32;
        let x1 = bar_rect.left() + bar_rect.width() * (i + 1) as f32 / steps as f32;
        let t = window.normalize(value_of((x0 + x1) / 2.0));
        let [r, g, b] = transfer.colormap.rgb(t);
        painter.rect_filled(
            Rect::from_min_max(pos2(x0, bar_rect.top()), pos2(x1, bar_rect.bottom())),
            CornerRadius::ZERO,
            Color32::from_rgb(r, g, b),
        );
    }

    // The opacity curve.
    let curve: Vec<_> = (0..=200)
        .map(|i| {
            let x = plot.left() + plot.width() * i as f32 / 200.0;
            let alpha =
                transfer.color_of_normalized(window.normalize(value_of(x)))[3] as f32 / 255.0;
            pos2(x, plot.bottom() - alpha * (plot.height() - 2.0))
        })
        .collect();
    let curve_color = Color32::from_rgb(255, 170, 40);
    painter.add(Shape::line(curve, Stroke::new(1.5, curve_color)));

    // Handles.
    let handle = |ui: &mut Ui, id: &str, value: f64, color: Color32, label: &str| -> Option<f64> {
        let x = x_of(value).clamp(plot.left(), plot.right());
        let hit = Rect::from_min_max(pos2(x - 5.0, plot.top()), pos2(x + 5.0, plot.bottom()));
        let response = ui
            .interact(hit, ui.scope_id().with(id), Sense::drag())
            .on_hover_cursor(egui::CursorIcon::ResizeHorizontal)
            .on_hover_text(label);
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Slider, true, label));
        let stroke = if response.hovered() || response.dragged() {
            3.0
        } else {
            1.5
        };
        ui.painter_at(rect).line_segment(
            [pos2(x, plot.top()), pos2(x, plot.bottom())],
            Stroke::new(stroke, color),
        );
        let pointer = response.interact_pointer_pos()?;
        response
            .dragged()
            .then(|| value_of(pointer.x.clamp(plot.left(), plot.right())))
    };
    let window_color = Color32::from_rgb(90, 170, 255);
    let min_gap = span / 1000.0;
    if let Some(low) = handle(
        ui,
        "window_low",
        window.low,
        window_color,
        "window low: drag",
    ) {
        window.low = low.min(window.high - min_gap);
    }
    if let Some(high) = handle(
        ui,
        "window_high",
        window.high,
        window_color,
        "window high: drag",
    ) {
        window.high = high.max(window.low + min_gap);
    }
    if settings.transfer.opacity == OpacityMode::Binary {
        let at = window.low + settings.transfer.threshold as f64 * (window.high - window.low);
        if let Some(value) = handle(ui, "threshold", at, curve_color, "binary threshold: drag") {
            settings.transfer.threshold = window.normalize(value) as f32;
        }
    }
    ui.horizontal(|ui| {
        ui.small(format_value(value_low));
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.small(format_value(value_high));
        });
    });
    ui.small("log counts · blue: window · orange: opacity / threshold");
}

/// A data value as people write it: integers plain, others with 4 significant digits.
fn format_value(value: f64) -> String {
    if value.fract() == 0.0 && value.abs() < 1e9 {
        format!("{value:.0}")
    } else if value != 0.0 && (value.abs() >= 1e5 || value.abs() < 1e-3) {
        format!("{value:.3e}")
    } else {
        let decimals = (3 - value.abs().log10().floor() as i32).clamp(0, 6) as usize;
        format!("{value:.decimals$}")
    }
}
