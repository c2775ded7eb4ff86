//! The colour scales drawn over the view: the heatmap's and the B − A difference's. One
//! bar with a title and three labels (its ends and its middle), at `scale` times the
//! normal size (the presentation layout scales it with the window).

use crate::app::worker::RenderJob;
use crate::render::Mode;
use crate::render::heat::HeatCurve;
use eframe::egui::{self};
use glam::Vec3;

/// The heatmap's scale: 0 to `max` of the counter shown, on the job's curve; a top set
/// by a percentile reads "max+" (the brightest pixels count more).
pub fn legend(ui: &mut egui::Ui, rect: egui::Rect, job: &RenderJob, max: u32, scale: f32) {
    let title = match job.mode {
        Mode::Heatmap(counter, rays) => format!("{} ({})", counter.label(), rays.label()),
        Mode::TestsReceived(_) => job.mode.label(),
        _ => return,
    };
    let style = &job.heat_style;
    let clipped = job.heat_max.is_none() && style.clip_percentile.is_some();
    let curve = match style.curve {
        HeatCurve::Linear => "",
        HeatCurve::Log => ", log scale",
    };
    scale_bar(
        ui,
        rect,
        scale,
        &format!("{title}{curve}"),
        crate::render::colormap::viridis,
        [
            "0".to_string(),
            format!("{}", style.curve.count_at(0.5, max)),
            if clipped {
                format!("{max}+")
            } else {
                format!("{max}")
            },
        ],
    );
}

/// The SAH cost per triangle's scale: from the cheapest to the dearest triangle shown
/// (`shown`), on a log scale, with the trees' whole costs (`trees`) in the title.
pub fn cost_legend(
    ui: &mut egui::Ui,
    rect: egui::Rect,
    shown: (f64, f64),
    trees: &str,
    scale: f32,
) {
    use crate::render::per_triangle::log_value_at;
    let at = |x| format!("{:.2e}", log_value_at(x, shown));
    scale_bar(
        ui,
        rect,
        scale,
        &format!("SAH cost per triangle, log scale ({trees})"),
        crate::render::colormap::viridis,
        [at(0.0), at(0.5), at(1.0)],
    );
}

/// A colour bar over the bottom left of `rect`: `color` maps 0..1 along it.
pub fn scale_bar(
    ui: &mut egui::Ui,
    rect: egui::Rect,
    scale: f32,
    title: &str,
    color: impl Fn(f32) -> Vec3,
    [low, middle, high]: [String; 3],
) {
    let painter = ui.painter_at(rect);
    let (w, h) = (200.0 * scale, 14.0 * scale);
    let origin = rect.left_bottom() + egui::vec2(12.0, -40.0 * scale);
    let bg = egui::Rect::from_min_size(
        origin - egui::vec2(6.0, 20.0 * scale),
        egui::vec2(w + 12.0, h + 40.0 * scale),
    );
    painter.rect_filled(bg, 4.0, egui::Color32::from_black_alpha(170));
    let steps = 64;
    for k in 0..steps {
        let c = color(k as f32 / (steps - 1) as f32);
        let x0 = origin.x + w * k as f32 / steps as f32;
        let r = egui::Rect::from_min_size(
            egui::pos2(x0, origin.y),
            egui::vec2(w / steps as f32 + 0.5, h),
        );
        let [r8, g8, b8] = [c.x, c.y, c.z].map(|v| (v.clamp(0.0, 1.0) * 255.0) as u8);
        painter.rect_filled(r, 0.0, egui::Color32::from_rgb(r8, g8, b8));
    }
    let font = egui::FontId::proportional(12.0 * scale);
    let white = egui::Color32::WHITE;
    painter.text(
        origin - egui::vec2(0.0, 4.0),
        egui::Align2::LEFT_BOTTOM,
        title,
        font.clone(),
        white,
    );
    for (x, align, text) in [
        (0.0, egui::Align2::LEFT_TOP, low),
        (w / 2.0, egui::Align2::CENTER_TOP, middle),
        (w, egui::Align2::RIGHT_TOP, high),
    ] {
        painter.text(
            origin + egui::vec2(x, h + 2.0),
            align,
            text,
            font.clone(),
            white,
        );
    }
}
