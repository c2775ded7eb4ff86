//! The central viewport: the worker's newest frame as a texture filling the panel, the
//! camera controls, picking and dragging triangles, the heatmap legend and the exact
//! counters of the pixel under the cursor.

use super::panels::{Step, legend};
use super::replay::Go;
use super::{BvhLabApp, Drag, Tool};
use crate::render::Mode;
use crate::render::compare::CompareView;
use crate::render::per_triangle::shared_shown;
use crate::scene::Camera;
use eframe::egui::{self, Key, PointerButton, Sense};
use std::sync::Arc;
use std::time::Instant;

pub fn show(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let rect = ui.available_rect_before_wrap();
    let ppp = ui.ctx().pixels_per_point();
    // Full resolution means one traced pixel per physical pixel (capped for huge screens).
    let scale = (ppp * rect.width()).min(2560.0) / rect.width().max(1.0);
    app.viewport_px = [
        (rect.width() * scale).round().max(1.0) as u32,
        (rect.height() * scale).round().max(1.0) as u32,
    ];
    let response = ui.allocate_rect(rect, Sense::click_and_drag());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 0.0, egui::Color32::from_rgb(15, 17, 22));
    if let Some(tex) = &app.texture {
        let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
        painter.image(tex.id(), rect, uv, egui::Color32::WHITE);
    }
    app.ask_for_cracks();
    super::cracks::draw(app, &painter, rect);
    super::cracks::in_view_controls(app, ui, rect);
    super::panels::walls_in_view(app, ui, rect);
    busy_overlay(app, ui, &painter, rect);
    handle_input(app, ui, &response, rect);
    super::replay::draw(app, &painter, rect);
    super::panels::draw_hovered_box(app, &painter, rect);
    app.probe = response.hover_pos().map(|p| {
        [
            (p.x - rect.min.x) / rect.width(),
            (p.y - rect.min.y) / rect.height(),
        ]
    });
    if let Some(shown) = &app.shown
        && let Some(values) = shown.frame.triangle_values(Mode::TriangleCost)
        && shown.job.mode == Mode::TriangleCost
    {
        let scale = super::panels::in_view_scale(app.settings.presentation, ui.ctx());
        // A | B side by side share the scale their images were coloured on.
        let a = shown
            .pinned_frame
            .as_ref()
            .filter(|_| {
                shown
                    .job
                    .compare
                    .is_some_and(|c| c.view == CompareView::Split)
            })
            .and_then(|a| Some((a, a.triangle_values(Mode::TriangleCost)?)));
        let (range, trees) = match a {
            Some((a_frame, a)) => (
                shared_shown(&[a_frame, &shown.frame], Mode::TriangleCost).unwrap_or(values.shown),
                format!("A: {:.2}, B: {:.2}", a.total, values.total),
            ),
            None => (values.shown, format!("tree: {:.2}", values.total)),
        };
        super::panels::cost_legend(ui, rect, range, &trees, scale);
    }
    if let Some(shown) = &app.shown
        && let Some(max) = shown.heat_max
    {
        let difference = shown
            .job
            .compare
            .is_some_and(|c| c.view == CompareView::Difference)
            && shown.compared.as_ref().is_some_and(|c| c.error.is_none());
        let scale = super::panels::in_view_scale(app.settings.presentation, ui.ctx());
        if difference {
            super::compare::difference_legend(ui, rect, &shown.job.mode.label(), max, scale);
        } else {
            legend(ui, rect, &shown.job, max, scale);
        }
    }
    // A screenshot shows the window, not where the pointer happens to rest.
    if let Some(pos) = response.hover_pos()
        && app.drag.is_none()
        && app.screenshot.is_none()
        && let Some(text) = pixel_report(app, rect, pos)
    {
        // Read from the back of the room in the presentation layout, as the legends are.
        let scale = super::panels::in_view_scale(app.settings.presentation, ui.ctx());
        response.on_hover_ui_at_pointer(|ui| {
            super::panels::scale_widgets(ui, scale);
            ui.label(text);
        });
    }
}

/// Work slower than this is shown over the view: the old image dimmed, what is being done
/// and how far along (a quicker answer only flickers).
const BUSY_AFTER: std::time::Duration = std::time::Duration::from_millis(100);

