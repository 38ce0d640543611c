//! Where every [`Command`] is carried out, and the file dialogs and browser that end in one:
//! one place for each action, whichever menu, toolbar button, shortcut, drop or test sent it
//! (rerun's `command_handling.rs`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::command::Command;
use super::dialogs::DialogAnswer;
use super::dialogs::{self, DialogKind, NOT_SHOWN_WITHIN};
use super::file_browser::FileBrowser;
use super::settings::AppSettings;
use super::url_dialog::UrlDialog;
use super::view_file;
use super::viewport;
use super::voxscope_app::VoxscopeApp;
use voxscope_scene::FrameKey;
use voxscope_scene::Job;
use voxscope_scene::{FrameChange, TransferRequest, VolumeSource, prepare_scene};

impl VoxscopeApp {
    /// Carries out `command` now. Menus, toolbar and shortcuts queue theirs and the app runs
    /// them after the frame's UI; tests call this directly.
    pub fn run_command(&mut self, command: Command, ctx: &egui::Context) {
        match command {
            Command::ShowFrame(selection) => self.show_frame(
                FrameKey {
                    time: selection.time,
                    channel: Some(selection.channel),
                },
                ctx,
            ),
            Command::ShowComposite => self.show_composite(ctx),
            Command::ShowTime(time) => self.show_time(time, ctx),
            Command::SelectChannel(index) => self.select_channel(index),
            Command::Open(source) => self.open(source, None, ctx),
            Command::ShowDialog(kind) if self.no_desktop_dialogs => self.browse(kind, ctx),
            Command::ShowDialog(kind) => self.show_dialog(kind, ctx),
            Command::Browse(kind) => self.browse(kind, ctx),
            Command::AskUrl => self.url_dialog = Some(UrlDialog::default()),
            Command::CancelOpen => self.jobs.cancel_open(),
            Command::SaveScreenshot(path) => self.reporting(|app| {
                app.save_screenshot(&path, ctx.pixels_per_point())
                    .map(|()| Some(app.saved(&path, "screenshot")))
            }),
            Command::SaveScaledScreenshot { path, scale } => {
                self.reporting(|app| app.save_scaled_screenshot(path, scale, ctx).map(|()| None))
            }
            Command::SetScreenshotScale(scale) => self.screenshot_scale = scale.max(1),
            Command::SaveTransfer(path) => self.reporting(|app| {
                app.save_transfer(&path)
                    .map(|()| Some(app.saved(&path, "transfer function")))
                    .map_err(|e| e.to_string())
            }),
            Command::LoadTransfer(path) => self.reporting(|app| {
                app.load_transfer(&path)
                    .map(|()| Some(format!("loaded {}", path.display())))
                    .map_err(|e| e.to_string())
            }),
            Command::OpenLabels(path) => self.labels.add_file(&path.display().to_string()),
            Command::SaveView(path) => {
                self.reporting(|app| app.save_view(path, ctx).map(|()| None))
            }
            Command::SaveViewAgain => match self.last_view_file.clone() {
                Some(path) => self.reporting(|app| app.save_view(path, ctx).map(|()| None)),
                None => self
                    .commands
                    .send(Command::ShowDialog(DialogKind::SaveView)),
            },
            Command::OpenView(path) => {
                let wake = ctx.clone();
                self.jobs.view_file =
                    Some(view_file::read_job(path, move || wake.request_repaint()));
            }
            Command::AddKeyframe => self.reporting(|app| app.add_keyframe().map(|()| None)),
            Command::MoveKeyframe { from, to } => self.move_keyframe(from, to),
            Command::DeleteKeyframe(index) => {
                if index < self.movie.keyframes.len() {
                    self.movie.keyframes.remove(index);
                }
            }
            Command::SetMovieOutput(path) => self.movie.output = path.display().to_string(),
            Command::PreviewMovie => self.reporting(|app| app.start_preview().map(|()| None)),
            Command::StopPreview => self.stop_preview(),
            Command::ExportMovie => self.reporting(|app| app.export_movie(ctx).map(|()| None)),
            Command::CancelExport => {
                if let Some(job) = &self.jobs.exporting {
                    job.progress.cancel();
                }
            }
            Command::SetLayout(layout) => self.settings.layout = layout,
            Command::ViewFrom(preset) => {
                let (azimuth, elevation) = preset.angles();
                self.settings.camera = viewport::preset(&self.settings.camera, azimuth, elevation);
            }
            Command::ResetCamera => self.settings.camera = Default::default(),
            Command::TogglePanel(panel) => self.settings.toggle_panel(panel),
            Command::SetTool(tool) => self.settings.tool = tool,
            Command::SetSliceLinear(linear) => self.settings.slice_linear = linear,
            Command::ShowSlicePlanes(show) => self.settings.show_slice_planes = show,
            Command::ClearRulers => self.view.rulers.clear(),
            Command::DismissError => self.error = None,
            Command::Quit => ctx.send_viewport_cmd(egui::ViewportCommand::Close),
        }
    }

