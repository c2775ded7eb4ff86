//! The Move and refit section: the move tool, the refit or rebuild it causes, the SAH
//! cost since the build, undo.

use crate::app::BvhLabApp;
use eframe::egui::{self, RichText};
use egui_plot::{HLine, Line, Plot, PlotPoints};

pub(super) fn refit_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("Drag to refit or rebuild")
        .default_open(true)
        .show(ui, |ui| {
            ui.label(
                RichText::new(
                    "Choose “move triangles”, then click a triangle to select it and drag it.",
                )
                .weak(),
            );
            ui.checkbox(&mut app.settings.move_whole_object, "move its whole object");
            if let (Some(t), Some(scene)) = (app.selection, &app.scene) {
                let object = scene
                    .object_of(t as usize)
                    .map_or("?".to_string(), |o| scene.objects[o].name.clone());
                ui.label(format!("selected: triangle {t} of '{object}'"));
            }
            ui.horizontal_wrapped(|ui| {
                if ui.button("Undo move (Ctrl+Z)").clicked() {
                    app.undo();
                }
                let rebuild = ui.button("Rebuild (B)").on_hover_text(
                    "Build the structure again over the scene as it is now. Under the two \
                     levels, after instances moved, only the top level is built again: the \
                     meshes did not change, so neither did their BLASes.",
                );
                if rebuild.clicked() {
                    app.rebuild();
                }
            });
            let mut auto = app.settings.auto_rebuild_percent.is_some();
            ui.horizontal_wrapped(|ui| {
                let label = ui.checkbox(&mut auto, "rebuild when SAH cost grows by").id;
                let mut p = app.settings.auto_rebuild_percent.unwrap_or(25.0);
                ui.add_enabled(
                    auto,
                    egui::DragValue::new(&mut p)
                        .range(1.0..=1000.0)
                        .suffix(" %"),
                )
                .labelled_by(label);
                app.settings.auto_rebuild_percent = auto.then_some(p);
            });
            if app.settings.structure.kind.places_instances() {
                grabbed_instance(app, ui);
                if let Some((refit, flat)) = app.last_instance_move {
                    ui.label(format!(
                        "last move: the instance moved, the top level refitted in {:.3} ms",
                        refit.as_secs_f64() * 1e3
                    ));
                    ui.label(match flat {
                        Some(f) => format!(
                            "a BVH over the flattened scene refits the same move in {:.2} ms",
                            f.as_secs_f64() * 1e3
                        ),
                        None => "the scene is too large to flatten: no flat BVH to refit".into(),
                    });
                }
            } else if app.settings.structure.kind.can_refit() {
                if let Some(t) = app.last_refit {
                    ui.label(format!("last refit {:.2} ms", t.as_secs_f64() * 1e3));
                }
            } else if let Some((rebuild, refit)) = app.last_rebuild {
                ui.label(format!(
                    "last move: rebuilt in {:.2} ms",
                    rebuild.as_secs_f64() * 1e3
                ));
                if let Some(r) = refit {
                    ui.label(format!(
                        "a BVH would refit it in {:.2} ms: a BVH is simpler to update",
                        r.as_secs_f64() * 1e3
                    ));
                }
            }
            if let Some(t) = app.drag_latency {
                ui.label(format!(
                    "move to refitted frame {:.1} ms",
                    t.as_secs_f64() * 1e3
                ));
            }
        });
}

/// The grabbed object's instance: which it is and its transform (object to world).
pub(super) fn grabbed_instance(app: &BvhLabApp, ui: &mut egui::Ui) {
    let (Some(object), Some(scene)) = (app.selected_object, &app.scene) else {
        return;
    };
    let Some(name) = scene.objects.get(object).map(|o| o.name.clone()) else {
        return;
    };
    // Before its first move: the scene's own instance, or the object as an instance of
    // its own triangles (the identity).
    let instance = scene.instance_of_object(object);
    let transform = app
        .moved_transforms
        .get(&object)
        .copied()
        .unwrap_or_else(|| {
            instance.map_or(glam::Affine3A::IDENTITY, |i| scene.instances[i].transform)
        });
    ui.label(match instance {
        Some(i) => format!("instance {i} ('{name}'), object to world:"),
        None => format!("'{name}' as an instance of its own triangles, object to world:"),
    });
    let m = transform.matrix3;
    let t = transform.translation;
    for row in 0..3 {
        ui.monospace(format!(
            "[{:>8.3} {:>8.3} {:>8.3} | {:>9.3}]",
            m.x_axis[row], m.y_axis[row], m.z_axis[row], t[row]
        ));
    }
}

/// The SAH cost since the last build, as growth in % of the built tree's cost. The axis
/// starts at 0 % and spans at least the auto-rebuild threshold (or 10 %), so a refit that
/// changes the cost by a millionth is drawn flat, as it is, and not as a steep climb.
pub(super) fn sah_growth(app: &BvhLabApp, ui: &mut egui::Ui) {
    ui.heading("SAH cost since the last build");
    let Some(&first) = app.sah_history.first() else {
        ui.label(RichText::new("Move a triangle (M, then drag) to refit the tree.").weak());
        return;
    };
    let growth = |c: f64| (c / first - 1.0) * 100.0;
    let points: PlotPoints = app
        .sah_history
        .iter()
        .enumerate()
        .map(|(i, &c)| [i as f64, growth(c)])
        .collect();
    let threshold = app.settings.auto_rebuild_percent;
    Plot::new("sah history")
        .height(150.0)
        .x_axis_label("refits")
        .y_axis_label("growth %")
        .include_y(0.0)
        .include_y(threshold.map_or(10.0, f64::from) * 1.1)
        .include_x(0.0)
        .include_x(4.0)
        .allow_scroll(false)
        .show(ui, |p| {
            p.line(Line::new("SAH cost", points));
            if let Some(t) = threshold {
                p.hline(HLine::new("rebuild threshold", f64::from(t)));
            }
        });
    let last = *app.sah_history.last().unwrap_or(&first);
    ui.label(format!(
        "{} since the build (from {first:.3} to {last:.3})",
        percent(growth(last))
    ));
}

/// A growth in %, with as many digits as it takes to show it is not zero.
fn percent(p: f64) -> String {
    match p.abs() {
        0.0 => "+0 %".to_string(),
        a if a >= 0.1 => format!("{p:+.1} %"),
        a if a >= 0.001 => format!("{p:+.3} %"),
        _ => format!("{} %", if p > 0.0 { "< +0.001" } else { "> -0.001" }),
    }
}
