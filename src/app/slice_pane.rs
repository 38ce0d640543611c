//! A slice view of the Slices layout: the pointer moves the shared cursor (click or drag), the
//! wheel or Page Up/Down steps one voxel through the slices, Ctrl+wheel zooms, a right or
//! middle drag pans, a double click fits the slice again; with the Ruler tool a drag measures.
//! Over the GPU's image it draws the cursor's crosshair, the crop box (whose edges drag), the
//! rulers on this slice, the slice's name and index, and the patient directions on the edges.

use egui::{Align2, Color32, PointerButton, Pos2, Rect, Response, Stroke, Ui, pos2, vec2};

use super::overlays::{RULER_COLOR, SLICE_COLORS};
use super::settings::{AppSettings, Tool};
use super::view_state::{Ruler, ViewState};
use super::wheel::WheelNotches;
use voxscope_render::{SliceConvention, SliceFrame, SliceView};
use voxscope_scene::Scene;

/// How close (in points) the pointer must be to a crop-box edge to drag it.
const EDGE_GRAB: f32 = 5.0;

/// The frame of the slice across `axis` drawn into a target of `target` pixels shown in `rect`
/// (`view.pan` is kept in points, the frame's in target pixels).
pub fn frame(
    scene: &Scene,
    view: &SliceView,
    rect: Rect,
    target: [u32; 2],
) -> (SliceFrame, SliceConvention) {
    let volume = &scene.data.volume;
    let convention = SliceConvention::of_volume(volume);
    let scale = target[0] as f64 / rect.width().max(1.0) as f64;
    let in_pixels = SliceView {
        pan: view.pan.map(|p| p * scale),
        ..*view
    };
    (
        SliceFrame::axis_aligned(&in_pixels, convention, volume.dims, volume.spacing, target),
        convention,
    )
}

/// A screen position in `rect` as a pixel position of a `target`-pixel image shown there.
fn to_pixel(pos: Pos2, rect: Rect, target: [u32; 2]) -> [f64; 2] {
    [
        ((pos.x - rect.left()) / rect.width().max(1.0)) as f64 * target[0] as f64,
        ((pos.y - rect.top()) / rect.height().max(1.0)) as f64 * target[1] as f64,
    ]
}

/// The inverse of [`to_pixel`].
fn to_screen(pixel: [f64; 2], rect: Rect, target: [u32; 2]) -> Pos2 {
    pos2(
        rect.left() + (pixel[0] / target[0].max(1) as f64) as f32 * rect.width(),
        rect.top() + (pixel[1] / target[1].max(1) as f64) as f32 * rect.height(),
    )
}

/// What a drag in a slice view is doing, kept between frames.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Drag {
    /// Moving the cursor.
    Cursor,
    /// Moving crop-box limit `bound` (0 low, 1 high) of `axis`.
    Edge { axis: usize, bound: usize },
    /// Measuring from this voxel-space point.
    Ruler { from: [f64; 3] },
}

/// Where a slice pane is and what it shows.
pub struct SlicePane {
    /// The axis the slice is across.
    pub axis: usize,
    /// The pane, in points.
    pub rect: Rect,
    /// Its image's size in pixels.
    pub target: [u32; 2],
}

