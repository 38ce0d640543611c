//! The one place where the app's state and a [`SavedView`] (voxscope-scene's view file, the
//! same the command line's `render --view` and `--save-view` read and write) meet: File ▸ Save
//! view… writes [`VoxscopeApp::saved_view`]; File ▸ Open view… and `voxscope --view V.ron` read
//! the file on a job thread, open its data like any open (in the background) and, once that is
//! on screen, apply the rest ([`VoxscopeApp::show_view_opened`]).
//!
//! What a view holds of the app: the data as given (the path or URL the volume was opened
//! from; an HCS plate's field and a container's series are part of that path), the channel
//! (`all` for the composite) and time point, the camera, the transfer function (for the
//! composite every channel's color, visibility and transfer function), the render settings
//! (mode, level, opacity scale and correction, shading, interpolation, heat map, clip box and
//! plane), the renderer and brick size, the rulers and the layout. The size is the 3D pane's.

use std::path::Path;

use voxscope_octree::TransferFunction;
use voxscope_render::{BUDGET_STEPS, RenderSettings, RendererOptions};
use voxscope_scene::{
    ChannelChoice, ChannelRequest, ChannelState, DrawOptions, FrameChange, Job, OpenOptions,
    Opened, SavedTransfer, SavedView, Shot, TransferChoice, TransferOptions, TransferRequest,
    VIEW_VERSION, ViewRuler, VolumeSource, opening_transfer,
};
use voxscope_stream::StreamOptions;
use voxscope_volume::{Selection, ValueWindow};

use super::settings::Layout;
use super::view_state::{Clipping, Ruler};
use super::voxscope_app::VoxscopeApp;

/// The view file's name of a layout (as `render --save-view` leaves it for the app).
pub fn layout_name(layout: Layout) -> &'static str {
    match layout {
        Layout::Single => "single",
        Layout::LevelGrid => "level-grid",
        Layout::TransferPair => "transfer-pair",
        Layout::Slices => "slices",
    }
}

/// The layout a view file names, if it names one this app knows.
pub fn layout_named(name: &str) -> Option<Layout> {
    Layout::ALL.into_iter().find(|&l| layout_name(l) == name)
}

/// The frame a view opens: its selection, and whether the composite of every channel is
/// shown (no channel chosen, or `all`).
fn view_selection(open: &OpenOptions) -> (Selection, bool) {
    let (channel, composite) = match open.channel {
        None | Some(ChannelChoice::All) => (0, true),
        Some(ChannelChoice::Index(channel)) => (channel, false),
    };
    (
        Selection {
            channel,
            time: open.time,
        },
        composite,
    )
}

impl VoxscopeApp {
    /// The view on screen as a view file holds it (`None` before a volume is shown).
    pub fn saved_view(&self) -> Option<SavedView> {
        let scene = self.scene.as_ref()?;
        let volume = &scene.data.volume;
        let channel = if scene.composite.is_some() {
            Some(ChannelChoice::All)
        } else if volume.series.channel_count() > 1 {
            Some(ChannelChoice::Index(volume.series.selected.channel))
        } else {
            None
        };
        let source = match &scene.data.source {
            VolumeSource::Sample => None,
            VolumeSource::Spec(spec) => Some(spec.clone()),
        };
        let live = self.transfer();
        let channels = match &scene.composite {
            Some(_) => self.view.composite_channels(live),
            None => Vec::new(),
        };
        // A composite's own function is channel 0's (the command line draws it so).
        let transfer = channels.first().map_or(live, |channel| channel.transfer);
        let size = self
            .central
            .pane_sizes()
            .first()
            .map(|&[w, h]| (w, h))
            .filter(|&(w, h)| w > 0 && h > 0)
            .unwrap_or(DrawOptions::default().size);
        // The in-memory composite's renderer is the data's choice (all channels), not one to
        // ask for; a streamed one's is asked for (a small store streams only when asked).
        let streamed = scene.composite.as_ref().is_some_and(|c| c.is_streamed());
        let renderer = (scene.composite.is_none() || streamed).then_some(scene.options.kind);
        // By the file's channel numbers where they are not simply its channels in order (a
        // streamed composite's, or one of a file of more channels than it draws), as the
        // command line's views keep them.
        let numbers = composite_numbers(scene);
        let in_order = numbers.iter().copied().eq(0..volume.series.channel_count());
        let request = match &scene.composite {
            Some(_) if streamed || !in_order => ChannelRequest::of_chosen(&channels, &numbers),
            _ => ChannelRequest::of_states(&channels),
        };
        let settings = self
            .settings
            .render_settings(self.view.max_level, self.view.clipping.clip());
        let saved = SavedTransfer {
            transfer,
            density: settings.density,
            mode: settings.mode,
        };
        let open = OpenOptions {
            source,
            channel,
            time: volume.series.selected.time,
            ..OpenOptions::default()
        };
        Some(SavedView {
            version: VIEW_VERSION,
            open: open.stored(),
            draw: DrawOptions {
                transfer: TransferOptions::drawn(Some(saved), &settings),
                clip: settings.clip,
                channels: request,
                renderer,
                brick_size: self.settings.brick_size,
                // The GPU budget the user chose; the rest is as the app streams (its
                // defaults).
                stream: StreamOptions {
                    gpu_memory: self.settings.stream_gpu_memory,
                    ..StreamOptions::default()
                },
                camera: self.settings.camera,
                size,
                labels: self.labels.drawn_options(),
                ..DrawOptions::default()
            },
            rulers: self
                .view
                .rulers
                .iter()
                .map(|r| ViewRuler {
                    from: r.from,
                    to: r.to,
                })
                .collect(),
            layout: Some(layout_name(self.settings.layout).to_owned()),
        })
    }

