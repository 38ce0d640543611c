//! The Transfer function panel's channel list, shown while the composite is: per channel its
//! name, a color swatch (click to pick a color), a visibility (eye) toggle, and its window; clicking a
//! row makes the transfer function editor below edit that channel. Every edit is live: the
//! central view rewrites the composite's tables, nothing is loaded again.

use egui::{Color32, RichText, Ui};

use super::command::{Command, CommandQueue};
use super::view_state::ViewState;
use voxscope_scene::CompositeScene;
use voxscope_volume::format_value;

/// Draws the list; edits the channels' colors and visibility in `view` and asks for another
/// channel to edit through `queue`.
pub fn show(
    ui: &mut Ui,
    composite: &CompositeScene,
    view: &mut ViewState,
    queue: &mut CommandQueue,
) {
    ui.heading("Channels");
    if composite.is_streamed() {
        ui.small("Streamed together through the GPU budget: colors added, each lit by its own gradient; a hidden channel is not read. Click a row to edit its transfer function.");
    } else {
        ui.small("Drawn together by the dense march: colors added, each lit by its own gradient. Click a row to edit its transfer function.");
    }
    ui.add_space(4.0);
    let active = view.active_channel;
    egui::Grid::new("channel_list")
        .num_columns(4)
        .spacing([6.0, 4.0])
        .striped(true)
        .show(ui, |ui| {
            for (index, state) in view.channels.iter_mut().enumerate() {
                ui.color_edit_button_srgb(&mut state.color)
                    .on_hover_text("The channel's color: black to this color over its window");
                // The eye toggle (egui's fonts have no eye glyph: a checkbox).
                ui.checkbox(&mut state.visible, "")
                    .on_hover_text("Shown (unticked: hidden, adding nothing to the composite)");
                let mut name = RichText::new(format!("{index}: {}", state.name));
                if !state.visible {
                    name = name.color(Color32::GRAY);
                } else if index == active {
                    name = name.strong();
                }
                if ui
                    .selectable_label(index == active, name)
                    .on_hover_text("Edit this channel's window and opacity below")
                    .clicked()
                {
                    queue.send(Command::SelectChannel(index));
                }
                // The active channel's window is the panel's, live.
                let window = if index == active {
                    view.window
                } else {
                    state.transfer.window
                };
                ui.small(format!(
                    "{} – {}",
                    format_value(window.low),
                    format_value(window.high)
                ));
                ui.end_row();
            }
        });
    if composite.is_streamed() {
        ui.small(format!(
            "{} channels streamed (the Streaming panel counts their bricks)",
            composite.channels.len()
        ));
    } else {
        ui.small(format!(
            "{} channels, {} on the GPU",
            composite.channels.len(),
            super::numbers::format_bytes(composite.gpu_bytes())
        ));
    }
    ui.separator();
}
