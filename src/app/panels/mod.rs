//! The side panels, top and bottom bars and the help window: plain functions of the app
//! state. Every control is labelled, for screen readers and for the UI tests.

mod bars;
mod help;
mod layout;
mod legend;
mod levels;
mod refit;
mod stats;
mod tree;
mod walk;

pub use bars::{status_bar, top_bar, walls_in_view};
pub use help::help_window;
pub use layout::{in_view_scale, presentation_bar, presentation_text, scale_widgets, side_panels};
pub use legend::{cost_legend, legend, scale_bar};
pub use stats::stats;
pub(crate) use stats::table;
pub use tree::{TreeView, draw_hovered_box, tree_panel};
pub use walk::Step;

use crate::app::BvhLabApp;
use crate::render::ViewMode;
use eframe::egui::{self, RichText};

pub fn controls(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.add_space(4.0);
    crate::app::lecture::error(app, ui);
    if let Some(e) = app.load_error.clone() {
        ui.colored_label(ui.visuals().error_fg_color, format!("Load failed: {e}"));
        if app.scene.is_some() {
            ui.label(RichText::new("The previous scene is still loaded.").weak());
        } else {
            // Nothing loaded yet (a bad first scene): offer the built-in ones.
            ui.label("No scene is loaded. Open a built-in scene:");
            ui.horizontal_wrapped(|ui| {
                for name in crate::scene::builtin::NAMES {
                    if ui.button(*name).clicked() {
                        app.load(name.to_string());
                    }
                }
            });
        }
        if ui.button("Dismiss").clicked() {
            app.load_error = None;
        }
        ui.separator();
    }
    load_warnings(app, ui);
    build_section(app, ui);
    view_section(app, ui);
    crate::app::compare::section(app, ui);
    levels::levels_section(app, ui);
    walk::walk_section(app, ui);
    refit::refit_section(app, ui);
}

/// What the loader of the scene shown skipped or could not use, until dismissed.
fn load_warnings(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let Some(scene) = app.scene.as_ref().filter(|s| !s.warnings.is_empty()) else {
        return;
    };
    if app.warnings_dismissed {
        return;
    }
    ui.colored_label(ui.visuals().warn_fg_color, "Loaded with warnings:");
    for w in &scene.warnings {
        ui.label(w);
    }
    if ui.button("Dismiss").clicked() {
        app.warnings_dismissed = true;
    }
    ui.separator();
}

fn build_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("Build")
        .default_open(true)
        .show(ui, |ui| {
            // The section keeps the height of the tallest parameter list shown so far, so
            // the controls below it stay where they are when the structure changes.
            let top = ui.cursor().top();
            crate::app::params::structure_params(ui, &mut app.settings.structure);
            let used = ui.cursor().top() - top;
            let id = ui.scope_id().with("parameters height");
            let tallest = ui.data(|d| d.get_temp::<f32>(id)).unwrap_or(0.0).max(used);
            ui.data_mut(|d| d.insert_temp(id, tallest));
            ui.add_space(tallest - used);
            if let Some(e) = &app.build_error {
                ui.colored_label(ui.visuals().error_fg_color, e);
            }
        });
}

fn view_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("View")
        .default_open(true)
        .show(ui, |ui| {
            let s = &mut app.settings;
            ui.horizontal_wrapped(|ui| {
                for (k, m) in ViewMode::ALL.into_iter().enumerate() {
                    // The split of the levels means something only for the two levels.
                    if m.is_two_level() && !s.structure.kind.places_instances() {
                        continue;
                    }
                    let button = ui.selectable_value(&mut s.mode, m, m.label());
                    if k < 10 {
                        button.on_hover_text(format!("Shift+{}", (k + 1) % 10));
                    }
                }
            });
            if s.mode.colours_triangles()
                && let Some(reason) = s.mode.missing_counts(&s.structure)
            {
                ui.colored_label(
                    ui.visuals().warn_fg_color,
                    format!("Nothing to show: {reason}."),
                );
            }
            if s.mode.is_heatmap() {
                ui.checkbox(&mut s.shadow_rays, "count shadow rays (instead of primary)");
                heat_style(ui, &mut s.heat_style, s.heat_max.is_some());
                let mut fixed = s.heat_max.is_some();
                ui.horizontal_wrapped(|ui| {
                    let label = ui.checkbox(&mut fixed, "fixed scale maximum").id;
                    let shown_max = app.shown.as_ref().and_then(|f| f.heat_max).unwrap_or(100);
                    match (fixed, &mut s.heat_max) {
                        (true, Some(m)) => {
                            ui.add(egui::DragValue::new(m).range(1..=100_000))
                                .labelled_by(label);
                        }
                        (true, m @ None) => *m = Some(shown_max),
                        (false, m) => *m = None,
                    }
                });
            }
            crate::app::cracks::controls(app, ui);
            if ui.button("Frame all (F)").clicked() {
                app.frame_all();
            }
        });
}

/// The heatmap's curve, its clipping at the 99th percentile (without a fixed maximum) and
/// the shaded scene under it.
fn heat_style(ui: &mut egui::Ui, style: &mut crate::render::heat::HeatStyle, fixed: bool) {
    use crate::render::heat::HeatCurve;
    ui.horizontal_wrapped(|ui| {
        ui.label("scale");
        for curve in HeatCurve::ALL {
            ui.selectable_value(&mut style.curve, curve, curve.label());
        }
    });
    let mut clip = style.clip_percentile.is_some();
    ui.add_enabled(
        !fixed,
        egui::Checkbox::new(&mut clip, "top at the 99th percentile"),
    )
    .on_hover_text("the brightest 1 % of pixels do not set the scale (a fixed maximum does)");
    style.clip_percentile = clip.then_some(99.0);
    ui.checkbox(&mut style.underlay, "shaded scene under the heat")
        .on_hover_text("the surfaces shaded faintly under the colours, so the geometry shows");
}
