//! The transfer function drawn and edited over the volume's histogram: log counts, the
//! opacity curve, the colormap (or the curve's own colors) under it, handles for the window's
//! ends and the binary threshold, and in Points mode the control points: click to add, drag to
//! move (the value and opacity shown while dragging), right-click to delete, and the selected
//! point's numbers and color below.

use egui::{Color32, CornerRadius, Pos2, Rect, Response, Sense, Shape, Stroke, Ui, pos2, vec2};

use super::settings::AppSettings;
use voxscope_octree::{ControlPoint, OpacityMode, TransferFunction};
use voxscope_scene::{HISTOGRAM_BINS, VolumeData};
use voxscope_volume::{ValueWindow, format_value};

/// Radius of a control point, in points.
const POINT_RADIUS: f32 = 4.5;

/// The window's handles.
const WINDOW_COLOR: Color32 = Color32::from_rgb(90, 170, 255);
/// The opacity curve and the threshold handle.
const CURVE_COLOR: Color32 = Color32::from_rgb(255, 170, 40);

/// Maps between the data's values and the editor's x, and opacity and y.
struct Axes {
    plot: Rect,
    value_low: f64,
    span: f64,
}

impl Axes {
    fn x_of(&self, value: f64) -> f32 {
        self.plot.left() + ((value - self.value_low) / self.span) as f32 * self.plot.width()
    }

    fn value_of(&self, x: f32) -> f64 {
        self.value_low + ((x - self.plot.left()) / self.plot.width()) as f64 * self.span
    }

    fn y_of(&self, opacity: f32) -> f32 {
        self.plot.bottom() - opacity * (self.plot.height() - 2.0)
    }

    fn opacity_of(&self, y: f32) -> f32 {
        ((self.plot.bottom() - y) / (self.plot.height() - 2.0)).clamp(0.0, 1.0)
    }

    fn point(&self, point: &ControlPoint) -> Pos2 {
        pos2(
            self.x_of(point.value)
                .clamp(self.plot.left(), self.plot.right()),
            self.y_of(point.opacity),
        )
    }
}

/// The histogram with the transfer function over it; edits `settings` and `window`.
pub fn show(ui: &mut Ui, settings: &mut AppSettings, window: &mut ValueWindow, data: &VolumeData) {
    let width = ui.available_width().max(120.0);
    let (rect, background) = ui.allocate_exact_size(vec2(width, 150.0), Sense::click());
    let bar_rect = Rect::from_min_max(rect.left_bottom() - vec2(0.0, 10.0), rect.right_bottom());
    let plot = Rect::from_min_max(rect.left_top(), pos2(rect.right(), bar_rect.top() - 2.0));
    let [value_low, value_high] = data.quantized.value_range;
    let axes = Axes {
        plot,
        value_low,
        span: (value_high - value_low).max(f64::MIN_POSITIVE),
    };
    let painter = ui.painter_at(rect);
    painter.rect_filled(plot, CornerRadius::same(2), ui.visuals().extreme_bg_color);
    histogram_bars(ui, &axes, data);

    let transfer = settings.transfer.with_window(*window);
    paint_color_bar(&painter, bar_rect, &axes, &transfer);
    let curve: Vec<Pos2> = (0..=240)
        .map(|i| {
            let x = plot.left() + plot.width() * i as f32 / 240.0;
            pos2(x, axes.y_of(transfer.opacity_of(axes.value_of(x))))
        })
        .collect();
    painter.add(Shape::line(curve, Stroke::new(1.5, CURVE_COLOR)));

    let min_gap = axes.span / 1000.0;
    if let Some(low) = handle(
        ui,
        &axes,
        "window_low",
        window.low,
        WINDOW_COLOR,
        "window low: drag",
    ) {
        window.low = low.min(window.high - min_gap);
    }
    if let Some(high) = handle(
        ui,
        &axes,
        "window_high",
        window.high,
        WINDOW_COLOR,
        "window high: drag",
    ) {
        window.high = high.max(window.low + min_gap);
    }
    match &mut settings.transfer.opacity {
        OpacityMode::Binary => {
            let at = window.low + settings.transfer.threshold as f64 * (window.high - window.low);
            if let Some(value) = handle(
                ui,
                &axes,
                "threshold",
                at,
                CURVE_COLOR,
                "binary threshold: drag",
            ) {
                settings.transfer.threshold = window.normalize(value) as f32;
            }
        }
        OpacityMode::Points(curve) => {
            edit_points(ui, &axes, curve, &background);
        }
        OpacityMode::Gray => {}
    }
    ui.horizontal(|ui| {
        ui.small(format_value(value_low));
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.small(format_value(value_high));
        });
    });
    match &mut settings.transfer.opacity {
        OpacityMode::Points(curve) => {
            ui.small("click: add a point · drag: move · right-click: delete");
            selected_point_fields(ui, curve);
        }
        _ => {
            ui.small("log counts · blue: window · orange: opacity / threshold");
        }
    }
}

