//! The ray replay in the app: click a pixel with the replay tool (P) and step through its
//! ray's traversal with ← / → (Home / End for the first and last visit). Each stop is one
//! node (cell, instance's node) visited: its box is drawn over the view, with the ray and
//! the best hit found so far on it, and the panel lists what the visit did: the children
//! tested and which is taken first and why, pushes, pops and skips, triangle tests.

use super::BvhLabApp;
use super::slab_picture;
use super::worker::{Command, ReplayRequest};
use crate::accel::replay::{Level, Step};
use crate::render::RayKind;
use crate::render::replay::{Ink, Replay, ReplayHit};
use eframe::egui::{self, Color32, Stroke};
use glam::Vec3;
use std::sync::Arc;

/// A replay and the stop shown (one per node visited).
#[derive(Clone, Debug)]
pub struct ReplayView {
    pub replay: Arc<Replay>,
    pub stop: usize,
}

/// A move through the stops.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Go {
    Previous,
    Next,
    First,
    Last,
}

impl ReplayView {
    pub fn new(replay: Arc<Replay>) -> Self {
        ReplayView { replay, stop: 0 }
    }

    pub fn go(&mut self, go: Go) {
        let last = self.replay.stops() - 1;
        self.stop = match go {
            Go::Previous => self.stop.saturating_sub(1),
            Go::Next => (self.stop + 1).min(last),
            Go::First => 0,
            Go::Last => last,
        };
    }

    /// The best hit among the triangle tests up to the end of the shown stop.
    pub fn best_so_far(&self) -> Option<ReplayHit> {
        self.replay
            .best_after(self.replay.stop_range(self.stop).end)
    }
}

impl BvhLabApp {
    /// Replays the ray of pixel (x, y) of the shown frame: the primary ray, or the shadow
    /// ray when the view shows shadow rays.
    pub fn replay_pixel(&mut self, x: u32, y: u32) {
        let Some(shown) = &self.shown else {
            return;
        };
        let rays = if self.settings.shadow_rays {
            RayKind::Shadow
        } else {
            RayKind::Primary
        };
        self.replay_error = None;
        let request = ReplayRequest {
            camera: shown.job.camera,
            width: shown.job.width,
            height: shown.job.height,
            pixel: (x, y),
            rays,
        };
        self.worker.send(Command::Replay(request));
    }

    /// How far to draw a ray that has no hit yet: twice the scene's size.
    pub fn ray_length(&self) -> f32 {
        2.0 * self
            .scene
            .as_ref()
            .map_or(10.0, |s| s.bounds().diagonal().max(1e-3))
    }

    /// Steps the replay; true if there is one to step.
    pub fn replay_go(&mut self, go: Go) -> bool {
        match &mut self.replay {
            Some(view) => {
                view.go(go);
                true
            }
            None => false,
        }
    }
}

/// Draws the replay's picture at the shown stop over the viewport `rect` (seen through the
/// shown frame's camera, so it stays in place in the world when the camera turns).
pub fn draw(app: &BvhLabApp, painter: &egui::Painter, rect: egui::Rect) {
    let (Some(view), Some(shown)) = (&app.replay, &app.shown) else {
        return;
    };
    let job = &shown.job;
    let to_screen = |p: Vec3| {
        let (x, y, _) = job.camera.project(p, job.width, job.height)?;
        Some(egui::pos2(
            rect.min.x + x / job.width as f32 * rect.width(),
            rect.min.y + y / job.height as f32 * rect.height(),
        ))
    };
    let picture = view.replay.picture(view.stop, app.ray_length());
    for &(a, b, ink) in &picture.segments {
        let [r, g, bl, alpha] = ink.color();
        let width = match ink {
            Ink::Current => 2.5,
            Ink::Ray => 2.0,
            Ink::Visited | Ink::VisitedLeaf => 1.0,
        };
        let stroke = Stroke::new(width, Color32::from_rgba_unmultiplied(r, g, bl, alpha));
        // In pieces, so a part behind the eye drops out without the rest.
        const PIECES: usize = 8;
        for k in 0..PIECES {
            let p = a.lerp(b, k as f32 / PIECES as f32);
            let q = a.lerp(b, (k + 1) as f32 / PIECES as f32);
            if let (Some(p), Some(q)) = (to_screen(p), to_screen(q)) {
                painter.line_segment([p, q], stroke);
            }
        }
    }
    if let Some(p) = picture.best.and_then(to_screen) {
        painter.circle_filled(p, 5.0, Color32::from_rgb(255, 90, 90));
        painter.circle_stroke(p, 5.0, Stroke::new(1.5, Color32::WHITE));
    }
}

