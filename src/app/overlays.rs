//! What is drawn over the panes: the slice views' colors, the rulers and the cursor over a 3D
//! view, the rulers drawn into a saved screenshot, and the error banner.

use egui::{Align2, Color32, Pos2, Rect, Ui, vec2};
use glam::DVec3;

use super::settings::{AppSettings, Layout};
use super::view_state::ViewState;
use super::viewport::{self, DrawKey};
use voxscope_scene::Scene;

/// The colors of the slice views, as 3D Slicer's: axial red, coronal green, sagittal yellow.
/// Index by the axis a slice is perpendicular to (x: sagittal, y: coronal, z: axial).
pub const SLICE_COLORS: [Color32; 3] = [
    Color32::from_rgb(230, 200, 60),
    Color32::from_rgb(90, 190, 90),
    Color32::from_rgb(225, 80, 70),
];

/// The ruler's color on every view.
pub const RULER_COLOR: Color32 = Color32::from_rgb(80, 220, 255);

/// Draws what the 3D pane `rect` shows over the volume: the rulers with their lengths, and in
/// the Slices layout the cursor and (as an option) the three slice planes through it.
pub fn paint_overlays_3d(
    ui: &Ui,
    rect: Rect,
    scene: &Scene,
    settings: &AppSettings,
    view: &ViewState,
) {
    let volume = &scene.data.volume;
    let (extent, spacing, dims) = (volume.extent(), volume.spacing, volume.dims);
    let project =
        |voxel: [f64; 3]| viewport::project(&settings.camera, extent, spacing, rect, voxel);
    let painter = ui.painter_at(rect);
    for ruler in &view.rulers {
        let (Some(from), Some(to)) = (project(ruler.from), project(ruler.to)) else {
            continue;
        };
        painter.line_segment([from, to], egui::Stroke::new(2.0, RULER_COLOR));
        painter.circle_filled(from, 3.0, RULER_COLOR);
        painter.circle_filled(to, 3.0, RULER_COLOR);
        painter.text(
            from.lerp(to, 0.5) + vec2(6.0, -6.0),
            Align2::LEFT_BOTTOM,
            volume.with_unit(format!("{:.1}", ruler.length(spacing))),
            egui::FontId::proportional(13.0),
            RULER_COLOR,
        );
    }
    if settings.layout != Layout::Slices {
        return;
    }
    let cursor = view.cursor;
    if settings.show_slice_planes {
        for (axis, color) in SLICE_COLORS.iter().enumerate() {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corners: Vec<Pos2> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                .iter()
                .filter_map(|&(a, b)| {
                    let mut point = cursor;
                    point[u] = a * dims[u] as f64;
                    point[v] = b * dims[v] as f64;
                    project(point)
                })
                .collect();
            if corners.len() == 4 {
                painter.add(egui::Shape::closed_line(
                    corners,
                    egui::Stroke::new(1.5, color.gamma_multiply(0.8)),
                ));
            }
        }
    }
    // Arms 4 % of the volume's largest physical side long.
    let arm = extent.iter().copied().fold(0.0, f64::max) * 0.04;
    for (axis, color) in SLICE_COLORS.iter().enumerate() {
        let mut from = cursor;
        let mut to = cursor;
        from[axis] -= arm / spacing[axis];
        to[axis] += arm / spacing[axis];
        if let (Some(a), Some(b)) = (project(from), project(to)) {
            painter.line_segment([a, b], egui::Stroke::new(2.0, *color));
        }
    }
}

/// Draws the rulers a pane shows into its place `rect` (pixels) of a screenshot: projected in
/// a 3D view, and in a slice those that lie in it.
pub fn draw_rulers(
    canvas: &mut image::RgbaImage,
    rect: Rect,
    drawn: &DrawKey,
    scene: &Scene,
    view: &ViewState,
) {
    let volume = &scene.data.volume;
    for ruler in &view.rulers {
        let ends = match drawn {
            DrawKey::Volume { camera, .. } => {
                let project =
                    |p| viewport::project(camera, volume.extent(), volume.spacing, rect, p);
                project(ruler.from).zip(project(ruler.to))
            }
            DrawKey::Slice {
                settings: slice, ..
            } => {
                let frame = &slice.frame;
                let axis = (0..3)
                    .find(|&a| frame.step_x[a] == 0.0 && frame.step_y[a] == 0.0)
                    .unwrap_or(2);
                let on_plane = |p: [f64; 3]| (p[axis] - frame.origin[axis]).abs() <= 0.5 + 1e-9;
                (on_plane(ruler.from) && on_plane(ruler.to)).then(|| {
                    let at = |p| {
                        let [x, y] = frame.pixel_of(p);
                        egui::pos2(rect.left() + x as f32, rect.top() + y as f32)
                    };
                    (at(ruler.from), at(ruler.to))
                })
            }
        };
        let Some((from, to)) = ends else { continue };
        let label = volume.with_unit(format!("{:.1}", ruler.length(volume.spacing)));
        draw_ruler(canvas, [from.x, from.y], [to.x, to.y], &label, 1);
    }
}

