//! The side panels, top and bottom bars and the help window: plain functions of the app
//! state. Every control is labelled, for screen readers and for the UI tests.

use super::settings::{StrategyChoice, ViewMode};
use super::{BvhLabApp, Tool};
use crate::accel::AccelKind;
use crate::accel::bvh::build::{
    MAX_BUCKETS, MAX_LEAF_SIZE, MAX_OVERLAP_PENALTY, MAX_REBRAID, MAX_SPLIT_BUDGET,
    MAX_TREELET_ROUNDS, MAX_TREELET_SIZE, MIN_BUCKETS, MIN_TREELET_SIZE,
};
use crate::accel::kdtree::{MAX_DEPTH as KD_MAX_DEPTH, MIN_BINS as KD_MIN_BINS};
use crate::accel::octree::MAX_DEPTH as OCTREE_MAX_DEPTH;
use crate::accel::split_costs::SplitMethod;
use crate::geometry::simd::SimdLevel;
use crate::render::Mode;
use crate::scene::builtin;
use eframe::egui::{self, RichText};
use egui_plot::{Bar, BarChart, Line, Plot, PlotPoints};
use std::sync::atomic::Ordering;

/// The widest a column of the build report grows before its values wrap.
const REPORT_VALUE_WIDTH: f32 = 180.0;

pub fn top_bar(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::Panel::top("top").show(ui, |ui| {
        ui.horizontal(|ui| {
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
            walls_angle_slider(app, ui, &current);
            ui.separator();
            ui.label("left drag:");
            ui.selectable_value(&mut app.tool, Tool::Orbit, "orbit (O)");
            ui.selectable_value(&mut app.tool, Tool::Move, "move triangles (M)");
            ui.selectable_value(&mut app.tool, Tool::Replay, "replay a ray (P)")
                .on_hover_text("Click a pixel, then step through its ray's traversal with ← / →");
            ui.separator();
            let scale = ui.add(
                egui::Slider::new(&mut app.settings.ui_scale, 0.75..=2.5)
                    .step_by(0.05)
                    .text("UI scale"),
            );
            if scale.drag_stopped() || scale.lost_focus() || (scale.changed() && !scale.dragged()) {
                ui.ctx().set_zoom_factor(app.settings.ui_scale);
            }
            super::lecture::menu(app, ui);
            if ui.button("Help (F1)").clicked() {
                app.show_help = true;
            }
        });
    });
}

/// On `walls-rotated`: the angle the walls are turned by, from 0° (the axis-aligned
/// `walls`) to 90°. Loads the turned scene when the slider is let go.
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

fn short_name(spec: &str) -> String {
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

pub fn controls(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.add_space(4.0);
    super::lecture::error(app, ui);
    if let Some(e) = &app.load_error {
        ui.colored_label(ui.visuals().error_fg_color, format!("Load failed: {e}"));
        ui.label(RichText::new("The previous scene is still loaded.").weak());
        if ui.button("Dismiss").clicked() {
            app.load_error = None;
        }
        ui.separator();
    }
    build_section(app, ui);
    view_section(app, ui);
    super::compare::section(app, ui);
    levels_section(app, ui);
    walk_section(app, ui);
    refit_section(app, ui);
}

fn build_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("Build")
        .default_open(true)
        .show(ui, |ui| {
            let s = &mut app.settings;
            // The layout this machine traces fastest says so (the default of a fresh start).
            let selected = if s.accel == AccelKind::fastest() {
                format!("{} (fastest here)", s.accel.title())
            } else {
                s.accel.title().to_string()
            };
            egui::ComboBox::from_label("structure")
                .selected_text(selected)
                .show_ui(ui, |ui| {
                    for kind in AccelKind::ALL {
                        ui.selectable_value(&mut s.accel, kind, kind.title());
                    }
                });
            if s.accel.is_spatial() {
                ui.checkbox(
                    &mut s.mailbox,
                    "mailboxing (test each triangle once per ray)",
                );
            }
            match s.accel {
                AccelKind::Bvh | AccelKind::TwoLevel => bvh_parameters(ui, s),
                AccelKind::Bvh4 | AccelKind::Bvh8 => {
                    bvh_parameters(ui, s);
                    egui::ComboBox::from_label("SIMD kernel")
                        .selected_text(s.simd.label())
                        .show_ui(ui, |ui| {
                            for level in SimdLevel::available() {
                                ui.selectable_value(&mut s.simd, level, level.label());
                            }
                        });
                }
                AccelKind::KdTree => kdtree_parameters(ui, s),
                AccelKind::Grid => {
                    ui.add(
                        egui::Slider::new(&mut s.grid_lambda, 1.0 / 16.0..=64.0)
                            .logarithmic(true)
                            .text("λ (cells ≈ λ·N)"),
                    );
                }
                AccelKind::Octree => {
                    ui.add(
                        egui::Slider::new(&mut s.octree_max_leaf_size, 1..=64)
                            .text("max leaf size"),
                    );
                    ui.add(
                        egui::Slider::new(&mut s.octree_max_depth, 0..=OCTREE_MAX_DEPTH)
                            .text("max depth"),
                    );
                }
                AccelKind::BruteForce | AccelKind::BruteForceBbox => {}
            }
            if let Some(e) = &app.build_error {
                ui.colored_label(ui.visuals().error_fg_color, e);
            }
        });
}

