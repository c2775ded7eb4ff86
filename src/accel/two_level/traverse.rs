//! Two-level traversal: the ray walks the TLAS front to back like any wide BVH; at a leaf
//! lane it is carried into the instance's object space by the inverse transform and walks
//! the BLAS there. The direction is not renormalised, so t along the object-space ray is
//! the world t: the BLAS search is clipped to the best world hit so far, and hits compare
//! directly.
//!
//! The TLAS walk is written once, generic over the SIMD slab kernel, with an entry point
//! compiled for each instruction set; a BLAS is walked by the BVH8's own traversal.
//! Counting: a TLAS node or instance popped is a top-level node visited, and each child of
//! a TLAS node a top-level box test; the BLAS walks count as the BVH8 does.

use super::TwoLevel;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::bvh::wide::node::INTERIOR;
use crate::accel::bvh::wide::stack::{Entry, Stack};
use crate::accel::replay::{Level, Order, Step};
use crate::accel::stats::{count_locally, record};
use crate::accel::{Accel, BestHit, Hit, Stats, TraversalOrder};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::simd::slab::{Avx2, Avx512, Portable, Sse41, WideSlab};
use crate::geometry::simd::{SimdLevel, WideRay};
use crate::geometry::{Intersector, Ray};
use crate::scene::Instance;
use std::mem::MaybeUninit;

/// `ray` in the instance's object space: the same t reaches the same point. The identity
/// leaves the ray as it is, signs of zero components included.
#[inline(always)]
fn to_object(instance: &Instance, ray: &Ray) -> Ray {
    if instance.is_identity() {
        return *ray;
    }
    Ray {
        origin: instance.inverse.transform_point3(ray.origin),
        direction: instance.inverse.transform_vector3(ray.direction),
        ..*ray
    }
}

impl TwoLevel {
    /// Walks instance `i`'s BLAS with the world ray `ray`, offering its hits to `best`
    /// under their flattened numbers. The BLAS ray ends just past the best hit so far
    /// (`best.limit`), so that a tie on a lower-numbered triangle still wins as in the
    /// flattened scene.
    #[inline(always)]
    fn enter_closest<I: Intersector, S: Stats>(
        &self,
        i: usize,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) {
        stats.instance_entered();
        let instance = &self.instances[i];
        let local = Ray {
            tmax: best.limit,
            ..to_object(instance, ray)
        };
        if let Some(h) = self.blases[instance.mesh].closest_hit::<I, S>(&local, stats) {
            let hit = TriangleHit {
                t: h.t,
                u: h.u,
                v: h.v,
            };
            best.offer(hit, self.first_triangle[i] + h.triangle);
        }
    }

