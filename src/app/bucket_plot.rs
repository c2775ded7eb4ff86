//! The bucket-cost plot of the tree walk: the SAH cost of every split the builder weighs
//! at the current node, one curve per axis, beside the cost of making it a leaf and the
//! cost of the split the tree has there.

use crate::accel::split_costs::SplitCosts;
use egui::Color32;
use egui_plot::{Corner, HLine, Legend, Line, LineStyle, Plot, PlotPoints, Points};

const AXIS_COLORS: [Color32; 3] = [
    Color32::from_rgb(230, 80, 70),
    Color32::from_rgb(90, 190, 90),
    Color32::from_rgb(80, 140, 240),
];
/// A curve keeps at most this many points: a full sweep at the root of a big scene weighs
/// hundreds of thousands of positions, more than the plot has pixels.
const MAX_POINTS: usize = 1024;

/// Draws the plot; `node_cost` is the cost of the split the tree actually has here (a BVH
/// built by another strategy, or refitted, may have another split than the cheapest).
pub fn show(ui: &mut egui::Ui, costs: &SplitCosts, node_cost: Option<f32>) {
    let what = costs.method.describe(costs.triangles);
    ui.label(format!(
        "Split costs: {what}, position across the node's box"
    ));
    let Some(cheapest) = costs.cheapest else {
        ui.label("no candidate plane separates these triangles");
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
    Plot::new("bucket costs")
        .height(190.0)
        .legend(Legend::default().position(Corner::LeftTop))
        .x_axis_label("split position (0 = box min, 1 = max)")
        .y_axis_label("SAH cost")
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show(ui, |plot| {
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
                    Line::new(name, PlotPoints::from(envelope(points))).color(AXIS_COLORS[axis]),
                );
            }
            plot.hline(
                HLine::new("leaf: C_isect·N", costs.leaf_cost as f64)
                    .color(Color32::GRAY)
                    .style(LineStyle::dashed_loose()),
            );
            if let Some(cost) = node_cost {
                plot.hline(
                    HLine::new("this node's split", cost as f64)
                        .color(Color32::from_rgb(255, 140, 40))
                        .style(LineStyle::dotted_dense()),
                );
            }
            let x = span(cheapest.axis)(cheapest.position);
            plot.points(
                Points::new("cheapest", vec![[x, cheapest.cost as f64]])
                    .radius(4.0)
                    .color(AXIS_COLORS[cheapest.axis]),
            );
        });
    let axis = ["x", "y", "z"][cheapest.axis];
    ui.label(format!(
        "cheapest: {axis} = {:.4}, cost {:.3} ({} | {} triangles); as a leaf {:.3}",
        cheapest.position, cheapest.cost, cheapest.left, cheapest.right, costs.leaf_cost
    ));
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
