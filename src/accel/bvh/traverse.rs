//! BVH traversal: closest hit front to back (or in the naive fixed order) and any hit for
//! shadow rays, one code path for the fast and the counting run.
//!
//! A stack holds the nodes still to visit together with the distance at which the ray enters
//! them. Every box test is clipped to the best hit found so far, and a popped node whose
//! entry lies beyond it is skipped: that is the pruning that makes front-to-back order pay.

use super::Bvh;
use super::build::MAX_DEPTH;
use crate::accel::replay::{Child, Level, Order, Step, Visited, entered};
use crate::accel::stats::record;
use crate::accel::{Accel, BestHit, Hit, Stats, TraversalOrder};
use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::{HIT_T_ERROR, Intersector, Ray, gamma};

/// Boxes are compared with the best t scaled by this, so that no hit is lost to rounding: a
/// box is entered at most 2γ(3) (relative) before its computed entry distance, and a
/// triangle's exact t is within `HIT_T_ERROR` of its computed one but for ill-conditioned
/// hits.
pub(crate) const T_SCALE: f32 = 1.0 + 2.0 * gamma(3) + 2.0 * HIT_T_ERROR;

/// The stack never holds more than one entry per level.
pub(crate) const STACK_SIZE: usize = MAX_DEPTH + 1;

impl Bvh {
    /// Closest hit, counting into a local sink (kept in registers) added to `stats` once.
    /// Written out rather than through `stats::count_locally`: the closure form measured
    /// 3–5 % slower on the BVH's primary rays (sponza, alternating runs).
    fn closest<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let mut local = S::default();
        let hit = self.closest_counted::<I, S, ORDERED>(ray, &mut local);
        stats.absorb(local);
        hit
    }

    #[inline(always)]
    fn closest_counted<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let slab = SlabRay::new(ray);
        let nodes = &self.nodes;
        stats.box_tests(1);
        let root = &nodes[0];
        let root_entry = slab_entry(&root.corners, &slab, ray.tmin, ray.tmax);
        record(stats, || Step::Bounds {
            entry: entered(root_entry),
        });
        if root_entry == f32::INFINITY {
            return None;
        }
        let data = I::prepare(ray);
        let mut best = BestHit::new(ray);
        let mut box_tmax = ray.tmax * T_SCALE;
        let mut stack = [(0u32, 0.0f32); STACK_SIZE];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            record(stats, || self.visit_step(index));
            if node.is_leaf() {
                for i in node.prim_range() {
                    stats.triangle_test();
                    let tri = &self.triangles[i];
                    let hit = I::intersect(&data, ray, tri, ray.tmin, best.limit);
                    record(stats, || Step::Triangle {
                        triangle: self.prim_indices[i].into(),
                        t: hit.map(|h| h.t),
                    });
                    if let Some(h) = hit {
                        best.offer(h, self.prim_indices[i]);
                        box_tmax = best.t * T_SCALE;
                    }
                }
            } else {
                let l = node.left_first as usize;
                let [a, b] = nodes.pair(l);
                stats.box_tests(2);
                let mut da = slab_entry(&a.corners, &slab, ray.tmin, box_tmax);
                let mut db = slab_entry(&b.corners, &slab, ray.tmin, box_tmax);
                let (mut ia, mut ib) = (l, l + 1);
                if ORDERED && db < da {
                    std::mem::swap(&mut da, &mut db);
                    std::mem::swap(&mut ia, &mut ib);
                }
                let order = if ORDERED {
                    Order::Nearest
                } else {
                    Order::Fixed
                };
                record(stats, || self.children_step([(ia, da), (ib, db)], order));
                if da != f32::INFINITY {
                    if db != f32::INFINITY {
                        record(stats, || self.push_step(ib, db));
                        stack[sp] = (ib as u32, db);
                        sp += 1;
                    }
                    index = ia;
                    continue;
                } else if db != f32::INFINITY {
                    index = ib;
                    continue;
                }
            }
            // Pop the next node the ray can still reach before the best hit.
            loop {
                if sp == 0 {
                    return best.hit();
                }
                sp -= 1;
                let (next, entry) = stack[sp];
                record(stats, || {
                    self.pop_step(next as usize, entry, box_tmax, best.t)
                });
                if entry <= box_tmax {
                    index = next as usize;
                    break;
                }
            }
        }
    }

    /// Any hit, counting like `closest`.
    fn occluded<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        let mut local = S::default();
        let hit = self.occluded_counted::<I, S>(ray, &mut local);
        stats.absorb(local);
        hit
    }

    #[inline(always)]
    fn occluded_counted<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        let slab = SlabRay::new(ray);
        let nodes = &self.nodes;
        stats.box_tests(1);
        let root = &nodes[0];
        let tmax = ray.tmax * T_SCALE;
        let root_entry = slab_entry(&root.corners, &slab, ray.tmin, tmax);
        record(stats, || Step::Bounds {
            entry: entered(root_entry),
        });
        if root_entry == f32::INFINITY {
            return false;
        }
        let data = I::prepare(ray);
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            record(stats, || self.visit_step(index));
            if node.is_leaf() {
                for i in node.prim_range() {
                    stats.triangle_test();
                    let hit = I::intersect(&data, ray, &self.triangles[i], ray.tmin, ray.tmax);
                    record(stats, || Step::Triangle {
                        triangle: self.prim_indices[i].into(),
                        t: hit.map(|h| h.t),
                    });
                    if hit.is_some() {
                        return true;
                    }
                }
            } else {
                let l = node.left_first as usize;
                let [a, b] = nodes.pair(l);
                stats.box_tests(2);
                let da = slab_entry(&a.corners, &slab, ray.tmin, tmax);
                let db = slab_entry(&b.corners, &slab, ray.tmin, tmax);
                record(stats, || {
                    self.children_step([(l, da), (l + 1, db)], Order::AnyHit)
                });
                let (hit_a, hit_b) = (da != f32::INFINITY, db != f32::INFINITY);
                if hit_a {
                    if hit_b {
                        record(stats, || self.push_step(l + 1, db));
                        stack[sp] = l as u32 + 1;
                        sp += 1;
                    }
                    index = l;
                    continue;
                } else if hit_b {
                    index = l + 1;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            index = stack[sp] as usize;
            record(stats, || Step::Pop {
                node: index as u32,
                leaf: nodes[index].is_leaf(),
                entry: None,
            });
        }
    }
}

