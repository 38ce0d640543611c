//! The menu bar with its toolbar, and the status bar. Every item sends a [`Command`]; the
//! layouts and view presets are listed once and shown in both the View menu and the toolbar.

use std::time::Duration;

use egui::Ui;

use super::command::{Command, CommandQueue, ViewPreset, command_button};
use super::dialogs::DialogKind;
use super::jobs::Jobs;
use super::settings::Panel;
use super::settings::{AppSettings, Layout, Tool};
use voxscope_scene::{Scene, VolumeSource};

/// How long a notice (`saved …`) stays in the status bar.
pub const NOTICE_DURATION: Duration = Duration::from_secs(5);

/// The File and View menus, then the toolbar: layouts and view presets.
pub fn menu_bar(ui: &mut Ui, settings: &AppSettings, has_scene: bool, queue: &mut CommandQueue) {
    egui::MenuBar::new().ui(ui, |ui| {
        ui.menu_button("File", |ui| file_menu(ui, settings, has_scene, queue));
        ui.menu_button("View", |ui| view_menu(ui, settings, queue));
        ui.separator();
        for layout in Layout::ALL {
            if ui
                .selectable_label(settings.layout == layout, layout.name())
                .clicked()
            {
                queue.send(Command::SetLayout(layout));
            }
        }
        ui.separator();
        for preset in ViewPreset::ALL {
            if ui.small_button(preset.name()).clicked() {
                queue.send(Command::ViewFrom(preset));
            }
        }
        ui.separator();
        let ruler = settings.tool == Tool::Ruler;
        if ui
            .selectable_label(ruler, "Ruler")
            .on_hover_text("Measure: drag in a slice, or click two points in the 3D view")
            .clicked()
        {
            queue.send(Command::SetTool(if ruler {
                Tool::Navigate
            } else {
                Tool::Ruler
            }));
        }
    });
}

fn file_menu(ui: &mut Ui, settings: &AppSettings, has_scene: bool, queue: &mut CommandQueue) {
    command_button(ui, "Open…", Command::ShowDialog(DialogKind::Open), queue).on_hover_text(
        "A volume file; an OME-Zarr store, N5 container or precomputed volume is a folder: Open folder… or Open path…",
    );
    command_button(
        ui,
        "Open folder…",
        Command::ShowDialog(DialogKind::OpenFolder),
        queue,
    )
    .on_hover_text(
        "A DICOM series, a folder of TIFF/PNG slices, an OME-Zarr store, an N5 container or a precomputed volume",
    );
    ui.menu_button("Open recent", |ui| {
        if settings.recent.is_empty() {
            ui.label("nothing yet");
        }
        for spec in &settings.recent {
            command_button(
                ui,
                spec,
                Command::Open(VolumeSource::from_spec(spec)),
                queue,
            );
        }
    });
    command_button(ui, "Open path…", Command::Browse(DialogKind::Open), queue)
        .on_hover_text("Type a path or a synthetic: spec, or browse folders");
    command_button(ui, "Open URL…", Command::AskUrl, queue).on_hover_text(
        "An OME-Zarr store, N5 container or neuroglancer precomputed volume on an HTTP server, in S3-compatible object storage or a public Google Cloud Storage bucket",
    );
    command_button(
        ui,
        "Open sample",
        Command::Open(VolumeSource::Sample),
        queue,
    );
    ui.separator();
    ui.add_enabled_ui(has_scene, |ui| {
        for (scale, text, hover) in [
            (1, "Save screenshot…", "The view as shown, at the window's pixels"),
            (2, "Save screenshot at 2×…", "The 3D view drawn again at twice its pixels, rulers and axes to scale"),
            (4, "Save screenshot at 4×…", "The 3D view drawn again at four times its pixels, in tiles beyond the GPU's limits"),
        ] {
            if ui.button(text).on_hover_text(hover).clicked() {
                queue.send(Command::SetScreenshotScale(scale));
                queue.send(Command::ShowDialog(DialogKind::SaveScreenshot));
            }
        }
    });
    ui.separator();
    command_button(
        ui,
        "Open view…",
        Command::ShowDialog(DialogKind::OpenView),
        queue,
    )
    .on_hover_text("A view file: its data, camera, transfer functions, settings and layout");
    ui.add_enabled_ui(has_scene, |ui| {
        // Always asks where; Ctrl+S saves again to the view file of this session.
        let shortcut = Command::SaveViewAgain.shortcut().map(|s| ui.ctx().format_shortcut(&s));
        let mut button = egui::Button::new("Save view…");
        if let Some(text) = shortcut {
            button = button.shortcut_text(text);
        }
        if ui
            .add(button)
            .on_hover_text("What is shown and how, as a file that Open view… and `voxscope render --view` read")
            .clicked()
        {
            queue.send(Command::ShowDialog(DialogKind::SaveView));
        }
    });
    ui.separator();
    command_button(
        ui,
        "Save transfer function…",
        Command::ShowDialog(DialogKind::SaveTransfer),
        queue,
    );
    command_button(
        ui,
        "Load transfer function…",
        Command::ShowDialog(DialogKind::LoadTransfer),
        queue,
    );
    ui.add_enabled_ui(has_scene, |ui| {
        command_button(
            ui,
            "Open labels…",
            Command::ShowDialog(DialogKind::OpenLabels),
            queue,
        )
        .on_hover_text("A label volume on the image's grid (NIfTI, NRRD, TIFF, …), drawn over it");
    });
    ui.separator();
    command_button(ui, "Quit", Command::Quit, queue);
}

