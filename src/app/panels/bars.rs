//! The top bar (scenes, tools, lecture, help) and the status bar under the view.

use crate::app::{BvhLabApp, Tool};
use crate::scene::builtin;
use eframe::egui::{self, RichText};
use std::sync::atomic::Ordering;

pub fn top_bar(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::Panel::top("top").show(ui, |ui| {
        // Wraps onto a second row rather than clip at a large UI scale.
        ui.horizontal_wrapped(|ui| {
            ui.strong("bvhlab");
            ui.separator();
            if ui
                .button("Open…")
                .on_hover_text("Open an OBJ file (Ctrl+O)")
                .clicked()
            {
                app.open_dialog(ui.ctx());
            }
            let current = app.settings.scene.clone();
            egui::ComboBox::from_label("scene")
                .selected_text(short_name(&current))
                .show_ui(ui, |ui| {
                    for name in builtin::NAMES {
                        if ui.selectable_label(current == *name, *name).clicked() {
                            app.load(name.to_string());
                        }
                    }
                    if !app.settings.recent.is_empty() {
                        ui.separator();
                        ui.label(RichText::new("recent files").weak());
                        for path in app.settings.recent.clone() {
                            if ui
                                .selectable_label(current == path, short_name(&path))
                                .on_hover_text(&path)
                                .clicked()
                            {
                                app.load(path);
                            }
                        }
                    }
                });
            ui.separator();
            ui.label("left drag:");
            ui.selectable_value(&mut app.tool, Tool::Orbit, "orbit (O)");
            ui.selectable_value(&mut app.tool, Tool::Move, "move triangles (M)");
            ui.selectable_value(&mut app.tool, Tool::Replay, "replay a ray (P)")
                .on_hover_text("Click a pixel, then step through its ray's traversal with ← / →");
            ui.separator();
            ui_scale_menu(app, ui);
            crate::app::lecture::menu(app, ui);
            ui.separator();
            ui.toggle_value(&mut app.settings.show_controls, "controls")
                .on_hover_text("show or hide the controls panel");
            ui.toggle_value(&mut app.settings.show_stats, "stats")
                .on_hover_text("show or hide the statistics panel");
            ui.toggle_value(&mut app.settings.show_tree, "tree")
                .on_hover_text("show or hide the hierarchy diagram under the view");
            if ui
                .button("Present (Tab)")
                .on_hover_text("the view fills the window under the caption (Tab or F11)")
                .clicked()
            {
                app.settings.presentation = true;
            }
            if ui.button("Help (F1)").clicked() {
                app.show_help = true;
            }
        });
    });
}

/// The UI scale as a short menu of steps: a slider wider than the bar's row would clip.
fn ui_scale_menu(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let current = app.settings.ui_scale;
    ui.menu_button(format!("UI scale {current:.2}×"), |ui| {
        for scale in [0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5] {
            if ui
                .selectable_label((current - scale).abs() < 1e-3, format!("{scale:.2}×"))
                .clicked()
            {
                app.settings.ui_scale = scale;
                ui.ctx().set_zoom_factor(scale);
            }
        }
    })
    .response
    .on_hover_text("the size of text and controls");
}

/// On `walls-rotated`, over the top of the view (where a class sees it, also in the
/// presentation layout): the angle the walls are turned by, from 0° (the axis-aligned
/// `walls`) to 90°. Loads the turned scene when the slider is let go.
pub fn walls_in_view(app: &mut BvhLabApp, ui: &egui::Ui, rect: egui::Rect) {
    if !app.settings.scene.starts_with("walls-rotated") {
        return;
    }
    let current = app.settings.scene.clone();
    let scale = super::in_view_scale(app.settings.presentation, ui.ctx());
    egui::Area::new(egui::Id::unique("walls angle"))
        .pivot(egui::Align2::CENTER_TOP)
        .fixed_pos(rect.center_top() + egui::vec2(0.0, 6.0))
        .show(ui.ctx(), |ui| {
            ui.spacing_mut().slider_width = 160.0;
            super::scale_widgets(ui, scale);
            egui::Frame::popup(ui.style()).show(ui, |ui| {
                walls_angle_slider(app, ui, &current);
            });
        });
}

fn walls_angle_slider(app: &mut BvhLabApp, ui: &mut egui::Ui, current: &str) {
    let (name, size) = match current.split_once(':') {
        Some((name, size)) => (name, Some(size)),
        None => (current, None),
    };
    let loaded = if name == "walls-rotated" {
        builtin::WALLS_ROTATION_DEG
    } else if let Some(angle) = name.strip_prefix("walls-rotated@") {
        angle.parse().unwrap_or(builtin::WALLS_ROTATION_DEG)
    } else {
        return;
    };
    // While dragging, the slider shows the angle it will load, not the loaded one.
    let id = ui.scope_id().with("walls angle");
    let mut degrees = ui.data(|d| d.get_temp::<f32>(id)).unwrap_or(loaded);
    let slider = ui
        .add(
            egui::Slider::new(&mut degrees, 0.0..=90.0)
                .step_by(1.0)
                .suffix("°")
                .text("walls turned"),
        )
        .on_hover_text("turn the walls about +Y: their boxes grow to cover their neighbours");
    if slider.dragged() {
        ui.data_mut(|d| d.insert_temp(id, degrees));
    }
    if slider.drag_stopped() || (slider.changed() && !slider.dragged()) {
        ui.data_mut(|d| d.remove::<f32>(id));
        let mut spec = builtin::walls_rotated_spec(degrees);
        if let Some(size) = size {
            spec = format!("{spec}:{size}");
        }
        app.load(spec);
    }
}

pub(super) fn short_name(spec: &str) -> String {
    std::path::Path::new(spec)
        .file_name()
        .map_or_else(|| spec.to_string(), |f| f.to_string_lossy().into_owned())
}

pub fn status_bar(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::Panel::bottom("status").show(ui, |ui| {
        ui.horizontal(|ui| {
            match &app.scene {
                Some(s) => {
                    // The placed triangles: an instanced scene need not store them.
                    ui.label(format!(
                        "{}: {} triangles, {} objects",
                        s.name,
                        s.placed_triangles(),
                        s.objects.len()
                    ));
                }
                None => {
                    ui.label("loading…");
                }
            }
            if app.building {
                let (done, all) = (
                    app.worker.progress.0.load(Ordering::Relaxed),
                    app.worker.progress.1.load(Ordering::Relaxed).max(1),
                );
                ui.separator();
                ui.add(
                    egui::ProgressBar::new(done as f32 / all as f32)
                        .desired_width(160.0)
                        .text("building"),
                );
            }
            if let Some(shown) = &app.shown {
                ui.separator();
                let s = &shown.frame.summary;
                // The time of the image on screen (its counts may come from a later pass).
                let ms = shown.image_time.as_secs_f64() * 1e3;
                ui.label(format!(
                    "{}×{}{}  {:.1} ms  {:.2} Mrays/s{}",
                    shown.job.width,
                    shown.job.height,
                    if shown.job.preview { " (preview)" } else { "" },
                    ms,
                    s.rays() as f64 / ms.max(1e-9) / 1e3,
                    if !shown.job.preview && !s.counted() {
                        "  counting…"
                    } else {
                        ""
                    }
                ));
            }
        });
    });
}
