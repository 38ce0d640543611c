//! The app's own file browser, for where the desktop's file dialog cannot be shown (no
//! portal, a bare X session, a remote display) and for File > Open path: a typed path, the
//! folder's subfolders, its Zarr stores (folders that open as a file does) and the files
//! voxscope reads, recent places, and the button that opens or saves. Folders are listed on
//! another thread, so a slow disk or network mount never stalls the UI.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, TryRecvError};

use egui::{Key, RichText, Ui};

use super::dialogs::{DialogKind, OPEN_FOLDER_TITLE, screenshot_file_name, screenshot_title};
use super::numbers::format_bytes;
use voxscope_volume::ome_zarr::{StoreKind, is_zarr_folder, store_kind};

/// Most entries shown of one folder (a folder of a million files stays usable).
const MAX_ENTRIES: usize = 5000;

/// Height of the list of entries, in points.
const LIST_HEIGHT: f32 = 320.0;

/// What the browser ended with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BrowserOutcome {
    /// The user chose this path (a file, a folder, or for saving a new file's path).
    Chosen(PathBuf),
    /// The user closed the browser.
    Cancelled,
}

/// One folder's listing.
#[derive(Debug, Clone, Default)]
struct Listing {
    folders: Vec<String>,
    /// Folders that are stores ([`store_kind`]: Zarr, N5, precomputed), each with its kind: a
    /// volume each, opened by a click rather than entered.
    stores: Vec<(String, StoreKind)>,
    /// File names and sizes.
    files: Vec<(String, u64)>,
    /// Entries left out beyond [`MAX_ENTRIES`].
    left_out: usize,
}

/// The browser's state while it is open.
pub struct FileBrowser {
    kind: DialogKind,
    /// A screenshot's scale (1, 2 or 4).
    screenshot_scale: u32,
    directory: PathBuf,
    /// The typed path: a folder to go to, a file to open, or a file name to save as.
    path_text: String,
    listing: Option<Result<Listing, String>>,
    pending: Option<Receiver<Result<Listing, String>>>,
    /// List every file, not only the formats voxscope reads.
    show_all: bool,
    /// Focus the path field in the next frame.
    focus_path: bool,
}

impl FileBrowser {
    /// A browser for `kind`, showing `directory` (the current folder if `None`);
    /// `screenshot_scale` is what a screenshot's pixels are multiplied by (its title and file
    /// name say so above 1).
    pub fn new(
        kind: DialogKind,
        directory: Option<PathBuf>,
        screenshot_scale: u32,
        ctx: &egui::Context,
    ) -> Self {
        let directory = directory
            .filter(|d| d.is_absolute())
            .or_else(|| std::env::current_dir().ok())
            .unwrap_or_else(|| PathBuf::from("/"));
        let path_text = match kind {
            DialogKind::SaveScreenshot => screenshot_file_name(screenshot_scale),
            DialogKind::SaveTransfer => "transfer.ron".to_owned(),
            DialogKind::SaveView => "view.ron".to_owned(),
            DialogKind::MovieOutput => "movie.webp".to_owned(),
            _ => String::new(),
        };
        let mut browser = Self {
            kind,
            screenshot_scale,
            directory: PathBuf::new(),
            path_text,
            listing: None,
            pending: None,
            show_all: false,
            focus_path: true,
        };
        browser.go_to(directory, ctx);
        browser
    }

    /// True while the folder is being listed.
    pub fn is_listing(&self) -> bool {
        self.pending.is_some()
    }

    /// What the browser is for.
    pub fn kind(&self) -> DialogKind {
        self.kind
    }

    /// Lists `directory` on another thread.
    fn go_to(&mut self, directory: PathBuf, ctx: &egui::Context) {
        let (sender, receiver) = mpsc::channel();
        let wake = ctx.clone();
        let listed = directory.clone();
        let folders_only = self.kind == DialogKind::OpenFolder;
        std::thread::spawn(move || {
            let _ = sender.send(list(&listed, folders_only));
            wake.request_repaint();
        });
        self.directory = directory;
        self.listing = None;
        self.pending = Some(receiver);
    }

