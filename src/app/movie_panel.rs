//! The Movie panel (View ▸ Movie panel): keyframes taken from the view on screen (each a
//! [`SavedView`]), reordered and deleted; frames per segment, frames per second, size and the
//! output; Preview plays the camera path in the central view; Export draws and writes the
//! movie in the background ([`super::movie_export`]) with a progress bar and Cancel in the
//! status bar. One keyframe makes a turntable from it (a full turn in "frames per segment"
//! frames); two or more a path through them, as `voxscope movie --keyframes` draws it.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use egui::Ui;
use voxscope_scene::{ChannelState, SavedView, Shot, keyframe_channels, keyframe_path, turntable};

use super::command::{Command, CommandQueue};
use super::dialogs::DialogKind;
use super::movie_export::{self, Export};
use super::offscreen::OffscreenSource;
use super::voxscope_app::VoxscopeApp;

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
    shots: Vec<Shot>,
    channels: Vec<Vec<ChannelState>>,
    fps: f64,
    started: Instant,
    shown: Option<usize>,
    before: (Shot, Vec<ChannelState>),
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

impl VoxscopeApp {
    /// The view on screen as a movie's shot, and the composite's channels as drawn.
    pub(super) fn current_shot(&self) -> (Shot, Vec<ChannelState>) {
        let transfer = self.transfer();
        (
            Shot {
                camera: self.settings.camera,
                settings: self
                    .settings
                    .render_settings(self.view.max_level, self.view.clipping.clip()),
                transfer,
            },
            self.view.composite_channels(transfer),
        )
    }

    /// Adds the view on screen as the last keyframe.
    pub(super) fn add_keyframe(&mut self) -> Result<(), String> {
        let view = self
            .saved_view()
            .ok_or("no volume is shown: there is no view to add")?;
        self.movie.keyframes.push(view);
        Ok(())
    }

    /// The frames of the movie planned, and the composite's channels of each (empty for one
    /// volume): one error line where there is nothing to draw or a keyframe shows other data.
    pub fn movie_shots(&self) -> Result<(Vec<Shot>, Vec<Vec<ChannelState>>), String> {
        let now = self
            .saved_view()
            .ok_or("no volume is shown: open one and add keyframes")?;
        if self.movie.keyframes.is_empty() {
            return Err("the movie has no keyframes: Add keyframe adds the view on screen".into());
        }
        let (current, current_channels) = self.current_shot();
        let depth = self.scene.as_ref().map_or(0, |scene| scene.depth());
        let mut shots = Vec::new();
        let mut channels = Vec::new();
        for (index, key) in self.movie.keyframes.iter().enumerate() {
            if !key.same_data(&now) {
                return Err(format!(
                    "keyframe {} shows {}, not the volume on screen",
                    index + 1,
                    key.open.source.as_deref().unwrap_or("the sample")
                ));
            }
            let transfer = key.transfer().unwrap_or(current.transfer);
            shots.push(Shot {
                camera: key.draw.camera,
                settings: key.render_settings(depth),
                transfer,
            });
            let mut states = current_channels.clone();
            if key.draw.channels.colors.len() == states.len() {
                super::saved_view::key_channels(&mut states, key, transfer);
            }
            channels.push(states);
        }
        let frames = self.movie.frames_per_segment.max(1) as usize;
        Ok(if shots.len() == 1 {
            let turn = turntable(&shots[0], frames);
            let channels = vec![channels[0].clone(); turn.len()];
            (turn, channels)
        } else {
            (
                keyframe_path(&shots, frames),
                keyframe_channels(&channels, frames),
            )
        })
    }

    /// Plays the movie's camera path in the central view, then goes back to the view before.
    pub(super) fn start_preview(&mut self) -> Result<(), String> {
        let (shots, channels) = self.movie_shots()?;
        self.preview = Some(MoviePreview {
            shots,
            channels,
            fps: self.movie.fps,
            started: Instant::now(),
            shown: None,
            before: self.current_shot(),
        });
        Ok(())
    }

    /// Ends the preview and shows the view as it was before it.
    pub(super) fn stop_preview(&mut self) {
        if let Some(preview) = self.preview.take() {
            let (shot, channels) = preview.before;
            self.apply_shot(&shot, &channels);
        }
    }

    /// Whether the movie's camera path is playing in the central view.
    pub fn previewing(&self) -> bool {
        self.preview.is_some()
    }

    /// Shows the preview's frame for the time that has passed (once a frame at most).
    pub(super) fn step_preview(&mut self, ctx: &egui::Context) {
        let Some(preview) = &mut self.preview else {
            return;
        };
        let frame = (preview.started.elapsed().as_secs_f64() * preview.fps) as usize;
        if frame >= preview.shots.len() {
            self.stop_preview();
            return;
        }
        if preview.shown != Some(frame) {
            preview.shown = Some(frame);
            let shot = preview.shots[frame];
            let channels = preview.channels.get(frame).cloned().unwrap_or_default();
            self.apply_shot(&shot, &channels);
        }
        ctx.request_repaint_after(Duration::from_secs_f64(1.0 / self.movie.fps.max(1.0)));
    }

    /// Starts writing the movie planned in the background.
    pub(super) fn export_movie(&mut self, ctx: &egui::Context) -> Result<(), String> {
        if self.jobs.exporting.is_some() {
            return Err("a movie is being written already".into());
        }
        let output = PathBuf::from(self.movie.output.trim());
        if output.as_os_str().is_empty() {
            return Err("the movie has no output: choose a file or folder".into());
        }
        let (shots, channels) = self.movie_shots()?;
        let (Some(scene), Some(gpu)) = (&self.scene, &self.gpu) else {
            return Err("no volume is shown".into());
        };
        let source = OffscreenSource::of_scene(scene);
        let export = Export {
            device: gpu.offscreen.clone(),
            source,
            shots,
            channels,
            size: self.movie.size,
            fps: self.movie.fps,
            output,
        };
        let wake = ctx.clone();
        self.jobs.exporting = Some(movie_export::spawn(export, move || wake.request_repaint()));
        Ok(())
    }

    /// Moves keyframe `from` to `to`.
    pub(super) fn move_keyframe(&mut self, from: usize, to: usize) {
        let keys = &mut self.movie.keyframes;
        if from < keys.len() && to < keys.len() {
            let key = keys.remove(from);
            keys.insert(to, key);
        }
    }
}