/// Handles the pointer over `pane` and draws its overlays. Returns the voxel under the
/// pointer, if any.
pub fn interact(
    ui: &mut Ui,
    response: &Response,
    pane: &SlicePane,
    scene: &Scene,
    settings: &AppSettings,
    view: &mut ViewState,
) -> Option<[usize; 3]> {
    let SlicePane { axis, rect, target } = *pane;
    let dims = scene.data.volume.dims;
    let drag_id = response.id.with("slice_drag");
    let mut slice_view = view.slice_views[axis];
    slice_view.index = view.cursor_voxel(dims)[axis];
    let (frame, convention) = frame(scene, &slice_view, rect, target);
    let pointer = response.hover_pos();
    let voxel_under = pointer.and_then(|p| frame.voxel_at(to_pixel(p, rect, target), dims));

    // Wheel and keys: step through the slices; Ctrl+wheel: zoom about the pointer.
    if response.hovered() {
        let (events, time, zoom, page) = ui.input(|i| {
            let page =
                i.key_pressed(egui::Key::PageUp) as i32 - i.key_pressed(egui::Key::PageDown) as i32;
            (i.events.clone(), i.time, i.zoom_delta(), page)
        });
        // One slice per notch, whatever the platform reports for it (wheel.rs); Ctrl+wheel is
        // egui's zoom and arrives as `zoom_delta` instead.
        let wheel_id = egui::Id::unique("slice_wheel_notches");
        let frame_nr = ui.ctx().cumulative_frame_nr();
        let notches = ui.data_mut(|d| {
            d.get_temp_mut_or_default::<WheelNotches>(wheel_id)
                .count(&events, frame_nr, time)
        });
        if zoom != 1.0 {
            zoom_about(view, axis, zoom as f64, pointer, rect);
        }
        let steps = notches + page;
        if steps != 0 {
            step_slice(view, axis, steps as f64, dims);
        }
    }
    if response.double_clicked() {
        view.slice_views[axis].zoom = 1.0;
        view.slice_views[axis].pan = [0.0; 2];
    }
    if response.dragged_by(PointerButton::Secondary) || response.dragged_by(PointerButton::Middle) {
        let delta = response.drag_delta();
        let pan = &mut view.slice_views[axis].pan;
        pan[0] += delta.x as f64;
        pan[1] += delta.y as f64;
    }

    // The primary button: the cursor, a crop-box edge, or a ruler.
    let point_at = |pos: Pos2| frame.point_at(to_pixel(pos, rect, target));
    // Where the button went down (a drag is recognized only once the pointer has moved).
    let pressed = ui.input(|i| i.pointer.press_origin());
    if response.drag_started_by(PointerButton::Primary)
        && let Some(start) = pressed.or(response.interact_pointer_pos())
    {
        let drag = match settings.tool {
            Tool::Ruler => Drag::Ruler {
                from: point_at(start),
            },
            Tool::Navigate => grabbed_edge(&frame, view, axis, dims, rect, target, start)
                .map_or(Drag::Cursor, |(axis, bound)| Drag::Edge { axis, bound }),
        };
        ui.data_mut(|d| d.insert_temp(drag_id, drag));
    }
    let drag: Option<Drag> = ui.data(|d| d.get_temp(drag_id));
    let pressed_at = response.interact_pointer_pos();
    if response.clicked() && settings.tool == Tool::Navigate {
        if let Some(pos) = pressed_at {
            move_cursor(view, point_at(pos), axis, dims);
        }
    } else if let (Some(drag), Some(pos)) = (drag, pressed_at)
        && response.dragged_by(PointerButton::Primary)
    {
        match drag {
            Drag::Cursor => move_cursor(view, point_at(pos), axis, dims),
            Drag::Edge {
                axis: edge_axis,
                bound,
            } => {
                let fraction = (point_at(pos)[edge_axis] / dims[edge_axis] as f64) as f32;
                let [low, high] = &mut view.clipping.bounds[edge_axis];
                if bound == 0 {
                    *low = fraction.clamp(0.0, *high - 0.001);
                } else {
                    *high = fraction.clamp(*low + 0.001, 1.0);
                }
            }
            Drag::Ruler { from } => {
                let to = point_at(pos);
                paint_ruler(ui, &frame, rect, target, &Ruler { from, to }, scene);
            }
        }
    }
    if response.drag_stopped() {
        if let (Some(Drag::Ruler { from }), Some(pos)) = (drag, pressed_at.or(pointer)) {
            let to = point_at(pos);
            if (0..3).any(|a| (to[a] - from[a]).abs() > 1e-6) {
                view.rulers.push(Ruler { from, to });
            }
        }
        ui.data_mut(|d| d.remove::<Drag>(drag_id));
    }

    paint_overlays(
        ui, &frame, convention, rect, target, axis, scene, view, pointer,
    );
    voxel_under
}