/// Log10(1 + count) bars, scaled to the tallest.
fn histogram_bars(ui: &Ui, axes: &Axes, data: &VolumeData) {
    let painter = ui.painter_at(axes.plot);
    let tallest = data
        .histogram
        .iter()
        .map(|&c| (1.0 + c as f64).log10())
        .fold(0.0, f64::max)
        .max(1e-9);
    let bar_width = axes.plot.width() / HISTOGRAM_BINS as f32;
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
        let height = ((1.0 + count as f64).log10() / tallest) as f32 * axes.plot.height();
        let x = axes.plot.left() + bin as f32 * bar_width;
        painter.rect_filled(
            Rect::from_min_max(
                pos2(x, axes.plot.bottom() - height),
                pos2(x + bar_width.max(1.0), axes.plot.bottom()),
            ),
            CornerRadius::ZERO,
            bar_color,
        );
    }
}

/// The colors the transfer function gives each value along the histogram's axis.
fn paint_color_bar(painter: &egui::Painter, bar: Rect, axes: &Axes, transfer: &TransferFunction) {
    let steps = 96;
    for i in 0..steps {
        let x0 = bar.left() + bar.width() * i as f32 / steps as f32;
        let x1 = bar.left() + bar.width() * (i + 1) as f32 / steps as f32;
        let value = axes.value_of((x0 + x1) / 2.0);
        let [r, g, b, _] = transfer.color_of(value, transfer.window.normalize(value));
        painter.rect_filled(
            Rect::from_min_max(pos2(x0, bar.top()), pos2(x1, bar.bottom())),
            CornerRadius::ZERO,
            Color32::from_rgb(r, g, b),
        );
    }
}

/// A vertical handle at `value`; returns the value it is dragged to.
fn handle(
    ui: &mut Ui,
    axes: &Axes,
    id: &str,
    value: f64,
    color: Color32,
    label: &str,
) -> Option<f64> {
    let plot = axes.plot;
    let x = axes.x_of(value).clamp(plot.left(), plot.right());
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
    ui.painter().line_segment(
        [pos2(x, plot.top()), pos2(x, plot.bottom())],
        Stroke::new(stroke, color),
    );
    let pointer = response.interact_pointer_pos()?;
    response
        .dragged()
        .then(|| axes.value_of(pointer.x.clamp(plot.left(), plot.right())))
}

/// The id under which the selected point's index is kept between frames.
fn selection_id(ui: &Ui) -> egui::Id {
    ui.scope_id().with("selected_point")
}

/// The index of the selected control point, as kept between frames.
fn selected_point(ui: &Ui) -> Option<usize> {
    ui.data(|d| d.get_temp::<Option<usize>>(selection_id(ui)))
        .flatten()
}

/// Control points: drawn on the curve, dragged, deleted with a right-click, added where the
/// empty plot is clicked.
fn edit_points(
    ui: &mut Ui,
    axes: &Axes,
    curve: &mut voxscope_octree::OpacityCurve,
    background: &Response,
) {
    let selection = selection_id(ui);
    let mut selected = selected_point(ui);
    let mut remove = None;
    let mut any_point_hit = false;
    for index in 0..curve.points().len() {
        let center = axes.point(&curve.points()[index]);
        let hit = Rect::from_center_size(center, vec2(14.0, 14.0));
        let label = format!("point {}: drag", index + 1);
        let response = ui
            .interact(
                hit,
                ui.scope_id().with(("point", index)),
                Sense::click_and_drag(),
            )
            .on_hover_cursor(egui::CursorIcon::Grab);
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Slider, true, &label));
        any_point_hit |= response.hovered() || response.dragged();
        if response.drag_started() || response.clicked() {
            selected = Some(index);
        }
        if response.dragged()
            && let Some(pointer) = response.interact_pointer_pos()
        {
            let x = pointer.x.clamp(axes.plot.left(), axes.plot.right());
            curve.move_point(index, axes.value_of(x), axes.opacity_of(pointer.y));
            let point = curve.points()[index];
            ui.painter().text(
                axes.point(&point) + vec2(8.0, -8.0),
                egui::Align2::LEFT_BOTTOM,
                format!("{} · {:.2}", format_value(point.value), point.opacity),
                egui::FontId::proportional(12.0),
                Color32::WHITE,
            );
        }
        if response.secondary_clicked() {
            remove = Some(index);
        }
    }
    if let Some(index) = remove
        && curve.remove(index)
    {
        selected = None;
    }
    if background.clicked()
        && !any_point_hit
        && let Some(pointer) = background.interact_pointer_pos()
        && axes.plot.contains(pointer)
    {
        let point = ControlPoint::new(axes.value_of(pointer.x), axes.opacity_of(pointer.y));
        if let Some(index) = curve.insert(point) {
            selected = Some(index);
        }
    }
    for (index, point) in curve.points().iter().enumerate() {
        let fill = match point.color {
            Some([r, g, b]) => Color32::from_rgb(r, g, b),
            None => CURVE_COLOR,
        };
        let stroke = if selected == Some(index) {
            Stroke::new(2.0, Color32::WHITE)
        } else {
            Stroke::new(1.0, Color32::BLACK)
        };
        ui.painter()
            .circle(axes.point(point), POINT_RADIUS, fill, stroke);
    }
    ui.data_mut(|d| d.insert_temp(selection, selected));
}