    /// Runs `action`, a command that can fail, and tells its outcome: the notice it returns
    /// (what was saved or loaded) or its error.
    fn reporting(&mut self, action: impl FnOnce(&mut Self) -> Result<Option<String>, String>) {
        match action(self) {
            Ok(Some(notice)) => self.notify(notice),
            Ok(None) => {}
            Err(message) => self.fail(message),
        }
    }

    /// Shows the composite of the time point on screen.
    fn show_composite(&mut self, ctx: &egui::Context) {
        if let Some(scene) = &self.scene {
            let time = scene.data.volume.series.selected.time;
            self.show_frame(
                FrameKey {
                    time,
                    channel: None,
                },
                ctx,
            );
        }
    }

    /// Shows time point `time` of the channel (or the composite) on screen.
    fn show_time(&mut self, time: usize, ctx: &egui::Context) {
        if let Some(scene) = &self.scene {
            let key = FrameKey {
                time,
                ..FrameKey::of_scene(scene)
            };
            self.show_frame(key, ctx);
        }
    }

    /// Shows frame `key` of the volume on screen with the transfer functions and view it has
    /// now: at once where it was prefetched, else when the background load ends (the
    /// prefetch's own job, where it is loading that frame).
    fn show_frame(&mut self, key: FrameKey, ctx: &egui::Context) {
        let Some(scene) = &self.scene else {
            return;
        };
        if FrameKey::of_scene(scene) == key {
            return;
        }
        let options = scene.options;
        if let Some(opened) = self.prefetch.take(key, options) {
            self.show_opened(opened);
            return;
        }
        if let Some(job) = self.prefetch.take_job(key, options) {
            self.jobs.open(job);
            return;
        }
        let frame = self.frame_change(key);
        let source = scene.data.source.clone();
        self.open(source, Some(frame), ctx);
    }

    /// What loading frame `key` needs to be shown as the view is now.
    pub(super) fn frame_change(&self, key: FrameKey) -> FrameChange {
        let transfer = self.transfer();
        FrameChange {
            selection: key.selection(),
            transfer,
            composite: key.channel.is_none(),
            channels: self.view.composite_channels(transfer),
        }
    }

    /// Makes the composite's channel `index` the one the panel edits: the live transfer
    /// function goes back to the channel it belongs to, and `index`'s comes to the panel.
    pub(super) fn select_channel(&mut self, index: usize) {
        if index >= self.view.channels.len() || index == self.view.active_channel {
            return;
        }
        let live = self.transfer();
        let active = self.view.active_channel;
        if let Some(state) = self.view.channels.get_mut(active) {
            state.transfer = live;
        }
        self.view.active_channel = index;
        let transfer = self.view.channels[index].transfer;
        self.settings.transfer = transfer.into();
        self.view.window = transfer.window;
    }

    /// Opens `source` (frame `frame` of it, else the first) in the background; the current
    /// volume stays until it is ready.
    pub(super) fn open(
        &mut self,
        source: VolumeSource,
        frame: Option<FrameChange>,
        ctx: &egui::Context,
    ) {
        let Some(gpu) = &self.gpu else {
            self.fail("no GPU device");
            return;
        };
        let context = Arc::clone(&gpu.context);
        // A new volume opens with what fits its data, unless the user pinned the transfer
        // function; with the renderer the user chose, not one the last volume called for.
        // In MIP, grays over the default window (a CT preset's colors say what its opacity
        // hides, which a projection does not), as on the command line.
        let request = TransferRequest {
            saved: self.pinned_transfer(),
            mip: self.settings.mode == voxscope_render::RenderMode::Mip,
            ..TransferRequest::default()
        };
        let options = match &frame {
            Some(_) => self.renderer_options(),
            None => self.chosen_renderer_options(),
        };
        let wake = ctx.clone();
        let title = match &frame {
            Some(frame) if frame.composite => format!(
                "all channels, time point {} of {}",
                frame.selection.time,
                source.spec()
            ),
            Some(frame) => format!(
                "channel {}, time point {} of {}",
                frame.selection.channel,
                frame.selection.time,
                source.spec()
            ),
            None => format!("opening {}", source.spec()),
        };
        self.jobs.open(Job::spawn(
            title,
            move || wake.request_repaint(),
            move |progress| prepare_scene(&source, frame, &request, &context, options, progress),
        ));
    }

    /// Starts a native file dialog on its own thread (the UI keeps running).
    pub(super) fn show_dialog(&mut self, kind: DialogKind, ctx: &egui::Context) {
        if self.jobs.dialog.is_some() {
            return;
        }
        let wake = ctx.clone();
        let receiver = dialogs::spawn(
            kind,
            start_directory(&self.settings, kind),
            self.screenshot_scale,
            move || wake.request_repaint(),
        );
        self.jobs.dialog = Some((kind, receiver));
    }

