//! The bucket-cost plot of the tree walk: the SAH cost of every split the builder weighs
//! at the current node, one curve per axis, beside the cost of making it a leaf and the
//! cost of the split the tree has there.

use crate::accel::split_costs::SplitCosts;
use egui::Color32;
use egui_plot::{HLine, Line, LineStyle, Plot, PlotPoints, Points};

/// The x, y and z axes' colours, in every plot and picture of the three axes.
pub(super) const AXIS_COLORS: [Color32; 3] = [
    Color32::from_rgb(230, 80, 70),
    Color32::from_rgb(90, 190, 90),
    Color32::from_rgb(80, 140, 240),
];
/// A curve keeps at most this many points: a full sweep at the root of a big scene weighs
/// hundreds of thousands of positions, more than the plot has pixels.
const MAX_POINTS: usize = 1024;

/// Draws the plot; `node_cost` is the cost of the split the tree actually has here (a BVH
/// built by another strategy, or refitted, may have another split than the cheapest). A
/// button opens it enlarged in a window of its own (resizable, for the projector).
pub fn show(ui: &mut egui::Ui, costs: &SplitCosts, node_cost: Option<f32>) {
    let what = costs.method.describe(costs.triangles);
    ui.label(format!(
        "Split costs: {what}, position across the node's box"
    ));
    let Some(cheapest) = costs.cheapest else {
        ui.label("no candidate plane separates these triangles");
        return;
    };
    let id = ui.scope_id().with("enlarged split costs");
    let mut enlarged = ui.data(|d| d.get_temp::<bool>(id)).unwrap_or(false);
    legend(ui, node_cost.is_some());
    plot(ui, "bucket costs", costs, node_cost, 190.0);
    let axis = ["x", "y", "z"][cheapest.axis];
    let summary = format!(
        "cheapest: {axis} = {:.4}, cost {:.3} ({} | {} triangles); as a leaf {:.3}",
        cheapest.position, cheapest.cost, cheapest.left, cheapest.right, costs.leaf_cost
    );
    ui.label(&summary);
    if ui.button("Enlarge the plot").clicked() {
        enlarged = true;
    }
    egui::Window::new(format!("Split costs: {what}"))
        .open(&mut enlarged)
        .default_size([760.0, 480.0])
        .resizable(true)
        .show(ui.ctx(), |ui| {
            legend(ui, node_cost.is_some());
            let height = (ui.available_height() - 28.0).max(160.0);
            plot(ui, "bucket costs enlarged", costs, node_cost, height);
            ui.label(&summary);
        });
    ui.data_mut(|d| d.insert_temp(id, enlarged));
}

/// The curves' key, above the plot rather than over its curves.
fn legend(ui: &mut egui::Ui, node_split: bool) {
    ui.horizontal_wrapped(|ui| {
        for (axis, name) in ["x", "y", "z"].iter().enumerate() {
            ui.colored_label(AXIS_COLORS[axis], format!("— {name} split"));
        }
        ui.colored_label(Color32::GRAY, "- - leaf: C_isect·N");
        if node_split {
            ui.colored_label(NODE_SPLIT, "··· this node's split");
        }
    });
}

const NODE_SPLIT: Color32 = Color32::from_rgb(255, 140, 40);

fn plot(ui: &mut egui::Ui, id: &str, costs: &SplitCosts, node_cost: Option<f32>, height: f32) {
    let Some(cheapest) = costs.cheapest else {
        return;
    };
    let span = |axis: usize| {
        let (lo, hi) = (costs.bounds.min[axis], costs.bounds.max[axis]);
        move |x: f32| {
            if hi > lo {
                ((x - lo) / (hi - lo)) as f64
            } else {
                0.5
            }
        }
    };
    Plot::new(id)
        .height(height)
        .x_axis_label("split position (0 = box min, 1 = max)")
        .y_axis_label("SAH cost")
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show(ui, |plot| {
            // The leaf's and the node's costs first, so the curves are drawn over them.
            plot.hline(
                HLine::new("leaf: C_isect·N", costs.leaf_cost as f64)
                    .color(Color32::GRAY)
                    .style(LineStyle::dashed_loose()),
            );
            if let Some(cost) = node_cost {
                plot.hline(
                    HLine::new("this node's split", cost as f64)
                        .color(NODE_SPLIT)
                        .style(LineStyle::dotted_dense()),
                );
            }
            for axis in 0..3 {
                let along = span(axis);
                let points: Vec<[f64; 2]> = costs
                    .candidates
                    .iter()
                    .filter(|c| c.axis == axis)
                    .map(|c| [along(c.position), c.cost as f64])
                    .collect();
                let name = ["x", "y", "z"][axis];
                plot.line(
                    Line::new(name, PlotPoints::from(envelope(points)))
                        .color(AXIS_COLORS[axis])
                        .width(2.0),
                );
            }
            let x = span(cheapest.axis)(cheapest.position);
            plot.points(
                Points::new("cheapest", vec![[x, cheapest.cost as f64]])
                    .radius(4.0)
                    .color(AXIS_COLORS[cheapest.axis]),
            );
        });
}

/// Thins a long curve to at most `MAX_POINTS`, keeping each stretch's lowest and highest
/// point so the minimum still shows.
fn envelope(points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    if points.len() <= MAX_POINTS {
        return points;
    }
    let chunk = points.len().div_ceil(MAX_POINTS / 2);
    points
        .chunks(chunk)
        .flat_map(|c| {
            let lo = c.iter().min_by(|a, b| a[1].total_cmp(&b[1])).copied();
            let hi = c.iter().max_by(|a, b| a[1].total_cmp(&b[1])).copied();
            let (lo, hi) = (lo.unwrap_or([0.0; 2]), hi.unwrap_or([0.0; 2]));
            if lo[0] <= hi[0] { [lo, hi] } else { [hi, lo] }
        })
        .collect()
}
