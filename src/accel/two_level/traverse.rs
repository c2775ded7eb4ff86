//! Two-level traversal: the ray walks the TLAS front to back like any BVH; at a leaf it is
//! carried into the instance's object space by the inverse transform and walks the BLAS
//! there. The direction is not renormalised, so t along the object-space ray is the world
//! t: the BLAS search is clipped to the best world hit so far, and hits compare directly.

use super::TwoLevel;
use crate::accel::bvh::traverse::{STACK_SIZE, T_SCALE};
use crate::accel::replay::{Level, Order, Step, entered};
use crate::accel::stats::{count_locally, record};
use crate::accel::{Accel, BestHit, Hit, Stats, TraversalOrder};
use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::{Intersector, Ray};
use crate::scene::Instance;

/// `ray` in the instance's object space: the same t reaches the same point.
#[inline(always)]
fn to_object(instance: &Instance, ray: &Ray) -> Ray {
    Ray {
        origin: instance.inverse.transform_point3(ray.origin),
        direction: instance.inverse.transform_vector3(ray.direction),
        ..*ray
    }
}

/// The part of a query that the TLAS hands down to a BLAS: the ray in the instance's space
/// with what the box and triangle tests precompute for it, and one stack for every BLAS
/// the ray enters, so entering an instance costs no more than its transform.
struct Descent<I: Intersector> {
    ray: Ray,
    slab: SlabRay,
    data: I::RayData,
    stack: [(u32, f32); STACK_SIZE],
}

impl<I: Intersector> Descent<I> {
    fn new(ray: &Ray) -> Self {
        Descent {
            ray: *ray,
            slab: SlabRay::new(ray),
            data: I::prepare(ray),
            stack: [(0, 0.0); STACK_SIZE],
        }
    }

    /// Carries the world ray `world` into `instance`'s space (nothing to do for the
    /// identity, whose descent is the world one).
    #[inline(always)]
    fn enter(&mut self, instance: &Instance, world: &Descent<I>) {
        if instance.is_identity() {
            self.ray = world.ray;
            self.slab = world.slab;
            self.data = world.data;
        } else {
            self.ray = to_object(instance, &world.ray);
            self.slab = SlabRay::new(&self.ray);
            self.data = I::prepare(&self.ray);
        }
    }
}

impl TwoLevel {
    fn closest<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let world = Descent::<I>::new(ray);
        let nodes = &self.tlas.nodes;
        stats.box_tests(1);
        let root_entry = slab_entry(&nodes[0].corners, &world.slab, ray.tmin, ray.tmax);
        record(stats, || Step::Bounds {
            entry: entered(root_entry),
        });
        if root_entry == f32::INFINITY {
            return None;
        }
        let mut local = Descent::<I>::new(ray);
        let mut best = BestHit::new(ray);
        let mut box_tmax = ray.tmax * T_SCALE;
        let mut stack = [(0u32, 0.0f32); STACK_SIZE];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            record(stats, || self.tlas.visit_step_at(index, Level::Top));
            if node.is_leaf() {
                for k in node.prim_range() {
                    let i = self.tlas.prim_indices[k] as usize;
                    let instance = &self.instances[i];
                    record(stats, || Step::Instance { instance: i as u32 });
                    local.enter(instance, &world);
                    self.blas_closest::<I, S, ORDERED>(
                        instance.mesh,
                        self.first_triangle[i],
                        &mut local,
                        &mut best,
                        stats,
                    );
                    box_tmax = best.t * T_SCALE;
                }
            } else {
                let l = node.left_first as usize;
                let [a, b] = nodes.pair(l);
                stats.box_tests(2);
                let mut da = slab_entry(&a.corners, &world.slab, ray.tmin, box_tmax);
                let mut db = slab_entry(&b.corners, &world.slab, ray.tmin, box_tmax);
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
                record(stats, || {
                    self.tlas.children_step([(ia, da), (ib, db)], order)
                });
                if da != f32::INFINITY {
                    if db != f32::INFINITY {
                        record(stats, || self.tlas.push_step(ib, db));
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
                record(stats, || {
                    self.tlas.pop_step(next as usize, entry, box_tmax, best.t)
                });
                if entry <= box_tmax {
                    index = next as usize;
                    break;
                }
            }
        }
    }

