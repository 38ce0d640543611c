//! The Labels section of the Transfer function panel, and the label overlays it draws over the
//! 3D panes.
//!
//! An OME-Zarr image with a `labels/` group lists its label images here (read by a job when the
//! image opens); File ▸ Open labels… adds a label file on the image's grid. Each label image has
//! a checkbox (drawn or not), an opacity, and a list of its label values with their colors
//! (`image-label`'s, else the labels palette) and a visibility checkbox each.
//!
//! Drawing happens in a background job, never on the UI thread: the job reads a label volume the
//! first time it is drawn, uploads it for the renderer of the image (voxscope-scene's
//! `label_overlay.rs`: the first-visible-label pass), draws it with the view's camera and
//! settings, waits for the device and turns the slots it read back into one premultiplied RGBA
//! image of every layer, which egui paints over each 3D pane. The job keeps the label volumes and
//! their uploads (handed back and forth with it), so a new view only draws. While the view
//! changes, the overlay of an older view is not shown; the newest view is drawn once the job
//! before it ended. Over a streamed image, a label image of the store streams from its own
//! pyramid (refined until complete on the job's thread); its label values are listed where
//! `image-label` gives their colors.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use egui::{Color32, ColorImage, RichText, TextureHandle, TextureOptions, Ui};

use super::AppGpu;
use super::central::{PaneKind, pane_kinds};
use super::settings::AppSettings;
use super::view_state::ViewState;
use voxscope_render::{
    Camera, GpuContext, RenderSettings, RenderTarget, RendererKind, RendererOptions,
};
use voxscope_scene::{
    DEFAULT_LABEL_OPACITY, Job, LabelOptions, LabelOverlay, Scene, SceneError, StreamedLabelLook,
    UploadedLabels, VolumeSource, open_streamed_label,
};
use voxscope_stream::StreamOptions;
use voxscope_volume::format_value;
use voxscope_volume::ome_zarr::{LabelImage, Pyramid, is_zarr_spec};
use voxscope_volume::remote::RemoteOptions;

mod drawing;
use drawing::draw_overlay;

/// Label values listed at most per label image (the rest are drawn, not listed).
const LISTED_LABELS: usize = 1000;

/// The longest a streamed label image's view is refined (on the drawing job's thread).
const STREAMED_LABELS_WAIT: Duration = Duration::from_secs(30);

/// The label layers of the image on screen, their overlay, and the jobs that make it.
#[derive(Default)]
pub struct LabelLayers {
    /// The image the layers belong to: its spec and its grid in memory.
    image: Option<(String, [usize; 3])>,
    /// Reading the image's label images.
    listing: Option<Job<Vec<LabelImage>>>,
    /// The label images and files, in the order drawn (later over earlier).
    pub layers: Vec<LabelLayer>,
    /// The label volumes read and uploaded; `None` while a drawing job holds them.
    cache: Option<OverlayCache>,
    /// Drawing the overlay of a view.
    drawing: Option<Job<DrawingResult>>,
    /// The overlay drawn last, and the view it is of.
    shown: Option<(OverlayKey, TextureHandle)>,
    /// Why the last overlay could not be drawn.
    error: Option<String>,
    /// The view last given to a drawing job (one that failed is not tried again).
    tried: Option<OverlayKey>,
    /// The layers a view file asked for, applied once the image's label images are listed.
    asked: Option<LabelOptions>,
}

/// One label image (or file) of the image on screen.
pub struct LabelLayer {
    /// Its name (a label image's) or path (a file's).
    pub name: String,
    /// Where it comes from.
    source: LayerSource,
    /// Drawn over the image.
    pub enabled: bool,
    /// Its opacity over the image, 0…1 (times each color's alpha).
    pub opacity: f32,
    /// Label values not drawn.
    pub hidden: Vec<f64>,
    /// Its label values and their colors, once read.
    labels: Vec<(f64, [u8; 4])>,
    /// Its label volume, once read (what the status bar reads the hovered label from).
    overlay: Option<Arc<LabelOverlay>>,
}

#[derive(Clone)]
enum LayerSource {
    /// A label image of the OME-Zarr image.
    Image(LabelImage),
    /// A label file on the image's grid.
    File(String),
}

/// What a drawing job keeps between views: each layer's label volume and its upload.
#[derive(Default)]
struct OverlayCache {
    loaded: HashMap<String, Arc<LabelOverlay>>,
    uploaded: HashMap<String, (UploadKey, UploadedLabels)>,
}

/// What an upload of a layer depends on.
#[derive(Clone, PartialEq)]
struct UploadKey {
    hidden: Vec<f64>,
    renderer: RendererOptions,
    max_level: u32,
}

