//! The left panel: DVR or MIP, the opacity (alpha = gray, binary, or a curve of points),
//! volume-rendering presets, opacity scale, colormap, the value window with its presets, and
//! the histogram editor ([`super::transfer_editor`]).

use egui::Ui;

use super::settings::AppSettings;
use super::transfer_editor;
use super::view_state::{ModeLook, ViewState};
use voxscope_octree::{
    Colormap, ControlPoint, DataKind, OpacityCurve, OpacityMode, Preset, labels_transfer,
};
use voxscope_render::RenderMode;
use voxscope_scene::{TransferChoice, TransferRequest, VolumeData, opening_transfer};
use voxscope_volume::ValueWindow;

/// 2-D windows for CT data (Hounsfield units) as level/width pairs radiologists use: they set
/// the colormap's range (and the slices'), not what is transparent.
const CT_WINDOWS: [(&str, f64, f64); 4] = [
    ("Brain", 40.0, 80.0),
    ("Soft tissue", 40.0, 400.0),
    ("Lung", -600.0, 1500.0),
    ("Bone", 400.0, 1800.0),
];

/// Draws the panel; edits `settings` and `window` in place. `data` is the volume's, or with
/// the `composite` shown, the channel being edited.
pub fn show(
    ui: &mut Ui,
    settings: &mut AppSettings,
    view: &mut ViewState,
    data: Option<&VolumeData>,
    composite: bool,
) {
    let mode_before = settings.mode;
    show_panel(ui, settings, &mut view.window, data, composite);
    if settings.mode != mode_before
        && let Some(data) = data.filter(|_| !composite)
    {
        switch_mode_look(settings, view, data);
    }
}

/// The mode changed to `settings.mode`: the panel takes that mode's transfer function (the
/// one it had when last shown, else what a volume opening in that mode gets: for MIP, grays
/// over the default window, [`opening_transfer`]) and keeps the other's for the way back. A
/// label volume keeps its colors (its MIP draws the first label shown, in its color), and a
/// transfer function the user pinned for every volume stays as it is.
fn switch_mode_look(settings: &mut AppSettings, view: &mut ViewState, data: &VolumeData) {
    if matches!(data.kind, DataKind::Labels(_)) || settings.pinned_transfer.is_some() {
        return;
    }
    let next = view.other_mode.take().unwrap_or_else(|| {
        let request = TransferRequest {
            mip: settings.mode == RenderMode::Mip,
            ..TransferRequest::default()
        };
        let transfer = opening_transfer(&data.quantized, data.kind, data.default_window, &request);
        ModeLook {
            transfer: TransferChoice::from(transfer),
            window: transfer.window,
        }
    });
    view.other_mode = Some(ModeLook {
        transfer: settings.transfer,
        window: view.window,
    });
    settings.transfer = next.transfer;
    view.window = next.window;
}

/// The panel's parts, top to bottom: what it edits, how the volume is drawn, the presets, the
/// value window and its presets, a label volume's choice of colors, and the histogram editor.
fn show_panel(
    ui: &mut Ui,
    settings: &mut AppSettings,
    window: &mut ValueWindow,
    data: Option<&VolumeData>,
    composite: bool,
) {
    heading(ui, settings, *window, data, composite);
    ui.add_space(4.0);
    let labels = data.is_some_and(|d| matches!(d.kind, DataKind::Labels(_)));
    look_grid(ui, settings, *window, labels, composite);
    if let Some(data) = data {
        ui.add_space(2.0);
        presets(ui, settings, window, data);
    }
    ui.separator();
    value_window(ui, window, data);
    let Some(data) = data else { return };
    window_presets(ui, window, data);
    if let DataKind::Labels(labels) = data.kind {
        labels_or_values(ui, settings, window, data, labels);
    }
    ui.add_space(4.0);
    transfer_editor::show(ui, settings, window, data);
}

/// The panel's title (the channel's, with the composite shown) and the choice to keep this
/// transfer function for the next volumes.
fn heading(
    ui: &mut Ui,
    settings: &mut AppSettings,
    window: ValueWindow,
    data: Option<&VolumeData>,
    composite: bool,
) {
    match data.filter(|_| composite) {
        Some(data) => ui.heading(format!(
            "Transfer function: channel {}",
            data.volume.series.selected.channel
        )),
        None => ui.heading("Transfer function"),
    };
    let mut keep = settings.pinned_transfer.is_some();
    if ui
        .checkbox(&mut keep, "Keep for the next volumes")
        .on_hover_text(
            "Open the next volumes with this transfer function (its curve, colors and window, in this data's units) instead of the one that fits their data (CT: soft tissue; labels: their colors; else gray over the robust window). Multi-channel files keep their channels' own.",
        )
        .changed()
    {
        settings.pinned_transfer = keep.then(|| settings.transfer.with_window(window));
    }
}