    /// The BVH2 closest-hit walk of `blas`'s tree, offering its hits to the query's `best`
    /// under their flattened numbers (`first` + the mesh's own). `best.limit` lets a hit
    /// at exactly the best t through, so that a tie on a lower-numbered triangle still wins
    /// as in the flattened scene.
    #[inline(always)]
    fn blas_closest<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        blas: usize,
        first: u64,
        d: &mut Descent<I>,
        best: &mut BestHit,
        stats: &mut S,
    ) {
        let blas = &self.blases[blas];
        let (ray, nodes) = (&d.ray, &blas.nodes);
        let mut box_tmax = best.t * T_SCALE;
        stats.box_tests(1);
        let root_entry = slab_entry(&nodes[0].corners, &d.slab, ray.tmin, box_tmax);
        record(stats, || Step::Bounds {
            entry: entered(root_entry),
        });
        if root_entry == f32::INFINITY {
            return;
        }
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            record(stats, || blas.visit_step_at(index, Level::Bottom));
            if node.is_leaf() {
                for i in node.prim_range() {
                    stats.triangle_test();
                    let tri = &blas.triangles[i];
                    let hit = I::intersect(&d.data, ray, tri, ray.tmin, best.limit);
                    record(stats, || Step::Triangle {
                        triangle: first + u64::from(blas.prim_indices[i]),
                        t: hit.map(|h| h.t),
                    });
                    if let Some(h) = hit {
                        best.offer(h, first + u64::from(blas.prim_indices[i]));
                        box_tmax = best.t * T_SCALE;
                    }
                }
            } else {
                let l = node.left_first as usize;
                let [a, b] = nodes.pair(l);
                stats.box_tests(2);
                let mut da = slab_entry(&a.corners, &d.slab, ray.tmin, box_tmax);
                let mut db = slab_entry(&b.corners, &d.slab, ray.tmin, box_tmax);
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
                record(stats, || blas.children_step([(ia, da), (ib, db)], order));
                if da != f32::INFINITY {
                    if db != f32::INFINITY {
                        record(stats, || blas.push_step(ib, db));
                        d.stack[sp] = (ib as u32, db);
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
                    return;
                }
                sp -= 1;
                let (next, entry) = d.stack[sp];
                record(stats, || {
                    blas.pop_step(next as usize, entry, box_tmax, best.t)
                });
                if entry <= box_tmax {
                    index = next as usize;
                    break;
                }
            }
        }
    }

    fn occluded<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        let world = Descent::<I>::new(ray);
        let nodes = &self.tlas.nodes;
        let tmax = ray.tmax * T_SCALE;
        stats.box_tests(1);
        let root_entry = slab_entry(&nodes[0].corners, &world.slab, ray.tmin, tmax);
        record(stats, || Step::Bounds {
            entry: entered(root_entry),
        });
        if root_entry == f32::INFINITY {
            return false;
        }
        let mut local = Descent::<I>::new(ray);
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            record(stats, || self.tlas.visit_step_at(index, Level::Top));
            if node.is_leaf() {
                for k in node.prim_range() {
                    let i = self.tlas.prim_indices[k] as usize;
                    let instance = &self.instances[i];
                    record(stats, || Step::Instance { instance: i as u32 });
                    local.enter(instance, &world);
                    if self.blas_any::<I, S>(
                        instance.mesh,
                        self.first_triangle[i],
                        &mut local,
                        stats,
                    ) {
                        return true;
                    }
                }
            } else {
                let l = node.left_first as usize;
                let [a, b] = nodes.pair(l);
                stats.box_tests(2);
                let da = slab_entry(&a.corners, &world.slab, ray.tmin, tmax);
                let db = slab_entry(&b.corners, &world.slab, ray.tmin, tmax);
                record(stats, || {
                    self.tlas
                        .children_step([(l, da), (l + 1, db)], Order::AnyHit)
                });
                let (hit_a, hit_b) = (da != f32::INFINITY, db != f32::INFINITY);
                if hit_a {
                    if hit_b {
                        record(stats, || self.tlas.push_step(l + 1, db));
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

    /// The BVH2 any-hit walk of `blas`'s tree; its triangles are `first` on in the
    /// flattened scene (as a replay names them).
    #[inline(always)]
    fn blas_any<I: Intersector, S: Stats>(
        &self,
        blas: usize,
        first: u64,
        d: &mut Descent<I>,
        stats: &mut S,
    ) -> bool {
        let blas = &self.blases[blas];
        let (ray, nodes) = (&d.ray, &blas.nodes);
        let tmax = ray.tmax * T_SCALE;
        stats.box_tests(1);
        let root_entry = slab_entry(&nodes[0].corners, &d.slab, ray.tmin, tmax);
        record(stats, || Step::Bounds {
            entry: entered(root_entry),
        });
        if root_entry == f32::INFINITY {
            return false;
        }
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            stats.node_visit();
            let node = &nodes[index];
            record(stats, || blas.visit_step_at(index, Level::Bottom));
            if node.is_leaf() {
                for i in node.prim_range() {
                    stats.triangle_test();
                    let tri = &blas.triangles[i];
                    let hit = I::intersect(&d.data, ray, tri, ray.tmin, ray.tmax);
                    record(stats, || Step::Triangle {
                        triangle: first + u64::from(blas.prim_indices[i]),
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
                let da = slab_entry(&a.corners, &d.slab, ray.tmin, tmax);
                let db = slab_entry(&b.corners, &d.slab, ray.tmin, tmax);
                record(stats, || {
                    blas.children_step([(l, da), (l + 1, db)], Order::AnyHit)
                });
                let (hit_a, hit_b) = (da != f32::INFINITY, db != f32::INFINITY);
                if hit_a {
                    if hit_b {
                        record(stats, || blas.push_step(l + 1, db));
                        d.stack[sp] = (l as u32 + 1, 0.0);
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
            index = d.stack[sp].0 as usize;
            record(stats, || Step::Pop {
                node: index as u32,
                leaf: nodes[index].is_leaf(),
                entry: None,
            });
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