    /// Opens the app's own file browser for `kind`, where its dialog would start
    /// ([`start_directory`]).
    pub(super) fn browse(&mut self, kind: DialogKind, ctx: &egui::Context) {
        self.browser = Some(FileBrowser::new(
            kind,
            start_directory(&self.settings, kind),
            self.screenshot_scale,
            ctx,
        ));
    }

    /// Writes the view on screen to `path` in the background; the status bar says when it is
    /// written, and Ctrl+S saves there from then on.
    fn save_view(&mut self, path: PathBuf, ctx: &egui::Context) -> Result<(), String> {
        let view = self
            .saved_view()
            .ok_or("no volume is shown: there is no view to save")?;
        let absolute = std::path::absolute(&path).unwrap_or_else(|_| path.clone());
        if let Some(folder) = absolute.parent() {
            self.settings.last_save_folder = Some(folder.to_path_buf());
        }
        let wake = ctx.clone();
        self.jobs.view_file = Some(view_file::write_job(view, path, move || {
            wake.request_repaint()
        }));
        Ok(())
    }

    /// Remembers `path`'s folder for the next save, and says what was saved where: the
    /// status bar's confirmation.
    pub(super) fn saved(&mut self, path: &Path, what: &str) -> String {
        let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some(folder) = absolute.parent() {
            self.settings.last_save_folder = Some(folder.to_path_buf());
        }
        format!("{what} saved: {}", absolute.display())
    }

    pub(super) fn dialog_closed(
        &mut self,
        kind: DialogKind,
        answer: DialogAnswer,
        ctx: &egui::Context,
    ) {
        match answer.path {
            Some(path) => self.chosen(kind, path, ctx),
            // Nobody cancels a dialog this fast: the desktop could not show one.
            None if answer.open_for < NOT_SHOWN_WITHIN => {
                eprintln!("voxscope: no desktop file dialog; using voxscope's own browser");
                self.no_desktop_dialogs = true;
                self.browse(kind, ctx);
            }
            None => {}
        }
    }

    /// Acts on a path chosen in a file dialog or the app's browser.
    pub(super) fn chosen(&mut self, kind: DialogKind, path: PathBuf, ctx: &egui::Context) {
        let command = match kind {
            DialogKind::Open | DialogKind::OpenFolder => {
                Command::Open(VolumeSource::from_spec(&path.display().to_string()))
            }
            DialogKind::SaveScreenshot => match std::mem::replace(&mut self.screenshot_scale, 1) {
                1 => Command::SaveScreenshot(path),
                scale => Command::SaveScaledScreenshot { path, scale },
            },
            DialogKind::SaveTransfer => Command::SaveTransfer(path),
            DialogKind::LoadTransfer => Command::LoadTransfer(path),
            DialogKind::OpenLabels => Command::OpenLabels(path),
            DialogKind::SaveView => Command::SaveView(path),
            DialogKind::OpenView => Command::OpenView(path),
            DialogKind::MovieOutput => Command::SetMovieOutput(path),
        };
        self.run_command(command, ctx);
    }

    /// Runs the commands queued this frame, in order.
    pub(super) fn run_queued_commands(&mut self, ctx: &egui::Context) {
        for command in Command::with_shortcuts() {
            if let Some(shortcut) = command.shortcut()
                && ctx.input_mut(|i| i.consume_shortcut(&shortcut))
            {
                self.commands.send(command);
            }
        }
        let dropped = ctx.input(|i| i.raw.dropped_files.first().map(|f| f.path().to_path_buf()));
        if let Some(path) = dropped.filter(|p| !p.as_os_str().is_empty()) {
            self.commands.send(Command::Open(VolumeSource::Spec(
                path.display().to_string(),
            )));
        }
        for command in self.commands.take() {
            self.run_command(command, ctx);
        }
    }
}

/// Where a file dialog of `kind` starts: a save (and loading a transfer function) where the
/// last save went, else in the most recent volume's folder; an open in the most recent
/// volume's folder.
pub(super) fn start_directory(settings: &AppSettings, kind: DialogKind) -> Option<PathBuf> {
    let recent = || {
        settings
            .recent
            .first()
            .and_then(|spec| Path::new(spec).parent().map(Path::to_path_buf))
    };
    match kind {
        // Transfer functions and views are opened from where they were saved.
        DialogKind::SaveScreenshot
        | DialogKind::SaveTransfer
        | DialogKind::LoadTransfer
        | DialogKind::SaveView
        | DialogKind::OpenView
        | DialogKind::MovieOutput => settings
            .last_save_folder
            .clone()
            .filter(|folder| folder.is_dir())
            .or_else(recent),
        DialogKind::Open | DialogKind::OpenFolder | DialogKind::OpenLabels => recent(),
    }
}
