//! Export from the app: the viewport as it is shown (with its overlays) as a PNG, and the
//! shown frame's per-pixel counters as CSV. The save dialog runs on its own thread so the
//! UI keeps drawing; the file is written once a path comes back.

use super::BvhLabApp;
use crate::render::export::{ExportError, save_counters_csv, save_png};
use crate::render::replay::draw_picture;
use eframe::egui;
use std::path::Path;

/// What to save.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Export {
    /// The viewport's image as a PNG.
    ViewPng,
    /// The frame's counters, one row per pixel.
    CountersCsv,
}

impl Export {
    fn filter(self) -> (&'static str, &'static str) {
        match self {
            Export::ViewPng => ("PNG image", "png"),
            Export::CountersCsv => ("CSV table", "csv"),
        }
    }
}

impl BvhLabApp {
    /// Saves `what` to `path` now, and says how it went in `export_status`.
    pub fn export(&mut self, what: Export, path: &Path) -> Result<(), String> {
        let result = self.write_export(what, path).map_err(|e| e.to_string());
        self.export_status = Some(match &result {
            Ok(()) => Ok(path.display().to_string()),
            Err(e) => Err(e.clone()),
        });
        result
    }

    fn write_export(&self, what: Export, path: &Path) -> Result<(), ExportError> {
        let shown = self.shown.as_ref().ok_or(ExportError::NoFrame)?;
        match what {
            Export::ViewPng => {
                let size = (shown.job.width, shown.job.height);
                // The replay is drawn over the view by the UI: draw it into the copy too.
                let mut rgba = shown.rgba.clone();
                if let Some(view) = &self.replay {
                    let picture = view.replay.picture(view.stop, self.ray_length());
                    draw_picture(&picture, &mut rgba, size, &shown.job.camera);
                }
                save_png(&rgba, size.0, size.1, path)
            }
            Export::CountersCsv => save_counters_csv(&shown.frame, path),
        }
    }

    /// Asks for a path in a save dialog (the system's, or the in-app browser); the file
    /// is written when it comes back.
    pub fn save_dialog(&mut self, what: Export, ctx: &egui::Context) {
        let (_, ext) = what.filter();
        let start = super::file_browser::Start {
            folder: None,
            file_name: Some(format!("bvhlab-{}.{ext}", short(&self.settings.scene))),
        };
        self.files
            .start(ctx, super::file_browser::Purpose::Export(what), start);
    }
}

/// A scene spec as a file name part: the file stem, or the built-in name.
fn short(spec: &str) -> String {
    Path::new(spec)
        .file_stem()
        .map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned())
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

/// The export buttons and the outcome of the last export.
pub fn section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.horizontal_wrapped(|ui| {
        let has_frame = app.shown.is_some();
        if ui
            .add_enabled(has_frame, egui::Button::new("Save view as PNG…"))
            .on_hover_text("The viewport as shown, overlays included")
            .clicked()
        {
            app.save_dialog(Export::ViewPng, ui.ctx());
        }
        if ui
            .add_enabled(has_frame, egui::Button::new("Save counters as CSV…"))
            .on_hover_text("One row per pixel: hit, lit, and the primary and shadow rays' counters")
            .clicked()
        {
            app.save_dialog(Export::CountersCsv, ui.ctx());
        }
    });
    match &app.export_status {
        Some(Ok(path)) => {
            ui.label(format!("saved {path}"));
        }
        Some(Err(e)) => {
            ui.colored_label(ui.visuals().error_fg_color, e);
        }
        None => {}
    }
}
