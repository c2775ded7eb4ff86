//! Choosing a file: a scene to open, presets to load, a preset or an export to save. The
//! system's dialog (rfd, through the XDG desktop portal) runs on its own thread so the UI
//! keeps drawing; where no portal answers (no D-Bus session, or the portal refuses at once,
//! as on a bare X server in a lecture hall's kiosk), an in-app file browser (the
//! `egui_file` crate) opens instead, so every Open… and Save… opens something.

use super::export::Export;
use eframe::egui;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What the chosen file is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    OpenScene,
    LoadPresets,
    SavePreset,
    Export(Export),
}

impl Purpose {
    fn title(self) -> &'static str {
        match self {
            Purpose::OpenScene => "Open a scene (OBJ, glTF)",
            Purpose::LoadPresets => "Load presets (TOML)",
            Purpose::SavePreset => "Save the view as a preset (TOML)",
            Purpose::Export(Export::ViewPng) => "Save the view as a PNG",
            Purpose::Export(Export::CountersCsv) => "Save the counters as CSV",
        }
    }

    /// The filter's name and its extensions.
    fn filter(self) -> (&'static str, &'static [&'static str]) {
        match self {
            Purpose::OpenScene => ("Scenes (OBJ, glTF)", &["obj", "gltf", "glb"]),
            Purpose::LoadPresets | Purpose::SavePreset => ("Presets (TOML)", &["toml"]),
            Purpose::Export(Export::ViewPng) => ("PNG image", &["png"]),
            Purpose::Export(Export::CountersCsv) => ("CSV table", &["csv"]),
        }
    }

    fn saves(self) -> bool {
        matches!(self, Purpose::SavePreset | Purpose::Export(_))
    }
}

/// A system dialog that comes back empty sooner than this never showed: no portal.
const NO_PORTAL: Duration = Duration::from_millis(400);

/// What the system dialog's thread found.
enum Answer {
    File(PathBuf),
    NoPortal,
}

/// Where a dialog starts and the name a save dialog proposes.
#[derive(Clone, Default)]
pub struct Start {
    pub folder: Option<PathBuf>,
    pub file_name: Option<String>,
}

#[derive(Default)]
pub struct FileDialog {
    answer: Arc<Mutex<Option<(Purpose, Start, Answer)>>>,
    browser: Option<(Purpose, egui_file::FileDialog)>,
}

impl FileDialog {
    /// Opens the system's dialog, or the in-app browser where there is no desktop portal.
    pub fn start(&mut self, ctx: &egui::Context, purpose: Purpose, start: Start) {
        if std::env::var_os("DBUS_SESSION_BUS_ADDRESS").is_none() {
            self.open_browser(purpose, &start);
            return;
        }
        let answer = self.answer.clone();
        let ctx = ctx.clone();
        std::thread::spawn(move || {
            let asked = Instant::now();
            let (name, extensions) = purpose.filter();
            let mut dialog = rfd::FileDialog::new().add_filter(name, extensions);
            if let Some(folder) = &start.folder {
                dialog = dialog.set_directory(folder);
            }
            let file = if purpose.saves() {
                if let Some(file_name) = &start.file_name {
                    dialog = dialog.set_file_name(file_name);
                }
                dialog.save_file()
            } else {
                dialog.pick_file()
            };
            let found = match file {
                Some(f) => Some(Answer::File(f)),
                None if asked.elapsed() < NO_PORTAL => Some(Answer::NoPortal),
                None => None,
            };
            if let (Some(found), Ok(mut a)) = (found, answer.lock()) {
                *a = Some((purpose, start, found));
                ctx.request_repaint();
            }
        });
    }

    /// The in-app browser, in `start.folder` (or the current folder).
    pub fn open_browser(&mut self, purpose: Purpose, start: &Start) {
        let (_, extensions) = purpose.filter();
        let filter: egui_file::Filter<PathBuf> = Box::new(move |path: &Path| {
            path.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.contains(&e.to_ascii_lowercase().as_str()))
        });
        let mut browser = if purpose.saves() {
            let mut b = egui_file::FileDialog::save_file();
            if let Some(name) = &start.file_name {
                b = b.default_filename(name.clone());
            }
            b
        } else {
            egui_file::FileDialog::open_file()
        }
        .title(purpose.title())
        .show_files_filter(filter)
        .show_new_folder(purpose.saves())
        .show_rename(false);
        if let Some(folder) = start.folder.as_ref().filter(|f| f.is_dir()) {
            browser = browser.initial_path(folder);
        }
        browser.open();
        self.browser = Some((purpose, browser));
    }

    /// Whether the in-app browser is open.
    pub fn browsing(&self) -> bool {
        self.browser.as_ref().is_some_and(|(_, b)| b.visible())
    }

    /// Each frame: shows the in-app browser if open, and returns the file chosen in either
    /// dialog and what it is for, once. A saved file gets the extension its kind needs if
    /// it was given none.
    pub fn poll(&mut self, ctx: &egui::Context) -> Option<(Purpose, PathBuf)> {
        let answer = self.answer.lock().ok().and_then(|mut a| a.take());
        match answer {
            Some((purpose, _, Answer::File(f))) => return Some((purpose, f)),
            Some((purpose, start, Answer::NoPortal)) => self.open_browser(purpose, &start),
            None => {}
        }
        let (purpose, browser) = self.browser.as_mut()?;
        let purpose = *purpose;
        browser.show(ctx);
        let chosen = browser
            .selected()
            .then(|| browser.path().map(Path::to_path_buf));
        if chosen.is_some() || !browser.visible() {
            self.browser = None;
        }
        let mut path = chosen.flatten()?;
        if purpose.saves() && path.extension().is_none() {
            path.set_extension(purpose.filter().1[0]);
        }
        Some((purpose, path))
    }
}
