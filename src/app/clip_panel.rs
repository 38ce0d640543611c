//! The clipping controls of the Octree panel: a crop box (six limits) and one clip plane
//! (typed, or through the cursor facing the view, flipped with a click).

use egui::Ui;
use glam::DVec3;

use super::view_state::Clipping;
use voxscope_octree::ClipPlane;
use voxscope_render::Camera;

/// What the plane's quick settings need of the volume and the view.
pub struct ClipContext {
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Physical size of the volume along x, y, z.
    pub extent: [f64; 3],
    /// The shared cursor, voxel space.
    pub cursor: [f64; 3],
    /// The 3D view's camera.
    pub camera: Camera,
}

/// Draws the section; edits `clipping`.
pub fn show(ui: &mut Ui, clipping: &mut Clipping, context: &ClipContext) {
    let active = clipping.box_on || clipping.plane_on;
    egui::CollapsingHeader::new(if active {
        "Clipping (on)"
    } else {
        "Clipping"
    })
    .id_salt("clipping")
    .show(ui, |ui| {
        ui.checkbox(&mut clipping.box_on, "Crop box")
            .on_hover_text("Keep only the part of the volume inside these fractions of each axis; the slice views show its edges, which can be dragged");
        ui.add_enabled_ui(clipping.box_on, |ui| {
            egui::Grid::new("crop_box").num_columns(3).show(ui, |ui| {
                for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
                    let [low, high] = &mut clipping.bounds[axis];
                    ui.label(name);
                    let low_label = format!("{name} low");
                    let high_label = format!("{name} high");
                    let max_low = *high - 0.001;
                    ui.add(
                        egui::DragValue::new(low)
                            .range(0.0..=max_low)
                            .speed(0.002)
                            .fixed_decimals(3),
                    )
                    .on_hover_text(&low_label);
                    let min_high = *low + 0.001;
                    ui.add(
                        egui::DragValue::new(high)
                            .range(min_high..=1.0)
                            .speed(0.002)
                            .fixed_decimals(3),
                    )
                    .on_hover_text(&high_label);
                    ui.end_row();
                }
            });
            if ui.small_button("Whole volume").clicked() {
                clipping.bounds = [[0.0, 1.0]; 3];
            }
        });
        ui.separator();
        ui.checkbox(&mut clipping.plane_on, "Clip plane")
            .on_hover_text("Keep the side of a plane where normal · p ≥ d (p: 0…1 along each axis)");
        ui.add_enabled_ui(clipping.plane_on, |ui| {
            ui.horizontal(|ui| {
                ui.label("normal");
                for component in &mut clipping.plane.normal {
                    ui.add(egui::DragValue::new(component).speed(0.01).fixed_decimals(2));
                }
                ui.label("d");
                ui.add(
                    egui::DragValue::new(&mut clipping.plane.distance)
                        .speed(0.005)
                        .fixed_decimals(3),
                );
            });
            if clipping.plane.normal == [0.0; 3] {
                clipping.plane.normal = [0.0, 0.0, 1.0];
            }
            ui.horizontal(|ui| {
                if ui
                    .button("Through cursor, facing the view")
                    .on_hover_text("Cut away what lies between the eye and the cursor")
                    .clicked()
                {
                    clipping.plane = plane_facing_view(context);
                    clipping.plane_on = true;
                }
                if ui.button("Flip side").clicked() {
                    let plane = &mut clipping.plane;
                    plane.normal = plane.normal.map(|n| -n);
                    plane.distance = -plane.distance;
                }
            });
        });
    });
}

/// The plane through the cursor whose normal is the view direction: it keeps what lies
/// beyond the cursor, seen from the eye. In normalized coordinates `p = voxel / dims`, a world
/// normal `n` becomes `n ⊙ extent`.
pub fn plane_facing_view(context: &ClipContext) -> ClipPlane {
    let frame = context.camera.frame(context.extent, 1.0);
    let normal = frame.forward * DVec3::from(context.extent);
    let normal = normal / normal.abs().max_element().max(f64::MIN_POSITIVE);
    let cursor = DVec3::from(context.cursor) / DVec3::from(context.dims.map(|d| d as f64));
    ClipPlane {
        normal: normal.as_vec3().to_array(),
        distance: normal.dot(cursor) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_view_plane_keeps_what_lies_beyond_the_cursor() {
        let context = ClipContext {
            dims: [100, 50, 20],
            extent: [100.0, 100.0, 40.0],
            cursor: [50.0, 25.0, 10.0],
            camera: Camera::default(),
        };
        let plane = plane_facing_view(&context);
        let frame = context.camera.frame(context.extent, 1.0);
        let keeps = |voxel: DVec3| {
            let p = voxel / DVec3::new(100.0, 50.0, 20.0);
            let n = DVec3::from(plane.normal.map(f64::from));
            n.dot(p) >= plane.distance as f64
        };
        let center = DVec3::new(50.0, 25.0, 10.0);
        // A step along the view direction, in voxels.
        let step = frame.forward / DVec3::new(1.0, 2.0, 2.0) * 5.0;
        assert!(keeps(center + step), "beyond the cursor is kept");
        assert!(
            !keeps(center - step),
            "between the eye and the cursor is cut"
        );
    }
}