// The steps of a BVH2 walk, for a recording sink; shared by the BVH2 and the two levels.
impl Bvh {
    pub(crate) fn visit_step_at(&self, index: usize, level: Level) -> Step {
        let node = &self.nodes[index];
        let what = if node.is_leaf() {
            Visited::Leaf
        } else {
            Visited::Node
        };
        Step::visit(index, what, level, node.bounds())
    }

    fn visit_step(&self, index: usize) -> Step {
        self.visit_step_at(index, Level::Single)
    }

    /// Two children in the order they are taken, with their entry distances (+∞: missed).
    pub(crate) fn children_step(&self, children: [(usize, f32); 2], order: Order) -> Step {
        let children: Vec<Child> = children
            .iter()
            .map(|&(i, t)| Child {
                node: i as u32,
                leaf: self.nodes[i].is_leaf(),
                entry: entered(t),
                bounds: self.nodes[i].bounds(),
            })
            .collect();
        let first = children.iter().find(|c| c.entry.is_some()).map(|c| c.node);
        Step::Children {
            children,
            first,
            order,
        }
    }

    pub(crate) fn push_step(&self, index: usize, entry: f32) -> Step {
        Step::Push {
            node: index as u32,
            leaf: self.nodes[index].is_leaf(),
            entry,
        }
    }

    /// A node popped with entry `entry`: visited if it starts within `reach` (the best
    /// hit so far, `best`, widened for rounding), skipped otherwise.
    pub(crate) fn pop_step(&self, index: usize, entry: f32, reach: f32, best: f32) -> Step {
        let leaf = self.nodes[index].is_leaf();
        let node = index as u32;
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

impl Accel for Bvh {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        match self.order {
            TraversalOrder::FrontToBack => self.closest::<I, S, true>(ray, stats),
            TraversalOrder::Naive => self.closest::<I, S, false>(ray, stats),
        }
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        self.occluded::<I, S>(ray, stats)
    }

    fn closest_hits<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.closest_hits_packet::<I>(rays, hits);
    }
}
