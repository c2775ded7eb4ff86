//! The hierarchy diagram under the view (`accel::hierarchy`): the structure's tree as an
//! icicle, the root on top, each node a cell within its parent's span. Linked both ways with
//! the view: hovering a cell names its node and outlines its box in the view; clicking one
//! walks the tree to it (and, during a replay, steps to its visit); the walk's node is
//! outlined here, and a replayed ray's path is drawn through the cells it visited, in order.
//! Subtrees too narrow to see are folded into one cell with a dark foot; the layout is made
//! again only when the tree, the choice or the size changes.

use crate::accel::Outline;
use crate::accel::hierarchy::{self, Cell, Diagram, Fit, Shade, Sizes, Width};
use crate::app::BvhLabApp;
use crate::app::worker::{Command, VisitsRequest};
use crate::render::RayKind;
use crate::render::node_visits::NodeVisits;
use crate::render::overlay::{BOX_EDGES, box_corners};
use crate::render::replay::Ink;
use eframe::egui::{self, Color32, Rect, Sense, Shape, Stroke, StrokeKind, pos2};
use std::sync::Arc;

/// What a diagram's sizes were made for: the outline (its address: a new build is a new
/// outline), the costs, and the measured visits (their address), if any.
#[derive(Clone, Copy, PartialEq)]
struct SizesKey {
    outline: usize,
    costs: [u32; 2],
    visits: usize,
}

/// What a diagram was laid out for.
#[derive(Clone, Copy, PartialEq)]
struct TreeKey {
    sizes: SizesKey,
    width: Width,
    shade: Shade,
    /// The drawing's width and its rows, in points.
    size: [u32; 2],
    /// The zoom window's ends, as bits.
    window: [u64; 2],
}

/// One diagram: its zoom, and its sizes and layout as last made (each made again only when
/// what it was made for changes).
pub struct TreeView {
    /// The span of the unit width shown: the whole tree is [0, 1).
    window: (f64, f64),
    /// The outline the window was zoomed on (a new tree opens whole).
    zoomed_on: usize,
    sizes: Option<(SizesKey, Arc<Sizes>)>,
    layout: Option<(TreeKey, Arc<Diagram>)>,
}

impl Default for TreeView {
    fn default() -> Self {
        TreeView {
            window: WHOLE,
            zoomed_on: 0,
            sizes: None,
            layout: None,
        }
    }
}

const WHOLE: (f64, f64) = (0.0, 1.0);
/// The narrowest window: a millionth of the tree (a leaf's cell is far wider on any scene
/// that loads).
const MIN_SPAN: f64 = 1e-6;

impl TreeView {
    /// Zooms by `factor` (above 1 in) keeping the point at `at` (0 to 1 across the drawing)
    /// where it is.
    fn zoom(&mut self, factor: f64, at: f64) {
        let (w0, w1) = self.window;
        let pivot = w0 + at * (w1 - w0);
        let span = ((w1 - w0) / factor).clamp(MIN_SPAN, 1.0);
        self.place(pivot - at * span, span);
    }

    /// Moves the window by `by` of its own width.
    fn pan(&mut self, by: f64) {
        let (w0, w1) = self.window;
        self.place(w0 + by * (w1 - w0), w1 - w0);
    }

    /// The window of width `span` from `start`, kept within the tree.
    fn place(&mut self, start: f64, span: f64) {
        let start = start.clamp(0.0, 1.0 - span);
        self.window = (start, start + span);
    }

    /// The span of the tree's unit width shown: (0, 1) for the whole tree.
    pub fn window(&self) -> (f64, f64) {
        self.window
    }

    /// The diagram as last laid out, if it has been.
    pub fn drawn(&self) -> Option<&Diagram> {
        self.layout.as_ref().map(|(_, d)| &**d)
    }

    /// The share of the tree's width shown.
    fn span(&self) -> f64 {
        self.window.1 - self.window.0
    }

    /// Where cell `c` is drawn in `area`, rows `row` points tall (a cell reaching past the
    /// window stops just past the drawing's edge).
    fn placed(&self, area: Rect, row: f32, c: &Cell) -> Rect {
        let (w0, w1) = self.window;
        let x = |t: f64| {
            let x = area.left() + ((t - w0) / (w1 - w0)) as f32 * area.width();
            x.clamp(area.left() - 2.0, area.right() + 2.0)
        };
        let y = area.top() + c.depth as f32 * row;
        Rect::from_min_max(pos2(x(c.x0), y), pos2(x(c.x1).max(x(c.x0) + 1.0), y + row))
    }

    /// The position across the tree's unit width under `x` in `area`.
    fn at(&self, area: Rect, x: f32) -> f64 {
        let (w0, w1) = self.window;
        w0 + f64::from((x - area.left()) / area.width()) * (w1 - w0)
    }
}

