//! Channels and time points of the volume on screen (a multi-channel or time-lapse file):
//! the composite of all channels or one channel, a time slider, play / pause at a chosen
//! frame rate, and how many frames to prefetch. A change shows that frame with the view as it
//! is: from the prefetch at once, else once loaded in the background. Where the image is one
//! of a container's (an HCS plate's fields, a bioformats2raw root's series), the well and
//! field, or the series, are picked here too: another image opens in the background.

use std::sync::Arc;
use std::time::{Duration, Instant};

use egui::Ui;

use super::command::{Command, CommandQueue};
use super::settings::AppSettings;
use voxscope_scene::{MAX_PREFETCH_FRAMES, VolumeSource};
use voxscope_volume::{Container, MAX_CHANNELS, Selection, Series};

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

/// The container the image on screen is one of, and its root as opened: another of its
/// images opens as `ROOT/PATH`.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenContainer {
    pub root: String,
    pub container: Arc<Container>,
}

impl OpenContainer {
    /// The container after `source` opened with `series`: the one it says it is in (opened
    /// at its root), else `previous` where `source` is one of its images (picked here, and
    /// opened at its own path), else none.
    pub fn follow(previous: Option<Self>, source: &VolumeSource, series: &Series) -> Option<Self> {
        let VolumeSource::Spec(spec) = source else {
            return None;
        };
        if let Some(container) = &series.container {
            return Some(Self {
                root: spec.trim_end_matches('/').to_owned(),
                container: container.clone(),
            });
        }
        let previous = previous?;
        let image = spec
            .strip_prefix(previous.root.as_str())?
            .strip_prefix('/')?
            .trim_end_matches('/');
        Some(Self {
            container: Arc::new(previous.container.with_opened(image)?),
            root: previous.root,
        })
    }

    /// The source of the container's image `path`.
    fn source(&self, path: &str) -> VolumeSource {
        VolumeSource::Spec(format!("{}/{path}", self.root))
    }
}

/// What the controls show of the frame on screen.
pub struct Shown<'a> {
    pub series: &'a Series,
    /// The container the image is one of, if any.
    pub container: Option<&'a OpenContainer>,
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
    if series.channels.len() < 2 && series.time_points < 2 && shown.container.is_none() {
        return;
    }
    let selected = series.selected;
    ui.heading(match shown.container.map(|c| c.container.as_ref()) {
        Some(Container::Plate(_)) => "Plate, channels and time",
        Some(Container::Series(_)) => "Series, channels and time",
        None => "Channels and time",
    });
    ui.add_space(4.0);
    egui::Grid::new("frame_grid")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            if let Some(open) = shown.container {
                container_rows(ui, open, queue);
            }
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
                        "All channels as the additive composite (drawn by the dense march, or streamed together), or one channel with any renderer",
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

/// The well and field of a plate, or the series of a bioformats2raw root: picking one opens
/// that image.
fn container_rows(ui: &mut Ui, open: &OpenContainer, queue: &mut CommandQueue) {
    let opened = open.container.opened();
    match open.container.as_ref() {
        Container::Plate(plate) => {
            let (well, field) = opened.rsplit_once('/').unwrap_or((opened.as_str(), ""));
            let label = ui.label("Well");
            egui::ComboBox::from_id_salt("well")
                .selected_text(well)
                .show_ui(ui, |ui| {
                    for (path, fields) in &plate.wells {
                        let text = format!("{path} ({} fields)", fields.len());
                        let clicked = ui
                            .add_enabled(
                                !fields.is_empty(),
                                egui::Button::selectable(path == well, text),
                            )
                            .clicked();
                        if clicked && path != well {
                            queue.send(Command::Open(open.source(&format!("{path}/{}", fields[0]))));
                        }
                    }
                })
                .response
                .labelled_by(label.id)
                .on_hover_text(format!(
                    "The plate{}: rows {}, columns {}; {} wells. Another well opens its first field",
                    plate.name.as_ref().map(|n| format!(" {n}")).unwrap_or_default(),
                    plate.rows.join(" "),
                    plate.columns.join(" "),
                    plate.wells.len()
                ));
            ui.end_row();
            let fields = plate
                .wells
                .iter()
                .find(|(path, _)| path == well)
                .map(|(_, fields)| fields.as_slice())
                .unwrap_or_default();
            let label = ui.label("Field");
            egui::ComboBox::from_id_salt("field")
                .selected_text(field)
                .show_ui(ui, |ui| {
                    for path in fields {
                        if ui.selectable_label(path == field, path).clicked() && path != field {
                            queue.send(Command::Open(open.source(&format!("{well}/{path}"))));
                        }
                    }
                })
                .response
                .labelled_by(label.id)
                .on_hover_text("The well's field (image) shown");
            ui.end_row();
        }
        Container::Series(found) => {
            let name = |index: usize| {
                let entry = &found.series[index];
                let mut text = index.to_string();
                if let Some(name) = &entry.name {
                    text.push_str(&format!(": {name}"));
                }
                if let Some((shape, _)) = &entry.dims {
                    let shape: Vec<String> = shape.iter().map(u64::to_string).collect();
                    text.push_str(&format!(" ({})", shape.join("×")));
                }
                text
            };
            let label = ui.label("Series");
            egui::ComboBox::from_id_salt("series")
                .selected_text(name(found.opened))
                .show_ui(ui, |ui| {
                    for index in 0..found.series.len() {
                        let this = index == found.opened;
                        if ui.selectable_label(this, name(index)).clicked() && !this {
                            queue.send(Command::Open(open.source(&found.series[index].path)));
                        }
                    }
                })
                .response
                .labelled_by(label.id)
                .on_hover_text("The bioformats2raw container's image shown");
            ui.end_row();
        }
    }
}
