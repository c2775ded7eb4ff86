//! k-d tree traversal front to back: each node's [t_entry, t_exit] interval is cut at the
//! split plane's distance, the near child is taken first and the far one kept on a stack
//! with its interval. A hit found in a cell is kept as the best so far even if it lies
//! beyond the cell (with mailboxing the triangle will not be tested again), and the search
//! stops once no remaining cell starts before the best hit.
//!
//! Every interval is widened by the relative rounding error of its plane distance, so
//! rounding can only make the traversal visit more cells, never fewer: a hit on a split
//! plane, or a few ulps beyond a cell, is found in either cell.

use super::{KdTree, MAX_DEPTH};
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::query::{AnyHit, Closest, Query};
use crate::accel::replay::{Level, Step, Visited, entered};
use crate::accel::stats::{count_locally, record};
use crate::accel::{Accel, Hit, Mailbox, Stats};
use crate::geometry::aabb::SlabRay;
use crate::geometry::{Aabb, Intersector, Ray};

/// The stack holds at most one cell per level below the root.
const STACK_SIZE: usize = MAX_DEPTH as usize + 1;
/// The stack of trees no deeper than this (the automatic depth bound of up to about 10^6
/// triangles): a smaller array to clear per ray.
const SHALLOW: usize = 32;
const INV_T_SCALE: f32 = 1.0 / T_SCALE;

/// A computed distance (three roundings: o − split, 1/d and the product) moved up past any
/// exact value it may stand for.
#[inline(always)]
fn round_up(t: f32) -> f32 {
    if t > 0.0 {
        t * T_SCALE
    } else {
        t * INV_T_SCALE
    }
}

/// The same moved down.
#[inline(always)]
fn round_down(t: f32) -> f32 {
    if t > 0.0 {
        t * INV_T_SCALE
    } else {
        t * T_SCALE
    }
}

/// `(round_up(t), round_down(t))` without a branch on the sign: the larger and the smaller
/// of t scaled up and down (both NaN for a NaN).
#[inline(always)]
fn widened(t: f32) -> (f32, f32) {
    let (a, b) = (t * T_SCALE, t * INV_T_SCALE);
    if a > b { (a, b) } else { (b, a) }
}

/// `t.max(x)` for a `t` that is never NaN, ignoring a NaN `x`, in one comparison (the
/// library's `max` also handles a NaN `t`, which the hot loop does not need).
#[inline(always)]
fn later(t: f32, x: f32) -> f32 {
    if x > t { x } else { t }
}

/// `t.min(x)` likewise.
#[inline(always)]
fn sooner(t: f32, x: f32) -> f32 {
    if x < t { x } else { t }
}

/// A cell to visit: node index and the ray's interval [tmin, tmax] in it.
type Cell = (usize, f32, f32);
/// The same as kept on the stack.
type Pending = (u32, f32, f32);

/// Per-ray values of the plane distance tests, indexed by axis.
struct PlaneRay {
    /// Four entries so that indexing by a node's two-bit axis needs no bounds check.
    origin: [f32; 4],
    inv_dir: [f32; 4],
    /// Whether the ray meets the below side of a plane first: the direction is positive
    /// (+0 included). With a zero component the ray never crosses the plane, and the
    /// distance's sign (±∞) leaves it on the side of its origin.
    below_first: [bool; 4],
}

impl PlaneRay {
    fn new(slab: &SlabRay) -> Self {
        let [ox, oy, oz] = slab.origin.to_array();
        let [ix, iy, iz] = slab.inv_dir.to_array();
        let [nx, ny, nz] = slab.near.map(|n| n == 0);
        PlaneRay {
            origin: [ox, oy, oz, 0.0],
            inv_dir: [ix, iy, iz, 0.0],
            below_first: [nx, ny, nz, false],
        }
    }
}