/// How the volume is drawn: DVR or MIP, the opacity, its scale, the shading and the colormap.
fn look_grid(
    ui: &mut Ui,
    settings: &mut AppSettings,
    window: ValueWindow,
    labels: bool,
    composite: bool,
) {
    egui::Grid::new("transfer_grid")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            ui.label("Rendering");
            ui.horizontal(|ui| {
                ui.selectable_value(&mut settings.mode, RenderMode::Dvr, "DVR")
                    .on_hover_text("Direct volume rendering: front-to-back compositing");
                let mip_text = if labels {
                    "For a label volume: the first label along each ray that the transfer function shows (label 0 is transparent), unblended; a maximum of labels would mean nothing"
                } else {
                    "Maximum intensity projection"
                };
                ui.selectable_value(&mut settings.mode, RenderMode::Mip, "MIP")
                    .on_hover_text(mip_text);
            });
            ui.end_row();

            ui.label("Opacity");
            ui.horizontal(|ui| opacity_modes(ui, settings, window));
            ui.end_row();

            if settings.transfer.opacity == OpacityMode::Binary {
                let label = ui.label("Threshold");
                threshold_slider(ui, &mut settings.transfer.threshold, window)
                    .labelled_by(label.id)
                    .on_hover_text("Opaque at and above this value (data units, within the window)");
                ui.end_row();
            }

            let label = ui.label("Opacity scale");
            ui.add(egui::Slider::new(&mut settings.density, 0.01..=1.0).logarithmic(true))
                .labelled_by(label.id)
                .on_hover_text("Multiplies every alpha: below 1 makes dense volumes see-through");
            ui.end_row();

            shading_rows(ui, settings, composite);

            let label = ui.label("Colormap");
            egui::ComboBox::from_id_salt("colormap")
                .selected_text(settings.transfer.colormap.name())
                .show_ui(ui, |ui| {
                    for colormap in Colormap::ALL {
                        ui.selectable_value(
                            &mut settings.transfer.colormap,
                            colormap,
                            colormap.name(),
                        );
                    }
                })
                .response
                .labelled_by(label.id);
            ui.end_row();
        });
}

/// The grid's shading rows: lit or not (DVR only), and the light's terms while lit.
fn shading_rows(ui: &mut Ui, settings: &mut AppSettings, composite: bool) {
    ui.label("Shading");
    let mip = settings.mode == RenderMode::Mip;
    ui.add_enabled(
        !mip,
        egui::Checkbox::new(&mut settings.shading.enabled, "Lit (headlight)"),
    )
    .on_hover_text(if composite {
        "Blinn-Phong lighting from the eye, each channel lit by its own gradient (weighted by its window); DVR only"
    } else {
        "Blinn-Phong lighting from the eye: gradients of the filtered volume (dense, bricks), the voxels' faces (octree and label volumes); DVR only"
    })
    .on_disabled_hover_text(
        "A maximum intensity projection is never shaded: it shows the brightest value along each ray, not a surface. Shading applies to DVR.",
    );
    ui.end_row();

    if settings.shading.enabled && !mip {
        let shading = &mut settings.shading;
        for (name, value, range) in [
            ("Ambient", &mut shading.ambient, 0.0..=1.0),
            ("Diffuse", &mut shading.diffuse, 0.0..=1.0),
            ("Specular", &mut shading.specular, 0.0..=1.0),
            ("Shininess", &mut shading.shininess, 1.0..=100.0),
        ] {
            let label = ui.label(name);
            ui.add(egui::Slider::new(value, range).fixed_decimals(2))
                .labelled_by(label.id);
            ui.end_row();
        }
    }
}

/// The value window's low and high in the data's units (dragged at a 500th of the data's
/// range), kept with high above low.
fn value_window(ui: &mut Ui, window: &mut ValueWindow, data: Option<&VolumeData>) {
    ui.label("Value window (data units)");
    let speed = data.map_or(1.0, |d| {
        let [low, high] = d.quantized.value_range;
        ((high - low) / 500.0).max(1e-6)
    });
    ui.horizontal(|ui| {
        let label = ui.label("low");
        ui.add(egui::DragValue::new(&mut window.low).speed(speed))
            .labelled_by(label.id);
        let label = ui.label("high");
        ui.add(egui::DragValue::new(&mut window.high).speed(speed))
            .labelled_by(label.id);
    });
    if window.high <= window.low {
        window.high = window.low + speed.max(f64::EPSILON * window.low.abs().max(1.0));
    }
}