/// While the worker builds or traces for longer than `BUSY_AFTER`: the image on screen is
/// the previous one, so it is dimmed and the work in hand is named with its progress.
fn busy_overlay(app: &BvhLabApp, ui: &egui::Ui, painter: &egui::Painter, rect: egui::Rect) {
    use std::sync::atomic::Ordering;
    let busy = app.busy_since.is_some_and(|t| t.elapsed() > BUSY_AFTER);
    if !busy && !app.building {
        return;
    }
    let (what, (done, all)) = if app.building {
        let p = &app.worker.progress;
        let kind = app.settings.structure.kind.title();
        (
            format!("building the {kind}"),
            (p.0.load(Ordering::Relaxed), p.1.load(Ordering::Relaxed)),
        )
    } else {
        let p = &app.worker.trace_progress;
        (
            "tracing".to_string(),
            (p.0.load(Ordering::Relaxed), p.1.load(Ordering::Relaxed)),
        )
    };
    let fraction = (done as f32 / all.max(1) as f32).min(1.0);
    let text = if app.building {
        format!("{what}… {:.0} %", fraction * 100.0)
    } else {
        format!("{what}… {:.0} % of tiles", fraction * 100.0)
    };
    painter.rect_filled(rect, 0.0, egui::Color32::from_black_alpha(120));
    let scale = if app.settings.presentation {
        super::panels::presentation_text(ui.ctx()) / 14.0
    } else {
        1.0
    };
    let centre = rect.center();
    let width = (rect.width() * 0.4).clamp(160.0, 520.0);
    let bar = egui::Rect::from_center_size(centre, egui::vec2(width, 10.0 * scale));
    painter.rect_filled(
        bar.expand(6.0 * scale),
        4.0,
        egui::Color32::from_black_alpha(180),
    );
    painter.rect_filled(bar, 2.0, egui::Color32::from_gray(60));
    let filled = egui::Rect::from_min_size(bar.min, egui::vec2(width * fraction, bar.height()));
    painter.rect_filled(filled, 2.0, egui::Color32::from_rgb(90, 170, 255));
    painter.text(
        bar.center_top() - egui::vec2(0.0, 10.0 * scale),
        egui::Align2::CENTER_BOTTOM,
        text,
        egui::FontId::proportional(16.0 * scale),
        egui::Color32::WHITE,
    );
}

/// The frame pixel under a screen position.
fn pixel_at(app: &BvhLabApp, rect: egui::Rect, pos: egui::Pos2) -> Option<(u32, u32)> {
    let f = &app.shown.as_ref()?.frame;
    let u = (pos.x - rect.min.x) / rect.width();
    let v = (pos.y - rect.min.y) / rect.height();
    if !(0.0..1.0).contains(&u) || !(0.0..1.0).contains(&v) {
        return None;
    }
    Some(((u * f.width as f32) as u32, (v * f.height as f32) as u32))
}

fn pixel_report(app: &BvhLabApp, rect: egui::Rect, pos: egui::Pos2) -> Option<String> {
    let (x, y) = pixel_at(app, rect, pos)?;
    let shown = app.shown.as_ref()?;
    if !shown.frame.summary.counted() {
        return Some(if shown.job.preview {
            "preview: the counts come with the full frame".into()
        } else {
            "counting…: the counts come with the counted pass".into()
        });
    }
    let s = app.shown.as_ref()?.frame.sample(x, y)?;
    let work = |c: &crate::accel::Counters| {
        let mut t = format!(
            "{} nodes, {} box tests, {} triangle tests",
            c.nodes_visited, c.box_tests, c.triangle_tests
        );
        if c.repeated_tests > 0 {
            t += &format!(" ({} repeated)", c.repeated_tests);
        }
        t
    };
    let mut text = format!("pixel ({x}, {y})\nprimary: {}", work(&s.primary));
    if s.is_hit() {
        text += &format!(
            "\nshadow: {} ({})\nhit triangle {} at t = {:.4}",
            work(&s.shadow),
            if s.lit { "lit" } else { "in shadow" },
            s.triangle,
            s.t
        );
    } else {
        text += "\nno hit";
    }
    // In a view that colours triangles: the hit triangle's value.
    let mode = app.shown.as_ref()?.job.mode;
    if let Some(v) = app.shown.as_ref()?.frame.triangle_values(mode)
        && let Some(value) = v.of(s)
    {
        text += &match mode {
            Mode::TriangleCost => format!(
                "\nSAH cost of the triangle: {value:.3e} ({:.2e} of the tree's {:.3})",
                value / v.total.max(f64::MIN_POSITIVE),
                v.total
            ),
            _ => format!(
                "\ntests the triangle received: {value} (rays of 1 pixel in {}²)",
                v.stride
            ),
        };
    }
    // With a pinned A: the same pixel's work under A.
    if let Some(a) = app.shown.as_ref()?.pinned_frame.as_ref()
        && let Some(a) = a.sample(x, y)
    {
        text += &format!("\nunder A, primary: {}", work(&a.primary));
        if a.is_hit() {
            text += &format!("\nunder A, shadow: {}", work(&a.shadow));
        }
    }
    Some(text)
}

