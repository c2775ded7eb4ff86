//! The views that colour each triangle by a value of its own, where the cost lives on the
//! geometry: its share of the tree's SAH cost (predicted: `accel::triangle_cost`) and the
//! ray–triangle tests the frame's rays did on it (measured: `node_visits::tally`). Each
//! pixel takes the value of the triangle its primary ray hits. The values are worked out
//! once per frame, kept with it (`Frame::triangle_values`) for recolouring and the pixel
//! report, and coloured here rather than in the heatmaps' per-pixel path.

use super::heat::HeatStyle;
use super::node_visits::{TallySize, TriangleCounts, tally};
use super::{BACKGROUND, Frame, Mode, RayKind, RenderSettings, Sample};
use crate::accel::triangle_cost::triangle_costs;
use crate::accel::{Structure, StructureParams};
use crate::geometry::Intersector;
use crate::scene::Scene;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

/// One value per scene triangle (numbered as in the flattened scene), for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleValues {
    pub values: PerTriangle,
    /// The scene's triangles (placed, under the two levels).
    pub triangles: u64,
    /// Of them, those with a value above 0 (tested at least once, for the tests).
    pub above_zero: u64,
    /// Their sum: the tree's SAH cost, or the tests the traced rays did.
    pub total: f64,
    /// The smallest positive and the largest value among the triangles the frame's pixels
    /// show ((0, 0) if none): the colour scale's ends.
    pub shown: (f64, f64),
    /// Measured values: the rays traced, those of every `stride`-th pixel across and down
    /// (1: every pixel's). Predicted values: 0 rays.
    pub rays: u64,
    pub stride: u32,
}

/// The values: every triangle's, or on a scene placing more than
/// `node_visits::EVERY_TRIANGLE_MAX` triangles only those of the triangles worked out (the
/// frame shows, or its rays tested); the others' are 0.
#[derive(Clone, Debug, PartialEq)]
pub enum PerTriangle {
    Every(Vec<f64>),
    Some(HashMap<u64, f64>),
}

impl PerTriangle {
    pub fn get(&self, t: u64) -> f64 {
        match self {
            PerTriangle::Every(v) => usize::try_from(t)
                .ok()
                .and_then(|t| v.get(t))
                .copied()
                .unwrap_or(0.0),
            PerTriangle::Some(m) => m.get(&t).copied().unwrap_or(0.0),
        }
    }

    fn above_zero(&self) -> u64 {
        match self {
            PerTriangle::Every(v) => v.iter().filter(|&&x| x > 0.0).count() as u64,
            PerTriangle::Some(m) => m.values().filter(|&&x| x > 0.0).count() as u64,
        }
    }
}

impl TriangleValues {
    /// The value of the triangle `sample` hit, if it hit one.
    pub fn of(&self, sample: &Sample) -> Option<f64> {
        Some(sample.triangle)
            .filter(|&t| t < self.triangles)
            .map(|t| self.values.get(t))
    }

    fn new(
        values: PerTriangle,
        triangles: u64,
        total: f64,
        frame: &Frame,
        rays: u64,
        stride: u32,
    ) -> Self {
        let mut v = TriangleValues {
            above_zero: values.above_zero(),
            values,
            triangles,
            total,
            shown: (0.0, 0.0),
            rays,
            stride,
        };
        let (lo, hi) = frame
            .samples
            .par_iter()
            .filter_map(|s| v.of(s).filter(|&x| x > 0.0))
            .fold(|| (f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)))
            .reduce(|| (f64::INFINITY, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
        if lo <= hi {
            v.shown = (lo, hi);
        }
        v
    }
}

/// Why a structure has no SAH cost per triangle to show.
pub const NO_SAH_COST: &str = "it splits a tree's SAH cost among the triangles, which only the \
     trees do: the BVHs, the k-d tree, the octree and the two levels (a grid or brute force \
     has no SAH cost)";

/// The per-triangle values kept with a frame, one slot per mode that colours triangles.
#[derive(Clone, Debug, Default)]
pub struct Slots([OnceLock<Arc<TriangleValues>>; 3]);

fn slot(mode: Mode) -> Option<usize> {
    match mode {
        Mode::TriangleCost => Some(0),
        Mode::TestsReceived(RayKind::Primary) => Some(1),
        Mode::TestsReceived(RayKind::Shadow) => Some(2),
        _ => None,
    }
}

impl Frame {
    /// The per-triangle values `mode` colours this frame by, once worked out
    /// (`triangle_values_for`).
    pub fn triangle_values(&self, mode: Mode) -> Option<&Arc<TriangleValues>> {
        self.per_triangle.0.get(slot(mode)?)?.get()
    }

