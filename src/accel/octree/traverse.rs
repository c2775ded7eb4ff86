//! Octree traversal front to back: within a cell the ray crosses the three mid planes at
//! most once each, so those crossings, sorted, cut its interval into at most four pieces,
//! one per octant it passes through, in the order it enters them. The octants are visited in
//! that order (missing ones skipped), the rest of a cell waiting on a stack with its entry t,
//! and the walk stops at the first cell entered beyond the best hit. t is in f64, and cells
//! halve exactly, so the intervals are those of the exact ray to f64 rounding.

use super::Octree;
use crate::accel::grid::dda::{Next, widened, widened64};
use crate::accel::query::{AnyHit, Closest, Query};
use crate::accel::replay::{Child, Level, Step, Visited, entered};
use crate::accel::stats::{count_locally, record};
use crate::accel::{Accel, Hit, Mailbox, Stats};
use crate::geometry::Aabb;
use crate::geometry::aabb::SlabRay;
use crate::geometry::{Intersector, Ray};
use glam::DVec3;

/// A cell still to visit: node, the ray's interval in it, its minimum corner and side.
#[derive(Clone, Copy)]
struct Cell {
    node: u32,
    t0: f64,
    t1: f64,
    min: DVec3,
    size: f64,
}

/// Each level pushes at most three cells (four pieces, the first visited at once).
const STACK_SIZE: usize = 3 * (super::MAX_DEPTH as usize + 1) + 1;

impl Octree {
    /// Visits the leaves the ray passes through within (tmin, tmax) in order, calling
    /// `visit` with each leaf's references. Counts a node visit per cell, one box test for
    /// the root cube and three per inner cell (the ray–plane distances to its mid planes,
    /// from which all its octants' intervals follow).
    #[inline(always)]
    fn walk<S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
        mut visit: impl FnMut(&[u32], &mut S) -> Next,
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
        let (lo, hi) = (self.root_min, self.root_min + self.root_size);
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
        // A grazing ray the f32 test admits may come out empty in f64 by rounding.
        let t1 = t1.max(t0);
        let exit = widened64(t1);
        let mut until = exit;
        let mut stack = [Cell {
            node: 0,
            t0,
            t1,
            min: lo,
            size: self.root_size,
        }; STACK_SIZE];
        let mut sp = 0;
        let mut cell = stack[0];
        loop {
            stats.node_visit();
            let node = self.nodes[cell.node as usize];
            record(stats, || {
                let what = if node.is_leaf() {
                    Visited::Leaf
                } else {
                    Visited::Node
                };
                let bounds = Aabb::new(
                    cell.min.as_vec3(),
                    (cell.min + DVec3::splat(cell.size)).as_vec3(),
                );
                Step::visit(cell.node as usize, what, Level::Single, bounds)
            });
            if node.is_leaf() {
                let refs = &self.refs[node.first as usize..(node.first + node.count) as usize];
                match visit(refs, stats) {
                    Next::Until(t) => until = t.min(exit),
                    Next::Stop => return,
                }
            } else {
                stats.box_tests(3);
                let half = cell.size * 0.5;
                let mid = cell.min + half;
                let mut octant = 0u32;
                let mut cross = [(f64::INFINITY, 0u32); 3];
                let mut n = 0;
                for k in 0..3 {
                    let upper = if d[k] != 0.0 {
                        let t = (mid[k] - o[k]) * inv[k];
                        if t > cell.t0 && t < cell.t1 {
                            cross[n] = (t, k as u32);
                            n += 1;
                        }
                        if d[k] > 0.0 {
                            t <= cell.t0
                        } else {
                            t > cell.t0
                        }
                    } else {
                        o[k] >= mid[k]
                    };
                    octant |= u32::from(upper) << k;
                }
                // Sort the (up to three) crossings.
                if cross[1].0 < cross[0].0 {
                    cross.swap(0, 1);
                }
                if cross[2].0 < cross[1].0 {
                    cross.swap(1, 2);
                    if cross[1].0 < cross[0].0 {
                        cross.swap(0, 1);
                    }
                }
                // The pieces in order: [t0, c0], [c0, c1], …, [c_{n−1}, t1].
                let mut pieces = [(0u32, 0.0f64, 0.0f64); 4];
                let mut start = cell.t0;
                for (i, &(t, k)) in cross[..n].iter().enumerate() {
                    pieces[i] = (octant, start, t);
                    octant ^= 1 << k;
                    start = t;
                }
                pieces[n] = (octant, start, cell.t1);
                record(stats, || Step::Octants {
                    children: pieces[..=n]
                        .iter()
                        .filter_map(|&(oct, a, _)| {
                            let child = node.child(oct)?;
                            let min = cell.min + octant_corner(oct) * half;
                            Some(Child {
                                node: child,
                                leaf: self.nodes[child as usize].is_leaf(),
                                entry: Some(a as f32),
                                bounds: Aabb::new(min.as_vec3(), (min + half).as_vec3()),
                            })
                        })
                        .collect(),
                });
                for &(oct, a, b) in pieces[..=n].iter().rev() {
                    if let Some(child) = node.child(oct) {
                        stack[sp] = Cell {
                            node: child,
                            t0: a,
                            t1: b,
                            min: cell.min + octant_corner(oct) * half,
                            size: half,
                        };
                        sp += 1;
                        record(stats, || Step::Push {
                            node: child,
                            leaf: self.nodes[child as usize].is_leaf(),
                            entry: a as f32,
                        });
                    }
                }
            }
            // The next cell the ray enters no later than the best hit.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                record(stats, || {
                    let (node, entry) = (stack[sp].node, stack[sp].t0 as f32);
                    let leaf = self.nodes[node as usize].is_leaf();
                    if stack[sp].t0 <= until {
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
                            best: until as f32,
                        }
                    }
                });
                if stack[sp].t0 <= until {
                    cell = stack[sp];
                    break;
                }
            }
        }
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
        self.walk(ray, stats, |refs, stats| {
            if mailbox.test_cell::<I, S, Q>(refs, &self.triangles, (&data, ray), &mut query, stats)
            {
                return Next::Stop;
            }
            Next::Until(query.found().map_or(f64::INFINITY, widened))
        });
        query.answer()
    }
}

impl Accel for Octree {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        count_locally(stats, |local| self.query::<I, S, Closest>(ray, local))
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        count_locally(stats, |local| self.query::<I, S, AnyHit>(ray, local))
    }
}

/// The corner of octant `oct` (bit k: the upper half on axis k) in units of half a cell.
fn octant_corner(oct: u32) -> DVec3 {
    DVec3::new(
        f64::from(oct & 1),
        f64::from(oct >> 1 & 1),
        f64::from(oct >> 2 & 1),
    )
}