/// Cells narrower than this many points are folded.
const FOLD: f32 = 1.5;
/// How much one point of scrolling zooms: e^(0.004) per point, about ×1.5 a wheel notch.
const ZOOM_PER_POINT: f32 = 0.004;
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

/// Height of the caption above each diagram of an A | B pair.
const LABEL: f32 = 16.0;

/// The layout of `outline` for `area` within the view's window, from the cache unless the
/// tree, the choice, the size, the costs, the visits or the window changed.
fn laid_out(
    view: &mut TreeView,
    outline: &Arc<Outline>,
    width: Width,
    shade: Shade,
    area: Rect,
    costs: (f32, f32),
    visits: Option<hierarchy::Visits>,
) -> Arc<Diagram> {
    let address = Arc::as_ptr(outline) as usize;
    if view.zoomed_on != address {
        (view.window, view.zoomed_on) = (WHOLE, address);
    }
    let sizes_key = SizesKey {
        outline: address,
        costs: [costs.0.to_bits(), costs.1.to_bits()],
        visits: visits.map_or(0, |v| v.per_node.as_ptr() as usize),
    };
    let sizes = match &view.sizes {
        Some((k, s)) if *k == sizes_key => s.clone(),
        _ => {
            let s = Arc::new(Sizes::of(outline, costs, visits));
            view.sizes = Some((sizes_key, s.clone()));
            s
        }
    };
    let max_rows = ((area.height() / MIN_ROW) as u32).max(1);
    let key = TreeKey {
        sizes: sizes_key,
        width,
        shade,
        size: [area.width() as u32, max_rows],
        window: [view.window.0.to_bits(), view.window.1.to_bits()],
    };
    match &view.layout {
        Some((k, d)) if *k == key => d.clone(),
        _ => {
            let fit = Fit {
                fold: f64::from(FOLD / area.width().max(1.0)),
                max_rows: max_rows - 1,
                window: view.window,
            };
            let d = Arc::new(sizes.layout(outline, width, shade, fit));
            view.layout = Some((key, d.clone()));
            d
        }
    }
}

/// Paints the cells of `d` over `area`: colour by `shade`, hairlines where there is room,
/// a dark foot under a folded subtree.
fn paint_cells(painter: &egui::Painter, view: &TreeView, area: Rect, d: &Diagram, shade: Shade) {
    let row = area.height() / (d.rows + 1) as f32;
    let painter = painter.with_clip_rect(area);
    for c in &d.cells {
        let r = view.placed(area, row, c);
        let [red, green, blue, _] = d.color(shade, c.value);
        painter.rect_filled(r, 0.0, Color32::from_rgb(red, green, blue));
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
}

/// "A: bvh (binned SAH): SAH cost 32.5; measured 41.2 per ray (30.1 nodes, 11.1 tests)".
fn tree_caption(
    name: &str,
    label: &str,
    sah: Option<(f64, f32, f32)>,
    frame: Option<&crate::render::Frame>,
    (c_trav, c_isect): (f32, f32),
) -> String {
    use crate::accel::Counter;
    let mut text = format!("{name}: {label}");
    if let Some((cost, _, _)) = sah {
        text += &format!(": SAH cost {cost:.2}");
    }
    if let Some(f) = frame.filter(|f| f.summary.counted()) {
        let mean = |c| f.summary.counter(RayKind::Primary, c).mean;
        let (nodes, tests) = (mean(Counter::NodesVisited), mean(Counter::TriangleTests));
        let per_ray = f64::from(c_trav) * nodes + f64::from(c_isect) * tests;
        text += &format!(
            "; measured {per_ray:.1} per primary ray ({nodes:.1} nodes, {tests:.1} tests)"
        );
    }
    text
}

/// The cell that shows `node`: its own, or its nearest drawn ancestor's when it is folded.
fn drawn_cell<'d>(d: &'d Diagram, outline: &Outline, node: u32) -> Option<&'d Cell> {
    let mut at = Some(node as usize).filter(|&n| n < outline.nodes.len());
    while let Some(n) = at {
        if let Some(c) = d.cell_of(n as u32) {
            return Some(c);
        }
        at = Some(outline.nodes[n].parent as usize).filter(|&p| p < outline.nodes.len());
    }
    None
}

