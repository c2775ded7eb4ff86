//! Two configurations side by side in the app: pin the current configuration as A, change
//! anything, and see A | B or the difference B − A of the heatmap's counter, with A's and
//! B's totals and means and the share of pixels B made cheaper.

use super::BvhLabApp;
use crate::render::compare::{CompareView, diverging};
use eframe::egui::{self, RichText};

/// The controls: pin or unpin, and the view.
pub fn section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    egui::CollapsingHeader::new("Compare A | B")
        .default_open(true)
        .show(ui, |ui| match &app.pinned {
            None => {
                ui.label(
                    RichText::new(
                        "Pin the current configuration as A, then change anything: \
                             the settings above become B.",
                    )
                    .weak(),
                );
                if ui
                    .button("Pin as A")
                    .on_hover_text("key A: the current structure and its parameters")
                    .clicked()
                {
                    app.pin();
                }
            }
            Some(pinned) => {
                ui.label(format!("A: {}", pinned.label()));
                ui.label(format!("B: {}", app.settings.structure.label()));
                ui.horizontal_wrapped(|ui| {
                    if ui.button("Pin B as A").clicked() {
                        app.pin();
                    }
                    if ui.button("Unpin").on_hover_text("key A").clicked() {
                        app.unpin();
                    }
                });
                let heatmap = app.settings.mode.is_heatmap();
                ui.horizontal_wrapped(|ui| {
                    for view in CompareView::ALL {
                        let enabled = heatmap || view != CompareView::Difference;
                        ui.add_enabled_ui(enabled, |ui| {
                            ui.selectable_value(&mut app.settings.compare_view, view, view.label())
                                .on_hover_text("key C cycles the views")
                                .on_disabled_hover_text("B − A needs a heatmap mode");
                        });
                    }
                });
                if app.settings.compare_view == CompareView::Difference && !heatmap {
                    ui.label(RichText::new("B − A needs a heatmap mode: showing B.").weak());
                }
                ui.label(
                    RichText::new(
                        "A is built afresh over each scene loaded and after each move: \
                         where B refits, B − A shows what the refit costs.",
                    )
                    .weak(),
                );
            }
        });
}

/// The summary in the stats panel: for each counter compared, A's and B's totals and
/// means, B − A, and the shares of pixels B made cheaper, left equal, made dearer.
pub fn summary(app: &BvhLabApp, ui: &mut egui::Ui) {
    if app.pinned.is_none() {
        return;
    }
    ui.heading("A against B");
    let Some(compared) = &app.compared else {
        ui.label("tracing A…");
        ui.separator();
        return;
    };
    if let Some(e) = &compared.error {
        ui.colored_label(ui.visuals().warn_fg_color, e);
    }
    for s in &compared.summaries {
        ui.strong(format!("{} ({})", s.counter.label(), s.rays.label()));
        let change = s
            .percent_change()
            .map(|p| format!(" ({p:+.1} %)"))
            .unwrap_or_default();
        let rows = vec![
            (
                "A".to_string(),
                vec![s.total_a.to_string(), format!("{:.2}", s.mean_a())],
            ),
            (
                "B".to_string(),
                vec![s.total_b.to_string(), format!("{:.2}", s.mean_b())],
            ),
            (
                "B − A".to_string(),
                vec![
                    format!("{:+}{change}", s.total_difference()),
                    format!("{:+.2}", s.mean_difference()),
                ],
            ),
        ];
        let id = ("compare", s.counter.label(), s.rays.label());
        crate::app::panels::table(ui, id, &["total", "mean"], rows);
        let [cheaper, equal, dearer] = s.shares().map(|x| 100.0 * x);
        ui.label(format!(
            "pixels cheaper under B {cheaper:.1} %, equal {equal:.1} %, dearer {dearer:.1} %"
        ));
    }
    ui.separator();
}

/// The B − A scale: blue where B does less work, red where more.
pub fn difference_legend(ui: &mut egui::Ui, rect: egui::Rect, label: &str, max: u32, scale: f32) {
    crate::app::panels::scale_bar(
        ui,
        rect,
        scale,
        &format!("B − A: {label}"),
        |x| diverging(2.0 * x - 1.0),
        [
            format!("−{max} (B cheaper)"),
            "0".to_string(),
            format!("+{max}"),
        ],
    );
}
