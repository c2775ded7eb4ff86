//! The hierarchy diagram under the view (`accel::hierarchy`): the structure's tree as an
//! icicle, the root on top, each node a cell within its parent's span. Hovering a cell names
//! its node; clicking one walks the tree to it, so its box is outlined in the view, and the
//! walk's node is outlined here. Subtrees too narrow to see are folded into one cell with a
//! dark foot; the layout is made again only when the tree, the choice or the size changes.

use crate::accel::hierarchy::{self, Shade, Width};
use crate::app::BvhLabApp;
use crate::render::colormap::{to_rgba8, viridis};
use eframe::egui::{self, Color32, Rect, Sense, Stroke, StrokeKind, pos2};
use std::sync::Arc;

/// What a diagram was laid out for.
#[derive(Clone, Copy, PartialEq)]
pub struct TreeKey {
    /// The outline it shows (its address: a new build is a new outline).
    outline: usize,
    width: Width,
    shade: Shade,
    /// The drawing's width and its rows, in points.
    size: [u32; 2],
    costs: [u32; 2],
}

/// Cells narrower than this many points are folded.
const FOLD: f32 = 1.5;
/// Rows are at least this tall.
const MIN_ROW: f32 = 4.0;

pub fn tree_panel(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let mut open = app.settings.show_tree;
    egui::Panel::bottom("tree")
        .resizable(true)
        .default_size(190.0)
        .size_range(90.0..=480.0)
        .show_collapsible(ui, &mut open, |ui| diagram(app, ui));
    app.settings.show_tree = open;
}

fn chosen<T: Copy + Send + Sync + 'static>(ui: &egui::Ui, salt: &str, default: T) -> (egui::Id, T) {
    let id = ui.scope_id().with(("tree diagram", salt));
    (id, ui.data(|d| d.get_temp(id)).unwrap_or(default))
}

fn diagram(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let (width_id, mut width) = chosen(ui, "width", Width::Triangles);
    let (shade_id, mut shade) = chosen(ui, "shade", Shade::Depth);
    ui.horizontal_wrapped(|ui| {
        ui.strong("Tree");
        ui.label("width:");
        for w in Width::ALL {
            ui.selectable_value(&mut width, w, w.short())
                .on_hover_text(w.label());
        }
        ui.separator();
        ui.label("colour:");
        for s in Shade::ALL {
            ui.selectable_value(&mut shade, s, s.short())
                .on_hover_text(s.label());
        }
    });
    ui.data_mut(|d| {
        d.insert_temp(width_id, width);
        d.insert_temp(shade_id, shade);
    });
    let outline = app.outline.clone();
    if outline.nodes.is_empty() {
        ui.label("No tree yet.");
        return;
    }
    let (response, painter) = ui.allocate_painter(ui.available_size(), Sense::click());
    response
        .widget_info(|| egui::WidgetInfo::labeled(egui::Role::Canvas, true, "hierarchy diagram"));
    let area = response.rect;
    let max_rows = ((area.height() / MIN_ROW) as u32).max(1);
    let b = &app.settings.structure.bvh;
    let key = TreeKey {
        outline: Arc::as_ptr(&outline) as usize,
        width,
        shade,
        size: [area.width() as u32, max_rows],
        costs: [b.c_trav.to_bits(), b.c_isect.to_bits()],
    };
    let d = match &app.tree_diagram {
        Some((k, d)) if *k == key => d.clone(),
        _ => {
            let d = Arc::new(hierarchy::layout(
                &outline,
                width,
                shade,
                f64::from(FOLD / area.width().max(1.0)),
                max_rows - 1,
                (b.c_trav, b.c_isect),
            ));
            app.tree_diagram = Some((key, d.clone()));
            d
        }
    };
    let row = area.height() / (d.rows + 1) as f32;
    let cell_rect = |c: &hierarchy::Cell| {
        let x = |t: f64| area.left() + t as f32 * area.width();
        let y = area.top() + c.depth as f32 * row;
        Rect::from_min_max(pos2(x(c.x0), y), pos2(x(c.x1).max(x(c.x0) + 1.0), y + row))
    };
    for c in &d.cells {
        let r = cell_rect(c);
        let [red, green, blue, _] = to_rgba8(viridis(d.scale(shade, c.value) as f32));
        let color = Color32::from_rgb(red, green, blue);
        painter.rect_filled(r, 0.0, color);
        if r.width() >= 4.0 && r.height() >= 4.0 {
            painter.rect_stroke(r, 0.0, Stroke::new(1.0, Color32::WHITE), StrokeKind::Inside);
        }
        if c.folded {
            let foot = Rect::from_min_max(
                pos2(r.left(), r.bottom() - (r.height() / 4.0).max(1.0)),
                r.max,
            );
            painter.rect_filled(foot, 0.0, Color32::from_gray(40));
        }
    }
    // The walk's node, or its nearest drawn ancestor when it is folded away.
    let mut walked = app
        .walk
        .map(|w| w as usize)
        .filter(|&w| w < outline.nodes.len());
    while let Some(w) = walked {
        if let Some(c) = d.cell_of(w as u32) {
            painter.rect_stroke(
                cell_rect(c),
                0.0,
                Stroke::new(2.5, Color32::from_rgb(255, 80, 80)),
                StrokeKind::Outside,
            );
            break;
        }
        walked = Some(outline.nodes[w].parent as usize).filter(|&p| p < outline.nodes.len());
    }
    let Some(pointer) = response.hover_pos() else {
        return;
    };
    let depth = ((pointer.y - area.top()) / row) as u32;
    let at = f64::from((pointer.x - area.left()) / area.width());
    let Some(cell) = d
        .cells
        .iter()
        .find(|c| c.depth == depth && c.x0 <= at && at < c.x1)
    else {
        return;
    };
    painter.rect_stroke(
        cell_rect(cell),
        0.0,
        Stroke::new(1.5, Color32::BLACK),
        StrokeKind::Inside,
    );
    let n = &outline.nodes[cell.node as usize];
    let what = if n.is_leaf() {
        format!("leaf, {} triangles", n.refs.1)
    } else if cell.folded {
        "subtree folded (too small to draw)".to_string()
    } else {
        format!("{} children", n.child_count)
    };
    let value = if shade == Shade::Depth {
        String::new()
    } else {
        format!(", {} {:.3e}", shade.short(), cell.value)
    };
    let response = response.on_hover_text(format!(
        "node {} at depth {}: {what}{value}; click to walk the tree to it",
        cell.node, n.depth
    ));
    if response.clicked() {
        app.walk = Some(cell.node);
    }
}