fn handle_input(app: &mut BvhLabApp, ui: &egui::Ui, response: &egui::Response, rect: egui::Rect) {
    let height = rect.height();
    let mut moved = false;
    let moving = app.tool == Tool::Move;

    if response.drag_started_by(PointerButton::Primary)
        && moving
        && let Some(pos) = response.interact_pointer_pos()
    {
        start_drag(app, rect, pos);
    }
    if response.dragged_by(PointerButton::Primary) {
        let d = response.drag_delta();
        if let Some(drag) = &app.drag {
            // Move in the view plane: a pixel at the grabbed depth is this long in the world.
            let cam = app.orbit.camera();
            let (right, up, _) = cam.basis();
            let s = 2.0 * drag.depth * (cam.fov_y_deg.to_radians() * 0.5).tan() / height.max(1.0);
            let delta = (right * d.x - up * d.y) * s;
            if delta != glam::Vec3::ZERO {
                match drag.object {
                    Some(object) => app.move_object(object, delta),
                    None => {
                        let set = drag.triangles.clone();
                        app.move_triangles(set, delta);
                    }
                }
            }
        } else if !moving {
            app.orbit.rotate(d.x, d.y, height);
        }
        moved = true;
    }
    if response.drag_stopped() && app.drag.take().is_some() {
        app.end_gesture();
    }
    if response.dragged_by(PointerButton::Secondary) || response.dragged_by(PointerButton::Middle) {
        let d = response.drag_delta();
        app.orbit.pan(d.x, d.y, height);
        moved = true;
    }
    if response.clicked()
        && moving
        && let Some(pos) = response.interact_pointer_pos()
    {
        app.selection = pick(app, rect, pos);
    }
    if response.clicked()
        && app.tool == Tool::Replay
        && let Some(pos) = response.interact_pointer_pos()
        && let Some((x, y)) = pixel_at(app, rect, pos)
    {
        app.replay_pixel(x, y);
    }
    if response.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            app.orbit.zoom(scroll);
            moved = true;
        }
    }
    if moved {
        app.last_interaction = Some(Instant::now());
    }
}

fn pick(app: &BvhLabApp, rect: egui::Rect, pos: egui::Pos2) -> Option<u32> {
    let (x, y) = pixel_at(app, rect, pos)?;
    let s = app.shown.as_ref()?.frame.sample(x, y)?;
    // The app selects triangles of scenes it can flatten, numbered in 32 bits.
    s.is_hit().then(|| u32::try_from(s.triangle).ok()).flatten()
}