fn view_menu(ui: &mut Ui, settings: &AppSettings, queue: &mut CommandQueue) {
    for layout in Layout::ALL {
        if ui
            .radio(settings.layout == layout, layout.description())
            .clicked()
        {
            queue.send(Command::SetLayout(layout));
        }
    }
    ui.separator();
    for preset in ViewPreset::ALL {
        command_button(ui, preset.name(), Command::ViewFrom(preset), queue);
    }
    command_button(ui, "Reset camera", Command::ResetCamera, queue);
    ui.separator();
    let mut linear = settings.slice_linear;
    if ui
        .checkbox(&mut linear, "Slices: linear interpolation")
        .changed()
    {
        queue.send(Command::SetSliceLinear(linear));
    }
    let mut planes = settings.show_slice_planes;
    if ui
        .checkbox(&mut planes, "Slices: planes in the 3D view")
        .changed()
    {
        queue.send(Command::ShowSlicePlanes(planes));
    }
    command_button(ui, "Remove all rulers", Command::ClearRulers, queue);
    ui.separator();
    for panel in Panel::ALL {
        let mut shown = settings.panel_shown(panel);
        if ui.checkbox(&mut shown, panel.name()).changed() {
            queue.send(Command::TogglePanel(panel));
        }
    }
}

/// The status bar: the open in progress (with Cancel), an upload, the volume on screen, and
/// the latest notice.
pub fn status_bar(
    ui: &mut Ui,
    jobs: &Jobs,
    scene: Option<&Scene>,
    hovered: Option<[usize; 3]>,
    hovered_labels: Option<&str>,
    notice: Option<&str>,
    queue: &mut CommandQueue,
) {
    ui.horizontal(|ui| {
        if let Some((title, stage, fraction)) = jobs.export_progress() {
            ui.spinner();
            if ui
                .button("Cancel")
                .on_hover_text("Stop writing the movie")
                .clicked()
            {
                queue.send(Command::CancelExport);
            }
            ui.add(
                egui::ProgressBar::new(fraction)
                    .desired_width(160.0)
                    .show_percentage(),
            );
            ui.label(format!("{title}: {stage}"));
            ui.separator();
        }
        if let Some((title, stage, fraction)) = jobs.open_progress() {
            // Fixed-width items first, so Cancel does not move as the text changes.
            ui.spinner();
            if ui.button("Cancel").clicked() {
                queue.send(Command::CancelOpen);
            }
            ui.add(
                egui::ProgressBar::new(fraction)
                    .desired_width(160.0)
                    .show_percentage(),
            );
            ui.label(format!("{title}: {stage}"));
            ui.separator();
        } else if let Some(job) = &jobs.screenshot {
            ui.spinner();
            ui.label(format!("{}: {}", job.title, job.progress.get().0));
            ui.separator();
        } else if let Some((options, _)) = &jobs.uploading {
            ui.spinner();
            ui.label(format!(
                "uploading for the {} renderer…",
                options.kind.name()
            ));
            ui.separator();
        }
        if let Some(refining) = scene.and_then(super::stream_panel::refining_text) {
            // A spinner while bricks are on their way; none for bricks that could not be
            // read (it would repaint an untouched window forever).
            if scene.is_some_and(|s| s.stream_status.as_ref().is_some_and(|s| s.missing > 0)) {
                ui.spinner();
                ui.label(refining);
            } else {
                ui.colored_label(ui.visuals().warn_fg_color, refining);
            }
            ui.separator();
        }
        // The notice first: the confirmation of what was just done must not be pushed past the
        // window's edge by the volume's description, which is cut short instead (in full on
        // hover).
        if let Some(notice) = notice {
            ui.add(egui::Label::new(egui::RichText::new(notice).strong()).truncate())
                .on_hover_text(notice);
            ui.separator();
            ui.ctx().request_repaint_after(Duration::from_millis(500));
        }
        if let Some(text) = scene
            .zip(hovered)
            .and_then(|(s, v)| match &s.composite {
                Some(composite) => composite.describe_voxel(v),
                None => s.data.describe_voxel(v),
            })
            .map(|text| match hovered_labels {
                Some(labels) => format!("{text} · {labels}"),
                None => text,
            })
        {
            ui.add(egui::Label::new(text).truncate());
        } else if let Some(scene) = scene {
            let description = volume_description(scene);
            ui.add(egui::Label::new(&description).truncate())
                .on_hover_text(&description);
        }
    });
}

/// The volume on screen in a line: name, format, size, voxel type, spacing, orientation. A
/// store streamed gives its own size and spacing; the level held in memory for the panels
/// (histogram, slices, probe) follows where it is coarser.
fn volume_description(scene: &Scene) -> String {
    let volume = &scene.data.volume;
    let (dims, spacing) = match scene.renderer.streamer() {
        Some(streamer) => (streamer.shape().dims(), streamer.source().spacing()),
        None => (volume.dims, volume.spacing),
    };
    let mut description = format!(
        "{} · {} · {}×{}×{} {} · spacing {:.3}×{:.3}×{:.3} · {}",
        volume.name,
        volume.format,
        dims[0],
        dims[1],
        dims[2],
        volume.data.voxel_type().name(),
        spacing[0],
        spacing[1],
        spacing[2],
        volume.orientation.describe(),
    );
    if dims != volume.dims {
        let [x, y, z] = volume.dims;
        description.push_str(&format!(" · streamed; panels at {x}×{y}×{z}"));
    }
    description
}