fn kdtree_parameters(ui: &mut egui::Ui, s: &mut super::settings::Settings) {
    ui.add(egui::Slider::new(&mut s.kd_c_trav, 0.0..=10.0).text("C_trav"));
    ui.add(
        egui::Slider::new(&mut s.kd_c_isect, 0.05..=100.0)
            .logarithmic(true)
            .text("C_isect"),
    );
    ui.add(egui::Slider::new(&mut s.kd_empty_bonus, 0.0..=0.95).text("empty bonus"));
    ui.add(
        egui::Slider::new(&mut s.kd_max_depth, 0..=KD_MAX_DEPTH)
            .text("depth bound (0: 8 + 1.3 log2 N)"),
    );
    ui.add(egui::Slider::new(&mut s.kd_max_leaf_size, 1..=64).text("max leaf size"));
    let mut sweep = s.kd_bins == 0;
    if ui
        .checkbox(&mut sweep, "perfect splits by exact event sweep")
        .changed()
    {
        s.kd_bins = if sweep { 0 } else { 32 };
    }
    if !sweep {
        ui.add(
            egui::Slider::new(&mut s.kd_bins, KD_MIN_BINS..=256)
                .logarithmic(true)
                .text("bins"),
        );
    }
}

fn bvh_parameters(ui: &mut egui::Ui, s: &mut super::settings::Settings) {
    ui.label("split strategy");
    for (choice, label) in [
        (StrategyChoice::ObjectMedian, "object median"),
        (StrategyChoice::SpatialMedian, "spatial median"),
        (StrategyChoice::SahSweep, "full-sweep SAH"),
        (StrategyChoice::SahBinned, "binned SAH"),
        (StrategyChoice::Lbvh, "LBVH"),
        (StrategyChoice::LbvhTreelet, "LBVH + treelets"),
        (StrategyChoice::Sbvh, "SBVH (spatial splits)"),
    ] {
        ui.radio_value(&mut s.strategy, choice, label);
    }
    ui.add_enabled(
        matches!(s.strategy, StrategyChoice::SahBinned | StrategyChoice::Sbvh),
        egui::Slider::new(&mut s.buckets, MIN_BUCKETS..=MAX_BUCKETS)
            .logarithmic(true)
            .text("buckets B"),
    );
    let treelets = s.strategy == StrategyChoice::LbvhTreelet;
    ui.add_enabled(
        treelets,
        egui::Slider::new(&mut s.treelet_size, MIN_TREELET_SIZE..=MAX_TREELET_SIZE)
            .text("treelet size n"),
    );
    ui.add_enabled(
        treelets,
        egui::Slider::new(&mut s.treelet_rounds, 0..=MAX_TREELET_ROUNDS).text("treelet rounds"),
    );
    let sbvh = s.strategy == StrategyChoice::Sbvh;
    ui.add_enabled(
        sbvh,
        egui::Slider::new(&mut s.split_alpha, 1e-8..=1.0)
            .logarithmic(true)
            .text("overlap threshold α"),
    )
    .on_hover_text("spatial splits only where the object split's children overlap by more than α × the root's area");
    ui.add_enabled(
        sbvh,
        egui::Slider::new(&mut s.overlap_penalty, 0.0..=MAX_OVERLAP_PENALTY).text("overlap penalty κ"),
    )
    .on_hover_text("weighed against a spatial split, an object split costs × (1 + κ × its children's overlap / the node's area): 0 = the plain SAH");
    ui.add_enabled(
        sbvh,
        egui::Slider::new(&mut s.split_budget, 0.0..=MAX_SPLIT_BUDGET).text("split budget × N"),
    )
    .on_hover_text("at most this many duplicated references, per triangle");
    let presplit = crate::accel::Strategy::from(s.strategy).takes_presplit();
    ui.add_enabled(
        presplit,
        egui::Slider::new(&mut s.presplit, 0.0..=MAX_SPLIT_BUDGET).text("pre-split budget × N"),
    )
    .on_hover_text("extra references for the triangles that waste most box area (0 = off)");
    if s.accel == AccelKind::TwoLevel {
        ui.add(
            egui::Slider::new(&mut s.rebraid, 0.0..=MAX_REBRAID)
                .logarithmic(true)
                .text("re-braiding budget per instance"),
        )
        .on_hover_text(
            "the top level opens the largest instances into references to their BLAS's \
             subtrees, up to this many extra references per instance, counting at least \
             40 960 instances (0 = whole instances)",
        );
    }
    ui.add(
        egui::Slider::new(&mut s.max_leaf_size, 1..=MAX_LEAF_SIZE.min(64)).text("max leaf size"),
    );
    ui.add(egui::Slider::new(&mut s.c_trav, 0.0..=10.0).text("C_trav"));
    ui.add(egui::Slider::new(&mut s.c_isect, 0.05..=10.0).text("C_isect"));
    ui.checkbox(
        &mut s.naive_order,
        "naive traversal order (no front-to-back)",
    );
}

