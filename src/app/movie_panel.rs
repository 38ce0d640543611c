//! The Movie panel (View ▸ Movie panel): keyframes taken from the view on screen (each a
//! [`SavedView`]), reordered and deleted; frames per segment, frames per second, size and the
//! output; Preview plays the camera path in the central view; Export draws and writes the
//! movie in the background ([`super::movie_export`]) with a progress bar and Cancel in the
//! status bar. One keyframe makes a turntable from it (a full turn in "frames per segment"
//! frames); two or more a path through them, as `voxscope movie --keyframes` draws it.

use std::time::Instant;

use egui::Ui;
use voxscope_scene::{ChannelState, SavedView, Shot};

use super::command::{Command, CommandQueue};
use super::dialogs::DialogKind;

/// What the movie will be: its keyframes and how it is written.
#[derive(Debug, Clone, PartialEq)]
pub struct MoviePlan {
    /// The views the camera passes through, in order.
    pub keyframes: Vec<SavedView>,
    /// Frames from one keyframe to the next (with one keyframe: frames of the turn).
    pub frames_per_segment: u32,
    pub fps: f64,
    /// Width and height of the frames, in pixels.
    pub size: [u32; 2],
    /// Where the movie goes: .gif, .webp, .png (animated), .mp4, or a folder of PNGs.
    pub output: String,
}

impl Default for MoviePlan {
    fn default() -> Self {
        Self {
            keyframes: Vec::new(),
            frames_per_segment: 60,
            fps: 30.0,
            size: [1024, 768],
            output: String::new(),
        }
    }
}

/// The camera path played in the central view, and what was on screen before it.
pub struct MoviePreview {
    pub(in crate::app) shots: Vec<Shot>,
    pub(in crate::app) channels: Vec<Vec<ChannelState>>,
    pub(in crate::app) fps: f64,
    pub(in crate::app) started: Instant,
    pub(in crate::app) shown: Option<usize>,
    pub(in crate::app) before: (Shot, Vec<ChannelState>),
}

/// The Movie panel, a window over the central view while shown.
pub fn show(
    ctx: &egui::Context,
    plan: &mut MoviePlan,
    open: &mut bool,
    state: PanelState,
    queue: &mut CommandQueue,
) {
    egui::Window::new("Movie")
        .open(open)
        .default_width(300.0)
        .resizable(false)
        .show(ctx, |ui| contents(ui, plan, state, queue));
}

/// What the panel shows beside the plan.
#[derive(Debug, Clone, Copy)]
pub struct PanelState {
    pub has_scene: bool,
    pub previewing: bool,
    pub exporting: bool,
}

fn contents(ui: &mut Ui, plan: &mut MoviePlan, state: PanelState, queue: &mut CommandQueue) {
    ui.add_enabled_ui(state.has_scene, |ui| {
        if ui
            .button("Add keyframe")
            .on_hover_text("The view on screen: camera, transfer function, level, clipping")
            .clicked()
        {
            queue.send(Command::AddKeyframe);
        }
    });
    let count = plan.keyframes.len();
    if count == 0 {
        ui.label("No keyframes yet: set up a view and add it.");
    }
    for (index, key) in plan.keyframes.iter().enumerate() {
        ui.horizontal(|ui| {
            let camera = key.draw.camera;
            ui.label(format!(
                "{}. azimuth {:.0}°, elevation {:.0}°, distance {:.2}",
                index + 1,
                camera.azimuth_deg,
                camera.elevation_deg,
                camera.distance
            ));
            if ui
                .add_enabled(index > 0, egui::Button::new("Up").small())
                .on_hover_text("Move it earlier")
                .clicked()
            {
                queue.send(Command::MoveKeyframe {
                    from: index,
                    to: index - 1,
                });
            }
            if ui
                .add_enabled(index + 1 < count, egui::Button::new("Down").small())
                .on_hover_text("Move it later")
                .clicked()
            {
                queue.send(Command::MoveKeyframe {
                    from: index,
                    to: index + 1,
                });
            }
            if ui
                .small_button("Delete")
                .on_hover_text("Delete this keyframe")
                .clicked()
            {
                queue.send(Command::DeleteKeyframe(index));
            }
        });
    }
    if count == 1 {
        ui.weak("One keyframe: a turntable from it.");
    }
    ui.separator();
    egui::Grid::new("movie_grid").num_columns(2).show(ui, |ui| {
        ui.label(if count == 1 {
            "Frames of the turn"
        } else {
            "Frames per segment"
        });
        ui.add(egui::DragValue::new(&mut plan.frames_per_segment).range(1..=100_000));
        ui.end_row();
        ui.label("Frames per second");
        ui.add(
            egui::DragValue::new(&mut plan.fps)
                .range(1.0..=240.0)
                .speed(0.5),
        );
        ui.end_row();
        ui.label("Size");
        ui.horizontal(|ui| {
            ui.add(egui::DragValue::new(&mut plan.size[0]).range(1..=16384));
            ui.label("×");
            ui.add(egui::DragValue::new(&mut plan.size[1]).range(1..=16384));
        });
        ui.end_row();
        ui.label("Output");
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut plan.output)
                    .hint_text("movie.webp, .gif, .png, .mp4 or a folder")
                    .desired_width(170.0),
            );
            if ui.button("Choose…").clicked() {
                queue.send(Command::ShowDialog(DialogKind::MovieOutput));
            }
        });
        ui.end_row();
    });
    ui.separator();
    ui.horizontal(|ui| {
        let ready = state.has_scene && count > 0;
        if state.previewing {
            if ui.button("Stop preview").clicked() {
                queue.send(Command::StopPreview);
            }
        } else if ui
            .add_enabled(ready, egui::Button::new("Preview"))
            .on_hover_text("Play the camera path in the view")
            .clicked()
        {
            queue.send(Command::PreviewMovie);
        }
        if ui
            .add_enabled(
                ready && !state.exporting && !plan.output.trim().is_empty(),
                egui::Button::new("Export"),
            )
            .on_hover_text("Draw and write the movie in the background")
            .clicked()
        {
            queue.send(Command::ExportMovie);
        }
    });
}
