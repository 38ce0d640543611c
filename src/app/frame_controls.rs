//! Channels and time points of the volume on screen (a multi-channel or time-lapse file):
//! the composite of all channels or one channel, a time slider, play / pause at a chosen
//! frame rate, and how many frames to prefetch. A change shows that frame with the view as it
//! is: from the prefetch at once, else once loaded in the background.

use std::time::{Duration, Instant};

use egui::Ui;

use super::command::{Command, CommandQueue};
use super::settings::AppSettings;
use voxscope_scene::MAX_PREFETCH_FRAMES;
use voxscope_volume::{MAX_CHANNELS, Selection, Series};

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
    /// The next time point to ask for, if playing, `frames_per_second` allows one now and no
    /// frame is still loading or being drawn (`waiting`: a slow load or device slows playback
    /// rather than queueing frames, or skipping ones never shown).
    pub fn next(
        &mut self,
        series: &Series,
        frames_per_second: f32,
        waiting: bool,
    ) -> Option<usize> {
        if !self.playing || waiting || series.time_points < 2 {
            return None;
        }
        let period = Duration::from_secs_f32(
            1.0 / frames_per_second.clamp(*FRAME_RATES.start(), *FRAME_RATES.end()),
        );
        if self.last_step.elapsed() < period {
            return None;
        }
        self.last_step = Instant::now();
        Some((series.selected.time + 1) % series.time_points)
    }

    /// How long until [`Self::next`] may give a frame (for the repaint timer).
    pub fn wait(&self, frames_per_second: f32) -> Duration {
        let period = Duration::from_secs_f32(
            1.0 / frames_per_second.clamp(*FRAME_RATES.start(), *FRAME_RATES.end()),
        );
        period.saturating_sub(self.last_step.elapsed())
    }
}

/// What the controls show of the frame on screen.
pub struct Shown<'a> {
    pub series: &'a Series,
    /// Every channel is shown as the composite.
    pub composite: bool,
    /// Frames held ready ahead.
    pub prefetched: usize,
    /// The volume is streamed (the next time point alone is prefetched).
    pub streamed: bool,
    /// The time point the 3D views show whole (another than the selected one while a slow
    /// device draws it).
    pub on_screen: Option<usize>,
}

/// The channel and time controls, shown where the file has more than one of either.
pub fn show(
    ui: &mut Ui,
    shown: &Shown<'_>,
    playback: &mut Playback,
    settings: &mut AppSettings,
    queue: &mut CommandQueue,
) {
    let series = shown.series;
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
                const ALL: &str = "All (composite)";
                let can_composite = series.channels.len() <= MAX_CHANNELS && !shown.streamed;
                egui::ComboBox::from_id_salt("channel")
                    .selected_text(if shown.composite {
                        ALL.to_owned()
                    } else {
                        name(selected.channel)
                    })
                    .show_ui(ui, |ui| {
                        if can_composite && ui.selectable_label(shown.composite, ALL).clicked() {
                            queue.send(Command::ShowComposite);
                        }
                        for index in 0..series.channels.len() {
                            let this = !shown.composite && index == selected.channel;
                            if ui.selectable_label(this, name(index)).clicked() {
                                queue.send(Command::ShowFrame(Selection {
                                    channel: index,
                                    ..selected
                                }));
                            }
                        }
                    })
                    .response
                    .labelled_by(label.id)
                    .on_hover_text(
                        "All channels as the additive composite (drawn by the dense march, unshaded), or one channel with any renderer",
                    );
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
                    queue.send(Command::ShowTime(time));
                }
                ui.end_row();
                if let Some(on_screen) = shown.on_screen.filter(|&t| t != selected.time) {
                    // A slow device: the picture is still the time point before.
                    ui.label("");
                    ui.horizontal(|ui| {
                        ui.spinner();
                        ui.small(format!("drawing {}; showing {on_screen}", selected.time));
                    });
                    ui.end_row();
                }
                ui.label("");
                ui.horizontal(|ui| {
                    let text = if playback.playing { "Pause" } else { "Play" };
                    if ui.button(text).clicked() {
                        playback.playing ^= true;
                        playback.last_step = Instant::now();
                    }
                    ui.add(
                        egui::DragValue::new(&mut settings.frame_rate)
                            .range(FRAME_RATES)
                            .speed(0.1)
                            .suffix(" fps"),
                    )
                    .on_hover_text(
                        "Frames a second while playing (slower where a frame takes longer to load)",
                    );
                });
                ui.end_row();
                let label = ui.label("Prefetch");
                ui.horizontal(|ui| {
                    let hover = if shown.streamed {
                        "A streamed store prefetches the next time point alone (any number above 0): its streaming renderer, another atlas of the GPU budget, reads this view's bricks into RAM ahead"
                    } else {
                        "Frames after this one kept loaded (within 1 GiB), so playing shows them from memory"
                    };
                    ui.add(
                        egui::DragValue::new(&mut settings.prefetch_frames)
                            .range(0..=MAX_PREFETCH_FRAMES)
                            .suffix(" frames"),
                    )
                    .labelled_by(label.id)
                    .on_hover_text(hover);
                    ui.small(format!("{} ready", shown.prefetched));
                });
                ui.end_row();
            }
        });
    ui.separator();
}
