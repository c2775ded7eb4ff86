//! Opening a scene file. The system's dialog (rfd, through the XDG desktop portal) runs on
//! its own thread so the UI keeps drawing; where no portal answers (no D-Bus session, or
//! the portal refuses at once, as on a bare X server in a lecture hall's kiosk), an in-app
//! file browser (the `egui_file` crate) opens instead, so Open… always opens something.

use eframe::egui;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The extensions of the scenes the app opens.
const SCENE_EXTENSIONS: [&str; 3] = ["obj", "gltf", "glb"];

/// A system dialog that comes back empty sooner than this never showed: no portal.
const NO_PORTAL: Duration = Duration::from_millis(400);

/// What the system dialog's thread found.
enum Answer {
    File(PathBuf),
    NoPortal,
}

#[derive(Default)]
pub struct OpenDialog {
    answer: Arc<Mutex<Option<Answer>>>,
    browser: Option<egui_file::FileDialog>,
}

impl OpenDialog {
    /// Opens the system's dialog, or the in-app browser where there is no desktop portal.
    pub fn start(&mut self, ctx: &egui::Context, start_in: Option<&Path>) {
        if std::env::var_os("DBUS_SESSION_BUS_ADDRESS").is_none() {
            self.open_browser(start_in);
            return;
        }
        let answer = self.answer.clone();
        let ctx = ctx.clone();
        std::thread::spawn(move || {
            let asked = Instant::now();
            let file = rfd::FileDialog::new()
                .add_filter("Scenes (OBJ, glTF)", &SCENE_EXTENSIONS)
                .pick_file();
            let found = match file {
                Some(f) => Some(Answer::File(f)),
                None if asked.elapsed() < NO_PORTAL => Some(Answer::NoPortal),
                None => None,
            };
            if let (Some(found), Ok(mut a)) = (found, answer.lock()) {
                *a = Some(found);
                ctx.request_repaint();
            }
        });
    }

    /// The in-app browser, in `start_in` (the folder of the scene open) or the current one.
    pub fn open_browser(&mut self, start_in: Option<&Path>) {
        let filter: egui_file::Filter<PathBuf> = Box::new(|path: &Path| {
            path.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| SCENE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        });
        let mut browser = egui_file::FileDialog::open_file()
            .title("Open a scene (OBJ, glTF)")
            .show_files_filter(filter)
            .show_new_folder(false)
            .show_rename(false);
        if let Some(folder) = start_in.filter(|f| f.is_dir()) {
            browser = browser.initial_path(folder);
        }
        browser.open();
        self.browser = Some(browser);
    }

    /// Whether the in-app browser is open.
    pub fn browsing(&self) -> bool {
        self.browser.as_ref().is_some_and(|b| b.visible())
    }

    /// Each frame: shows the in-app browser if open, and returns the file chosen in either
    /// dialog, once.
    pub fn poll(&mut self, ctx: &egui::Context) -> Option<PathBuf> {
        let answer = self.answer.lock().ok().and_then(|mut a| a.take());
        match answer {
            Some(Answer::File(f)) => return Some(f),
            Some(Answer::NoPortal) => self.open_browser(None),
            None => {}
        }
        let browser = self.browser.as_mut()?;
        browser.show(ctx);
        let chosen = browser
            .selected()
            .then(|| browser.path().map(Path::to_path_buf));
        if chosen.is_some() || !browser.visible() {
            self.browser = None;
        }
        chosen.flatten()
    }
}