fn view_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("View")
        .default_open(true)
        .show(ui, |ui| {
            let s = &mut app.settings;
            ui.horizontal_wrapped(|ui| {
                for (k, m) in ViewMode::ALL.into_iter().enumerate() {
                    // The split of the levels means something only for the two levels.
                    if m.is_two_level() && s.accel != AccelKind::TwoLevel {
                        continue;
                    }
                    ui.selectable_value(&mut s.mode, m, m.label())
                        .on_hover_text(format!("Shift+{}", (k + 1) % 10));
                }
            });
            if s.mode.is_heatmap() {
                ui.checkbox(&mut s.shadow_rays, "count shadow rays (instead of primary)");
                let mut fixed = s.heat_max.is_some();
                ui.horizontal(|ui| {
                    ui.checkbox(&mut fixed, "fixed scale maximum");
                    let shown_max = app.shown.as_ref().and_then(|f| f.heat_max).unwrap_or(100);
                    match (fixed, &mut s.heat_max) {
                        (true, Some(m)) => {
                            ui.add(egui::DragValue::new(m).range(1..=100_000));
                        }
                        (true, m @ None) => *m = Some(shown_max),
                        (false, m) => *m = None,
                    }
                });
            }
            if ui.button("Frame all (F)").clicked() {
                app.frame_all();
            }
        });
}

fn levels_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
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
                ui.horizontal(|ui| {
                    if ui.button("< previous").clicked() {
                        s.level = s.level.saturating_sub(1);
                    }
                    if ui.button("next >").clicked() {
                        s.level = (s.level + 1).min(max);
                    }
                });
                ui.add(egui::Slider::new(&mut s.level, 0..=max).text("depth"));
                ui.checkbox(&mut s.see_through, "see through surfaces");
                ui.horizontal(|ui| {
                    ui.label("colour by");
                    ui.radio_value(&mut s.color_by_node, false, "depth");
                    ui.radio_value(&mut s.color_by_node, true, "node");
                });
                ui.label(format!("{level_count} nodes or cells at depth {}", s.level));
                if s.accel == AccelKind::TwoLevel {
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
            if app.settings.accel == AccelKind::TwoLevel {
                selected_instance(app, ui);
            }
        });
}