    /// Opens `view`'s data in the background (the frame it names, with its renderer and
    /// transfer function); the rest of the view is applied when it is on screen.
    pub(super) fn open_view(&mut self, view: SavedView, ctx: &egui::Context) -> Result<(), String> {
        let gpu = self.gpu.as_ref().ok_or("no GPU device")?;
        let (selection, composite) = view_selection(&view.open);
        let source = view.open.volume_source();
        let saved = view.transfer();
        // The frame, where it is not the first: drawn with the view's function at once (a
        // view without one takes the data's own once open).
        let frame = (selection != Selection::default() || !composite).then(|| FrameChange {
            selection,
            transfer: saved.unwrap_or(TransferFunction::gray(ValueWindow {
                low: 0.0,
                high: 1.0,
            })),
            composite,
            channels: Vec::new(),
        });
        let request = TransferRequest {
            saved,
            ..TransferRequest::default()
        };
        let options = RendererOptions {
            kind: view.draw.renderer.unwrap_or(self.settings.renderer),
            brick_size: view.draw.brick_size,
            gpu_memory: view_gpu_memory(&view).unwrap_or(self.settings.stream_gpu_memory),
        };
        let context = std::sync::Arc::clone(&gpu.context);
        let wake = ctx.clone();
        let job = Job::spawn(
            format!("opening {}", source.spec()),
            move || wake.request_repaint(),
            move |progress| {
                voxscope_scene::prepare_scene(&source, frame, &request, &context, options, progress)
            },
        );
        self.jobs.open_view(job, view);
        Ok(())
    }

    /// Shows the data a view file opened, then everything else the view holds.
    pub(super) fn show_view_opened(&mut self, mut opened: Opened, view: &SavedView) {
        // The view's renderer is the user's choice now, so that the renderer the data opened
        // with is not replaced by the one chosen before.
        if let Some(kind) = view.draw.renderer {
            self.settings.renderer = kind;
        }
        self.settings.brick_size = view.draw.brick_size;
        // Its GPU budget too (the app's other streaming budgets are its defaults; `render
        // --view` takes them all).
        if let Some(bytes) = view_gpu_memory(view) {
            self.settings.stream_gpu_memory = bytes;
        }
        // A new volume, whatever frame of it the view shows.
        opened.frame_change = false;
        self.show_opened(opened);
        let Some(scene) = &self.scene else {
            return;
        };
        let depth = scene.depth();
        let transfer = view.transfer().unwrap_or_else(|| {
            let data = &scene.data;
            opening_transfer(
                &data.quantized,
                data.kind,
                data.default_window,
                &TransferRequest::default(),
            )
        });
        let asked = &view.draw.channels;
        let numbers = composite_numbers(scene);
        if scene.composite.is_some() && asked.fits(&numbers) {
            key_channels(&mut self.view.channels, &numbers, view, transfer);
            self.view.active_channel = 0;
            let first = self.view.channels.first().map_or(transfer, |c| c.transfer);
            self.set_panel_transfer(first);
        } else {
            self.set_panel_transfer(transfer);
        }
        self.settings.camera = view.draw.camera;
        self.apply_render_settings(&view.render_settings(depth), depth);
        self.view.rulers = view
            .rulers
            .iter()
            .map(|r| Ruler {
                from: r.from,
                to: r.to,
            })
            .collect();
        if let Some(layout) = view.layout.as_deref().and_then(layout_named) {
            self.settings.layout = layout;
        }
        self.labels.ask(view.draw.labels.clone());
    }