/// Moves the cursor to `point` within the slice's plane (its coordinate across `axis` stays).
fn move_cursor(view: &mut ViewState, point: [f64; 3], axis: usize, dims: [usize; 3]) {
    for a in 0..3 {
        if a != axis {
            view.cursor[a] = point[a].clamp(0.0, dims[a] as f64 - 1e-6);
        }
    }
}

/// Moves the slice across `axis` by `steps` voxels (the cursor moves with it).
fn step_slice(view: &mut ViewState, axis: usize, steps: f64, dims: [usize; 3]) {
    let index = (view.cursor[axis].floor() + steps).clamp(0.0, dims[axis] as f64 - 1.0);
    view.cursor[axis] = index + 0.5;
}

/// Zooms the view across `axis` by `factor`, keeping the point under `pointer` in place.
fn zoom_about(view: &mut ViewState, axis: usize, factor: f64, pointer: Option<Pos2>, rect: Rect) {
    let slice = &mut view.slice_views[axis];
    let zoom = (slice.zoom * factor).clamp(0.1, 200.0);
    let applied = zoom / slice.zoom;
    if let Some(pointer) = pointer {
        // The slice's center sits at the view's center plus pan; scale its offset from the
        // pointer.
        let center = rect.center();
        let from_pointer = [
            center.x as f64 + slice.pan[0] - pointer.x as f64,
            center.y as f64 + slice.pan[1] - pointer.y as f64,
        ];
        slice.pan = [
            pointer.x as f64 + from_pointer[0] * applied - center.x as f64,
            pointer.y as f64 + from_pointer[1] * applied - center.y as f64,
        ];
    }
    slice.zoom = zoom;
}

/// The crop-box edge (axis, low 0 / high 1) within [`EDGE_GRAB`] of `pos`, when the box is on.
fn grabbed_edge(
    frame: &SliceFrame,
    view: &ViewState,
    axis: usize,
    dims: [usize; 3],
    rect: Rect,
    target: [u32; 2],
    pos: Pos2,
) -> Option<(usize, usize)> {
    if !view.clipping.box_on {
        return None;
    }
    let mut best: Option<(f32, (usize, usize))> = None;
    for (edge_axis, bounds) in view.clipping.bounds.iter().enumerate() {
        if edge_axis == axis {
            continue;
        }
        for (bound, fraction) in bounds.iter().enumerate() {
            let mut point = view.cursor;
            point[edge_axis] = *fraction as f64 * dims[edge_axis] as f64;
            let on_screen = to_screen(frame.pixel_of(point), rect, target);
            // The edge is a line across the view, perpendicular to the axis it limits.
            let runs_vertically = frame.step_x[edge_axis].abs() > frame.step_y[edge_axis].abs();
            let distance = if runs_vertically {
                (on_screen.x - pos.x).abs()
            } else {
                (on_screen.y - pos.y).abs()
            };
            if distance <= EDGE_GRAB && best.is_none_or(|(d, _)| distance < d) {
                best = Some((distance, (edge_axis, bound)));
            }
        }
    }
    best.map(|(_, edge)| edge)
}

