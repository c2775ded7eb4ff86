//! Two-level traversal: the ray walks the TLAS front to back like any wide BVH; at a leaf
//! lane, which holds a reference (an instance and a subtree of its BLAS, read from the
//! slot's `LeafReference`, one cache line), it is carried
//! into the instance's object space by the inverse transform and walks the BLAS there from
//! the reference's subtree (the root, for an instance left whole). The direction is not
//! renormalised, so t along the object-space ray is the world t: the BLAS search is
//! clipped to the best world hit so far, and hits compare directly.
//!
//! The TLAS walk is written once, generic over the SIMD slab kernel, with an entry point
//! compiled for each instruction set; a BLAS is walked by the BVH8's own traversal.
//! Counting: a TLAS node or leaf popped is a top-level node visited, and each child of a
//! TLAS node a top-level box test; the BLAS walks count as the BVH8 does. An instance is
//! entered each time the ray crosses from the TLAS into a BLAS: once per reference walked,
//! so an instance opened into several references that the ray reaches counts once for each.

use super::TwoLevel;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::bvh::wide::node::{Subtree, WideNode};
use crate::accel::bvh::wide::stack::{Entry, EntryRow, Stack};
use crate::accel::replay::{Level, Order, Step};
use crate::accel::stats::{count_locally, record};
use crate::accel::{Accel, BestHit, Hit, Stats, TraversalOrder};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::simd::slab::{Avx2, Avx512, Portable, Sse41, WideSlab, slab_test};
use crate::geometry::simd::{PACKET_RAYS, SimdLevel, TriangleKernel, WideRay, prefetch_packet};
use crate::geometry::{Intersector, Ray};
use std::mem::MaybeUninit;

impl TwoLevel {
    /// Walks the subtree of the reference in TLAS leaf slot `k` with the world ray `ray`,
    /// offering its hits to `best` under their flattened numbers. The BLAS ray ends just
    /// past the best hit so far (`best.limit`), so that a tie on a lower-numbered triangle
    /// still wins as in the flattened scene. An identity instance's BLAS is walked with the
    /// world ray's slab and intersector data (`world`) when the caller made them once for
    /// the ray; they depend on the ray's origin and direction alone, so made here from the
    /// BLAS ray they are the same.
    #[inline(always)]
    pub(super) fn enter_closest<
        K: WideSlab<8> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
    >(
        &self,
        k: usize,
        ray: &Ray,
        world: Option<(&WideRay, &I::RayData)>,
        best: &mut BestHit,
        stats: &mut S,
    ) {
        stats.instance_entered();
        let leaf = &self.leaves[k];
        let i = leaf.instance();
        record(stats, || Step::Instance { instance: i });
        let blas = &self.blases[leaf.blas as usize];
        let start = leaf.subtree;
        // A BLAS walk begins with a cache miss, as the references a ray enters lie
        // far apart: the subtree's first node or block loads while the ray is carried over.
        blas.prefetch_child(start);
        let local = Ray {
            tmax: best.limit,
            ..match leaf.is_identity() {
                true => *ray,
                false => leaf.to_object(ray),
            }
        };
        let found = match world.filter(|_| leaf.is_identity()) {
            Some((wray, data)) => {
                blas.closest_prepared::<K, I, S, ORDERED>(start, &local, wray, data, stats)
            }
            None => {
                let (wray, data) = (WideRay::new(&local), I::prepare(&local));
                blas.closest_prepared::<K, I, S, ORDERED>(start, &local, &wray, &data, stats)
            }
        };
        if let Some(h) = found {
            let hit = TriangleHit {
                t: h.t,
                u: h.u,
                v: h.v,
            };
            best.offer(hit, self.first_triangle[i as usize] + h.triangle);
        }
    }

