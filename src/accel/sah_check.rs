//! The SAH's prediction against what rays measure. The SAH cost of a tree is the expected
//! cost of a ray through the scene box under its assumptions: rays are uniformly
//! distributed lines (so a ray hits a box with probability ∝ its surface area), nothing
//! stops them (no hit ends the traversal early), and a leaf visit costs only its triangle
//! tests. Measured cost per ray is C_trav · nodes visited + C_isect · triangle tests; here
//! for random lines through the box, the rays the SAH assumes (the app and `bench` set the
//! view's own rays beside it).

use super::{Accel, Counters, Structure, StructureParams};
use crate::geometry::{Aabb, Ray, Watertight};
use crate::random::{cosine_direction, splitmix64};
use glam::Vec3;
use rayon::prelude::*;

/// How many random lines measure the SAH's own case: a mean within about a per cent.
pub const RANDOM_RAYS: usize = 1 << 16;

/// A tree's SAH cost against the cost per ray measured on uniformly random lines through
/// the scene box, in the SAH's units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SahPrediction {
    pub c_trav: f32,
    pub c_isect: f32,
    /// The tree's SAH cost.
    pub predicted: f64,
    /// C_trav · nodes visited + C_isect · triangle tests per random line, closest hit.
    pub random: f64,
    /// The tree's EPO (`accel::epo`), once computed (the app computes it after the frame).
    pub epo: Option<crate::accel::epo::Epo>,
}

impl SahPrediction {
    /// Measured with `rays` random lines; `None` for structures without an SAH cost (grid,
    /// octree, brute force, two levels).
    pub fn of(
        accel: &Structure,
        params: &StructureParams,
        bounds: &Aabb,
        rays: usize,
    ) -> Option<SahPrediction> {
        let (predicted, c_trav, c_isect) = accel.sah_cost(params)?;
        let m = mean_work_of(accel, &random_lines(bounds, rays, 1), false);
        Some(SahPrediction {
            c_trav,
            c_isect,
            predicted,
            random: m.cost(c_trav, c_isect),
            epo: None,
        })
    }
}

/// The mean work per ray of a ray set.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeanWork {
    pub nodes: f64,
    pub box_tests: f64,
    pub triangle_tests: f64,
    pub repeated_tests: f64,
    /// Two-level structures: of `nodes` and `box_tests`, those in the top level, and the
    /// instances entered (all 0 for other structures).
    pub top_nodes: f64,
    pub top_box_tests: f64,
    pub instances_entered: f64,
}

impl MeanWork {
    /// C_trav · nodes visited + C_isect · triangle tests: the SAH's cost of this work.
    pub fn cost(&self, c_trav: f32, c_isect: f32) -> f64 {
        c_trav as f64 * self.nodes + c_isect as f64 * self.triangle_tests
    }
}

/// Uniformly distributed lines through `bounds`, as rays starting on its surface: a point
/// uniform over the surface (faces chosen by area) and a cosine-distributed direction into
/// the box give every line through a convex body the same density.
pub fn random_lines(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let e = (bounds.max - bounds.min).max(Vec3::ZERO);
    // Face pairs by axis: the faces normal to x have area e.y·e.z.
    let areas = [e.y * e.z, e.z * e.x, e.x * e.y];
    let total: f32 = areas.iter().sum();
    (0..n)
        .into_par_iter()
        .map(|i| {
            let h = splitmix64(seed ^ (i as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
            let unit = |shift: u32| ((h >> shift) & 0xff_ffff) as f32 / (1u32 << 24) as f32;
            let pick = unit(0) * total;
            let axis = if pick < areas[0] {
                0
            } else if pick < areas[0] + areas[1] {
                1
            } else {
                2
            };
            let max_side = h >> 63 == 1;
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut point = bounds.min;
            point[u] += unit(24) * e[u];
            point[v] += unit(40).min(0.999_999) * e[v];
            point[axis] = if max_side {
                bounds.max[axis]
            } else {
                bounds.min[axis]
            };
            let mut inward = Vec3::ZERO;
            inward[axis] = if max_side { -1.0 } else { 1.0 };
            Ray::new(point, cosine_direction(inward, h))
        })
        .collect()
}

/// The mean counters per ray of `rays`: closest hit, or any hit for shadow rays.
pub fn mean_work_of(accel: &Structure, rays: &[Ray], any_hit: bool) -> MeanWork {
    let sum = rays
        .par_chunks(256)
        .map(|chunk| {
            let mut c = Counters::default();
            for r in chunk {
                if any_hit {
                    accel.any_hit::<Watertight, _>(r, &mut c);
                } else {
                    accel.closest_hit::<Watertight, _>(r, &mut c);
                }
            }
            [
                c.nodes_visited,
                c.box_tests,
                c.triangle_tests,
                c.repeated_tests,
                c.top_nodes_visited,
                c.top_box_tests,
                c.instances_entered,
            ]
            .map(u64::from)
        })
        .reduce(|| [0; 7], |a, b| std::array::from_fn(|k| a[k] + b[k]));
    let n = rays.len().max(1) as f64;
    MeanWork {
        nodes: sum[0] as f64 / n,
        box_tests: sum[1] as f64 / n,
        triangle_tests: sum[2] as f64 / n,
        repeated_tests: sum[3] as f64 / n,
        top_nodes: sum[4] as f64 / n,
        top_box_tests: sum[5] as f64 / n,
        instances_entered: sum[6] as f64 / n,
    }
}