impl KdTree {
    /// The ray's interval inside the root cell, widened for rounding, or `None` if it
    /// misses the tree's bounds within (tmin, tmax).
    #[inline(always)]
    fn root_interval<S: Stats>(
        &self,
        ray: &Ray,
        slab: &SlabRay,
        stats: &mut S,
    ) -> Option<(f32, f32)> {
        let entry = self.bounds.slab_test(slab, ray.tmin, ray.tmax);
        record(stats, || Step::Bounds {
            entry: entered(entry),
        });
        if entry == f32::INFINITY {
            return None;
        }
        let corners = [self.bounds.min, self.bounds.max];
        let mut exit = ray.tmax;
        for k in 0..3 {
            let far = corners[(slab.near[k] ^ 1) & 1][k];
            let t = round_up((far - slab.origin[k]) * slab.inv_dir[k]);
            // A NaN (the ray lies in the face plane) never wins: the cell is closed.
            if t < exit {
                exit = t;
            }
        }
        Some((ray.tmin.max(round_down(entry)), exit))
    }

    /// One step down from interior node `index`, whose cell the ray crosses over [tmin,
    /// tmax]: the child to take next with its interval, and the other child with its
    /// interval if that one is to be visited later. `reach` bounds where a cell may start
    /// and still be worth visiting (it is at least `tmin`).
    #[inline(always)]
    fn step(
        &self,
        index: usize,
        ray: &PlaneRay,
        tmin: f32,
        tmax: f32,
        reach: f32,
    ) -> (Cell, Option<Pending>) {
        let node = &self.nodes[index];
        let axis = node.axis() & 3;
        let t_plane = (node.split() - ray.origin[axis]) * ray.inv_dir[axis];
        let (below, above) = (index + 1, node.above_child());
        let (first, second) = if ray.below_first[axis] {
            (below, above)
        } else {
            (above, below)
        };
        let (up, down) = widened(t_plane);
        if up < tmin {
            // The plane lies before the interval: only the second cell (down < tmin ≤ reach).
            return ((second, later(tmin, down), tmax), None);
        }
        if down > tmax || down > reach {
            return ((first, tmin, sooner(tmax, up)), None);
        }
        // Both cells. A NaN distance (the ray lies in the plane, 0 · ∞) fails every test
        // above and comes here too, and `later`/`sooner` ignore it: both cells, all along.
        (
            (first, tmin, sooner(tmax, up)),
            Some((second as u32, later(tmin, down), tmax)),
        )
    }

    /// The query's answer for `ray`, counting into a local sink (kept in registers) added
    /// to `stats` once.
    fn query<I: Intersector, S: Stats, Q: Query>(&self, ray: &Ray, stats: &mut S) -> Q::Answer {
        if self.depth_bound as usize <= SHALLOW {
            count_locally(stats, |local| {
                self.front_to_back::<I, S, Q, SHALLOW>(ray, local)
            })
        } else {
            count_locally(stats, |local| {
                self.front_to_back::<I, S, Q, STACK_SIZE>(ray, local)
            })
        }
    }

    #[inline(always)]
    fn front_to_back<I: Intersector, S: Stats, Q: Query, const N: usize>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Q::Answer {
        let mut query = Q::new(ray);
        let slab = SlabRay::new(ray);
        stats.box_tests(1);
        let Some((t0, t1)) = self.root_interval(ray, &slab, stats) else {
            return query.answer();
        };
        let plane_ray = PlaneRay::new(&slab);
        let data = I::prepare(ray);
        // A cell entered beyond this cannot hold a hit closer than the best.
        let mut reach = query.reach() * T_SCALE;
        let mut mailbox = Mailbox::new(self.mailbox);
        let mut stack: [Pending; N] = [(0, 0.0, 0.0); N];
        let mut sp = 0;
        let (mut index, mut tmin, mut tmax) = (0usize, t0, t1);
        loop {
            stats.node_visit();
            let node = &self.nodes[index];
            record(stats, || self.visit_step(index));
            if !node.is_leaf() {
                stats.box_tests(1);
                let (next, later) = self.step(index, &plane_ray, tmin, tmax, reach);
                record(stats, || self.plane_step(index, &plane_ray, next.0, later));
                if let Some(entry) = later {
                    record(stats, || self.push_step(entry));
                    stack[sp] = entry;
                    sp += 1;
                }
                (index, tmin, tmax) = next;
                continue;
            }
            for &tri in node.leaf_refs(&self.refs) {
                if !mailbox.admit(tri, stats) {
                    record(stats, || Step::Mailboxed {
                        triangle: tri.into(),
                    });
                    continue;
                }
                stats.triangle_test();
                let t = &self.triangles[tri as usize];
                let hit = I::intersect(&data, ray, t, ray.tmin, query.limit());
                record(stats, || Step::Triangle {
                    triangle: tri.into(),
                    t: hit.map(|h| h.t),
                });
                if let Some(h) = hit {
                    if query.offer(h, tri) {
                        return query.answer();
                    }
                    reach = query.reach() * T_SCALE;
                }
            }
            // The next cell that starts before the best hit.
            loop {
                if sp == 0 {
                    return query.answer();
                }
                sp -= 1;
                let (next, start, end) = stack[sp];
                record(stats, || self.pop_step(next, start, reach, query.reach()));
                if start <= reach {
                    (index, tmin, tmax) = (next as usize, start, end);
                    break;
                }
            }
        }
    }
}

