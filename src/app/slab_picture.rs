//! The slab test as a picture, in the ray replay: for the box of the visit shown, the ray's
//! interval [t_near, t_far] between each axis's pair of planes, one bar per axis on a
//! common t axis, and below them their intersection with the ray's own interval — the box's
//! hit — or, where the largest near lies beyond the smallest far, the empty one that makes
//! it a miss. The lecture's "intersect with all planes, take the intersection of the
//! intervals", drawn from the replay's real numbers.

use super::bucket_plot::AXIS_COLORS;
use crate::geometry::slab::Slabs;
use crate::geometry::{Aabb, Ray};
use eframe::egui::{self, Color32, Stroke};

pub fn show(ui: &mut egui::Ui, title: &str, ray: &Ray, bounds: &Aabb) {
    let s = Slabs::of(ray, bounds);
    ui.label(egui::RichText::new(title).strong());
    // The t range shown: around where the intervals meet (or fail to), a few times its
    // width either side, within the finite ends; a bar running past it reaches the edge.
    let ends = s
        .axes
        .iter()
        .flat_map(|&(a, b)| [a, b])
        .chain([ray.tmin.max(0.0)]);
    let finite: Vec<f32> = ends.filter(|t| t.is_finite()).collect();
    let first = finite.iter().copied().fold(f32::INFINITY, f32::min);
    let last = finite.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let (a, b) = (s.enter.min(s.exit), s.enter.max(s.exit));
    let (a, b) = (a.max(first), b.min(last));
    let span = (b - a).max((last - first) * 1e-3).max(1e-3);
    let (lo, hi) = ((a - 2.0 * span).max(first), (b + 2.0 * span).min(last));
    let pad = (hi - lo) * 0.05;
    let (lo, hi) = (lo - pad, hi + pad);
    let row = 18.0;
    let label_width = 58.0;
    // The panel's visible width (inside a scroll area the available width is unbounded).
    let width = (ui.clip_rect().right() - ui.cursor().left() - 8.0).max(160.0);
    let (rect, _) = ui.allocate_exact_size(egui::vec2(width, row * 4.6), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    let bar_left = rect.left() + label_width;
    let x_of = |t: f32| {
        let t = t.clamp(lo, hi);
        bar_left + (t - lo) / (hi - lo) * (rect.right() - bar_left - 4.0)
    };
    let font = egui::FontId::proportional(12.0);
    let text = ui.visuals().text_color();
    let rows = [
        ("x slab", s.axes[0], AXIS_COLORS[0]),
        ("y slab", s.axes[1], AXIS_COLORS[1]),
        ("z slab", s.axes[2], AXIS_COLORS[2]),
    ];
    for (k, (name, (near, far), color)) in rows.into_iter().enumerate() {
        let y = rect.top() + row * (k as f32 + 0.5);
        painter.text(
            egui::pos2(rect.left(), y),
            egui::Align2::LEFT_CENTER,
            name,
            font.clone(),
            text,
        );
        if near <= far {
            let bar = egui::Rect::from_x_y_ranges(x_of(near)..=x_of(far), y - 5.0..=y + 5.0);
            painter.rect_filled(bar, 2.0, color);
        }
    }
    // The intersection, and the guides from its ends up through the three bars.
    let y = rect.top() + row * 3.5;
    painter.text(
        egui::pos2(rect.left(), y),
        egui::Align2::LEFT_CENTER,
        "all three",
        font.clone(),
        text,
    );
    let guide = Stroke::new(1.0, Color32::from_white_alpha(120));
    for t in [s.enter, s.exit].into_iter().filter(|t| t.is_finite()) {
        let x = x_of(t);
        painter.line_segment([egui::pos2(x, rect.top()), egui::pos2(x, y + 6.0)], guide);
    }
    if s.hit() {
        let bar = egui::Rect::from_x_y_ranges(x_of(s.enter)..=x_of(s.exit), y - 6.0..=y + 6.0);
        painter.rect_filled(bar, 2.0, Color32::WHITE);
    } else {
        painter.text(
            egui::pos2(bar_left, y),
            egui::Align2::LEFT_CENTER,
            "empty: the largest near is past the smallest far",
            font.clone(),
            Color32::from_rgb(255, 150, 90),
        );
    }
    let interval = |(a, b): (f32, f32)| {
        if a > b {
            "empty (parallel, outside)".to_string()
        } else {
            format!("[{}, {}]", number(a), number(b))
        }
    };
    ui.label(format!(
        "x {}  y {}  z {}",
        interval(s.axes[0]),
        interval(s.axes[1]),
        interval(s.axes[2])
    ));
    ui.label(if s.hit() {
        format!(
            "enter at max(near) = {}, leave at min(far) = {}: a hit",
            number(s.enter),
            number(s.exit)
        )
    } else {
        format!(
            "max(near) = {} > min(far) = {}: a miss",
            number(s.enter),
            number(s.exit)
        )
    });
}

fn number(t: f32) -> String {
    if t == f32::INFINITY {
        "inf".into()
    } else if t == f32::NEG_INFINITY {
        "-inf".into()
    } else {
        format!("{t:.3}")
    }
}
