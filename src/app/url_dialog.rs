//! File ▸ Open URL…: a window to type (or pick from the recent ones) the URL of an OME-Zarr
//! store on an HTTP server or in S3-compatible object storage. The store opens like a file, on
//! a background thread: the window never waits on the network.

use egui::{Context, Key};

use voxscope_volume::remote::is_url;

/// The text being typed, kept while the window is open.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UrlDialog {
    pub text: String,
    /// Give the text field the keyboard focus in the next frame (when the window opens).
    focus: bool,
}

impl Default for UrlDialog {
    fn default() -> Self {
        Self {
            text: String::new(),
            focus: true,
        }
    }
}

/// What the window's user did this frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum UrlOutcome {
    /// Still typing.
    Open,
    /// Open this URL.
    Chosen(String),
    /// Closed without choosing.
    Cancelled,
}

impl UrlDialog {
    /// Shows the window; `recent` are the recent files, of which the URLs are offered.
    pub fn show(&mut self, ctx: &Context, recent: &[String]) -> UrlOutcome {
        let mut outcome = UrlOutcome::Open;
        let mut open = true;
        // Below the menu bar and centered, not over the menus at the window's corner.
        egui::Window::new("Open URL")
            .open(&mut open)
            .collapsible(false)
            .resizable(false)
            .default_width(460.0)
            .pivot(egui::Align2::CENTER_TOP)
            .default_pos(ctx.content_rect().center_top() + egui::vec2(0.0, 80.0))
            .show(ctx, |ui| {
                ui.label("An OME-Zarr store, N5 container or precomputed volume on an HTTP server, in S3 or a public gs:// bucket (credentials, region and endpoint from the AWS environment and config files):");
                let response = ui.add(
                    egui::TextEdit::singleline(&mut self.text)
                        .hint_text("https://host/path/image.ome.zarr or s3://bucket/image.ome.zarr")
                        .desired_width(440.0),
                );
                // Focus once: asking every frame took it back from the Enter that had just
                // left the field, so Enter never opened.
                if std::mem::take(&mut self.focus) {
                    response.request_focus();
                }
                let text = self.text.trim();
                // Checked as the store will check it (no secret of it in the words).
                let checked = voxscope_volume::remote::check_url(text);
                let valid = checked.is_ok();
                if !text.is_empty()
                    && let Err(problem) = checked
                {
                    let problem = if is_url(text) {
                        problem.to_string()
                    } else {
                        "a URL starts with http://, https:// or s3://".to_owned()
                    };
                    ui.colored_label(ui.visuals().warn_fg_color, problem);
                }
                ui.horizontal(|ui| {
                    let enter = (response.lost_focus() || response.has_focus())
                        && ui.input(|i| i.key_pressed(Key::Enter));
                    if ui.add_enabled(valid, egui::Button::new("Open")).clicked()
                        || (enter && valid)
                    {
                        outcome = UrlOutcome::Chosen(text.to_owned());
                    }
                    if ui.button("Cancel").clicked() {
                        outcome = UrlOutcome::Cancelled;
                    }
                });
                let urls: Vec<&String> = recent.iter().filter(|s| is_url(s)).collect();
                if !urls.is_empty() {
                    ui.separator();
                    ui.label("Recent");
                    for url in urls {
                        if ui.link(url.as_str()).clicked() {
                            outcome = UrlOutcome::Chosen(url.clone());
                        }
                    }
                }
            });
        if !open {
            outcome = UrlOutcome::Cancelled;
        }
        outcome
    }
}
