//! The Tree walk section: node by node from the root, with the SAH cost of its split.

use crate::app::BvhLabApp;
use eframe::egui::{self};

pub(super) fn walk_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("Tree walk")
        .default_open(true)
        .show(ui, |ui| {
            let mut on = app.walk.is_some();
            if ui.checkbox(&mut on, "walk the tree node by node").changed() {
                app.walk = on.then_some(0);
            }
            if app.walk.is_none() {
                return;
            }
            ui.horizontal_wrapped(|ui| {
                if ui.button("parent (Up)").clicked() {
                    app.walk_to(Step::Parent);
                }
                if ui.button("first child (Left)").clicked() {
                    app.walk_to(Step::Left);
                }
                if ui.button("last child (Right)").clicked() {
                    app.walk_to(Step::Right);
                }
            });
            let levels = app.levels();
            let children: Vec<u32> =
                app.walk
                    .and_then(|w| levels.node(w))
                    .map_or(Vec::new(), |n| {
                        levels
                            .children(n)
                            .into_iter()
                            .map(|c| levels.id(c))
                            .collect()
                    });
            if children.len() > 2 {
                ui.horizontal_wrapped(|ui| {
                    ui.label("child");
                    for (k, &c) in children.iter().enumerate() {
                        if ui.small_button((k + 1).to_string()).clicked() {
                            app.walk = Some(c);
                        }
                    }
                });
            }
            if let Some(info) = app.shown.as_ref().and_then(|s| s.walk.as_ref()) {
                egui::Grid::new("walk").num_columns(2).show(ui, |ui| {
                    ui.label("node");
                    ui.label(match (info.in_blas, info.instance) {
                        (true, Some(i)) => format!("{} (BLAS of instance {i})", info.node),
                        (false, Some(i)) if info.whole_instance => {
                            format!("{} (TLAS leaf: instance {i})", info.node)
                        }
                        (false, Some(i)) => {
                            format!("{} (TLAS leaf: a subtree of instance {i})", info.node)
                        }
                        _ => info.node.to_string(),
                    });
                    ui.end_row();
                    ui.label("depth");
                    ui.label(info.depth.to_string());
                    ui.end_row();
                    ui.label("triangles");
                    ui.label(info.triangles.to_string());
                    ui.end_row();
                    ui.label(if info.in_blas {
                        "surface area (mesh space)"
                    } else {
                        "surface area"
                    });
                    ui.label(format!("{:.4}", info.surface_area));
                    ui.end_row();
                    ui.label(if !info.children.is_empty() {
                        "SAH cost of split"
                    } else {
                        "leaf cost N·C_isect"
                    });
                    ui.label(format!("{:.3}", info.sah_cost));
                    ui.end_row();
                });
                if info.children.len() == 2 {
                    ui.horizontal_wrapped(|ui| {
                        ui.colored_label(egui::Color32::from_rgb(255, 140, 40), "first child");
                        ui.colored_label(egui::Color32::from_rgb(60, 170, 255), "second child");
                    });
                }
            }
        });
}

/// A step of the tree walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    Parent,
    Left,
    Right,
}

impl BvhLabApp {
    /// Steps the walk. Under the two levels a step down from a top-level leaf enters its
    /// instance's BLAS (selecting the instance first if it is not the selected one), and a
    /// step up from the BLAS's root comes back to that leaf.
    pub fn walk_to(&mut self, step: Step) {
        let Some(id) = self.walk else { return };
        let levels = self.levels();
        let Some(node) = levels.node(id) else {
            return;
        };
        let children = levels.children(node);
        let next = match step {
            Step::Parent => levels.parent(node),
            Step::Left => children.first().copied(),
            Step::Right => children.last().copied(),
        };
        if let Some(n) = next {
            self.walk = Some(levels.id(n));
            return;
        }
        let leaf_instance = match node {
            crate::app::levels::WalkNode::Top(k) => self.leaf_instances.get(k).copied(),
            crate::app::levels::WalkNode::Bottom(_) => None,
        };
        if step != Step::Parent
            && let Some(i) = leaf_instance.filter(|&i| i != u32::MAX)
        {
            self.enter_blas = true;
            self.select_instance(Some(i as usize));
        }
    }

    pub fn frame_all(&mut self) {
        if let Some(scene) = &self.scene {
            self.orbit.frame_all(&scene.bounds());
        }
    }
}
