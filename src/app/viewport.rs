//! One view of the volume in the central panel: what its image depends on ([`DrawKey`]), the
//! mouse controls of the orbit camera and the orientation gizmo. (The pane's images are
//! `central/pane.rs`'s.)

use egui::{Color32, PointerButton, Pos2, Rect, Response, Sense, Stroke, Ui, Vec2, pos2, vec2};
use glam::DVec3;

use voxscope_octree::TransferFunction;
use voxscope_render::{Camera, RenderSettings, SliceSettings};

/// Everything a pane's image depends on; a pane is drawn again when this changes.
// Inline like the transfer function it holds: compared for every pane every frame.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DrawKey {
    /// A 3D view.
    Volume {
        size: [u32; 2],
        camera: Camera,
        settings: RenderSettings,
        transfer: TransferFunction,
        /// Changes with every new scene (volume or renderer).
        scene: u64,
        /// The composite's table generation (0 when one channel is drawn).
        layers: u64,
    },
    /// A slice view.
    Slice {
        settings: SliceSettings,
        size: [u32; 2],
        scene: u64,
    },
}

/// Pixel size of a rect of `points` at `pixels_per_point`.
pub fn pixel_size(rect: Rect, pixels_per_point: f32) -> [u32; 2] {
    let size = rect.size() * pixels_per_point;
    [
        size.x.round().max(1.0) as u32,
        size.y.round().max(1.0) as u32,
    ]
}

/// Degrees of orbit per point of drag.
const ORBIT_DEGREES_PER_POINT: f64 = 0.4;

/// Orbits (left drag), pans (right or middle drag), zooms (wheel) and resets (double-click)
/// `camera` from the pointer over `response`. `extent` is the volume's physical size.
/// Returns true when the camera changed.
pub fn control_camera(camera: &mut Camera, response: &Response, ui: &Ui, extent: [f64; 3]) -> bool {
    let before = *camera;
    if response.double_clicked() {
        *camera = Camera {
            fov_y_deg: camera.fov_y_deg,
            ..Camera::default()
        };
        return *camera != before;
    }
    let delta = response.drag_delta();
    if response.dragged_by(PointerButton::Primary) {
        camera.azimuth_deg =
            (camera.azimuth_deg + delta.x as f64 * ORBIT_DEGREES_PER_POINT).rem_euclid(360.0);
        camera.elevation_deg =
            (camera.elevation_deg + delta.y as f64 * ORBIT_DEGREES_PER_POINT).clamp(-89.0, 89.0);
    } else if response.dragged_by(PointerButton::Secondary)
        || response.dragged_by(PointerButton::Middle)
    {
        let frame = camera.frame(extent, 1.0);
        let radius = 0.5 * DVec3::from(extent).length();
        let world_per_point = 2.0 * camera.distance * radius * frame.tan_half_fov_y
            / response.rect.height().max(1.0) as f64;
        let pan = DVec3::from(camera.pan) - frame.right * (delta.x as f64 * world_per_point)
            + frame.up * (delta.y as f64 * world_per_point);
        camera.pan = pan.to_array();
    }
    if response.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y + i.zoom_delta().ln() * 200.0);
        if scroll != 0.0 {
            camera.distance =
                (camera.distance * (-(scroll as f64) * 0.002).exp()).clamp(0.05, 50.0);
        }
    }
    *camera != before
}

/// The view presets: front, side, top (for RAS data: anterior, patient's right, superior).
pub fn preset(camera: &Camera, azimuth_deg: f64, elevation_deg: f64) -> Camera {
    Camera {
        azimuth_deg,
        elevation_deg,
        pan: [0.0; 3],
        ..*camera
    }
}

/// Draws the world axes as seen by `camera` in the bottom-left corner of `rect`.
/// `labels` name +x, +y, +z (`R A S` for patient data).
pub fn paint_axis_gizmo(ui: &Ui, rect: Rect, camera: &Camera, labels: [&str; 3]) {
    let frame = camera.frame([1.0, 1.0, 1.0], 1.0);
    let length = 28.0;
    let center = rect.left_bottom() + vec2(14.0 + length, -(14.0 + length));
    let colors = [
        Color32::from_rgb(230, 70, 70),
        Color32::from_rgb(80, 200, 90),
        Color32::from_rgb(90, 140, 255),
    ];
    let painter = ui.painter_at(rect);
    painter.circle_filled(center, length + 10.0, Color32::from_black_alpha(110));
    let mut axes: Vec<(f64, Vec2, usize)> = [DVec3::X, DVec3::Y, DVec3::Z]
        .iter()
        .enumerate()
        .map(|(i, axis)| {
            let screen = vec2(axis.dot(frame.right) as f32, -(axis.dot(frame.up) as f32));
            (axis.dot(frame.forward), screen, i)
        })
        .collect();
    // Far axes first, so near ones are drawn over them.
    axes.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (_, screen, i) in axes {
        let tip: Pos2 = center + screen * length;
        painter.line_segment([center, tip], Stroke::new(2.5, colors[i]));
        painter.text(
            center + screen * (length + 8.0),
            egui::Align2::CENTER_CENTER,
            labels[i],
            egui::FontId::proportional(12.0),
            colors[i],
        );
    }
}

/// Allocates a pane of `size` that senses clicks and drags.
pub fn allocate_pane(ui: &mut Ui, size: Vec2) -> Response {
    ui.allocate_response(size, Sense::click_and_drag())
}

/// Where the voxel-space point `voxel` of a volume of `spacing` and physical `extent` appears
/// in a pane `rect` seen by `camera`; `None` behind the eye.
pub fn project(
    camera: &Camera,
    extent: [f64; 3],
    spacing: [f64; 3],
    rect: Rect,
    voxel: [f64; 3],
) -> Option<Pos2> {
    let aspect = (rect.width() / rect.height().max(1.0)) as f64;
    let frame = camera.frame(extent, aspect);
    let world = DVec3::from(voxel) * DVec3::from(spacing) - DVec3::from(extent) * 0.5;
    let toward = world - frame.eye;
    let depth = toward.dot(frame.forward);
    if depth <= 1e-9 {
        return None;
    }
    let ndc_x = toward.dot(frame.right) / (depth * frame.tan_half_fov_y * frame.aspect);
    let ndc_y = toward.dot(frame.up) / (depth * frame.tan_half_fov_y);
    Some(pos2(
        rect.left() + (ndc_x as f32 + 1.0) * 0.5 * rect.width(),
        rect.top() + (1.0 - ndc_y as f32) * 0.5 * rect.height(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_volume_center_projects_to_the_pane_center_and_right_is_minus_x_from_the_front() {
        let camera = Camera {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            ..Camera::default()
        };
        let rect = Rect::from_min_size(pos2(10.0, 20.0), vec2(200.0, 100.0));
        let extent = [100.0, 100.0, 100.0];
        let center = project(&camera, extent, [1.0; 3], rect, [50.0; 3]).expect("in front");
        assert!((center - rect.center()).length() < 1e-3, "{center:?}");
        // From the front, the patient's left (−x) is on the screen's right.
        let left = project(&camera, extent, [1.0; 3], rect, [30.0, 50.0, 50.0]).expect("in front");
        assert!(left.x > center.x);
        let up = project(&camera, extent, [1.0; 3], rect, [50.0, 50.0, 70.0]).expect("in front");
        assert!(up.y < center.y, "superior is up");
    }
}