/// The view an overlay is of.
#[derive(Clone, PartialEq)]
struct OverlayKey {
    size: [u32; 2],
    camera: Camera,
    settings: RenderSettings,
    renderer: RendererOptions,
    image: (String, [usize; 3]),
    /// The image's voxel size (the labels are drawn on its grid).
    spacing: [f64; 3],
    layers: Vec<(String, Vec<f64>, f32)>,
}

/// A drawn overlay: its view, the image, and each layer's labels and colors.
struct DrawnOverlay {
    key: OverlayKey,
    image: ColorImage,
    layers: Vec<DrawnLayer>,
}

/// A layer of a drawn overlay: its label volume and its labels' colors.
struct DrawnLayer {
    name: String,
    /// None where it streams (its labels are not read whole).
    overlay: Option<Arc<LabelOverlay>>,
    labels: Vec<(f64, [u8; 4])>,
}

/// What a drawing job hands back: the label volumes and uploads, and the overlay.
type DrawingResult = (OverlayCache, Result<DrawnOverlay, String>);

impl LabelLayers {
    /// Whether a job of the labels runs.
    pub fn is_busy(&self) -> bool {
        self.listing.is_some() || self.drawing.is_some()
    }

    /// Follows the scene on screen: lists a newly opened image's label images, takes in what
    /// jobs finished, and starts drawing the overlay of the view where it is out of date.
    pub fn follow(
        &mut self,
        ctx: &egui::Context,
        gpu: &AppGpu,
        scene: &Scene,
        settings: &AppSettings,
        view: &ViewState,
        pane_sizes: &[[u32; 2]],
    ) {
        let image = match &scene.data.source {
            VolumeSource::Spec(spec) => Some((spec.clone(), scene.data.volume.dims)),
            _ => None,
        };
        if image != self.image {
            self.reset(ctx, image.clone());
        }
        if let Some(job) = &self.listing
            && let Some(result) = job.try_take()
        {
            self.listing = None;
            self.layers = result
                .unwrap_or_default()
                .into_iter()
                .map(|label| LabelLayer::new(label.name.clone(), LayerSource::Image(label)))
                .collect();
        }
        // A view file's layers, once the image they are of is listed.
        if self.listing.is_none()
            && self.image.is_some()
            && let Some(asked) = self.asked.take()
        {
            self.apply(&asked);
        }
        if let Some(job) = &self.drawing
            && let Some(result) = job.try_take()
        {
            self.drawing = None;
            match result {
                Ok((cache, drawn)) => {
                    self.cache = Some(cache);
                    self.take_drawn(ctx, drawn);
                }
                Err(error) => {
                    self.cache = Some(OverlayCache::default());
                    self.error = Some(error.to_string());
                }
            }
        }
        let Some(image) = image else { return };
        let Some(key) = self.view_key(scene, settings, view, pane_sizes, image) else {
            return;
        };
        let current = self.shown.as_ref().is_some_and(|(shown, _)| *shown == key);
        if current || self.drawing.is_some() {
            return;
        }
        // A view that failed is not tried again until it changes.
        if self.error.is_some() && self.tried.as_ref() == Some(&key) {
            return;
        }
        let Some(cache) = self.cache.take() else {
            return;
        };
        self.tried = Some(key.clone());
        let sources: Vec<(String, LayerSource)> = self
            .layers
            .iter()
            .filter(|layer| layer.enabled)
            .map(|layer| (layer.name.clone(), layer.source.clone()))
            .collect();
        let device = gpu.offscreen.clone();
        let wake = ctx.clone();
        self.drawing = Some(Job::spawn(
            "label overlay".to_owned(),
            move || wake.request_repaint(),
            move |_| {
                let mut cache = cache;
                let drawn = device
                    .context()
                    .and_then(|context| draw_overlay(&context, &mut cache, &sources, key));
                Ok::<_, SceneError>((cache, drawn))
            },
        ));
    }

    /// Forgets the layers of the last image and lists the label images of `image`.
    fn reset(&mut self, ctx: &egui::Context, image: Option<(String, [usize; 3])>) {
        self.layers.clear();
        self.shown = None;
        self.error = None;
        self.tried = None;
        if self.drawing.is_none() {
            self.cache = Some(OverlayCache::default());
        }
        self.listing = image
            .as_ref()
            .filter(|(spec, _)| is_zarr_spec(spec))
            .map(|(spec, _)| {
                let spec = spec.clone();
                let wake = ctx.clone();
                Job::spawn(
                    format!("labels of {spec}"),
                    move || wake.request_repaint(),
                    move |_| {
                        let pyramid =
                            Pyramid::open_spec(&spec, Default::default(), RemoteOptions::default())
                                .map_err(|e| SceneError::failed(e.to_string()))?;
                        Ok(pyramid.label_images())
                    },
                )
            });
        self.image = image;
    }

