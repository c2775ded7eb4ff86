//! The statistics panel: the build report, the frame's counters and the SAH predicted
//! against measured.

use crate::accel::split_costs::SplitMethod;
use crate::app::preset::Focus;
use crate::app::{BvhLabApp, Tool};
use eframe::egui::{self};
use egui_plot::{Bar, BarChart, Line, Plot, PlotPoints};

/// The widest a column of the build report grows before its values wrap.
const REPORT_VALUE_WIDTH: f32 = 180.0;
/// Below this width (points) the report's rows are lines, not a two-column table.
const NARROW: f32 = 280.0;

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
        crate::app::bucket_plot::show(ui, costs, own.then_some(info.sah_cost));
        ui.separator();
    }
    // With a pinned A, the comparison is what the user is looking at: first.
    super::layout::section_starts(app, ui, Focus::Compare);
    crate::app::compare::summary(app, ui);
    // While moving triangles, what the move does to the tree is the point: first.
    let moving = app.tool == Tool::Move && app.bvh_report.is_some();
    if moving {
        super::layout::section_starts(app, ui, Focus::Refit);
        super::refit::sah_growth(app, ui);
        ui.separator();
    }
    if app.replay.is_some() || app.replay_error.is_some() || app.tool == Tool::Replay {
        super::layout::section_starts(app, ui, Focus::Replay);
        crate::app::replay::section(app, ui);
        ui.separator();
    }
    ui.heading("Build");
    if let Some(r) = &app.report {
        // A scene with instances of its own first says how it is instanced, as `bvhlab
        // stats` does: the instanced triangles and the memory a flattened copy would take.
        let rows: Vec<(String, String)> = (app.scene_rows.iter().cloned())
            .chain(r.rows())
            .filter(|(k, _)| !k.starts_with("leaf sizes"))
            .map(|(k, v)| {
                // The report is the build's; after refits the cost has moved on.
                match (k.as_str(), app.sah_history.len(), app.sah_history.last()) {
                    ("SAH cost", 2.., Some(now)) => (k, format!("{v} at build, {now:.3} now")),
                    _ => (k, v),
                }
            })
            .collect();
        let rows = rows.into_iter().map(|(k, v)| (k, vec![v])).collect();
        table(ui, "report", &[], rows);
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
    crate::app::export::section(app, ui);
    if app.bvh_report.is_some() && !moving {
        ui.separator();
        super::layout::section_starts(app, ui, Focus::Refit);
        super::refit::sah_growth(app, ui);
    }
}

/// The counted frame's mean and maximum of every counter, for both kinds of ray.
pub(super) fn counter_grid(ui: &mut egui::Ui, s: &crate::render::FrameSummary) {
    let two_level =
        s.counter(
            crate::render::RayKind::Primary,
            crate::accel::Counter::TopNodesVisited,
        )
        .max > 0;
    let rows = crate::accel::Counter::ALL
        .into_iter()
        .filter(|which| two_level || !which.is_two_level())
        .map(|which| {
            let of = |rays| {
                let c = s.counter(rays, which);
                format!("{:.1} / {}", c.mean, c.max)
            };
            let values = vec![
                of(crate::render::RayKind::Primary),
                of(crate::render::RayKind::Shadow),
            ];
            (which.label().to_string(), values)
        })
        .collect();
    ui.label(egui::RichText::new("per ray: mean / max").weak());
    table(ui, "counters", &["primary", "shadow"], rows);
}

/// The SAH's prediction against the cost per ray measured: on the random lines it assumes,
/// and on the frame's own rays, which start at the camera or on surfaces and stop at hits.
pub(super) fn sah_check_section(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let (Some(p), Some(s)) = (app.sah_prediction, app.full_summary.clone()) else {
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
    super::layout::section_starts(app, ui, Focus::SahCheck);
    ui.heading("SAH predicted against measured");
    ui.label("cost per ray: C_trav · nodes visited + C_isect · triangle tests");
    let ratio = |x: f64| format!("{:.0} %", 100.0 * x / p.predicted.max(f64::MIN_POSITIVE));
    let mut rows = vec![(
        "SAH cost (predicted)".to_string(),
        vec![format!("{:.2}", p.predicted)],
    )];
    for (label, cost) in [
        ("random lines through the box", p.random),
        ("this frame's primary rays", measured(RayKind::Primary)),
        ("this frame's shadow rays", measured(RayKind::Shadow)),
    ] {
        rows.push((
            label.into(),
            vec![format!("{cost:.2} ({} of it)", ratio(cost))],
        ));
    }
    // The second predictor: what the SAH does not see, the other geometry inside each box.
    // Under the two levels, past a few million placed triangles, estimated from end points.
    let kind = app.settings.structure.kind;
    rows.push((
        match p.epo.and_then(|e| e.estimate) {
            None => "EPO (end-point overlap)".into(),
            Some(e) => format!("EPO, from {} end points drawn by area", e.end_points),
        },
        vec![match p.epo {
            Some(epo) => format!("{} ({} of the SAH cost)", epo.label(2), ratio(epo.value)),
            None => "computing…".into(),
        }],
    ));
    // Under the two levels, the selected BLAS weighed as a tree of its own.
    if !kind.has_sah_cost() {
        match &app.blas_costs {
            Some(b) => {
                let of_it =
                    |x: f64| format!("{:.0} %", 100.0 * x / b.sah_cost.max(f64::MIN_POSITIVE));
                rows.push((
                    format!(
                        "instance {}'s BLAS, in its mesh's space: SAH cost",
                        b.instance
                    ),
                    vec![format!("{:.2}", b.sah_cost)],
                ));
                rows.push((
                    "its EPO".into(),
                    vec![b.epo.map_or("computing…".into(), |e| {
                        format!("{e:.2} ({} of its SAH cost)", of_it(e))
                    })],
                ));
            }
            None => rows.push((
                "a BLAS's SAH cost and EPO".into(),
                vec!["select an instance".into()],
            )),
        }
    }
    table(ui, "sah check", &[], rows);
}

/// Rows of a name and its values under `header` (one heading per value column; none for
/// a two-column table): a table, or in a narrow panel (the view keeps its share of a small
/// window) each row on one wrapped line, the name dimmed and each value after its
/// heading, rather than value columns squeezed to a letter or cut off at the panel's edge.
pub(crate) fn table(
    ui: &mut egui::Ui,
    id: impl std::hash::Hash + std::fmt::Debug,
    header: &[&str],
    rows: Vec<(String, Vec<String>)>,
) {
    // The visible width: inside a sideways scroll area the available one is unbounded.
    if ui.clip_rect().width() < NARROW {
        for (k, values) in rows {
            ui.horizontal_wrapped(|ui| {
                ui.label(egui::RichText::new(k).weak());
                let values = values.iter().enumerate().map(|(j, v)| match header.get(j) {
                    Some(h) if !h.is_empty() => format!("{h} {v}"),
                    _ => v.clone(),
                });
                ui.label(values.collect::<Vec<_>>().join(", "));
            });
        }
    } else {
        // Long values (the island's re-braiding budget) wrap within their column
        // instead of widening the panel and squeezing the view.
        egui::Grid::new(id)
            .num_columns(1 + header.len().max(1))
            .striped(true)
            .max_col_width(REPORT_VALUE_WIDTH)
            .show(ui, |ui| {
                if !header.is_empty() {
                    ui.label("");
                    for h in header {
                        ui.strong(*h);
                    }
                    ui.end_row();
                }
                for (k, values) in rows {
                    ui.label(k);
                    for v in values {
                        ui.add(egui::Label::new(v).wrap());
                    }
                    ui.end_row();
                }
            });
    }
}