// The steps of the walk, for a recording sink.
impl KdTree {
    fn is_leaf(&self, index: u32) -> bool {
        self.nodes[index as usize].is_leaf()
    }

    /// The cell of node `index`: the root's box cut by the planes on the way down to it
    /// (nodes are stored depth first, the below child right after its parent).
    fn cell_bounds(&self, index: usize) -> Aabb {
        let mut cell = self.bounds;
        let mut at = 0;
        while at != index && !self.nodes[at].is_leaf() {
            let node = &self.nodes[at];
            let (axis, split) = (node.axis(), node.split());
            if index < node.above_child() {
                cell.max[axis] = split;
                at += 1;
            } else {
                cell.min[axis] = split;
                at = node.above_child();
            }
        }
        cell
    }

    fn visit_step(&self, index: usize) -> Step {
        let what = if self.nodes[index].is_leaf() {
            Visited::Leaf
        } else {
            Visited::Node
        };
        Step::visit(index, what, Level::Single, self.cell_bounds(index))
    }

    fn plane_step(&self, index: usize, ray: &PlaneRay, near: usize, far: Option<Pending>) -> Step {
        let node = &self.nodes[index];
        let axis = node.axis() & 3;
        Step::Plane {
            axis: axis as u8,
            t: (node.split() - ray.origin[axis]) * ray.inv_dir[axis],
            near: near as u32,
            far: far.map(|p| p.0),
        }
    }

    fn push_step(&self, (node, entry, _): Pending) -> Step {
        Step::Push {
            node,
            leaf: self.is_leaf(node),
            entry,
        }
    }

    fn pop_step(&self, node: u32, entry: f32, reach: f32, best: f32) -> Step {
        let leaf = self.is_leaf(node);
        if entry <= reach {
            Step::Pop {
                node,
                leaf,
                entry: Some(entry),
            }
        } else {
            Step::Skip {
                node,
                leaf,
                entry,
                best,
            }
        }
    }
}

impl Accel for KdTree {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        self.query::<I, S, Closest>(ray, stats)
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        self.query::<I, S, AnyHit>(ray, stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_moves_distances_outward_whatever_their_sign() {
        for t in [1.0f32, 1e-30, 123.456, -2.0, -1e-30] {
            assert!(round_up(t) > t && round_down(t) < t, "{t}");
        }
        for t in [
            1.0f32,
            1e-30,
            -2.0,
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3e38,
        ] {
            assert_eq!(widened(t), (round_up(t), round_down(t)), "{t}");
        }
        let (up, down) = widened(f32::NAN);
        assert!(up.is_nan() && down.is_nan());
        assert_eq!((later(1.0, f32::NAN), sooner(1.0, f32::NAN)), (1.0, 1.0));
        assert_eq!(round_up(0.0), 0.0);
        assert_eq!(round_up(f32::INFINITY), f32::INFINITY);
        assert_eq!(round_down(f32::NEG_INFINITY), f32::NEG_INFINITY);
    }
}