    /// The view the overlay must show now, if any layer is drawn and a 3D pane shows.
    fn view_key(
        &self,
        scene: &Scene,
        settings: &AppSettings,
        view: &ViewState,
        pane_sizes: &[[u32; 2]],
        image: (String, [usize; 3]),
    ) -> Option<OverlayKey> {
        let layers: Vec<(String, Vec<f64>, f32)> = self
            .layers
            .iter()
            .filter(|layer| layer.enabled)
            .map(|layer| (layer.name.clone(), layer.hidden.clone(), layer.opacity))
            .collect();
        if layers.is_empty() {
            return None;
        }
        let index = pane_kinds(settings)
            .iter()
            .position(|kind| matches!(kind, PaneKind::Volume))?;
        let size = *pane_sizes.get(index)?;
        if size.contains(&0) {
            return None;
        }
        let kind = match scene.options.kind {
            // The in-memory composite is drawn by the dense march: its labels too (a streamed
            // one's stream, as the scene's renderer does).
            _ if scene.composite.as_ref().is_some_and(|c| !c.is_streamed()) => RendererKind::Dense,
            kind => kind,
        };
        Some(OverlayKey {
            size,
            camera: settings.camera,
            settings: RenderSettings {
                mode: settings.mode,
                // The in-memory composite is drawn at full detail: so are its labels (as the
                // command line and Python draw them).
                max_level: if kind == RendererKind::Dense && scene.composite.is_some() {
                    scene.depth()
                } else {
                    view.max_level.min(scene.depth())
                },
                pixel_lod: settings.pixel_lod,
                opacity_correction: settings.opacity_correction,
                density: settings.density,
                heatmap: false,
                trilinear: settings.trilinear,
                shading: settings.shading,
                clip: view.clipping.clip(),
            },
            renderer: RendererOptions {
                kind,
                ..scene.options
            },
            image,
            spacing: scene.data.volume.spacing,
            layers,
        })
    }

    fn take_drawn(&mut self, ctx: &egui::Context, drawn: Result<DrawnOverlay, String>) {
        match drawn {
            Ok(drawn) => {
                for drawn_layer in drawn.layers {
                    if let Some(layer) = self.layers.iter_mut().find(|l| l.name == drawn_layer.name)
                    {
                        layer.labels = drawn_layer.labels;
                        layer.overlay = drawn_layer.overlay;
                    }
                }
                let texture =
                    ctx.load_texture("label_overlay", drawn.image, TextureOptions::NEAREST);
                self.shown = Some((drawn.key, texture));
                self.error = None;
            }
            Err(error) => {
                self.error = Some(error);
            }
        }
    }

    /// The layers drawn, as a view file keeps them: their names in order, the first one's
    /// opacity and the values any of them hides.
    pub fn drawn_options(&self) -> LabelOptions {
        let drawn: Vec<&LabelLayer> = self.layers.iter().filter(|l| l.enabled).collect();
        let mut hide: Vec<f64> = drawn
            .iter()
            .flat_map(|l| l.hidden.iter().copied())
            .collect();
        hide.sort_by(f64::total_cmp);
        hide.dedup();
        LabelOptions {
            names: drawn.iter().map(|l| l.name.clone()).collect(),
            opacity: drawn.first().map_or(DEFAULT_LABEL_OPACITY, |l| l.opacity),
            hide,
        }
    }

    /// Draws the layers `asked` names (a view file's), with its opacity and hidden values,
    /// once the image on screen has its label images listed (at the next [`Self::follow`]);
    /// a name that is not one of them is a label file on the image's grid.
    pub fn ask(&mut self, asked: LabelOptions) {
        self.asked = Some(asked);
    }

    fn apply(&mut self, asked: &LabelOptions) {
        for name in &asked.names {
            if !self.layers.iter().any(|layer| &layer.name == name) {
                self.add_file(name);
            }
        }
        for layer in &mut self.layers {
            layer.enabled = asked.names.contains(&layer.name);
            if layer.enabled {
                layer.opacity = asked.opacity;
                layer.hidden.clone_from(&asked.hide);
            }
        }
    }

    /// Adds the label file at `path` (on the image's grid) as a layer, drawn.
    pub fn add_file(&mut self, path: &str) {
        if self.image.is_none() || self.layers.iter().any(|layer| layer.name == path) {
            return;
        }
        let mut layer = LabelLayer::new(path.to_owned(), LayerSource::File(path.to_owned()));
        layer.enabled = true;
        self.layers.push(layer);
    }

