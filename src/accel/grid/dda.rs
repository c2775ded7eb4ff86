//! Grid traversal by the 3D-DDA (Amanatides and Woo 1987): from the cell where the ray
//! enters the grid, step into whichever neighbour's shared face the ray crosses first, the
//! 3D version of rasterising a line. The t arithmetic is in f64, and each axis' next crossing
//! is recomputed from the cell index (never accumulated), so the walk stays on the cells the
//! exact ray passes through, far from the origin too; a zero direction component never steps.
//!
//! A hit may lie beyond the cell being visited (its triangle reaches into later cells); it is
//! kept as the best so far, and the walk stops only once the next cell is entered beyond it.
//! Keeping it is what makes mailboxing exact: the triangle will not be tested again there.

use super::Grid;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::query::{AnyHit, Closest, Query};
use crate::accel::replay::{Level, Step, Visited, entered};
use crate::accel::stats::{count_locally, record};
use crate::accel::{Accel, Hit, Mailbox, NoStats, Stats};
use crate::geometry::aabb::SlabRay;
use crate::geometry::{Aabb, Intersector, Ray};
use glam::DVec3;

/// `t` widened by the relative rounding bound of a box's entry distance: a cell entered
/// beyond it cannot hold a hit at `t` or a tie with it.
#[inline(always)]
pub(crate) fn widened(t: f32) -> f64 {
    widened64(f64::from(t))
}

#[inline(always)]
pub(crate) fn widened64(t: f64) -> f64 {
    t + t.abs() * (T_SCALE as f64 - 1.0)
}

/// What a cell visit tells the walk: go on to cells entered up to this t, or stop now.
pub(crate) enum Next {
    Until(f64),
    Stop,
}

impl Grid {
    /// Walks the cells the ray passes through within (tmin, tmax), in order, calling
    /// `visit` with each cell's index. Counts a node visit per cell, one box test for the
    /// grid's box, and one ray–plane test per step (the crossing of the face just stepped
    /// through, the one new plane distance a step computes).
    #[inline(always)]
    pub(crate) fn walk<S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
        mut visit: impl FnMut(usize, &mut S) -> Next,
    ) {
        stats.box_tests(1);
        let entry = self
            .bounds
            .slab_test(&SlabRay::new(ray), ray.tmin, ray.tmax);
        record(stats, || Step::Bounds {
            entry: entered(entry),
        });
        if entry == f32::INFINITY {
            return;
        }
        let o = ray.origin.as_dvec3();
        let d = ray.direction.as_dvec3();
        let (lo, hi) = (self.bounds.min.as_dvec3(), self.bounds.max.as_dvec3());
        // The entry and exit again in f64, to place the first cell; the f32 test above is
        // the conservative yes/no, so a grazing ray whose f64 interval comes out empty by
        // rounding still visits the cell it touches.
        let mut t0 = f64::from(ray.tmin);
        let mut t1 = f64::from(ray.tmax);
        let mut inv = DVec3::ZERO;
        for k in 0..3 {
            if d[k] != 0.0 {
                inv[k] = 1.0 / d[k];
                let (a, b) = ((lo[k] - o[k]) * inv[k], (hi[k] - o[k]) * inv[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        let mut idx = [0u32; 3];
        let mut next = [f64::INFINITY; 3];
        let mut step = [0i32; 3];
        for k in 0..3 {
            let p = if d[k] != 0.0 { o[k] + t0 * d[k] } else { o[k] };
            idx[k] = self.cell_of(k, p);
            if d[k] > 0.0 {
                step[k] = 1;
                next[k] = (self.plane(k, idx[k] + 1) - o[k]) * inv[k];
            } else if d[k] < 0.0 {
                step[k] = -1;
                next[k] = (self.plane(k, idx[k]) - o[k]) * inv[k];
            }
        }
        let exit = widened64(t1);
        loop {
            stats.node_visit();
            record(stats, || {
                let bounds = self.cell_bounds(idx);
                Step::visit(self.linear(idx), Visited::Cell, Level::Single, bounds)
            });
            let until = match visit(self.linear(idx), stats) {
                Next::Until(t) => t.min(exit),
                Next::Stop => return,
            };
            let k = if next[0] <= next[1] && next[0] <= next[2] {
                0
            } else if next[1] <= next[2] {
                1
            } else {
                2
            };
            // The next cell is entered at next[k]; past `until` it cannot hold a hit that
            // beats (or ties) the best one, or lies beyond tmax.
            let t = next[k] as f32;
            if next[k] > until {
                record(stats, || Step::Stop { t });
                return;
            }
            if step[k] > 0 {
                idx[k] += 1;
                if idx[k] == self.res[k] {
                    record(stats, || Step::Stop { t });
                    return;
                }
                next[k] = (self.plane(k, idx[k] + 1) - o[k]) * inv[k];
            } else {
                if idx[k] == 0 {
                    record(stats, || Step::Stop { t });
                    return;
                }
                idx[k] -= 1;
                next[k] = (self.plane(k, idx[k]) - o[k]) * inv[k];
            }
            stats.box_tests(1);
            record(stats, || Step::Cross { axis: k as u8, t });
        }
    }

    /// The cells the ray's walk passes through within (tmin, tmax), in order: what the app
    /// highlights when the pointer hovers a pixel.
    pub fn cells_along(&self, ray: &Ray) -> Vec<Aabb> {
        let mut out = Vec::new();
        let [nx, ny, _] = self.res.map(|n| n as usize);
        self.walk(ray, &mut NoStats, |c, _| {
            let i = [
                (c % nx) as u32,
                ((c / nx) % ny) as u32,
                (c / (nx * ny)) as u32,
            ];
            out.push(self.cell_bounds(i));
            Next::Until(f64::INFINITY)
        });
        out
    }

    /// The query's answer for `ray`, the cells tested as the walk reaches them.
    #[inline(always)]
    fn query<I: Intersector, S: Stats, Q: Query>(&self, ray: &Ray, stats: &mut S) -> Q::Answer {
        let mut query = Q::new(ray);
        if self.triangles.is_empty() {
            return query.answer();
        }
        let data = I::prepare(ray);
        let mut mailbox = Mailbox::new(self.mailbox);
        self.walk(ray, stats, |c, stats| {
            let (a, b) = (self.offsets[c] as usize, self.offsets[c + 1] as usize);
            let ids = &self.ids[a..b];
            if mailbox.test_cell::<I, S, Q>(ids, &self.triangles, (&data, ray), &mut query, stats) {
                return Next::Stop;
            }
            Next::Until(query.found().map_or(f64::INFINITY, widened))
        });
        query.answer()
    }
}

impl Accel for Grid {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        count_locally(stats, |local| self.query::<I, S, Closest>(ray, local))
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        count_locally(stats, |local| self.query::<I, S, AnyHit>(ray, local))
    }
}