    /// Whether the subtree of the reference in TLAS leaf slot `k` blocks the world ray
    /// `ray` (see `enter_closest`).
    #[inline(always)]
    fn enter_any<K: WideSlab<8> + TriangleKernel, I: Intersector, S: Stats>(
        &self,
        k: usize,
        ray: &Ray,
        (wray, data): (&WideRay, &I::RayData),
        stats: &mut S,
    ) -> bool {
        stats.instance_entered();
        let leaf = &self.leaves[k];
        let i = leaf.instance();
        record(stats, || Step::Instance { instance: i });
        let blas = &self.blases[leaf.blas as usize];
        let start = leaf.subtree;
        // A BLAS walk begins with a cache miss, as the references a ray enters lie
        // far apart: the subtree's first node or block loads while the ray is carried over.
        blas.prefetch_child(start);
        if leaf.is_identity() {
            return blas.occluded_prepared::<K, I, S>(start, ray, wray, data, stats);
        }
        let local = leaf.to_object(ray);
        let (wray, data) = (WideRay::new(&local), I::prepare(&local));
        blas.occluded_prepared::<K, I, S>(start, &local, &wray, &data, stats)
    }

    #[inline(always)]
    fn closest_with<
        K: WideSlab<8> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
    >(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let wray = WideRay::new(ray);
        let data = I::prepare(ray);
        let mut best = BestHit::new(ray);
        let root = Entry {
            child: Subtree::ROOT,
            entry: ray.tmin,
        };
        self.closest_from::<K, I, S, ORDERED>(root, ray, (&wray, &data), &mut best, stats);
        best.hit()
    }

    /// Walks the TLAS below `start` (the root, or a child a packet left to this ray alone)
    /// with `ray`, keeping the closest hit in `best`; in the kernel's fused slab form where
    /// the ray's fused constants are usable (as the BVH8's walk does).
    #[inline(always)]
    pub(super) fn closest_from<
        K: WideSlab<8> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
    >(
        &self,
        start: Entry,
        ray: &Ray,
        prepared: (&WideRay, &I::RayData),
        best: &mut BestHit,
        stats: &mut S,
    ) {
        match K::FUSED && prepared.0.fused_usable() {
            true => self.closest_walk::<K, I, S, ORDERED, true>(start, ray, prepared, best, stats),
            false => {
                self.closest_walk::<K, I, S, ORDERED, false>(start, ray, prepared, best, stats)
            }
        }
    }

