//! Everything a user can ask of the app, as one enum: the menus, the toolbar, keyboard
//! shortcuts, dropped files and the tests all send [`Command`]s, and the app handles each in
//! one place ([`super::VoxscopeApp::run_command`]), so an action exists once.

use std::path::PathBuf;

use egui::{Key, KeyboardShortcut, Modifiers};

use super::dialogs::DialogKind;
use super::settings::{Layout, Panel, Tool};
use voxscope_scene::VolumeSource;
use voxscope_volume::Selection;

/// An action of the app.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Open a volume in the background; the one on screen stays until it is ready.
    Open(VolumeSource),
    /// Show one channel at a time point of the volume on screen, keeping the view.
    ShowFrame(Selection),
    /// Show every channel of the time point on screen as the composite, keeping the view.
    ShowComposite,
    /// Show another time point as the one on screen is shown (the composite, or the same
    /// channel): the time slider and playback.
    ShowTime(usize),
    /// Make the composite's channel `0` the one the transfer function editor edits.
    SelectChannel(usize),
    /// Show the desktop's file dialog (the app's own browser where the desktop has none);
    /// its answer becomes another command.
    ShowDialog(DialogKind),
    /// Show the app's own file browser (File > Open path…).
    Browse(DialogKind),
    /// Ask for the URL of a remote store (File > Open URL…).
    AskUrl,
    /// Stop the open in progress.
    CancelOpen,
    /// Save what the central view shows as PNG.
    SaveScreenshot(PathBuf),
    /// Save the 3D view drawn again at `scale` times its pixels as PNG, in the background.
    SaveScaledScreenshot { path: PathBuf, scale: u32 },
    /// The scale the next screenshot chosen in the file dialog is saved at (1, 2 or 4).
    SetScreenshotScale(u32),
    /// Save the transfer function as RON.
    SaveTransfer(PathBuf),
    /// Load a transfer function saved by [`Command::SaveTransfer`].
    LoadTransfer(PathBuf),
    /// Add a label file on the image's grid to the Labels section, drawn over the image.
    OpenLabels(PathBuf),
    /// Save the view (data, camera, transfer functions, settings, rulers, layout) as a view
    /// file (RON, voxscope-scene's `SavedView`), in the background.
    SaveView(PathBuf),
    /// Save the view to the view file saved or opened last in this session, else ask where
    /// (Ctrl+S).
    SaveViewAgain,
    /// Open a view file: its data in the background, then the rest of the view.
    OpenView(PathBuf),
    /// Add the view on screen as the movie's last keyframe.
    AddKeyframe,
    /// Move the movie's keyframe `from` to place `to`.
    MoveKeyframe { from: usize, to: usize },
    /// Delete the movie's keyframe.
    DeleteKeyframe(usize),
    /// Where the movie goes (the Movie panel's output).
    SetMovieOutput(PathBuf),
    /// Play the movie's camera path in the central view.
    PreviewMovie,
    /// Stop the preview and show the view before it.
    StopPreview,
    /// Draw and write the movie in the background.
    ExportMovie,
    /// Stop the movie being written.
    CancelExport,
    /// Split the central view another way.
    SetLayout(Layout),
    /// Look from the front, side or top.
    ViewFrom(ViewPreset),
    /// The default camera.
    ResetCamera,
    /// Show or hide a side panel.
    TogglePanel(Panel),
    /// Choose what a click in a view does.
    SetTool(Tool),
    /// Remove every ruler.
    ClearRulers,
    /// Slices sample linearly (else the nearest voxel).
    SetSliceLinear(bool),
    /// The Slices layout's 3D view shows the slice planes.
    ShowSlicePlanes(bool),
    /// Hide the error banner.
    DismissError,
    /// Close the window.
    Quit,
}

/// The camera presets: front, side, top (for RAS data: anterior, patient's right, superior).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewPreset {
    Front,
    Side,
    Top,
}

impl ViewPreset {
    pub const ALL: [Self; 3] = [Self::Front, Self::Side, Self::Top];

    /// `Front`, `Side`, `Top`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Front => "Front",
            Self::Side => "Side",
            Self::Top => "Top",
        }
    }

    /// Azimuth and elevation in degrees (top stops short of the pole, where the orbit's
    /// up vector would be undefined).
    pub fn angles(self) -> (f64, f64) {
        match self {
            Self::Front => (0.0, 0.0),
            Self::Side => (90.0, 0.0),
            Self::Top => (0.0, 89.0),
        }
    }
}

impl Command {
    /// The keyboard shortcut of a command, shown in its menu item too.
    pub fn shortcut(&self) -> Option<KeyboardShortcut> {
        match self {
            Self::ShowDialog(DialogKind::Open) => {
                Some(KeyboardShortcut::new(Modifiers::COMMAND, Key::O))
            }
            Self::SaveViewAgain => Some(KeyboardShortcut::new(Modifiers::COMMAND, Key::S)),
            Self::Quit => Some(KeyboardShortcut::new(Modifiers::COMMAND, Key::Q)),
            _ => None,
        }
    }

    /// The commands that have a keyboard shortcut.
    pub fn with_shortcuts() -> [Self; 3] {
        [
            Self::ShowDialog(DialogKind::Open),
            Self::SaveViewAgain,
            Self::Quit,
        ]
    }
}

/// The commands sent during a frame, handled once the frame's UI is built.
#[derive(Debug, Default)]
pub struct CommandQueue(Vec<Command>);

impl CommandQueue {
    /// Queues `command`.
    pub fn send(&mut self, command: Command) {
        self.0.push(command);
    }

    /// Takes the queued commands in the order they were sent.
    pub fn take(&mut self) -> Vec<Command> {
        std::mem::take(&mut self.0)
    }
}

/// A menu item or button that sends `command` when clicked, with its shortcut shown.
pub fn command_button(
    ui: &mut egui::Ui,
    text: &str,
    command: Command,
    queue: &mut CommandQueue,
) -> egui::Response {
    let mut button = egui::Button::new(text);
    if let Some(shortcut) = command.shortcut() {
        button = button.shortcut_text(ui.ctx().format_shortcut(&shortcut));
    }
    let response = ui.add(button);
    if response.clicked() {
        queue.send(command);
    }
    response
}
