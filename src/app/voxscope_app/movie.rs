//! The app's movie (the Movie panel's commands): the view on screen as a keyframe, the
//! shots and channels of the movie planned, Preview played in the central view, and the
//! export started in the background ([`crate::app::movie_export`]).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::super::movie_export::{self, Export};
use super::super::movie_panel::MoviePreview;
use super::super::offscreen::OffscreenSource;
use super::super::saved_view::key_channels;
use super::VoxscopeApp;
use voxscope_scene::{ChannelState, Shot, keyframe_channels, keyframe_path, turntable};

impl VoxscopeApp {
    /// The view on screen as a movie's shot, and the composite's channels as drawn.
    pub(in crate::app) fn current_shot(&self) -> (Shot, Vec<ChannelState>) {
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
    pub(in crate::app) fn add_keyframe(&mut self) -> Result<(), String> {
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
        let numbers = self
            .scene
            .as_ref()
            .map_or_else(Vec::new, crate::app::saved_view::composite_numbers);
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
            if key.draw.channels.fits(&numbers) {
                key_channels(&mut states, &numbers, key, transfer);
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
    pub(in crate::app) fn start_preview(&mut self) -> Result<(), String> {
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
    pub(in crate::app) fn stop_preview(&mut self) {
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
    pub(in crate::app) fn step_preview(&mut self, ctx: &egui::Context) {
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
    pub(in crate::app) fn export_movie(&mut self, ctx: &egui::Context) -> Result<(), String> {
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
    pub(in crate::app) fn move_keyframe(&mut self, from: usize, to: usize) {
        let keys = &mut self.movie.keyframes;
        if from < keys.len() && to < keys.len() {
            let key = keys.remove(from);
            keys.insert(to, key);
        }
    }
}
