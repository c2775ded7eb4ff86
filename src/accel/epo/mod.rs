//! EPO, the end-point overlap of a tree (Aila, Karras & Laine 2013): a second predictor of
//! trace cost beside the SAH. A ray that ends on a surface point p pays for every node whose
//! box holds p. The nodes above p's own triangle are unavoidable; every other node holding p
//! is overlap the SAH does not see (it weighs a box by its area, not by what else lies in
//! it). EPO is that extra cost for an end point spread uniformly over the scene's surfaces:
//!
//! EPO = Σ_n C(n) · A((S \ Q(n)) ∩ n) / A(S)
//!
//! with S the scene's triangles, Q(n) those referenced under node n, A the surface area of
//! geometry (clipped to n's box for ∩ n), and C(n) the node's cost in the SAH's units:
//! C_trav for an interior node, C_isect times its triangles for a leaf.
//!
//! It is computed triangle by triangle (`by_triangle`): each walks the tree from the root
//! into the nodes its part overlaps, skipping the cost of the nodes it is referenced under.
//! A triangle split into several references (SBVH, pre-splitting) is "under" every node
//! above any of them.

pub(crate) mod by_triangle;
pub mod end_points;
pub(crate) mod part;

use super::Outline;
use crate::geometry::{Aabb, Triangle};
pub use end_points::epo_estimate;
use part::{Against, Part};

/// A tree's EPO, in the units of its SAH cost: clipped exactly triangle by triangle, or,
/// for two levels placing more triangles than can be clipped one by one, estimated from
/// end points sampled uniformly over the placed surfaces (`TwoLevel::epo_unless`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epo {
    pub value: f64,
    /// `None` when exact.
    pub estimate: Option<Estimate>,
}

/// How an EPO is found: clipped exactly, or estimated from end points drawn by area.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EpoWay {
    #[default]
    Exact,
    Estimate {
        end_points: u64,
    },
}

/// How good an estimated EPO is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The standard error of the mean over the end points.
    pub std_error: f64,
    pub end_points: u64,
}

impl Epo {
    pub fn exact(value: f64) -> Epo {
        Epo {
            value,
            estimate: None,
        }
    }

    /// "0.123", or "0.1234 ± 0.0021" for an estimate: `decimals` after the point, more
    /// where the standard error needs them to show two digits.
    pub fn label(&self, decimals: usize) -> String {
        match self.estimate {
            None => format!("{:.decimals$}", self.value),
            Some(e) => {
                let needed = (1.0 - e.std_error.max(1e-12).log10().floor()) as usize;
                let d = decimals.max(needed.min(12));
                format!("{:.d$} ± {:.d$}", self.value, e.std_error)
            }
        }
    }
}

/// The EPO of a tree given as its `outline` (BVH2, BVH4/8, k-d tree, octree), whose leaves
/// reference `scene`'s triangles. 0 for a scene without area.
pub fn epo(outline: &Outline, scene: &[Triangle], c_trav: f32, c_isect: f32) -> f64 {
    epo_unless(outline, scene, c_trav, c_isect, &|| false).unwrap_or_default()
}

/// `epo`, given up (`None`) as soon as `abandon` says so: the app computes it at quiet
/// moments and any command comes first.
pub fn epo_unless(
    outline: &Outline,
    scene: &[Triangle],
    c_trav: f32,
    c_isect: f32,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<f64> {
    if outline.nodes.is_empty() {
        return Some(0.0);
    }
    let total_area: f64 = scene.iter().map(area).sum();
    if total_area <= 0.0 {
        return Some(0.0);
    }
    let tree = Tree::of(outline, c_trav, c_isect);
    let overlap = by_triangle::overlap(&tree, outline, scene, abandon);
    overlap.map(|sum| sum / total_area)
}

/// The outline as the walks read it: 32 bytes a node, and each node's cost.
struct Tree {
    nodes: Vec<TreeNode>,
    parent: Vec<u32>,
    /// C_trav for an interior node, C_isect times its triangles for a leaf.
    cost: Vec<f64>,
}

#[derive(Clone, Copy)]
struct TreeNode {
    min: [f32; 3],
    max: [f32; 3],
    first_child: u32,
    child_count: u32,
}

impl Tree {
    fn of(outline: &Outline, c_trav: f32, c_isect: f32) -> Tree {
        let n = &outline.nodes;
        Tree {
            nodes: n
                .iter()
                .map(|o| TreeNode {
                    min: o.bounds.min.into(),
                    max: o.bounds.max.into(),
                    first_child: o.first_child,
                    child_count: o.child_count,
                })
                .collect(),
            parent: n.iter().map(|o| o.parent).collect(),
            cost: n
                .iter()
                .map(|o| {
                    if o.is_leaf() {
                        f64::from(c_isect) * f64::from(o.refs.1)
                    } else {
                        f64::from(c_trav)
                    }
                })
                .collect(),
        }
    }
}

/// A triangle's area, in f64 as its clipped parts' are.
pub fn area(tri: &Triangle) -> f64 {
    Part::of(tri).area
}

/// The area of `tri` clipped to the closed box `cell`.
pub fn clipped_area(tri: &Triangle, cell: &Aabb) -> f64 {
    let whole = Part::of(tri);
    let (min, max) = (cell.min.as_dvec3().into(), cell.max.as_dvec3().into());
    match whole.against(&min, &max) {
        Against::Outside => 0.0,
        Against::Inside => whole.area,
        Against::Crossing => whole.clipped(&min, &max).map_or(0.0, |p| p.area),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_triangle_clipped_by_half_a_box_keeps_half_its_area() {
        // The right triangle (0,0)-(2,0)-(0,2) in z = 0, area 2; the box x ≤ 1 keeps the
        // trapezoid of area 2 − 0.5 = 1.5, the box x ≤ 1, y ≤ 1 the unit square.
        let tri = Triangle::new(
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        );
        let cell = |max: Vec3| Aabb::new(Vec3::splat(-1.0), max);
        assert!((clipped_area(&tri, &cell(Vec3::new(1.0, 5.0, 1.0))) - 1.5).abs() < 1e-12);
        assert!((clipped_area(&tri, &cell(Vec3::new(1.0, 1.0, 1.0))) - 1.0).abs() < 1e-12);
        // A box the triangle only touches, and one in its plane's face.
        assert_eq!(clipped_area(&tri, &cell(Vec3::new(0.0, 5.0, 1.0))), 0.0);
        assert!((clipped_area(&tri, &cell(Vec3::new(5.0, 5.0, 0.0))) - 2.0).abs() < 1e-12);
    }
}