/// The selected point's value, opacity and own color, as numbers to type.
fn selected_point_fields(ui: &mut Ui, curve: &mut voxscope_octree::OpacityCurve) {
    let Some(index) = selected_point(ui).filter(|&i| i < curve.points().len()) else {
        return;
    };
    let point = curve.points()[index];
    ui.horizontal(|ui| {
        ui.label(format!("point {}", index + 1));
        let mut value = point.value;
        let mut opacity = point.opacity;
        let speed = (point.value.abs() / 200.0).max(0.01);
        let value_label = ui.label("value");
        let changed_value = ui
            .add(egui::DragValue::new(&mut value).speed(speed))
            .labelled_by(value_label.id)
            .changed();
        let opacity_label = ui.label("opacity");
        let changed_opacity = ui
            .add(
                egui::DragValue::new(&mut opacity)
                    .range(0.0..=1.0)
                    .speed(0.005),
            )
            .labelled_by(opacity_label.id)
            .changed();
        if changed_value || changed_opacity {
            curve.move_point(index, value, opacity);
        }
    });
    ui.horizontal(|ui| {
        let mut own = point.color.is_some();
        if ui
            .checkbox(&mut own, "own color")
            .on_hover_text("Color this point's values itself instead of the colormap")
            .changed()
        {
            curve.set_color(index, own.then_some([255, 255, 255]));
        }
        if let Some(color) = point.color {
            let mut rgb = color;
            if ui.color_edit_button_srgb(&mut rgb).changed() {
                curve.set_color(index, Some(rgb));
            }
        }
    });
}

/// A button showing a preset's opacity curve over the data's values, in its colors.
pub fn preset_button(
    ui: &mut Ui,
    label: &str,
    transfer: &TransferFunction,
    data: &VolumeData,
) -> Response {
    let size = vec2(86.0, 34.0);
    let (rect, response) = ui.allocate_exact_size(size, Sense::click());
    response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Button, true, label));
    let visuals = ui.style().interact(&response);
    let painter = ui.painter_at(rect);
    painter.rect(
        rect,
        CornerRadius::same(3),
        visuals.bg_fill,
        visuals.bg_stroke,
        egui::StrokeKind::Inside,
    );
    let plot = Rect::from_min_max(rect.min + vec2(3.0, 14.0), rect.max - vec2(3.0, 3.0));
    let [low, high] = data.quantized.value_range;
    let axes = Axes {
        plot,
        value_low: low,
        span: (high - low).max(f64::MIN_POSITIVE),
    };
    let samples = 48;
    for i in 0..samples {
        let x0 = plot.left() + plot.width() * i as f32 / samples as f32;
        let x1 = plot.left() + plot.width() * (i + 1) as f32 / samples as f32;
        let value = axes.value_of((x0 + x1) / 2.0);
        let [r, g, b, a] = transfer.color_of(value, transfer.window.normalize(value));
        let top = axes.y_of(a as f32 / 255.0).min(plot.bottom() - 1.0);
        painter.rect_filled(
            Rect::from_min_max(pos2(x0, top), pos2(x1, plot.bottom())),
            CornerRadius::ZERO,
            Color32::from_rgb(r, g, b),
        );
    }
    painter.text(
        rect.left_top() + vec2(4.0, 1.0),
        egui::Align2::LEFT_TOP,
        label,
        egui::FontId::proportional(11.0),
        visuals.text_color(),
    );
    response
}