/// One ruler from `from` to `to` (pixels) labelled `label`, its line, ends and text `scale`
/// times their size in a screenshot at 1×.
pub fn draw_ruler(
    canvas: &mut image::RgbaImage,
    from: [f32; 2],
    to: [f32; 2],
    label: &str,
    scale: u32,
) {
    let color = image::Rgba(RULER_COLOR.to_array());
    let s = scale.max(1) as f32;
    super::annotate::line(canvas, from, to, 2.0 * s, color);
    super::annotate::disc(canvas, from, 3.0 * s, color);
    super::annotate::disc(canvas, to, 3.0 * s, color);
    let middle = [(from[0] + to[0]) / 2.0, (from[1] + to[1]) / 2.0];
    super::annotate::text(
        canvas,
        [middle[0] + 6.0 * s, middle[1] - 16.0 * s],
        label,
        2 * scale.max(1),
        color,
    );
}

/// The world axes as `camera` sees them in the bottom-left corner of `rect` (pixels of
/// `canvas`), as the window paints them ([`super::viewport::paint_axis_gizmo`]) at `scale`
/// pixels per point: +x, +y, +z named `labels`, far axes first.
pub fn draw_axis_gizmo(
    canvas: &mut image::RgbaImage,
    rect: Rect,
    camera: &voxscope_render::Camera,
    labels: [&str; 3],
    scale: f32,
) {
    let frame = camera.frame([1.0, 1.0, 1.0], 1.0);
    let length = 28.0 * scale;
    let center = [
        rect.left() + 14.0 * scale + length,
        rect.bottom() - (14.0 * scale + length),
    ];
    super::annotate::shade_disc(canvas, center, length + 10.0 * scale, 1.0 - 110.0 / 255.0);
    let mut axes: Vec<(f64, [f32; 2], usize)> = [DVec3::X, DVec3::Y, DVec3::Z]
        .iter()
        .enumerate()
        .map(|(i, axis)| {
            let screen = [axis.dot(frame.right) as f32, -(axis.dot(frame.up) as f32)];
            (axis.dot(frame.forward), screen, i)
        })
        .collect();
    axes.sort_by(|a, b| b.0.total_cmp(&a.0));
    let font = (2.0 * scale).round().max(1.0) as u32;
    for (_, screen, i) in axes {
        let color = image::Rgba(GIZMO_COLORS[i]);
        let tip = [
            center[0] + screen[0] * length,
            center[1] + screen[1] * length,
        ];
        super::annotate::line(canvas, center, tip, 2.5 * scale, color);
        let [w, h] = super::annotate::text_size(labels[i], font);
        let at = [
            center[0] + screen[0] * (length + 8.0 * scale) - w / 2.0,
            center[1] + screen[1] * (length + 8.0 * scale) - h / 2.0,
        ];
        super::annotate::text(canvas, at, labels[i], font, color);
    }
}

/// The gizmo's colors of +x, +y, +z (as [`super::viewport::paint_axis_gizmo`]'s).
const GIZMO_COLORS: [[u8; 4]; 3] = [[230, 70, 70, 255], [80, 200, 90, 255], [90, 140, 255, 255]];

/// The error banner over the bottom of `view_rect`, as tall as its wrapped message needs;
/// returns true when Dismiss was clicked.
pub fn error_banner(ui: &mut Ui, view_rect: Rect, message: &str) -> bool {
    const MARGIN: f32 = 8.0;
    const BUTTON_WIDTH: f32 = 70.0;
    let area = view_rect.shrink(12.0);
    let text_width = (area.width() - 2.0 * MARGIN - BUTTON_WIDTH).max(40.0);
    let galley = ui.painter().layout(
        format!("Error: {message}"),
        egui::TextStyle::Body.resolve(ui.style()),
        Color32::WHITE,
        text_width,
    );
    let height = (galley.size().y + 2.0 * MARGIN).clamp(36.0, area.height());
    let banner = Rect::from_min_max(egui::pos2(area.left(), area.bottom() - height), area.max);
    ui.painter()
        .rect_filled(banner, 4.0, Color32::from_rgb(120, 24, 24));
    let text_at = banner.min + vec2(MARGIN, MARGIN);
    ui.painter().galley(text_at, galley, Color32::WHITE);
    let button = Rect::from_min_size(
        egui::pos2(
            banner.right() - MARGIN - BUTTON_WIDTH,
            banner.top() + MARGIN,
        ),
        vec2(BUTTON_WIDTH, 20.0),
    );
    ui.put(button, egui::Button::new("Dismiss")).clicked()
}