fn ink(i: Ink) -> Color32 {
    let [r, g, b, _] = i.color();
    Color32::from_rgb(r, g, b)
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
        ui.separator();
        let views = [&mut app.tree_diagram, &mut app.tree_diagram_a];
        let span = views.iter().map(|v| v.span()).fold(1.0, f64::min);
        if span < 1.0 {
            ui.label(format!("zoomed ×{:.0}", 1.0 / span));
            if ui
                .button("whole tree")
                .on_hover_text("Show the whole tree again (or double-click the diagram)")
                .clicked()
            {
                views.into_iter().for_each(|v| v.window = WHOLE);
            }
        } else {
            ui.weak("scroll to zoom, drag to pan");
        }
    });
    ui.data_mut(|d| {
        d.insert_temp(width_id, width);
        d.insert_temp(shade_id, shade);
    });
    let outline = app.outline.clone();
    if outline.nodes.is_empty() {
        ui.label("No tree yet.");
        // Filled all the same: a panel keeps the height its contents take at first.
        ui.allocate_space(ui.available_size());
        return;
    }
    let visits = if shade.is_measured() || width == Width::Visits {
        let v = measured_visits(app);
        ui.label(match &v {
            Some(v) => format!(
                "measured: the visits of {} {} rays of the frame in view",
                v.rays,
                if app.settings.shadow_rays {
                    "shadow"
                } else {
                    "primary"
                }
            ),
            None => "counting the visits of the frame's rays…".to_string(),
        });
        v
    } else {
        None
    };
    let (response, painter) = ui.allocate_painter(ui.available_size(), Sense::click_and_drag());
    response
        .widget_info(|| egui::WidgetInfo::labeled(egui::Role::Canvas, true, "hierarchy diagram"));
    // With a pinned A: A's tree above B's, on one colour scale, each with its costs.
    let pinned = app.shown.as_ref().and_then(|s| s.pinned_tree.clone());
    let mut area = response.rect;
    let costs = app.settings.structure.sah_constants();
    let a_area = pinned.as_ref().map(|_| {
        let half = area.height() / 2.0;
        let a_area = Rect::from_min_max(area.min, pos2(area.right(), area.top() + half - 2.0))
            .with_min_y(area.top() + LABEL);
        area = area.with_min_y(area.top() + half + LABEL);
        a_area
    });
    // Scrolling (or pinching) zooms the diagram under the pointer, dragging pans it, and a
    // double click shows the whole tree again.
    if let Some(pointer) = response.hover_pos() {
        let (view, under) = match a_area {
            Some(a) if pointer.y < a.bottom() + LABEL / 2.0 => (&mut app.tree_diagram_a, a),
            _ => (&mut app.tree_diagram, area),
        };
        let (scroll, pinch) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
        let factor = f64::from(pinch) * f64::from(scroll * ZOOM_PER_POINT).exp();
        if factor != 1.0 {
            view.zoom(
                factor,
                f64::from((pointer.x - under.left()) / under.width()),
            );
        }
        if response.dragged() {
            view.pan(f64::from(-response.drag_delta().x / under.width()));
        }
        if response.double_clicked() {
            view.window = WHOLE;
        }
    }
    let a_diagram = pinned.as_ref().zip(a_area).map(|(a, a_area)| {
        let a_costs = a.sah_cost.map_or(costs, |(_, t, i)| (t, i));
        let d = laid_out(
            &mut app.tree_diagram_a,
            &a.outline,
            width,
            shade,
            a_area,
            a_costs,
            None,
        );
        (a, a_area, d)
    });
    let visits = visits.as_ref().map(|v| hierarchy::Visits {
        per_node: &v.per_node,
        rays: v.rays,
    });
    let mut d = laid_out(
        &mut app.tree_diagram,
        &outline,
        width,
        shade,
        area,
        costs,
        visits,
    );
    if let Some((a, a_area, a_d)) = &a_diagram {
        // One colour scale for both: the union of their ranges.
        let range = (a_d.range.0.min(d.range.0), a_d.range.1.max(d.range.1));
        let mut a_d = (**a_d).clone();
        a_d.range = range;
        Arc::make_mut(&mut d).range = range;
        paint_cells(&painter, &app.tree_diagram_a, *a_area, &a_d, shade);
        let a_frame = app.shown.as_ref().and_then(|s| s.pinned_frame.clone());
        let label = |y: f32, what: String| {
            painter.text(
                pos2(area.left() + 4.0, y),
                egui::Align2::LEFT_BOTTOM,
                what,
                egui::FontId::proportional(13.0),
                ui.visuals().strong_text_color(),
            );
        };
        let a_costs = a.sah_cost.map_or(costs, |(_, t, i)| (t, i));
        label(
            a_area.top() - 1.0,
            tree_caption("A", &a.label, a.sah_cost, a_frame.as_deref(), a_costs),
        );
        let b_frame = app.shown.as_ref().map(|s| s.frame.clone());
        let b_sah = app
            .sah_prediction
            .as_ref()
            .map(|p| (p.predicted, p.c_trav, p.c_isect));
        label(
            area.top() - 1.0,
            tree_caption(
                "B",
                &app.settings.structure.label(),
                b_sah,
                b_frame.as_deref(),
                costs,
            ),
        );
    }
    let d = d;
    let row = area.height() / (d.rows + 1) as f32;
    let view = &app.tree_diagram;
    let cell_rect = |c: &hierarchy::Cell| view.placed(area, row, c);
    paint_cells(&painter, view, area, &d, shade);
    // The replayed ray's path: the cells it visited up to the shown stop, joined in order,
    // the stop's own cell brightest; the visits still to come faintly.
    let mut replay_visit = None;
    if let Some(view) = &app.replay {
        let path = &view.replay.outline_nodes;
        let mut centres = Vec::new();
        for (k, node) in path.iter().enumerate() {
            let Some(c) = node.and_then(|n| drawn_cell(&d, &outline, n)) else {
                continue;
            };
            let r = cell_rect(c);
            let (width, color) = match k.cmp(&view.stop) {
                std::cmp::Ordering::Less => (2.0, ink(Ink::Visited)),
                std::cmp::Ordering::Equal => (3.0, ink(Ink::Current)),
                std::cmp::Ordering::Greater => (1.0, Color32::from_white_alpha(90)),
            };
            painter.rect_stroke(r, 0.0, Stroke::new(width, color), StrokeKind::Inside);
            if k <= view.stop {
                centres.push(r.center());
            }
        }
        painter.add(Shape::line(centres, Stroke::new(1.5, ink(Ink::Current))));
        replay_visit = Some(path.clone());
    }
    // The walk's node, or its nearest drawn ancestor when it is folded away.
    if let Some(c) = app.walk.and_then(|w| drawn_cell(&d, &outline, w)) {
        painter.rect_stroke(
            cell_rect(c),
            0.0,
            Stroke::new(2.5, Color32::from_rgb(255, 80, 80)),
            StrokeKind::Outside,
        );
    }
    // Hovering and clicking name B's nodes only (over A's diagram, nothing).
    let Some(pointer) = response.hover_pos().filter(|p| area.contains(*p)) else {
        return;
    };
    let depth = ((pointer.y - area.top()) / row) as u32;
    let at = app.tree_diagram.at(area, pointer.x);
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
    // During a replay, the ray's first visit of the node (or of a node folded into it).
    let visit = replay_visit.and_then(|path| {
        path.iter().position(|p| {
            p.and_then(|p| drawn_cell(&d, &outline, p))
                .is_some_and(|c| c.node == cell.node)
        })
    });
    let also = match visit {
        Some(k) => format!(" (the replayed ray's visit {})", k + 1),
        None => String::new(),
    };
    app.tree_hover = Some(cell.node);
    let response = response.on_hover_text(format!(
        "node {} at depth {}: {what}{value}; click to walk the tree to it{also}",
        cell.node, n.depth
    ));
    if response.clicked() {
        app.walk = Some(cell.node);
        if let (Some(k), Some(view)) = (visit, &mut app.replay) {
            view.stop = k;
        }
    }
}

