//! Channels and time points of the volume on screen (a multi-channel or time-lapse file):
//! which channel is shown, a time slider, and play / pause at a chosen frame rate. A change
//! loads that frame in the background and shows it with the view as it is.

use std::time::{Duration, Instant};

use egui::Ui;

use super::command::{Command, CommandQueue};
use crate::volume::{Selection, Series};

/// Frames a second that playback may ask for.
pub const FRAME_RATES: std::ops::RangeInclusive<f32> = 0.5..=30.0;

/// Playback of a time series.
#[derive(Debug, Clone, Copy)]
pub struct Playback {
    pub playing: bool,
    /// When the last frame was asked for.
    pub last_step: Instant,
}

impl Default for Playback {
    fn default() -> Self {
        Self {
            playing: false,
            last_step: Instant::now(),
        }
    }
}

impl Playback {
    /// The next frame to ask for, if playing, `frames_per_second` allows one now and no frame
    /// is still loading (a slow load slows playback rather than queueing frames).
    pub fn next(
        &mut self,
        series: &Series,
        frames_per_second: f32,
        loading: bool,
    ) -> Option<Selection> {
        if !self.playing || loading || series.time_points < 2 {
            return None;
        }
        let period = Duration::from_secs_f32(
            1.0 / frames_per_second.clamp(*FRAME_RATES.start(), *FRAME_RATES.end()),
        );
        if self.last_step.elapsed() < period {
            return None;
        }
        self.last_step = Instant::now();
        Some(Selection {
            time: (series.selected.time + 1) % series.time_points,
            ..series.selected
        })
    }

    /// How long until [`Self::next`] may give a frame (for the repaint timer).
    pub fn wait(&self, frames_per_second: f32) -> Duration {
        let period = Duration::from_secs_f32(
            1.0 / frames_per_second.clamp(*FRAME_RATES.start(), *FRAME_RATES.end()),
        );
        period.saturating_sub(self.last_step.elapsed())
    }
}

/// The channel and time controls, shown where the file has more than one of either.
pub fn show(
    ui: &mut Ui,
    series: &Series,
    playback: &mut Playback,
    frames_per_second: &mut f32,
    queue: &mut CommandQueue,
) {
    if series.channels.len() < 2 && series.time_points < 2 {
        return;
    }
    let selected = series.selected;
    ui.heading("Channels and time");
    ui.add_space(4.0);
    egui::Grid::new("frame_grid")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            if series.channels.len() > 1 {
                let label = ui.label("Channel");
                let name = |index: usize| match &series.channels[index].name {
                    Some(name) => format!("{index}: {name}"),
                    None => index.to_string(),
                };
                egui::ComboBox::from_id_salt("channel")
                    .selected_text(name(selected.channel))
                    .show_ui(ui, |ui| {
                        for index in 0..series.channels.len() {
                            if ui
                                .selectable_label(index == selected.channel, name(index))
                                .clicked()
                            {
                                queue.send(Command::ShowFrame(Selection {
                                    channel: index,
                                    ..selected
                                }));
                            }
                        }
                    })
                    .response
                    .labelled_by(label.id)
                    .on_hover_text("The channel shown (the file's name where it has one)");
                ui.end_row();
            }
            if series.time_points > 1 {
                let label = ui.label("Time");
                let mut time = selected.time;
                let last = series.time_points - 1;
                let response = ui
                    .add(egui::Slider::new(&mut time, 0..=last).suffix(format!(" / {last}")))
                    .labelled_by(label.id);
                if response.changed() && time != selected.time {
                    queue.send(Command::ShowFrame(Selection { time, ..selected }));
                }
                ui.end_row();
                ui.label("");
                ui.horizontal(|ui| {
                    let text = if playback.playing { "Pause" } else { "Play" };
                    if ui.button(text).clicked() {
                        playback.playing ^= true;
                        playback.last_step = Instant::now();
                    }
                    ui.add(
                        egui::DragValue::new(frames_per_second)
                            .range(FRAME_RATES)
                            .speed(0.1)
                            .suffix(" fps"),
                    )
                    .on_hover_text(
                        "Frames a second while playing (slower where a frame takes longer to load)",
                    );
                });
                ui.end_row();
            }
        });
    ui.separator();
}