fn start_drag(app: &mut BvhLabApp, rect: egui::Rect, pos: egui::Pos2) {
    let Some((x, y)) = pixel_at(app, rect, pos) else {
        return;
    };
    let Some(s) = app
        .shown
        .as_ref()
        .and_then(|sh| sh.frame.sample(x, y).copied())
    else {
        return;
    };
    if !s.is_hit() {
        return;
    }
    // Under the two levels a click selects the object's instance: the levels and the walk
    // continue into its BLAS.
    if app.settings.structure.kind.places_instances()
        && let Some(object) = usize::try_from(s.triangle)
            .ok()
            .and_then(|t| app.scene.as_ref()?.object_of(t))
    {
        app.select_object_instance(object);
    }
    // Under the two levels a whole object moves as its instance: the top level is refitted.
    // This works for any triangle number, also past 32 bits (the island).
    if app.settings.structure.kind.places_instances() && app.settings.move_whole_object {
        let object = usize::try_from(s.triangle)
            .ok()
            .and_then(|t| app.scene.as_ref()?.object_of(t));
        if let Some(object) = object {
            app.selection = u32::try_from(s.triangle).ok();
            app.selected_object = Some(object);
            app.drag = Some(Drag {
                triangles: Arc::new(Vec::new()),
                object: Some(object),
                depth: s.t,
            });
            return;
        }
    }
    let Some(triangle) = u32::try_from(s.triangle).ok() else {
        return;
    };
    app.selection = Some(triangle);
    app.drag = Some(Drag {
        triangles: app.drag_set(triangle),
        object: None,
        depth: s.t,
    });
}

impl BvhLabApp {
    /// Keyboard shortcuts (listed in the help window).
    pub(super) fn shortcuts(&mut self, ctx: &egui::Context) {
        // Only typing into a field takes the keys: a button or slider keeps the focus
        // after a click (and Tab moves it), which must not switch the shortcuts off.
        if ctx.text_edit_focused() {
            return;
        }
        let pressed = |k: Key| ctx.input(|i| i.key_pressed(k));
        let ctrl = ctx.input(|i| i.modifiers.command);
        let max_level = self.levels().max_depth();
        // Digits: presets, view modes (Shift) and bookmarks (Ctrl).
        self.lecture_keys(ctx);
        let s = &mut self.settings;
        if pressed(Key::S) {
            s.shadow_rays = !s.shadow_rays;
        }
        if pressed(Key::C) {
            s.compare_view = s.compare_view.next();
        }
        if pressed(Key::L) {
            s.show_levels = !s.show_levels;
        }
        if pressed(Key::OpenBracket) {
            s.level = s.level.saturating_sub(1);
        }
        if pressed(Key::CloseBracket) {
            s.level = (s.level + 1).min(max_level);
        }
        if pressed(Key::O) && !ctrl {
            self.tool = Tool::Orbit;
        }
        if pressed(Key::O) && ctrl {
            self.open_dialog(ctx);
        }
        if pressed(Key::M) {
            self.tool = Tool::Move;
        }
        if pressed(Key::P) {
            self.tool = Tool::Replay;
        }
        if pressed(Key::Escape) {
            self.replay = None;
        }
        // While a replay is open the arrows step through it, not the tree walk.
        if self.replay.is_some() {
            for (k, go) in [
                (Key::ArrowLeft, Go::Previous),
                (Key::ArrowRight, Go::Next),
                (Key::Home, Go::First),
                (Key::End, Go::Last),
            ] {
                if pressed(k) {
                    self.replay_go(go);
                }
            }
        }
        if pressed(Key::W) {
            self.walk = if self.walk.is_some() { None } else { Some(0) };
        }
        if pressed(Key::ArrowUp) {
            self.walk_to(Step::Parent);
        }
        if pressed(Key::ArrowLeft) && self.replay.is_none() {
            self.walk_to(Step::Left);
        }
        if pressed(Key::ArrowRight) && self.replay.is_none() {
            self.walk_to(Step::Right);
        }
        if pressed(Key::F) {
            self.frame_all();
            self.last_interaction = Some(Instant::now());
        }
        if pressed(Key::R)
            && let Some(scene) = &self.scene
        {
            let cam: Camera = scene.camera();
            self.orbit = super::Orbit::from_camera(&cam);
        }
        if pressed(Key::B) {
            self.rebuild();
        }
        if pressed(Key::A) {
            self.toggle_pin();
        }
        if pressed(Key::Z) && ctrl {
            self.undo();
        }
        if pressed(Key::F1) {
            self.show_help = !self.show_help;
        }
        if pressed(Key::F11) || pressed(Key::Tab) {
            self.settings.presentation = !self.settings.presentation;
        }
    }
}