    #[inline(always)]
    fn closest_with<K: WideSlab<8>, I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let tlas = &self.tlas;
        let wray = WideRay::new(ray);
        let mut best = BestHit::new(ray);
        let mut box_tmax = ray.tmax * T_SCALE;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::new(&mut storage);
        let mut entry = [0.0f32; 8];
        let mut cur = Entry {
            child: 0,
            count: INTERIOR,
            entry: ray.tmin,
        };
        loop {
            stats.top_node_visit();
            record(stats, || {
                tlas.visit_step_at(cur.child, cur.count, Level::Top)
            });
            if cur.count != INTERIOR {
                for k in cur.child..cur.child + cur.count {
                    let i = tlas.prim_indices[k as usize] as usize;
                    record(stats, || Step::Instance { instance: i as u32 });
                    self.enter_closest::<I, S>(i, ray, &mut best, stats);
                }
                box_tmax = best.t * T_SCALE;
            } else {
                let node = &tlas.nodes[cur.child as usize];
                if S::COUNTING {
                    stats.top_box_tests(node.child_count() as u32);
                }
                // SAFETY: the TLAS only selects a kernel its CPU supports (`set_simd`), and
                // the entry points below are compiled for it.
                let mut mask =
                    unsafe { K::entries(&node.bounds, &wray, ray.tmin, box_tmax, &mut entry) };
                let order = if ORDERED {
                    Order::Nearest
                } else {
                    Order::Fixed
                };
                record(stats, || tlas.children_step(cur.child, mask, &entry, order));
                let lane = |i: u32| Entry {
                    child: node.child[i as usize],
                    count: node.count[i as usize],
                    entry: entry[i as usize],
                };
                if mask != 0 && mask & (mask - 1) == 0 {
                    cur = lane(mask.trailing_zeros());
                    continue;
                }
                let mut n = 0;
                while mask != 0 {
                    // Naive order: pushed last first, so the first child is on top.
                    let i = if ORDERED {
                        mask.trailing_zeros()
                    } else {
                        31 - mask.leading_zeros()
                    };
                    stack.push(lane(i));
                    mask &= !(1 << i);
                    n += 1;
                }
                if ORDERED && n > 1 {
                    stack.sort_top(n);
                }
            }
            // Pop the next child the ray can still reach before the best hit.
            loop {
                match stack.pop() {
                    None => return best.hit(),
                    Some(e) if e.entry <= box_tmax => {
                        cur = e;
                        break;
                    }
                    Some(_) => {}
                }
            }
        }
    }

    #[inline(always)]
    fn occluded_with<K: WideSlab<8>, I: Intersector, S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        let tlas = &self.tlas;
        let wray = WideRay::new(ray);
        let tmax = ray.tmax * T_SCALE;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::new(&mut storage);
        let mut entry = [0.0f32; 8];
        let mut cur = Entry {
            child: 0,
            count: INTERIOR,
            entry: ray.tmin,
        };
        loop {
            stats.top_node_visit();
            record(stats, || {
                tlas.visit_step_at(cur.child, cur.count, Level::Top)
            });
            if cur.count != INTERIOR {
                for k in cur.child..cur.child + cur.count {
                    stats.instance_entered();
                    let i = tlas.prim_indices[k as usize];
                    record(stats, || Step::Instance { instance: i });
                    let instance = &self.instances[i as usize];
                    let local = to_object(instance, ray);
                    if self.blases[instance.mesh].any_hit::<I, S>(&local, stats) {
                        return true;
                    }
                }
            } else {
                let node = &tlas.nodes[cur.child as usize];
                if S::COUNTING {
                    stats.top_box_tests(node.child_count() as u32);
                }
                // SAFETY: as in `closest_with`.
                let mut mask =
                    unsafe { K::entries(&node.bounds, &wray, ray.tmin, tmax, &mut entry) };
                record(stats, || {
                    tlas.children_step(cur.child, mask, &entry, Order::AnyHit)
                });
                while mask != 0 {
                    let j = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack.push(Entry {
                        child: node.child[j],
                        count: node.count[j],
                        entry: entry[j],
                    });
                }
            }
            match stack.pop() {
                None => return false,
                Some(e) => cur = e,
            }
        }
    }
}

/// Entry points compiled for each instruction set: the TLAS walk and its kernel are inlined
/// into them.
macro_rules! entry_points {
    ($closest:ident, $occluded:ident, $kernel:ty, $features:literal) => {
        impl TwoLevel {
            #[target_feature(enable = $features)]
            fn $closest<I: Intersector, S: Stats, const ORDERED: bool>(
                &self,
                ray: &Ray,
                stats: &mut S,
            ) -> Option<Hit> {
                self.closest_with::<$kernel, I, S, ORDERED>(ray, stats)
            }

            #[target_feature(enable = $features)]
            fn $occluded<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
                self.occluded_with::<$kernel, I, S>(ray, stats)
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
entry_points!(closest_sse41, occluded_sse41, Sse41, "sse4.1");
#[cfg(target_arch = "x86_64")]
entry_points!(closest_avx2, occluded_avx2, Avx2, "avx2");
#[cfg(target_arch = "x86_64")]
entry_points!(closest_avx512, occluded_avx512, Avx512, "avx512f,avx512vl");

impl TwoLevel {
    #[inline(always)]
    fn closest_dispatch<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` only holds a level this CPU supports (`set_simd`).
            SimdLevel::Sse41 => unsafe { self.closest_sse41::<I, S, ORDERED>(ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx2 => unsafe { self.closest_avx2::<I, S, ORDERED>(ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.closest_avx512::<I, S, ORDERED>(ray, stats) },
            _ => self.closest_with::<Portable, I, S, ORDERED>(ray, stats),
        }
    }

    #[inline(always)]
    fn occluded_dispatch<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` only holds a level this CPU supports (`set_simd`).
            SimdLevel::Sse41 => unsafe { self.occluded_sse41::<I, S>(ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx2 => unsafe { self.occluded_avx2::<I, S>(ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.occluded_avx512::<I, S>(ray, stats) },
            _ => self.occluded_with::<Portable, I, S>(ray, stats),
        }
    }
}

impl Accel for TwoLevel {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        count_locally(stats, |s| match self.order {
            TraversalOrder::FrontToBack => self.closest_dispatch::<I, S, true>(ray, s),
            TraversalOrder::Naive => self.closest_dispatch::<I, S, false>(ray, s),
        })
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        count_locally(stats, |s| self.occluded_dispatch::<I, S>(ray, s))
    }
}
