//! Two-level traversal: the ray walks the TLAS front to back like any BVH; at a leaf it is
//! carried into the instance's object space by the inverse transform and walks the BLAS
//! there. The direction is not renormalised, so t along the object-space ray is the world
//! t: the BLAS search is clipped to the best world hit so far, and hits compare directly.

use super::TwoLevel;
use crate::accel::bvh::traverse::{STACK_SIZE, T_SCALE};
use crate::accel::stats::count_locally;
use crate::accel::{Accel, BestHit, Hit, Stats, TraversalOrder};
use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::{Intersector, Ray};
use crate::scene::Instance;

/// `ray` in the instance's object space, searched up to `tmax`.
#[inline(always)]
fn to_object(instance: &Instance, ray: &Ray, tmax: f32) -> Ray {
    if instance.is_identity() {
        return Ray { tmax, ..*ray };
    }
    Ray {
        origin: instance.inverse.transform_point3(ray.origin),
        direction: instance.inverse.transform_vector3(ray.direction),
        tmin: ray.tmin,
        tmax,
    }
}

impl TwoLevel {
    fn closest<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let slab = SlabRay::new(ray);
        let nodes = &self.tlas.nodes;
        stats.box_tests(1);
        if slab_entry(&nodes[0].corners, &slab, ray.tmin, ray.tmax) == f32::INFINITY {
            return None;
        }
        let mut best = BestHit::new(ray);
        let mut box_tmax = ray.tmax * T_SCALE;
        let mut stack = [(0u32, 0.0f32); STACK_SIZE];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            if node.is_leaf() {
                for k in node.prim_range() {
                    let i = self.tlas.prim_indices[k] as usize;
                    let instance = &self.instances[i];
                    // `limit` lets a hit at exactly the best t through, so that a tie on a
                    // lower-numbered triangle still wins as in the flattened scene.
                    let local = to_object(instance, ray, best.limit);
                    if let Some(h) = self.blases[instance.mesh].closest_hit::<I, S>(&local, stats) {
                        let found = TriangleHit {
                            t: h.t,
                            u: h.u,
                            v: h.v,
                        };
                        best.offer(found, self.first_triangle[i] + h.triangle);
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
                if da != f32::INFINITY {
                    if db != f32::INFINITY {
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
            loop {
                if sp == 0 {
                    return best.hit();
                }
                sp -= 1;
                let (next, entry) = stack[sp];
                if entry <= box_tmax {
                    index = next as usize;
                    break;
                }
            }
        }
    }

    fn occluded<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        let slab = SlabRay::new(ray);
        let nodes = &self.tlas.nodes;
        let tmax = ray.tmax * T_SCALE;
        stats.box_tests(1);
        if slab_entry(&nodes[0].corners, &slab, ray.tmin, tmax) == f32::INFINITY {
            return false;
        }
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            if node.is_leaf() {
                for k in node.prim_range() {
                    let instance = &self.instances[self.tlas.prim_indices[k] as usize];
                    let local = to_object(instance, ray, ray.tmax);
                    if self.blases[instance.mesh].any_hit::<I, S>(&local, stats) {
                        return true;
                    }
                }
            } else {
                let l = node.left_first as usize;
                let [a, b] = nodes.pair(l);
                stats.box_tests(2);
                let hit_a = slab_entry(&a.corners, &slab, ray.tmin, tmax) != f32::INFINITY;
                let hit_b = slab_entry(&b.corners, &slab, ray.tmin, tmax) != f32::INFINITY;
                if hit_a {
                    if hit_b {
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
        }
    }
}

impl Accel for TwoLevel {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        count_locally(stats, |s| match self.order {
            TraversalOrder::FrontToBack => self.closest::<I, S, true>(ray, s),
            TraversalOrder::Naive => self.closest::<I, S, false>(ray, s),
        })
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        count_locally(stats, |s| self.occluded::<I, S>(ray, s))
    }
}