    /// Shows the browser as a modal window; `recent` are recent volumes (their folders are
    /// offered as places). Returns the outcome once the user chose or cancelled.
    pub fn show(&mut self, ctx: &egui::Context, recent: &[String]) -> Option<BrowserOutcome> {
        if let Some(receiver) = &self.pending {
            match receiver.try_recv() {
                Ok(listing) => {
                    self.listing = Some(listing);
                    self.pending = None;
                }
                Err(TryRecvError::Disconnected) => {
                    self.listing = Some(Err("the folder could not be listed".into()));
                    self.pending = None;
                }
                Err(TryRecvError::Empty) => {}
            }
        }
        let mut outcome = None;
        let mut go_to = None;
        let modal = egui::Modal::new(egui::Id::unique("file_browser")).show(ctx, |ui| {
            ui.set_width(640.0);
            ui.heading(self.title());
            ui.add_space(4.0);
            self.path_row(ui, &mut outcome, &mut go_to);
            ui.separator();
            // A fixed height: a separator or list that fills the available height would grow
            // the modal every frame.
            ui.allocate_ui_with_layout(
                egui::vec2(ui.available_width(), LIST_HEIGHT),
                egui::Layout::left_to_right(egui::Align::Min),
                |ui| {
                    ui.vertical(|ui| {
                        ui.set_width(150.0);
                        places(ui, &self.directory, recent, &mut go_to);
                    });
                    ui.add_space(8.0);
                    ui.vertical(|ui| self.entries(ui, &mut outcome, &mut go_to));
                },
            );
            ui.separator();
            ui.horizontal(|ui| {
                if self.kind == DialogKind::Open {
                    ui.checkbox(&mut self.show_all, "Show all files");
                }
                ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                    if ui.button("Cancel").clicked() {
                        outcome = Some(BrowserOutcome::Cancelled);
                    }
                    let typed = !self.path_text.trim().is_empty();
                    if ui
                        .add_enabled(
                            typed || self.kind == DialogKind::OpenFolder,
                            egui::Button::new(self.action_name()),
                        )
                        .on_hover_text("The path typed above (Enter does the same)")
                        .on_disabled_hover_text("Type a name or a path above, or click a file")
                        .clicked()
                    {
                        self.accept_typed(&mut outcome, &mut go_to);
                    }
                    if self.kind == DialogKind::OpenFolder
                        && ui.button("Open this folder").clicked()
                    {
                        outcome = Some(BrowserOutcome::Chosen(self.directory.clone()));
                    }
                });
            });
        });
        if modal.should_close() && outcome.is_none() {
            outcome = Some(BrowserOutcome::Cancelled);
        }
        if let Some(directory) = go_to {
            self.go_to(directory, ctx);
        }
        outcome
    }

    fn title(&self) -> String {
        match self.kind {
            DialogKind::SaveScreenshot => {
                format!("{} (PNG)", screenshot_title(self.screenshot_scale))
            }
            kind => Self::fixed_title(kind).to_owned(),
        }
    }

    fn fixed_title(kind: DialogKind) -> &'static str {
        match kind {
            DialogKind::Open => {
                "Open a volume: a file, an OME-Zarr store, an N5 container or a precomputed volume"
            }
            DialogKind::OpenFolder => OPEN_FOLDER_TITLE,
            DialogKind::SaveScreenshot => "Save screenshot (PNG)",
            DialogKind::SaveTransfer => "Save transfer function (RON)",
            DialogKind::LoadTransfer => "Load transfer function (RON)",
            DialogKind::OpenLabels => "Open labels on the image's grid",
            DialogKind::SaveView => "Save view (RON)",
            DialogKind::OpenView => "Open view (RON)",
            DialogKind::MovieOutput => "Movie: .webp, .gif, .png, .mp4, or a folder of PNGs",
        }
    }

    /// The typed path: Enter goes to a folder, or opens (saves) a file.
    fn path_row(
        &mut self,
        ui: &mut Ui,
        outcome: &mut Option<BrowserOutcome>,
        go_to: &mut Option<PathBuf>,
    ) {
        ui.horizontal(|ui| {
            let label = ui.label("Path");
            let hint = match self.kind {
                DialogKind::SaveScreenshot
                | DialogKind::SaveTransfer
                | DialogKind::SaveView
                | DialogKind::MovieOutput => "file name or path",
                DialogKind::OpenView => "view.ron",
                _ => "/path/to/volume.nii.gz, a folder, or synthetic:sphere:64",
            };
            let edit = ui
                .add(
                    egui::TextEdit::singleline(&mut self.path_text)
                        .hint_text(hint)
                        .desired_width(f32::INFINITY),
                )
                .labelled_by(label.id);
            if std::mem::take(&mut self.focus_path) {
                edit.request_focus();
            }
            let entered = edit.lost_focus() && ui.input(|i| i.key_pressed(Key::Enter));
            if entered {
                self.accept_typed(outcome, go_to);
            }
        });
        ui.horizontal(|ui| {
            if ui.small_button("Up").clicked()
                && let Some(parent) = self.directory.parent()
            {
                *go_to = Some(parent.to_path_buf());
            }
            ui.label(RichText::new(self.directory.display().to_string()).monospace());
        });
    }

    /// Acts on the typed path (Enter, or the Open/Save button): a `synthetic:` spec or a Zarr
    /// store opens, a folder is entered (or, for Open folder, chosen), anything else is the
    /// file chosen. Nothing typed: Open folder chooses the folder shown, the others nothing.
    fn accept_typed(&mut self, outcome: &mut Option<BrowserOutcome>, go_to: &mut Option<PathBuf>) {
        let typed = self.path_text.trim();
        if typed.is_empty() {
            if self.kind == DialogKind::OpenFolder {
                *outcome = Some(BrowserOutcome::Chosen(self.directory.clone()));
            }
            return;
        }
        if typed.starts_with("synthetic:") && self.kind == DialogKind::Open {
            *outcome = Some(BrowserOutcome::Chosen(PathBuf::from(typed)));
            return;
        }
        let path = self.directory.join(typed);
        let opens_stores = matches!(self.kind, DialogKind::Open | DialogKind::OpenFolder);
        if path.is_dir()
            && self.kind != DialogKind::OpenFolder
            && !(opens_stores && is_zarr_folder(&path))
        {
            *go_to = Some(path);
            self.path_text.clear();
            self.focus_path = true;
        } else {
            *outcome = Some(BrowserOutcome::Chosen(path));
        }
    }

    /// The button that does what Enter in the path field does: Open, Save or Load.
    fn action_name(&self) -> &'static str {
        match self.kind {
            DialogKind::Open | DialogKind::OpenFolder | DialogKind::OpenLabels => "Open",
            DialogKind::SaveScreenshot | DialogKind::SaveTransfer | DialogKind::SaveView => "Save",
            DialogKind::MovieOutput => "Choose",
            DialogKind::LoadTransfer => "Load",
            DialogKind::OpenView => "Open",
        }
    }

    /// The folder's subfolders and matching files, in a list of fixed height (so the modal
    /// keeps its size, and place, while a folder is listed).
    fn entries(
        &mut self,
        ui: &mut Ui,
        outcome: &mut Option<BrowserOutcome>,
        go_to: &mut Option<PathBuf>,
    ) {
        let wanted = |name: &str| match self.kind {
            DialogKind::Open | DialogKind::OpenLabels => self.show_all || is_volume_file(name),
            DialogKind::OpenFolder => false,
            DialogKind::SaveScreenshot => has_extension(name, "png"),
            DialogKind::SaveTransfer
            | DialogKind::LoadTransfer
            | DialogKind::SaveView
            | DialogKind::OpenView => has_extension(name, "ron"),
            DialogKind::MovieOutput => ["webp", "gif", "png", "mp4"]
                .iter()
                .any(|extension| has_extension(name, extension)),
        };
        egui::ScrollArea::vertical()
            .id_salt("file_browser_entries")
            .min_scrolled_height(LIST_HEIGHT)
            .max_height(LIST_HEIGHT)
            .auto_shrink([false, false])
            .show(ui, |ui| {
                let listing = match &self.listing {
                    None => {
                        ui.horizontal(|ui| {
                            ui.spinner();
                            ui.label("listing…");
                        });
                        return;
                    }
                    Some(Err(message)) => {
                        ui.colored_label(ui.visuals().error_fg_color, message);
                        return;
                    }
                    Some(Ok(listing)) => listing,
                };
                let opens_stores = matches!(self.kind, DialogKind::Open | DialogKind::OpenFolder);
                for folder in &listing.folders {
                    let store = listing.stores.iter().find(|(name, _)| name == folder);
                    if let Some((_, kind)) = store.filter(|_| opens_stores) {
                        // A store is a volume: a click opens it, as a file's does.
                        let hover = match *kind {
                            StoreKind::N5 => "An N5 container, group or dataset: click to open it",
                            StoreKind::Precomputed => {
                                "A neuroglancer precomputed volume: click to open it"
                            }
                            StoreKind::Zarr => "An OME-Zarr (or Zarr) store: click to open it",
                        };
                        let kind = kind.name();
                        if ui
                            .selectable_label(false, format!("{folder}  ·  {kind}"))
                            .on_hover_text(hover)
                            .clicked()
                        {
                            *outcome = Some(BrowserOutcome::Chosen(self.directory.join(folder)));
                        }
                    } else if ui.selectable_label(false, format!("{folder}/")).clicked() {
                        *go_to = Some(self.directory.join(folder));
                    }
                }
                for (name, bytes) in listing.files.iter().filter(|(n, _)| wanted(n)) {
                    let text = format!("{name}  ·  {}", format_bytes(*bytes));
                    if ui.selectable_label(false, text).clicked() {
                        match self.kind {
                            DialogKind::SaveScreenshot
                            | DialogKind::SaveTransfer
                            | DialogKind::SaveView
                            | DialogKind::MovieOutput => {
                                self.path_text = name.clone();
                            }
                            _ => {
                                *outcome = Some(BrowserOutcome::Chosen(self.directory.join(name)));
                            }
                        }
                    }
                }
                if listing.left_out > 0 {
                    ui.small(format!("… {} more entries not shown", listing.left_out));
                }
                if listing.folders.is_empty() && !listing.files.iter().any(|(n, _)| wanted(n)) {
                    ui.small("nothing here to open");
                }
            });
    }
}

