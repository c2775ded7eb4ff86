//! The crack view in the app: exact rays aimed at every shared edge and closed vertex fan
//! in view (`render::cracks`), and a red dot wherever the chosen ray–triangle test lets one
//! slip through, over the view dimmed; the scene (with its camera) can be moved far from
//! the origin first. The worker makes the rays once per view and judges them with every
//! test, so the counts of all three stand side by side.

use super::BvhLabApp;
use super::worker::{Command, CracksRequest};
use crate::geometry::IntersectorKind;
use crate::render::cracks::group;
use eframe::egui::{self, Color32, Stroke};

/// The offsets offered: the origin, then powers of ten.
pub const OFFSETS: [f64; 7] = [0.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6];

/// How an offset reads on a button.
fn offset_label(offset: f64) -> String {
    if offset == 0.0 {
        "0".into()
    } else {
        format!("10^{}", offset.log10().round())
    }
}

/// A test's name in the lecture's words.
fn test_name(kind: IntersectorKind) -> &'static str {
    match kind {
        IntersectorKind::Watertight => "watertight",
        IntersectorKind::MollerTrumbore => "Möller–Trumbore",
        IntersectorKind::F64 => "f64 reference",
    }
}

impl BvhLabApp {
    /// The crack view the settings ask of the shown frame, if they ask for one.
    fn cracks_request(&self) -> Option<CracksRequest> {
        let shown = self.shown.as_ref().filter(|_| self.settings.show_cracks)?;
        Some(CracksRequest {
            camera: shown.job.camera,
            width: shown.job.width,
            height: shown.job.height,
            intersector: self.settings.crack_intersector,
            offset: self.settings.crack_offset,
        })
    }

    /// Whether the crack view asked of the shown frame, if any, has come (or failed).
    pub(super) fn cracks_shown(&self) -> bool {
        self.cracks_request()
            .is_none_or(|r| self.cracks.as_ref().is_some_and(|(made, _)| *made == r))
    }

    /// Asks the worker for the crack view of the shown frame once it is a full frame (not
    /// while the camera moves), unless it has been asked for or made already.
    pub(super) fn ask_for_cracks(&mut self) {
        let Some(request) = self.cracks_request() else {
            return;
        };
        if self.shown.as_ref().is_some_and(|s| s.job.preview) {
            return;
        }
        let made = self.cracks.as_ref().is_some_and(|(r, _)| *r == request);
        if !made && self.cracks_asked.as_ref() != Some(&request) {
            self.cracks_asked = Some(request.clone());
            self.worker.send(Command::Cracks(request));
        }
    }
}

/// The View section's controls: on or off, the test, the offset, and the counts.
pub fn controls(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let s = &mut app.settings;
    ui.checkbox(
        &mut s.show_cracks,
        "cracks: rays at every shared edge and vertex",
    )
    .on_hover_text(
        "exact rays through the points where triangles meet; red where one slips through",
    );
    if !s.show_cracks {
        return;
    }
    choices(ui, s);
    match app.cracks.as_ref() {
        Some((request, Ok(shown))) if Some(request) == app.cracks_request().as_ref() => {
            for (kind, report) in &shown.reports {
                ui.label(format!(
                    "{}: {} of {} slip through",
                    test_name(*kind),
                    group(report.leaks()),
                    group(shown.rays as u64)
                ));
            }
        }
        Some((request, Err(e))) if Some(request) == app.cracks_request().as_ref() => {
            ui.colored_label(ui.visuals().error_fg_color, e);
        }
        _ => {
            ui.label("aiming the rays…");
        }
    }
}

/// The test and the offset, chosen: in the View section, and over the view itself (where a
/// lecture's audience looks, and where the choice is in reach whatever the panel shows).
fn choices(ui: &mut egui::Ui, s: &mut crate::app::settings::Settings) {
    ui.horizontal_wrapped(|ui| {
        ui.label("test");
        for kind in IntersectorKind::ALL {
            ui.selectable_value(&mut s.crack_intersector, kind, test_name(kind));
        }
    });
    ui.horizontal_wrapped(|ui| {
        ui.label("scene moved to")
            .on_hover_text("the scene and its camera moved by (d, d, d): far from the origin");
        for offset in OFFSETS {
            ui.selectable_value(&mut s.crack_offset, offset, offset_label(offset));
        }
    });
}

/// The choices over the view's top-left corner, under the count, while the cracks are shown.
pub fn in_view_controls(app: &mut BvhLabApp, ui: &egui::Ui, rect: egui::Rect) {
    if app.cracks_request().is_none() {
        return;
    }
    let scale = super::panels::in_view_scale(app.settings.presentation, ui.ctx());
    // Under the count: its margin, its line and a gap.
    let below = 12.0 + 1.3 * count_size(scale) + 16.0;
    let width = (rect.width() - 12.0).max(200.0);
    // An area keeps the width it first had, and the rows wrap at it: a new one for each
    // width of the view and size of the text, so they wrap only where the view is narrow.
    let id = egui::Id::unique(("crack choices", width as u32, scale.to_bits()));
    egui::Area::new(id)
        .fixed_pos(rect.left_top() + egui::vec2(6.0, below))
        .default_width(width)
        .show(ui.ctx(), |ui| {
            super::panels::scale_widgets(ui, scale);
            egui::Frame::popup(ui.style()).show(ui, |ui| choices(ui, &mut app.settings));
        });
}

/// The size of the count over the view (points): 18, or in the presentation layout the
/// size of the in-view text there if larger.
fn count_size(scale: f32) -> f32 {
    (12.0 * scale).max(18.0)
}

/// Over the view: the image dimmed, a red dot at every leak, and what the dots are.
pub fn draw(app: &BvhLabApp, painter: &egui::Painter, rect: egui::Rect) {
    let Some(request) = app.cracks_request() else {
        return;
    };
    let Some((made, Ok(shown))) = &app.cracks else {
        return;
    };
    if *made != request {
        return;
    }
    painter.rect_filled(rect, 0.0, Color32::from_black_alpha(110));
    let (w, h) = (request.width as f32, request.height as f32);
    for m in shown.markers.iter().filter(|m| m.leaked) {
        let at = egui::pos2(
            rect.min.x + m.x / w * rect.width(),
            rect.min.y + m.y / h * rect.height(),
        );
        painter.circle(
            at,
            2.5,
            Color32::from_rgb(255, 40, 40),
            Stroke::new(1.0, Color32::BLACK),
        );
    }
    let leaks = shown
        .reports
        .iter()
        .find(|(k, _)| *k == request.intersector)
        .map_or(0, |(_, r)| r.leaks());
    let text = format!(
        "{}: {} of {} edge and vertex rays slip through (red){}",
        test_name(request.intersector),
        group(leaks),
        group(shown.rays as u64),
        if request.offset == 0.0 {
            String::new()
        } else {
            format!(", scene moved to {}", offset_label(request.offset))
        }
    );
    let scale = super::panels::in_view_scale(app.settings.presentation, painter.ctx());
    let font = egui::FontId::proportional(count_size(scale));
    let galley = painter.layout_no_wrap(text, font, Color32::WHITE);
    let at = rect.left_top() + egui::vec2(12.0, 12.0);
    let back = egui::Rect::from_min_size(at, galley.size()).expand(6.0);
    painter.rect_filled(back, 4.0, Color32::from_black_alpha(200));
    painter.galley(at, galley, Color32::WHITE);
}