/// The replay section of the stats panel: where the replay is, what the current visit
/// did, and the controls.
pub fn section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.heading("Ray replay");
    if let Some(e) = &app.replay_error {
        ui.colored_label(ui.visuals().error_fg_color, e);
    }
    let Some(view) = &app.replay else {
        ui.label(
            "Choose the replay tool (P) and click a pixel to step through its ray's traversal.",
        );
        return;
    };
    let replay = view.replay.clone();
    let (x, y) = replay.pixel;
    let kind = match replay.rays {
        RayKind::Primary => "primary ray, closest hit",
        RayKind::Shadow => "shadow ray, any hit",
    };
    ui.label(format!("pixel ({x}, {y}): {kind}"));
    let mut go = None;
    ui.horizontal_wrapped(|ui| {
        for (label, g, hover) in [
            ("first visit", Go::First, "Home"),
            ("previous visit", Go::Previous, "Left arrow"),
            ("next visit", Go::Next, "Right arrow"),
            ("last visit", Go::Last, "End"),
        ] {
            if ui.button(label).on_hover_text(hover).clicked() {
                go = Some(g);
            }
        }
    });
    ui.label(format!(
        "visit {} of {}",
        (view.stop + 1).min(replay.visit_count()),
        replay.visit_count()
    ));
    let stop = view.stop;
    let best = view.best_so_far();
    ui.label(match best {
        Some(h) => format!("best hit so far: triangle {} at t = {:.4}", h.triangle, h.t),
        None => "best hit so far: none".into(),
    });
    egui::Frame::group(ui.style()).show(ui, |ui| {
        for i in replay.stop_range(stop) {
            let text = replay.describe(i);
            if replay.steps[i].is_visit() {
                ui.strong(text);
            } else {
                ui.label(text);
            }
        }
    });
    slab_pictures(ui, &replay, stop, best);
    let c = &replay.counters;
    ui.label(format!(
        "whole ray: {} nodes visited, {} box tests, {} triangle tests",
        c.nodes_visited, c.box_tests, c.triangle_tests
    ));
    if ui.button("close replay (Esc)").clicked() {
        app.replay = None;
        return;
    }
    if let Some(g) = go {
        app.replay_go(g);
    }
}

/// The visit's box as the slab test sees it, and each child box its node tested and did
/// not take: the picture of a miss (its intervals do not meet), or of a box that starts
/// beyond the best hit so far (the ray's interval is clipped there). A BLAS box is in its
/// object space, where the world ray is not: only one-level and top-level boxes are drawn.
fn slab_pictures(ui: &mut egui::Ui, replay: &Replay, stop: usize, best: Option<ReplayHit>) {
    let mut world = true;
    for i in replay.stop_range(stop) {
        match &replay.steps[i] {
            Step::Visit { bounds, level, .. } => {
                world = *level != Level::Bottom;
                if world {
                    slab_picture::show(ui, "The slab test of this box", &replay.ray, bounds);
                }
            }
            Step::Children { children, .. } if world => {
                let mut clipped = replay.ray;
                if let Some(h) = best {
                    clipped.tmax = clipped.tmax.min(h.t);
                }
                for c in children.iter().filter(|c| c.entry.is_none()) {
                    let title = format!("The slab test of child {}, not taken", c.node);
                    slab_picture::show(ui, &title, &clipped, &c.bounds);
                }
            }
            _ => {}
        }
    }
}
