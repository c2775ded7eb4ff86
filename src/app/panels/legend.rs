//! The heatmap legend drawn over the view.

use crate::render::Mode;
use eframe::egui::{self};

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