    /// Shows `shot` (a movie's frame: its camera, settings and transfer function) and, for the
    /// composite, its `channels`.
    pub(super) fn apply_shot(&mut self, shot: &Shot, channels: &[ChannelState]) {
        let Some(scene) = &self.scene else {
            return;
        };
        let (depth, composite) = (scene.depth(), scene.composite.is_some());
        self.settings.camera = shot.camera;
        self.apply_render_settings(&shot.settings, depth);
        if composite && channels.len() == self.view.channels.len() {
            self.view.channels = channels.to_vec();
            let active = channels
                .get(self.view.active_channel)
                .map_or(shot.transfer, |c| c.transfer);
            self.set_panel_transfer(active);
        } else {
            self.set_panel_transfer(shot.transfer);
        }
    }

    /// Takes what `settings` holds into the app's settings and view state (the level at most
    /// `depth`).
    fn apply_render_settings(&mut self, settings: &RenderSettings, depth: u32) {
        if self.settings.mode != settings.mode {
            // The view's transfer function is its mode's; the other mode's is not known.
            self.view.other_mode = None;
        }
        self.settings.mode = settings.mode;
        self.settings.density = settings.density;
        self.settings.pixel_lod = settings.pixel_lod;
        self.settings.opacity_correction = settings.opacity_correction;
        self.settings.trilinear = settings.trilinear;
        self.settings.heatmap = settings.heatmap;
        self.settings.shading = settings.shading;
        self.view.max_level = settings.max_level.min(depth);
        self.view.clipping = Clipping::from(settings.clip);
    }

    /// Makes `transfer` the one the Transfer function panel shows and edits.
    fn set_panel_transfer(&mut self, transfer: TransferFunction) {
        self.settings.transfer = TransferChoice::from(transfer);
        self.view.window = transfer.window;
    }

    /// Remembers `path` as the view file Ctrl+S saves to, and says what was done with it.
    pub(super) fn view_file_done(&mut self, path: &Path, what: &str) -> String {
        self.last_view_file = Some(path.to_path_buf());
        let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        format!("{what}: {}", absolute.display())
    }
}

/// The composite's channels as `view` shows them: `transfer` (the view's function, which
/// every channel shares) over each channel's window, with the view's colors and visibility.
pub fn key_channels(
    states: &mut [ChannelState],
    numbers: &[usize],
    view: &SavedView,
    transfer: TransferFunction,
) {
    for state in states.iter_mut() {
        state.transfer = TransferFunction {
            window: state.transfer.window,
            colormap: state.transfer.colormap,
            ..transfer
        };
    }
    let asked = &view.draw.channels;
    if asked.chosen.is_empty() {
        asked.apply_to(states);
    } else {
        asked.apply_to_numbered(states, numbers);
    }
}

/// The file's channel numbers of the composite on screen, in order (a streamed one's chosen
/// channels; the in-memory one's every channel).
pub fn composite_numbers(scene: &voxscope_scene::Scene) -> Vec<usize> {
    scene.composite.as_ref().map_or_else(Vec::new, |composite| {
        composite
            .channels
            .iter()
            .map(|data| data.volume.series.selected.channel)
            .collect()
    })
}

/// The GPU budget a view names, where it is one a streaming renderer can use (a file edited to
/// less than the smallest step the budget-limited status names is ignored, as a file from
/// before budgets were saved).
fn view_gpu_memory(view: &SavedView) -> Option<u64> {
    Some(view.draw.stream.gpu_memory).filter(|&bytes| bytes >= BUDGET_STEPS[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_round_trip_through_their_view_names() {
        for layout in Layout::ALL {
            assert_eq!(layout_named(layout_name(layout)), Some(layout));
        }
        assert_eq!(layout_named("mosaic"), None);
    }

    #[test]
    fn a_view_names_its_frame() {
        let open = |channel, time| OpenOptions {
            channel,
            time,
            ..OpenOptions::default()
        };
        let frame = |channel, time| Selection { channel, time };
        assert_eq!(view_selection(&open(None, 2)), (frame(0, 2), true));
        assert_eq!(
            view_selection(&open(Some(ChannelChoice::All), 0)),
            (frame(0, 0), true)
        );
        assert_eq!(
            view_selection(&open(Some(ChannelChoice::Index(1)), 0)),
            (frame(1, 0), false)
        );
    }
}