/// The crosshair, crop box, rulers, name and index, and edge labels.
#[allow(clippy::too_many_arguments)]
fn paint_overlays(
    ui: &Ui,
    frame: &SliceFrame,
    convention: SliceConvention,
    rect: Rect,
    target: [u32; 2],
    axis: usize,
    scene: &Scene,
    view: &ViewState,
    pointer: Option<Pos2>,
) {
    let painter = ui.painter_at(rect);
    let dims = scene.data.volume.dims;
    let cursor = to_screen(frame.pixel_of(view.cursor), rect, target);
    // The crosshair: each line is another view's slice, in its color.
    for other in (0..3).filter(|&a| a != axis) {
        let color = SLICE_COLORS[other].gamma_multiply(0.85);
        let vertical = frame.step_x[other].abs() > frame.step_y[other].abs();
        let line = if vertical {
            [pos2(cursor.x, rect.top()), pos2(cursor.x, rect.bottom())]
        } else {
            [pos2(rect.left(), cursor.y), pos2(rect.right(), cursor.y)]
        };
        painter.line_segment(line, Stroke::new(1.0, color));
    }
    if view.clipping.box_on {
        let bounds = view.clipping.bounds;
        let corner = |fractions: [usize; 3]| {
            let mut point = view.cursor;
            for a in (0..3).filter(|&a| a != axis) {
                point[a] = bounds[a][fractions[a]] as f64 * dims[a] as f64;
            }
            to_screen(frame.pixel_of(point), rect, target)
        };
        let box_rect = Rect::from_two_pos(corner([0, 0, 0]), corner([1, 1, 1]));
        let hovered_edge =
            pointer.and_then(|p| grabbed_edge(frame, view, axis, dims, rect, target, p).map(|_| p));
        let stroke = Stroke::new(
            if hovered_edge.is_some() { 2.5 } else { 1.5 },
            Color32::from_rgb(255, 200, 60),
        );
        painter.rect_stroke(box_rect, 0.0, stroke, egui::StrokeKind::Middle);
        if hovered_edge.is_some() {
            ui.ctx().set_cursor_icon(egui::CursorIcon::Grab);
        }
    }
    for ruler in &view.rulers {
        // Rulers lying in this slice (both ends within half a voxel of its plane).
        let on_plane = |p: [f64; 3]| (p[axis] - view.cursor[axis]).abs() <= 0.5 + 1e-9;
        if on_plane(ruler.from) && on_plane(ruler.to) {
            paint_ruler(ui, frame, rect, target, ruler, scene);
        }
    }
    let index = view.cursor_voxel(dims)[axis];
    painter.text(
        rect.left_top() + vec2(6.0, 4.0),
        Align2::LEFT_TOP,
        match &scene.composite {
            // The slices come from the renderer of one channel: say which.
            Some(_) => format!(
                "{} {index} / {} · channel 0",
                convention.view_name(axis),
                dims[axis]
            ),
            None => format!("{} {index} / {}", convention.view_name(axis), dims[axis]),
        },
        egui::FontId::proportional(13.0),
        SLICE_COLORS[axis],
    );
    let labels = frame.edge_labels(convention);
    let label = |pos: Pos2, align: Align2, text: &str| {
        painter.text(
            pos,
            align,
            text,
            egui::FontId::proportional(13.0),
            Color32::from_gray(200),
        );
    };
    label(
        rect.left_center() + vec2(4.0, 0.0),
        Align2::LEFT_CENTER,
        labels.left,
    );
    label(
        rect.right_center() - vec2(4.0, 0.0),
        Align2::RIGHT_CENTER,
        labels.right,
    );
    label(
        rect.center_top() + vec2(0.0, 4.0),
        Align2::CENTER_TOP,
        labels.top,
    );
    label(
        rect.center_bottom() - vec2(0.0, 4.0),
        Align2::CENTER_BOTTOM,
        labels.bottom,
    );
}

/// A ruler on the slice, with its length.
fn paint_ruler(
    ui: &Ui,
    frame: &SliceFrame,
    rect: Rect,
    target: [u32; 2],
    ruler: &Ruler,
    scene: &Scene,
) {
    let painter = ui.painter_at(rect);
    let from = to_screen(frame.pixel_of(ruler.from), rect, target);
    let to = to_screen(frame.pixel_of(ruler.to), rect, target);
    painter.line_segment([from, to], Stroke::new(2.0, RULER_COLOR));
    painter.circle_filled(from, 3.0, RULER_COLOR);
    painter.circle_filled(to, 3.0, RULER_COLOR);
    let volume = &scene.data.volume;
    painter.text(
        from.lerp(to, 0.5) + vec2(6.0, -6.0),
        Align2::LEFT_BOTTOM,
        volume.with_unit(format!("{:.1}", ruler.length(volume.spacing))),
        egui::FontId::proportional(13.0),
        RULER_COLOR,
    );
}