/// The value window's presets: the file's own (or the percentiles'), the full range, and for
/// CT the radiologists' 2-D windows.
fn window_presets(ui: &mut Ui, window: &mut ValueWindow, data: &VolumeData) {
    ui.horizontal_wrapped(|ui| {
        if ui
            .button("Auto")
            .on_hover_text("The file's own window where it has one, else the 0.5–99.5 percentiles")
            .clicked()
        {
            *window = data.default_window;
        }
        if ui.button("Full range").clicked() {
            let [low, high] = data.quantized.value_range;
            if high > low {
                *window = ValueWindow { low, high };
            }
        }
        if data.kind == DataKind::Ct {
            for (name, level, width) in CT_WINDOWS {
                if ui
                    .button(format!("{name} L{level}/W{width}"))
                    .on_hover_text(format!(
                        "2-D window: level {level} HU, width {width} HU (colormap and slices)"
                    ))
                    .clicked()
                {
                    *window = ValueWindow {
                        low: level - width / 2.0,
                        high: level + width / 2.0,
                    };
                }
            }
        }
    });
}

/// A label volume of `labels` distinct values: drawn as labels (categorical colors) or as
/// values (grays), and the button that switches to the other.
fn labels_or_values(
    ui: &mut Ui,
    settings: &mut AppSettings,
    window: &mut ValueWindow,
    data: &VolumeData,
    labels: usize,
) {
    ui.horizontal_wrapped(|ui| {
        ui.small(format!("Label volume: {labels} distinct values."));
        let as_labels = labels_transfer(&data.quantized);
        let shown =
            settings.transfer == TransferChoice::from(as_labels) && *window == as_labels.window;
        if shown {
            ui.small("Drawn as labels.");
            if ui
                .button("Show values")
                .on_hover_text("Alpha = gray over the volume's window: the values' magnitudes in grays (still sampled at the nearest voxel, as categories)")
                .clicked()
            {
                let values = voxscope_octree::TransferFunction::gray(data.default_window);
                *window = values.window;
                settings.transfer = values.into();
            }
        } else if ui
            .button("Show labels")
            .on_hover_text("Categorical colors per value, label 0 transparent")
            .clicked()
        {
            *window = as_labels.window;
            settings.transfer = as_labels.into();
        }
    });
}

/// Gray, Binary and Points. Choosing Points turns what is shown into a curve to edit: the
/// gray ramp over the window, or the binary step at its threshold.
fn opacity_modes(ui: &mut Ui, settings: &mut AppSettings, window: ValueWindow) {
    let opacity = &mut settings.transfer.opacity;
    ui.selectable_value(opacity, OpacityMode::Gray, "Gray")
        .on_hover_text("Alpha equals the windowed gray value (the paper's default)");
    ui.selectable_value(opacity, OpacityMode::Binary, "Binary")
        .on_hover_text("Transparent below the threshold, opaque above");
    let is_points = matches!(opacity, OpacityMode::Points(_));
    if ui
        .selectable_label(is_points, "Points")
        .on_hover_text(
            "A curve of control points on the histogram: click to add, drag to move, right-click to delete",
        )
        .clicked()
        && !is_points
    {
        let curve = match *opacity {
            OpacityMode::Binary => {
                let at = window.low + settings.transfer.threshold as f64 * (window.high - window.low);
                let before = at - (window.high - window.low) * 1e-3;
                OpacityCurve::new(&[ControlPoint::new(before, 0.0), ControlPoint::new(at, 1.0)])
                    .unwrap_or_else(|_| OpacityCurve::ramp(window.low, window.high, 1.0))
            }
            _ => OpacityCurve::ramp(window.low, window.high, 1.0),
        };
        *opacity = OpacityMode::Points(curve);
    }
}

/// The volume-rendering presets that fit the data, each drawn as its curve over the data's
/// values; a click applies it (curve, colors and window).
fn presets(ui: &mut Ui, settings: &mut AppSettings, window: &mut ValueWindow, data: &VolumeData) {
    ui.horizontal_wrapped(|ui| {
        ui.label("Presets");
        for preset in Preset::ALL {
            if preset.is_ct() && data.kind != DataKind::Ct {
                continue;
            }
            let transfer = preset.transfer(&data.quantized, settings.transfer.colormap);
            let response = transfer_editor::preset_button(ui, preset.label(), &transfer, data);
            if response.clicked() {
                *window = transfer.window;
                settings.transfer = transfer.into();
            }
        }
    });
}

/// The binary threshold in the data's units, as the window and the histogram show values,
/// though it is kept as a fraction of the window (so it follows the window, as the
/// histogram's handle does).
pub fn threshold_slider(ui: &mut Ui, threshold: &mut f32, window: ValueWindow) -> egui::Response {
    let width = window.high - window.low;
    let mut value = window.low + *threshold as f64 * width;
    let digits = if width >= 100.0 {
        0
    } else if width >= 1.0 {
        2
    } else {
        4
    };
    let response =
        ui.add(egui::Slider::new(&mut value, window.low..=window.high).fixed_decimals(digits));
    if response.changed() && width > 0.0 {
        *threshold = ((value - window.low) / width).clamp(0.0, 1.0) as f32;
    }
    response
}