/// Under the two levels: which instance's BLAS the levels and the walk continue into, and
/// what it is: its mesh, its triangles and its transform (object to world).
fn selected_instance(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.separator();
    let count = app.report.as_ref().and_then(|r| {
        r.details
            .iter()
            .find(|(k, _)| k == "instances")
            .and_then(|(_, v)| v.parse::<usize>().ok())
    });
    let current = app.instance_outline.as_ref().map(|i| i.instance);
    let mut chosen = current.unwrap_or(0);
    let mut send = None;
    ui.horizontal(|ui| {
        ui.label("selected instance");
        let max = count.unwrap_or(1).saturating_sub(1);
        if ui
            .add(egui::DragValue::new(&mut chosen).range(0..=max))
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
fn mesh_name(scene: &crate::scene::Scene, mesh: usize) -> String {
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
fn transform_text(ui: &mut egui::Ui, transform: &glam::Affine3A) {
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

fn walk_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
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
            ui.horizontal(|ui| {
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
                    ui.horizontal(|ui| {
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
            super::levels::WalkNode::Top(k) => self.leaf_instances.get(k).copied(),
            super::levels::WalkNode::Bottom(_) => None,
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

fn refit_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
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
            ui.horizontal(|ui| {
                if ui.button("Undo move (Ctrl+Z)").clicked() {
                    app.undo();
                }
                if ui.button("Rebuild (B)").clicked() {
                    app.rebuild();
                }
            });
            let mut auto = app.settings.auto_rebuild_percent.is_some();
            ui.horizontal(|ui| {
                ui.checkbox(&mut auto, "rebuild when SAH cost grows by");
                let mut p = app.settings.auto_rebuild_percent.unwrap_or(25.0);
                ui.add_enabled(
                    auto,
                    egui::DragValue::new(&mut p)
                        .range(1.0..=1000.0)
                        .suffix(" %"),
                );
                app.settings.auto_rebuild_percent = auto.then_some(p);
            });
            if app.settings.accel == AccelKind::TwoLevel {
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
            } else if app.settings.accel.can_refit() {
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
fn grabbed_instance(app: &BvhLabApp, ui: &mut egui::Ui) {
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

pub fn stats(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.add_space(4.0);
    let walked = app.shown.as_ref().and_then(|s| s.walk.as_ref());
    if let Some((info, costs)) = walked.and_then(|w| Some((w, w.split_costs.as_ref()?))) {
        ui.heading(format!("Splits of node {}", info.node));
        // A k-d node's split is the cheapest plane by construction (the plot replays its
        // build); a BVH node's may differ, so its own cost is drawn too.
        let own = matches!(
            costs.method,
            SplitMethod::Binned { .. } | SplitMethod::Sweep
        );
        super::bucket_plot::show(ui, costs, own.then_some(info.sah_cost));
        ui.separator();
    }
    // With a pinned A, the comparison is what the user is looking at: first.
    super::compare::summary(app, ui);
    if app.replay.is_some() || app.replay_error.is_some() || app.tool == Tool::Replay {
        super::replay::section(app, ui);
        ui.separator();
    }
    ui.heading("Build");
    if let Some(r) = &app.report {
        // A scene with instances of its own first says how it is instanced, as `bvhlab
        // stats` does: the instanced triangles and the memory a flattened copy would take.
        let scene_rows = app.scene_rows.iter().cloned();
        // Long values (the island's re-braiding budget) wrap within their column instead
        // of widening the panel and squeezing the view.
        egui::Grid::new("report")
            .num_columns(2)
            .striped(true)
            .max_col_width(REPORT_VALUE_WIDTH)
            .show(ui, |ui| {
                for (k, v) in scene_rows.chain(r.rows()) {
                    if k.starts_with("leaf sizes") {
                        continue;
                    }
                    ui.label(k);
                    ui.add(egui::Label::new(v).wrap());
                    ui.end_row();
                }
            });
    }
    if let Some(r) = &app.bvh_report {
        ui.label("leaf sizes");
        let bars: Vec<Bar> = r
            .tree
            .leaf_size_histogram
            .iter()
            .enumerate()
            .filter(|&(_, &c)| c > 0)
            .map(|(size, &c)| Bar::new(size as f64, c as f64).width(0.8))
            .collect();
        Plot::new("leaf sizes")
            .height(110.0)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .x_axis_label("triangles in leaf")
            .y_axis_label("leaves")
            .show(ui, |p| p.bar_chart(BarChart::new("leaves", bars)));
        if let Some(before) = r.phases.sah_before_rounds {
            ui.label("SAH cost per treelet round");
            let points: PlotPoints = std::iter::once(before)
                .chain(r.phases.sah_after_round.iter().copied())
                .enumerate()
                .map(|(round, c)| [round as f64, c])
                .collect();
            Plot::new("treelet rounds")
                .height(110.0)
                .allow_drag(false)
                .allow_zoom(false)
                .allow_scroll(false)
                .x_axis_label("round (0: the LBVH)")
                .y_axis_label("SAH cost")
                .show(ui, |p| p.line(Line::new("SAH cost", points)));
        }
    }
    if app.report.is_none() {
        ui.label("building…");
    }
    ui.separator();
    ui.heading("Last frame");
    if let Some(s) = &app.full_summary {
        ui.label(format!(
            "{} rays ({} primary, {} shadow), {:.2} Mrays/s",
            s.rays(),
            s.primary_rays,
            s.shadow_rays,
            s.mrays_per_s()
        ));
        // The frame on screen was traced without counting; its counted pass follows.
        if !s.counted() {
            ui.label("counting…");
        } else {
            counter_grid(ui, s);
        }
    }
    sah_check_section(app, ui);
    super::export::section(app, ui);
    if app.bvh_report.is_none() {
        return;
    }
    ui.separator();
    ui.heading("SAH cost since the last build");
    let points: PlotPoints = app
        .sah_history
        .iter()
        .enumerate()
        .map(|(i, &c)| [i as f64, c])
        .collect();
    Plot::new("sah history")
        .height(130.0)
        .x_axis_label("refits")
        .y_axis_label("SAH cost")
        .show(ui, |p| p.line(Line::new("SAH cost", points)));
    if let (Some(first), Some(last)) = (app.sah_history.first(), app.sah_history.last()) {
        ui.label(format!(
            "{:+.1} % since the build",
            (last / first - 1.0) * 100.0
        ));
    }
}

/// The counted frame's mean and maximum of every counter, for both kinds of ray.
fn counter_grid(ui: &mut egui::Ui, s: &crate::render::FrameSummary) {
    egui::Grid::new("counters")
        .num_columns(3)
        .striped(true)
        .show(ui, |ui| {
            ui.label("");
            ui.strong("primary mean / max");
            ui.strong("shadow mean / max");
            ui.end_row();
            let two_level =
                s.counter(
                    crate::render::RayKind::Primary,
                    crate::accel::Counter::TopNodesVisited,
                )
                .max > 0;
            for which in crate::accel::Counter::ALL {
                if which.is_two_level() && !two_level {
                    continue;
                }
                ui.label(which.label());
                for rays in [
                    crate::render::RayKind::Primary,
                    crate::render::RayKind::Shadow,
                ] {
                    let c = s.counter(rays, which);
                    ui.label(format!("{:.1} / {}", c.mean, c.max));
                }
                ui.end_row();
            }
        });
}

/// The SAH's prediction against the cost per ray measured: on the random lines it assumes,
/// and on the frame's own rays, which start at the camera or on surfaces and stop at hits.
fn sah_check_section(app: &BvhLabApp, ui: &mut egui::Ui) {
    let (Some(p), Some(s)) = (&app.sah_prediction, &app.full_summary) else {
        return;
    };
    // Nothing measured yet: the counted pass is still on its way.
    if !s.counted() {
        return;
    }
    use crate::accel::Counter;
    use crate::render::RayKind;
    let measured = |rays: RayKind| {
        p.c_trav as f64 * s.counter(rays, Counter::NodesVisited).mean
            + p.c_isect as f64 * s.counter(rays, Counter::TriangleTests).mean
    };
    ui.separator();
    ui.heading("SAH predicted against measured");
    ui.label("cost per ray: C_trav · nodes visited + C_isect · triangle tests");
    egui::Grid::new("sah check")
        .num_columns(3)
        .striped(true)
        .show(ui, |ui| {
            let ratio = |x: f64| format!("{:.0} %", 100.0 * x / p.predicted.max(f64::MIN_POSITIVE));
            ui.label("SAH cost (predicted)");
            ui.label(format!("{:.2}", p.predicted));
            ui.label("");
            ui.end_row();
            for (label, cost) in [
                ("random lines through the box", p.random),
                ("this frame's primary rays", measured(RayKind::Primary)),
                ("this frame's shadow rays", measured(RayKind::Shadow)),
            ] {
                ui.label(label);
                ui.label(format!("{cost:.2}"));
                ui.label(ratio(cost));
                ui.end_row();
            }
        });
}

pub fn legend(ui: &mut egui::Ui, rect: egui::Rect, mode: Mode, max: u32) {
    let Mode::Heatmap(counter, rays) = mode else {
        return;
    };
    let painter = ui.painter_at(rect);
    let (w, h) = (200.0, 14.0);
    let origin = rect.left_bottom() + egui::vec2(12.0, -40.0);
    let bg = egui::Rect::from_min_size(
        origin - egui::vec2(6.0, 20.0),
        egui::vec2(w + 12.0, h + 40.0),
    );
    painter.rect_filled(bg, 4.0, egui::Color32::from_black_alpha(170));
    let steps = 64;
    for k in 0..steps {
        let c = crate::render::colormap::viridis(k as f32 / (steps - 1) as f32);
        let x0 = origin.x + w * k as f32 / steps as f32;
        let r = egui::Rect::from_min_size(
            egui::pos2(x0, origin.y),
            egui::vec2(w / steps as f32 + 0.5, h),
        );
        painter.rect_filled(
            r,
            0.0,
            egui::Color32::from_rgb(
                (c.x * 255.0) as u8,
                (c.y * 255.0) as u8,
                (c.z * 255.0) as u8,
            ),
        );
    }
    let font = egui::FontId::proportional(12.0);
    let white = egui::Color32::WHITE;
    painter.text(
        origin - egui::vec2(0.0, 4.0),
        egui::Align2::LEFT_BOTTOM,
        format!("{} ({})", counter.label(), rays.label()),
        font.clone(),
        white,
    );
    painter.text(
        origin + egui::vec2(0.0, h + 2.0),
        egui::Align2::LEFT_TOP,
        "0",
        font.clone(),
        white,
    );
    painter.text(
        origin + egui::vec2(w / 2.0, h + 2.0),
        egui::Align2::CENTER_TOP,
        format!("{}", max / 2),
        font.clone(),
        white,
    );
    painter.text(
        origin + egui::vec2(w, h + 2.0),
        egui::Align2::RIGHT_TOP,
        format!("{max}"),
        font,
        white,
    );
}

pub fn help_window(app: &mut BvhLabApp, ctx: &egui::Context) {
    let mut open = app.show_help;
    egui::Window::new("Help")
        .open(&mut open)
        .resizable(false)
        .show(ctx, |ui| {
            egui::Grid::new("keys")
                .num_columns(2)
                .striped(true)
                .show(ui, |ui| {
                    for (k, what) in [
                        ("left drag", "orbit (or move a triangle with the move tool)"),
                        ("right / middle drag", "pan"),
                        ("wheel", "zoom"),
                        ("F", "frame the whole scene"),
                        ("R", "back to the scene's own view"),
                        ("O / M", "orbit tool / move-triangles tool"),
                        ("P", "replay tool: click a pixel to replay its ray"),
                        (
                            "Left / Right, Home / End",
                            "replay: previous / next visit, first / last visit",
                        ),
                        ("Esc", "close the replay"),
                        ("1 … 9", "lecture presets 1 to 9"),
                        ("Page Down / Page Up", "next / previous preset"),
                        (
                            "Shift+1 … 7",
                            "shaded, normals, depth, nodes, box tests, triangle tests, repeated tests",
                        ),
                        (
                            "Shift+8, 9, 0",
                            "two levels: top-level nodes, bottom-level nodes, instances entered",
                        ),
                        ("Ctrl+1 … 9", "the scene's camera bookmarks"),
                        ("S", "heatmaps of shadow rays on/off"),
                        ("A", "pin the current configuration as A / unpin"),
                        ("C", "comparison view: B only, A | B, B − A"),
                        ("L", "level boxes on/off"),
                        ("[ / ]", "previous / next level"),
                        ("W", "tree walk on/off"),
                        (
                            "Up / Left / Right",
                            "walk to parent / first child / last child",
                        ),
                        ("B", "rebuild the structure"),
                        ("Ctrl+Z", "undo the last move"),
                        ("Ctrl+O", "open an OBJ file (or drop one on the window)"),
                        ("F1", "this help"),
                    ] {
                        ui.strong(k);
                        ui.label(what);
                        ui.end_row();
                    }
                });
        });
    app.show_help = open;
}