/// Home, the working folder, the folders of recent volumes, and the root.
fn places(ui: &mut Ui, current: &Path, recent: &[String], go_to: &mut Option<PathBuf>) {
    ui.strong("Places");
    let mut shown: Vec<PathBuf> = Vec::new();
    let home = std::env::var_os("HOME").map(PathBuf::from);
    let candidates = home
        .into_iter()
        .map(|p| ("Home".to_owned(), p))
        .chain(
            std::env::current_dir()
                .ok()
                .map(|p| ("Working folder".to_owned(), p)),
        )
        .chain(recent.iter().filter_map(|spec| {
            let parent = Path::new(spec).parent()?.to_path_buf();
            let name = parent.file_name()?.to_string_lossy().into_owned();
            Some((name, parent))
        }))
        .chain(std::iter::once(("/".to_owned(), PathBuf::from("/"))));
    for (name, path) in candidates {
        if !path.is_absolute() || shown.contains(&path) {
            continue;
        }
        if ui
            .selectable_label(path == current, name)
            .on_hover_text(path.display().to_string())
            .clicked()
        {
            *go_to = Some(path.clone());
        }
        shown.push(path);
    }
}

/// Lists `directory`: subfolders and files, sorted by name, hidden entries left out.
fn list(directory: &Path, folders_only: bool) -> Result<Listing, String> {
    let entries = std::fs::read_dir(directory)
        .map_err(|e| format!("{}: cannot list: {e}", directory.display()))?;
    let mut listing = Listing::default();
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        if listing.folders.len() + listing.files.len() >= MAX_ENTRIES {
            listing.left_out += 1;
            continue;
        }
        // Follows links, so a link to a folder is a folder.
        let Ok(metadata) = std::fs::metadata(entry.path()) else {
            continue;
        };
        if metadata.is_dir() {
            if let Some(kind) = store_kind(&entry.path()) {
                listing.stores.push((name.clone(), kind));
            }
            listing.folders.push(name);
        } else if !folders_only {
            listing.files.push((name, metadata.len()));
        }
    }
    listing.folders.sort_by_key(|n| n.to_lowercase());
    listing.files.sort_by_key(|(n, _)| n.to_lowercase());
    Ok(listing)
}

/// True when `name` ends with `.extension` (any case).
fn has_extension(name: &str, extension: &str) -> bool {
    name.rsplit_once('.')
        .is_some_and(|(_, e)| e.eq_ignore_ascii_case(extension))
}

/// True for the files File > Open offers: those whose extension the format table knows.
pub fn is_volume_file(name: &str) -> bool {
    voxscope_volume::format::by_extension(name).is_some()
}