/// The visits of the shown frame's rays to the outline's nodes, if counted for this outline,
/// view and kind of ray; otherwise asks the worker to count them (once) and gives `None`.
fn measured_visits(app: &mut BvhLabApp) -> Option<Arc<NodeVisits>> {
    let shown = app.shown.as_ref()?;
    let request = VisitsRequest {
        camera: shown.job.camera,
        width: shown.job.width,
        height: shown.job.height,
        rays: if app.settings.shadow_rays {
            RayKind::Shadow
        } else {
            RayKind::Primary
        },
    };
    let outline = Arc::as_ptr(&app.outline) as usize;
    match &app.node_visits {
        Some((o, r, v)) if *o == outline && *r == request => return Some(v.clone()),
        _ => {}
    }
    if app.visits_asked.as_ref() != Some(&request) {
        app.visits_asked = Some(request.clone());
        app.worker.send(Command::NodeVisits(request));
    }
    None
}

/// The hovered cell's node outlined in the view, seen through the shown frame's camera.
pub fn draw_hovered_box(app: &BvhLabApp, painter: &egui::Painter, rect: Rect) {
    let (Some(node), Some(shown)) = (app.tree_hover, &app.shown) else {
        return;
    };
    let Some(n) = app.outline.nodes.get(node as usize) else {
        return;
    };
    let job = &shown.job;
    let corners = box_corners(&n.bounds).map(|p| {
        let (x, y, _) = job.camera.project(p, job.width, job.height)?;
        Some(pos2(
            rect.min.x + x / job.width as f32 * rect.width(),
            rect.min.y + y / job.height as f32 * rect.height(),
        ))
    });
    for (a, b) in BOX_EDGES {
        if let (Some(a), Some(b)) = (corners[a], corners[b]) {
            // Dark under light, so the box reads on any colour.
            painter.line_segment([a, b], Stroke::new(4.0, Color32::from_black_alpha(160)));
            painter.line_segment([a, b], Stroke::new(2.0, Color32::WHITE));
        }
    }
}
