//! The window's parts, shown once a UI frame in egui's order (the bars and side panels before
//! the central panel that fills what is left, the floating windows after): the menu and
//! status bars, the transfer function panel on the left, the Octree panel on the right, the
//! central view with its label overlays and error banner, the movie panel, the file browser
//! and the URL dialog.

use super::*;

impl VoxscopeApp {
    /// The menu bar at the top and the status bar at the bottom.
    pub(super) fn show_bars(&mut self, ui: &mut Ui) {
        let has_scene = self.scene.is_some();
        egui::Panel::top("menu_bar").show(ui, |ui| {
            menu::menu_bar(ui, &self.settings, has_scene, &mut self.commands)
        });
        let notice = self.notice().map(str::to_owned);
        let hovered = self
            .scene
            .as_ref()
            .and_then(|s| self.central.hovered_voxel(s.data.volume.dims));
        let hovered_labels = hovered.and_then(|voxel| self.labels.describe_at(voxel));
        egui::Panel::bottom("status_bar").show(ui, |ui| {
            menu::status_bar(
                ui,
                &self.jobs,
                self.scene.as_ref(),
                hovered,
                hovered_labels.as_deref(),
                notice.as_deref(),
                &mut self.commands,
            )
        });
    }

    /// The left panel: the frame controls, the channel list, the label list and the transfer
    /// function of the volume (or of the composite's active channel).
    pub(super) fn show_transfer_panel(&mut self, ui: &mut Ui) {
        egui::Panel::left("transfer_panel")
            .default_size(300.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    if let Some(scene) = &self.scene {
                        let shown = frame_controls::Shown {
                            series: &scene.data.volume.series,
                            container: self.container.as_ref(),
                            composite: scene.composite.is_some(),
                            prefetched: self.prefetch.ready().len(),
                            streamed: scene.renderer.streamer().is_some(),
                            on_screen: self.shown_time,
                        };
                        frame_controls::show(
                            ui,
                            &shown,
                            &mut self.playback,
                            &mut self.settings,
                            &mut self.commands,
                        );
                    }
                    let composite = self.scene.as_ref().and_then(|s| s.composite.as_ref());
                    if let Some(composite) = composite {
                        channel_list::show(ui, composite, &mut self.view, &mut self.commands);
                    }
                    label_list::show(ui, &mut self.labels);
                    let data = match composite {
                        Some(composite) => composite
                            .channels
                            .get(self.view.active_channel)
                            .map(Arc::as_ref),
                        None => self.scene.as_ref().map(|s| s.data.as_ref()),
                    };
                    transfer_panel::show(
                        ui,
                        &mut self.settings,
                        &mut self.view,
                        data,
                        composite.is_some(),
                    );
                });
            });
    }

    /// The right panel: the Octree panel's settings and numbers.
    pub(super) fn show_octree_panel(&mut self, ui: &mut Ui) {
        let transfer = self.transfer();
        let statistics_pending =
            self.jobs.counting.is_some() || !self.view.statistics_current(&transfer);
        // Lent to the panel's facts while the panel edits the rest of the view state.
        let statistics = std::mem::take(&mut self.view.statistics);
        egui::Panel::right("octree_panel")
            .default_size(410.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    let facts = OctreeFacts {
                        scene: self.scene.as_ref(),
                        statistics: &statistics,
                        statistics_pending,
                        frame: self.central.frame_facts(self.scene_serial),
                        fps: self.central.fps(self.settings.continuous),
                        adapter: self
                            .gpu
                            .as_ref()
                            .map_or("none", |g| g.context.adapter_info.name.as_str()),
                        target_bytes: self.central.target_bytes(),
                    };
                    octree_panel::show(ui, &mut self.settings, &mut self.view, &facts);
                });
            });
        self.view.statistics = statistics;
    }

    /// The central view's panes with the label overlays over them, and the error banner.
    pub(super) fn show_central_panel(&mut self, ui: &mut Ui) {
        egui::CentralPanel::no_frame().show(ui, |ui| {
            self.central.ui(
                ui,
                ViewInputs {
                    gpu: self.gpu.as_ref(),
                    scene: self.scene.as_ref(),
                    settings: &mut self.settings,
                    view: &mut self.view,
                    opening: self.jobs.opening.is_some(),
                },
            );
            if let Some(scene) = &self.scene {
                let sizes = self.central.pane_sizes();
                let rects = self.central.pane_rects();
                label_list::paint(
                    ui,
                    &self.labels,
                    scene,
                    &self.settings,
                    &self.view,
                    rects,
                    &sizes,
                );
            }
            if let Some(message) = &self.error
                && overlays::error_banner(ui, self.central.rect(), message)
            {
                self.commands.send(Command::DismissError);
            }
        });
    }

    /// The floating windows: the movie panel, the app's file browser and the URL dialog.
    pub(super) fn show_windows(&mut self, ctx: &egui::Context) {
        if self.settings.show_movie_panel {
            let state = movie_panel::PanelState {
                has_scene: self.scene.is_some(),
                previewing: self.preview.is_some(),
                exporting: self.jobs.exporting.is_some(),
            };
            let mut open = true;
            movie_panel::show(ctx, &mut self.movie, &mut open, state, &mut self.commands);
            if !open {
                self.commands
                    .send(Command::TogglePanel(super::super::Panel::Movie));
            }
        }
        if let Some(browser) = &mut self.browser
            && let Some(outcome) = browser.show(ctx, &self.settings.recent)
        {
            let kind = browser.kind();
            self.browser = None;
            if let BrowserOutcome::Chosen(path) = outcome {
                self.chosen(kind, path, ctx);
            }
        }
        if let Some(dialog) = &mut self.url_dialog {
            match dialog.show(ctx, &self.settings.recent) {
                UrlOutcome::Open => {}
                UrlOutcome::Cancelled => self.url_dialog = None,
                UrlOutcome::Chosen(url) => {
                    self.url_dialog = None;
                    self.commands.send(Command::Open(VolumeSource::Spec(url)));
                }
            }
        }
    }

    /// Hands the panes' drawing to the device (the label overlays follow the view first), and
    /// notes the time point the 3D views now show whole.
    pub(super) fn draw_panes(&mut self, ctx: &egui::Context) {
        if let (Some(gpu), Some(scene)) = (&self.gpu, &self.scene) {
            let sizes = self.central.pane_sizes();
            self.labels
                .follow(ctx, gpu, scene, &self.settings, &self.view, &sizes);
        }
        if let (Some(gpu), Some(scene)) = (&self.gpu, &mut self.scene) {
            match self.central.draw(
                ctx,
                gpu,
                scene,
                self.scene_serial,
                &self.settings,
                &self.view,
            ) {
                // Bands left to draw, the stream refining, the device busy: look again.
                Ok(Some(after)) => ctx.request_repaint_after(after),
                Ok(None) => {}
                Err(error) => self.fail(error.to_string()),
            }
            self.tell_stream_failures(ctx);
        }
        if let Some(scene) = &self.scene
            && self.central.shows_scene(self.scene_serial)
        {
            self.shown_time = Some(scene.data.volume.series.selected.time);
        }
    }
}