    /// The labels at `voxel` of the layers drawn (`label 2 (cells)`), for the status bar.
    pub fn describe_at(&self, voxel: [usize; 3]) -> Option<String> {
        let parts: Vec<String> = self
            .layers
            .iter()
            .filter(|layer| layer.enabled)
            .filter_map(|layer| {
                let value = layer.overlay.as_ref()?.value_at(voxel);
                Some(format!("label {} ({})", format_value(value), layer.name))
            })
            .collect();
        (!parts.is_empty()).then(|| parts.join(" · "))
    }

    /// The overlay's texture, where it shows the view that `key_of` the panes would draw now:
    /// what [`paint`] puts over the 3D panes.
    fn current_texture(
        &self,
        scene: &Scene,
        settings: &AppSettings,
        view: &ViewState,
        pane_sizes: &[[u32; 2]],
    ) -> Option<&TextureHandle> {
        let image = self.image.clone()?;
        let key = self.view_key(scene, settings, view, pane_sizes, image)?;
        self.shown
            .as_ref()
            .filter(|(shown, _)| *shown == key)
            .map(|(_, texture)| texture)
    }
}

impl LabelLayer {
    fn new(name: String, source: LayerSource) -> Self {
        Self {
            name,
            source,
            enabled: false,
            opacity: DEFAULT_LABEL_OPACITY,
            hidden: Vec::new(),
            labels: Vec::new(),
            overlay: None,
        }
    }
}

/// Draws the Labels section, where the image has label images (or a label file was added):
/// a checkbox per label image, its opacity, its label values with their colors and visibility.
pub fn show(ui: &mut Ui, labels: &mut LabelLayers) {
    if labels.image.is_none() || labels.layers.is_empty() {
        return;
    }
    ui.heading("Labels");
    ui.small("Drawn over the image: the first visible label along each ray.");
    for layer in &mut labels.layers {
        ui.horizontal(|ui| {
            // A file by its name (its path on hover).
            let shown_name = match &layer.source {
                LayerSource::File(path) => std::path::Path::new(path)
                    .file_name()
                    .map_or_else(|| path.clone(), |n| n.to_string_lossy().into_owned()),
                LayerSource::Image(_) => layer.name.clone(),
            };
            ui.checkbox(&mut layer.enabled, RichText::new(shown_name).strong())
                .on_hover_text(match &layer.source {
                    LayerSource::Image(label) => format!(
                        "{} ({})",
                        label.path,
                        if label.colors.is_empty() {
                            "labels palette".to_owned()
                        } else {
                            format!("{} colors from image-label", label.colors.len())
                        }
                    ),
                    LayerSource::File(path) => path.clone(),
                });
            ui.add(egui::Slider::new(&mut layer.opacity, 0.0..=1.0).text("opacity"));
        });
        if layer.enabled && !layer.labels.is_empty() {
            label_values(ui, layer);
        }
    }
    if labels.drawing.is_some() {
        ui.small("drawing the labels…");
    }
    if let Some(error) = &labels.error {
        ui.colored_label(Color32::from_rgb(230, 120, 100), error);
    }
    ui.small("File > Open labels… adds a label file on the image's grid.");
    ui.separator();
}

/// A layer's label values: a color swatch and a visibility checkbox each, in a scrolled list.
fn label_values(ui: &mut Ui, layer: &mut LabelLayer) {
    egui::ScrollArea::vertical()
        .id_salt(("label_values", layer.name.as_str()))
        .max_height(140.0)
        .show(ui, |ui| {
            for &(value, rgba) in &layer.labels {
                ui.horizontal(|ui| {
                    let mut visible = !layer.hidden.contains(&value);
                    let (rect, _) =
                        ui.allocate_exact_size(egui::vec2(14.0, 14.0), egui::Sense::hover());
                    ui.painter().rect_filled(
                        rect,
                        2.0,
                        Color32::from_rgba_unmultiplied(rgba[0], rgba[1], rgba[2], rgba[3]),
                    );
                    if ui
                        .checkbox(&mut visible, format!("label {}", format_value(value)))
                        .on_hover_text("Drawn (unticked: hidden; rays show the next label behind)")
                        .changed()
                    {
                        if visible {
                            layer.hidden.retain(|&v| v != value);
                        } else {
                            layer.hidden.push(value);
                        }
                    }
                });
            }
        });
}

/// Paints the overlay over every 3D pane, where it shows the view the panes show.
pub fn paint(
    ui: &Ui,
    labels: &LabelLayers,
    scene: &Scene,
    settings: &AppSettings,
    view: &ViewState,
    pane_rects: &[egui::Rect],
    pane_sizes: &[[u32; 2]],
) {
    let Some(texture) = labels.current_texture(scene, settings, view, pane_sizes) else {
        return;
    };
    let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
    for (rect, kind) in pane_rects.iter().zip(pane_kinds(settings)) {
        if matches!(kind, PaneKind::Volume) {
            ui.painter().image(texture.id(), *rect, uv, Color32::WHITE);
        }
    }
}
