//! The Levels section: the boxes or cells at one depth, and under the two levels the
//! selected instance.

use crate::app::BvhLabApp;
use eframe::egui::{self};

pub(super) fn levels_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("Levels")
        .default_open(true)
        .show(ui, |ui| {
            if app.report.is_none() {
                // Until the tree exists its depth is unknown: no slider to clamp the level.
                ui.label("building…");
                return;
            }
            let levels = app.levels();
            let max = levels.max_depth();
            let top = levels.top_depth();
            let in_blas = levels.instance.map(|i| i.instance);
            let level_count = levels.level(app.settings.level).len();
            let s = &mut app.settings;
            ui.checkbox(&mut s.show_levels, "show the boxes or cells of one level");
            ui.add_enabled_ui(s.show_levels, |ui| {
                ui.horizontal_wrapped(|ui| {
                    if ui.button("< previous").clicked() {
                        s.level = s.level.saturating_sub(1);
                    }
                    if ui.button("next >").clicked() {
                        s.level = (s.level + 1).min(max);
                    }
                });
                ui.add(egui::Slider::new(&mut s.level, 0..=max).text("depth"));
                ui.checkbox(&mut s.see_through, "see through surfaces");
                ui.horizontal_wrapped(|ui| {
                    ui.label("colour by");
                    ui.radio_value(&mut s.color_by_node, false, "depth");
                    ui.radio_value(&mut s.color_by_node, true, "node");
                });
                ui.label(format!("{level_count} nodes or cells at depth {}", s.level));
                if s.structure.kind.places_instances() {
                    ui.label(match in_blas {
                        Some(i) if s.level > top => format!(
                            "BLAS of instance {i}, its level {} (placed by the instance's \
                             transform: oriented boxes)",
                            s.level - top - 1
                        ),
                        Some(i) => format!(
                            "TLAS levels 0–{top} (world boxes), then instance {i}'s BLAS \
                             levels {}–{max}",
                            top + 1
                        ),
                        None => format!(
                            "TLAS levels 0–{top} (world boxes); select an instance to see \
                             its BLAS levels below"
                        ),
                    });
                }
            });
            if app.settings.structure.kind.places_instances() {
                selected_instance(app, ui);
            }
        });
}

/// Under the two levels: which instance's BLAS the levels and the walk continue into, and
/// what it is: its mesh, its triangles and its transform (object to world).
pub(super) fn selected_instance(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.separator();
    let count = app.report.as_ref().and_then(|r| {
        r.detail("instances")
            .and_then(|v| v.as_count())
            .map(|n| n as usize)
    });
    let current = app.instance_outline.as_ref().map(|i| i.instance);
    let mut chosen = current.unwrap_or(0);
    let mut send = None;
    ui.horizontal_wrapped(|ui| {
        let label = ui.label("selected instance").id;
        let max = count.unwrap_or(1).saturating_sub(1);
        if ui
            .add(egui::DragValue::new(&mut chosen).range(0..=max))
            .labelled_by(label)
            .on_hover_text("or click an object with the move tool")
            .changed()
        {
            send = Some(Some(chosen));
        }
        if current.is_none() && ui.button("select").clicked() {
            send = Some(Some(chosen));
        }
        if current.is_some() && ui.button("none").clicked() {
            send = Some(None);
        }
    });
    if let Some(i) = send {
        app.select_instance(i);
    }
    let Some(inst) = app.instance_outline.clone() else {
        return;
    };
    let mesh = app
        .scene
        .as_ref()
        .map_or(String::new(), |s| mesh_name(s, inst.mesh));
    ui.label(format!(
        "instance {} of mesh {} '{mesh}': {} triangles, BLAS depth {}",
        inst.instance,
        inst.mesh,
        inst.triangle_count,
        inst.blas.max_depth()
    ));
    transform_text(ui, &inst.transform);
}

/// The name of mesh `mesh` of the structure: the scene's own mesh, or the object that is
/// its own mesh under the two levels.
pub(super) fn mesh_name(scene: &crate::scene::Scene, mesh: usize) -> String {
    if !scene.meshes.is_empty() {
        return scene
            .meshes
            .get(mesh)
            .map_or("?".into(), |m| m.name.clone());
    }
    scene
        .objects
        .get(mesh)
        .map_or("?".into(), |o| o.name.clone())
}

/// A transform as translation, rotation (axis and angle), scale and its 3×4 matrix.
pub(super) fn transform_text(ui: &mut egui::Ui, transform: &glam::Affine3A) {
    let (scale, rotation, translation) = transform.to_scale_rotation_translation();
    let (axis, angle) = rotation.to_axis_angle();
    let v = |v: glam::Vec3| format!("({:.3}, {:.3}, {:.3})", v.x, v.y, v.z);
    ui.label(format!("translation {}", v(translation)));
    ui.label(format!(
        "rotation {:.1}° about {}",
        angle.to_degrees(),
        v(axis)
    ));
    ui.label(format!(
        "scale {}{}",
        v(scale),
        if transform.matrix3.determinant() < 0.0 {
            " (mirrored)"
        } else {
            ""
        }
    ));
    let m = transform.matrix3;
    let t = transform.translation;
    for row in 0..3 {
        ui.monospace(format!(
            "[{:>8.3} {:>8.3} {:>8.3} | {:>9.3}]",
            m.x_axis[row], m.y_axis[row], m.z_axis[row], t[row]
        ));
    }
}