    /// Works out (once) the per-triangle values `mode` colours this frame by: the SAH cost
    /// per triangle of `structure` weighed as `params` say, or the tests per triangle of
    /// the rays of every `stride`-th pixel of the frame `settings` describes (the frame's
    /// own). `Ok(None)` for a mode that colours no triangles or when `abandon` says so;
    /// an error for a structure without an SAH cost.
    #[allow(clippy::too_many_arguments)]
    pub fn triangle_values_for<I: Intersector>(
        &self,
        mode: Mode,
        structure: &Structure,
        params: &StructureParams,
        scene: &Scene,
        settings: &RenderSettings,
        stride: u32,
        abandon: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Arc<TriangleValues>>, &'static str> {
        let Some(cell) = slot(mode).and_then(|k| self.per_triangle.0.get(k)) else {
            return Ok(None);
        };
        if let Some(v) = cell.get() {
            return Ok(Some(v.clone()));
        }
        let triangles = scene.placed_triangles();
        let count = triangles as u64;
        let values = match (mode, structure) {
            // Both levels' shares, worked out for the triangles the frame shows.
            (Mode::TriangleCost, Structure::TwoLevel(tl)) => {
                let (total, c_trav, c_isect) = structure.sah_cost(params).ok_or(NO_SAH_COST)?;
                let costs = tl.placed_costs(c_trav, c_isect);
                let shown = self
                    .samples
                    .iter()
                    .map(|s| s.triangle)
                    .filter(|&t| t < count);
                let values = PerTriangle::Some(costs.of_all(shown));
                TriangleValues::new(values, count, total, self, 0, 0)
            }
            (Mode::TriangleCost, _) => {
                let costs = triangle_costs(structure, params, triangles).ok_or(NO_SAH_COST)?;
                let values = PerTriangle::Every(costs.per_triangle);
                TriangleValues::new(values, count, costs.total, self, 0, 0)
            }
            (Mode::TestsReceived(rays), _) => {
                let size = TallySize {
                    nodes: 0,
                    triangles,
                };
                let Some(t) = tally::<I>(structure, scene, settings, rays, stride, size, abandon)
                else {
                    return Ok(None);
                };
                let total = t.per_triangle.total() as f64;
                let values = match t.per_triangle {
                    TriangleCounts::Every(v) => {
                        PerTriangle::Every(v.iter().map(|&n| n as f64).collect())
                    }
                    TriangleCounts::Tested(m) => {
                        PerTriangle::Some(m.into_iter().map(|(t, n)| (t, n as f64)).collect())
                    }
                };
                TriangleValues::new(values, count, total, self, t.rays, stride.max(1))
            }
            _ => return Ok(None),
        };
        Ok(Some(cell.get_or_init(|| Arc::new(values)).clone()))
    }
}

/// The pixels of a frame in a mode that colours triangles, and for the tests a count at
/// the top of the scale (`heat_max`, else the style's percentile or the largest shown);
/// `None` for another mode. Without the frame's values worked out, hits are grey.
pub(super) fn colorize(
    frame: &Frame,
    mode: Mode,
    heat_max: Option<u32>,
    style: &HeatStyle,
) -> Option<(Vec<u8>, Option<u32>)> {
    colorize_on(frame, mode, heat_max, style, None)
}

/// A value's test count, as the scale reads it.
fn count(values: Option<&TriangleValues>, s: &Sample) -> u32 {
    values
        .and_then(|v| v.of(s))
        .map_or(0, |x| x.min(f64::from(u32::MAX)) as u32)
}

/// The top of the tests' scale for `frame` alone (`heat_max`, else the style's percentile
/// or the largest count shown); `None` in another mode or before its values are worked out.
pub(super) fn tests_top(
    frame: &Frame,
    mode: Mode,
    heat_max: Option<u32>,
    style: &HeatStyle,
) -> Option<u32> {
    let values = frame.triangle_values(mode).map(|v| &**v);
    match (mode, values) {
        (Mode::TestsReceived(_), Some(v)) => Some(style.top(heat_max, v.shown.1 as u32, || {
            frame
                .samples
                .iter()
                .filter(|s| s.is_hit())
                .map(|s| count(values, s))
                .collect()
        })),
        _ => None,
    }
}

/// The cost scale two frames shown side by side share: from the smallest value either
/// shows to the largest; `None` if neither has values.
pub fn shared_shown(frames: &[&Frame], mode: Mode) -> Option<(f64, f64)> {
    frames
        .iter()
        .filter_map(|f| f.triangle_values(mode))
        .map(|v| v.shown)
        .filter(|&(_, hi)| hi > 0.0)
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// `colorize`, the SAH cost on the log scale `shown` when given (else the frame's own).
pub(super) fn colorize_on(
    frame: &Frame,
    mode: Mode,
    heat_max: Option<u32>,
    style: &HeatStyle,
    shown: Option<(f64, f64)>,
) -> Option<(Vec<u8>, Option<u32>)> {
    slot(mode)?;
    let values = frame.triangle_values(mode).map(|v| &**v);
    let top = tests_top(frame, mode, heat_max, style);
    // The SAH cost is always on a log scale, under the shaded scene.
    let shaded = HeatStyle {
        underlay: true,
        ..HeatStyle::default()
    };
    let color = |s: &Sample| -> [u8; 4] {
        let Some(v) = values else {
            return super::colormap::to_rgba8(if s.is_hit() {
                glam::Vec3::splat(0.5)
            } else {
                BACKGROUND
            });
        };
        if !s.is_hit() {
            return super::colormap::to_rgba8(BACKGROUND);
        }
        let c = match (mode, top) {
            (Mode::TestsReceived(_), Some(top)) => style.color(count(values, s), top, s),
            _ => {
                let at = log_position(v.of(s).unwrap_or(0.0), shown.unwrap_or(v.shown));
                shaded.color_at(at, s)
            }
        };
        super::colormap::to_rgba8(c)
    };
    Some((super::paint(&frame.samples, color), top))
}

/// Where `value` sits between `lo` and `hi` on a log scale (0..=1; 0 for nothing).
pub fn log_position(value: f64, (lo, hi): (f64, f64)) -> f32 {
    if value <= 0.0 || lo <= 0.0 || hi <= lo {
        return if value > 0.0 { 1.0 } else { 0.0 };
    }
    (((value.ln() - lo.ln()) / (hi.ln() - lo.ln())) as f32).clamp(0.0, 1.0)
}

/// The value at position `x` (0..=1) of a log scale from `lo` to `hi`: the legend's labels.
pub fn log_value_at(x: f64, (lo, hi): (f64, f64)) -> f64 {
    if lo <= 0.0 || hi <= lo {
        return hi;
    }
    (lo.ln() + x * (hi.ln() - lo.ln())).exp()
}