    #[inline(always)]
    fn closest_walk<
        K: WideSlab<8> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
        const FUSED: bool,
    >(
        &self,
        start: Entry,
        ray: &Ray,
        (wray, data): (&WideRay, &I::RayData),
        best: &mut BestHit,
        stats: &mut S,
    ) {
        let tlas = &self.tlas;
        let mut box_tmax = best.t * T_SCALE;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::new(&mut storage);
        let mut row = EntryRow([0.0; 8]);
        let entry = &mut row.0;
        let mut cur = start;
        loop {
            stats.top_node_visit();
            record(stats, || tlas.visit_step_at(cur.child, Level::Top));
            if cur.child.is_leaf() {
                for k in cur.child.slots() {
                    self.enter_closest::<K, I, S, ORDERED>(k, ray, Some((wray, data)), best, stats);
                }
                box_tmax = best.t * T_SCALE;
            } else {
                let node = WideNode::of_row(&tlas.nodes, cur.child);
                if S::COUNTING {
                    stats.top_box_tests(node.child_count() as u32);
                }
                // SAFETY: the TLAS only selects a kernel its CPU supports (`set_simd`), and
                // the entry points below are compiled for it.
                let mut mask = unsafe {
                    slab_test::<8, K, FUSED>(&node.bounds, wray, ray.tmin, box_tmax, entry)
                };
                let order = if ORDERED {
                    Order::Nearest
                } else {
                    Order::Fixed
                };
                record(stats, || tlas.children_step(cur.child, mask, entry, order));
                let lane = |i: u32| Entry {
                    child: node.child[i as usize],
                    entry: entry[i as usize],
                };
                if mask != 0 && mask & (mask - 1) == 0 {
                    cur = lane(mask.trailing_zeros());
                    continue;
                }
                if ORDERED && mask != 0 && (mask & (mask - 1)).count_ones() == 1 {
                    // Two children, the commonest case: one compare, no sort.
                    let a = lane(mask.trailing_zeros());
                    let b = lane((mask & (mask - 1)).trailing_zeros());
                    let (near, far) = if b.entry < a.entry { (b, a) } else { (a, b) };
                    stack.push(far);
                    cur = near;
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
                    None => return,
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
    fn occluded_with<K: WideSlab<8> + TriangleKernel, I: Intersector, S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        let wray = WideRay::new(ray);
        let data = I::prepare(ray);
        match K::FUSED && wray.fused_usable() {
            true => self.occluded_walk::<K, I, S, true>(ray, (&wray, &data), stats),
            false => self.occluded_walk::<K, I, S, false>(ray, (&wray, &data), stats),
        }
    }

    #[inline(always)]
    fn occluded_walk<
        K: WideSlab<8> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const FUSED: bool,
    >(
        &self,
        ray: &Ray,
        (wray, data): (&WideRay, &I::RayData),
        stats: &mut S,
    ) -> bool {
        let tlas = &self.tlas;
        let tmax = ray.tmax * T_SCALE;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::new(&mut storage);
        let mut row = EntryRow([0.0; 8]);
        let entry = &mut row.0;
        let mut cur = Entry {
            child: Subtree::ROOT,
            entry: ray.tmin,
        };
        loop {
            stats.top_node_visit();
            record(stats, || tlas.visit_step_at(cur.child, Level::Top));
            if cur.child.is_leaf() {
                for k in cur.child.slots() {
                    if self.enter_any::<K, I, S>(k, ray, (wray, data), stats) {
                        return true;
                    }
                }
            } else {
                let node = WideNode::of_row(&tlas.nodes, cur.child);
                if S::COUNTING {
                    stats.top_box_tests(node.child_count() as u32);
                }
                // SAFETY: as in `closest_with`.
                let mut mask =
                    unsafe { slab_test::<8, K, FUSED>(&node.bounds, wray, ray.tmin, tmax, entry) };
                record(stats, || {
                    tlas.children_step(cur.child, mask, entry, Order::AnyHit)
                });
                while mask != 0 {
                    let j = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack.push(Entry {
                        child: node.child[j],
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
    ($closest:ident, $occluded:ident, $packets:ident, $kernel:ty, $features:literal) => {
        impl TwoLevel {
            #[target_feature(enable = $features)]
            fn $packets<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
                let packets = rays.chunks(PACKET_RAYS).zip(hits.chunks_mut(PACKET_RAYS));
                for (k, (packet, hits)) in packets.enumerate() {
                    prefetch_packet(rays.as_ptr().wrapping_add((k + 1) * PACKET_RAYS));
                    self.trace_packet::<$kernel, I>(packet, hits);
                }
            }

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
entry_points!(
    closest_sse41,
    occluded_sse41,
    packets_sse41,
    Sse41,
    "sse4.1"
);
#[cfg(target_arch = "x86_64")]
entry_points!(
    closest_avx2,
    occluded_avx2,
    packets_avx2,
    Avx2,
    "avx2,popcnt,bmi1,lzcnt"
);
#[cfg(target_arch = "x86_64")]
entry_points!(
    closest_avx512,
    occluded_avx512,
    packets_avx512,
    Avx512,
    "avx512f,avx512vl,fma,popcnt,bmi1,lzcnt"
);

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

    /// Closest hits in packets of 8 × 8 coherent rays through the top level
    /// (`two_level::packet`), the same hits as ray by ray.
    fn closest_hits<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` only holds a level this CPU supports (`set_simd`).
            SimdLevel::Sse41 => unsafe { self.packets_sse41::<I>(rays, hits) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx2 => unsafe { self.packets_avx2::<I>(rays, hits) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.packets_avx512::<I>(rays, hits) },
            _ => {
                for (rays, hits) in rays.chunks(PACKET_RAYS).zip(hits.chunks_mut(PACKET_RAYS)) {
                    self.trace_packet::<Portable, I>(rays, hits);
                }
            }
        }
    }
}
