//! Packets through the two levels: a tile of 8 × 8 primary rays walks the top level
//! together, as through a wide BVH (`bvh::wide::packet`): one interval test over the
//! packet's directions culls the children no ray can enter, each remaining child box is
//! tested against all active rays at once (SIMD across the rays), and the entered children
//! are pushed with the mask of their rays, nearest first. The top level is where a packet's
//! rays agree longest: they look over the same part of the island, and only near its
//! leaves do they part for different trees. At a leaf, each ray of the mask enters the
//! reference's BLAS on its own (the rays of one instance are as coherent as the world's, but
//! a BLAS walk starts from a subtree, under each ray's own best hit, and most references are
//! entered by few of the packet's rays). Walking the BLAS as a packet instead (the mask's
//! rays carried into the instance's space together, then the wide BVH's packet walk from the
//! reference's subtree) was measured on the island's view and cost more: 38 % more
//! instructions when four or more rays entered together, and slower at every threshold up
//! to 16 rays, as the terrain's references are small subtrees and the crowns' cards part the
//! rays at once. An identity instance's rays, though, need no carrying: the world packet is
//! already in its space, so it walks on into the BLAS with the BVH8's packet walk (sponza's
//! objects loaded as instances). A child entered by at most `HYBRID_RAYS` rays is finished
//! ray by ray with the single-ray walk.
//!
//! The hits are exactly those of `closest_hit` ray by ray: every ray tests each box with its
//! own slab test and enters every reference whose box it reaches before its best hit, and
//! the closest-hit rule (lowest triangle on equal t) does not depend on the order.

use super::TwoLevel;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::bvh::wide::packet::{
    HYBRID_RAYS, PacketKernels, Pending, each_ray, enter_children, next_pending,
};
use crate::accel::bvh::wide::stack::Stack;
use crate::accel::{BestHit, Hit, NoStats};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::simd::{PACKET_RAYS, PacketShear, RayPacket, WideInterval, WideRay};
use crate::geometry::{Intersector, Ray};
use std::mem::MaybeUninit;

impl TwoLevel {
    /// The closest hit of each ray of `rays` (at most `PACKET_RAYS`).
    #[inline(always)]
    pub(super) fn trace_packet<K: PacketKernels<8>, I: Intersector>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
    ) {
        let n = rays.len().min(PACKET_RAYS).min(out.len());
        if n == 0 {
            return;
        }
        let rays = &rays[..n];
        // SAFETY: the TLAS only selects a kernel its CPU supports (`set_simd`), and the
        // entry points are compiled for it.
        let mut soa = unsafe { RayPacket::load::<K>(rays, T_SCALE) };
        let mut best: [BestHit; PACKET_RAYS] =
            std::array::from_fn(|i| BestHit::new(&rays[i.min(n - 1)]));
        // Incremented whenever some ray's limit shrinks.
        let mut found = 0u32;
        let interval = WideInterval::of_packet(&soa);
        // Each ray's shear for the packet triangle test, made at the first identity
        // instance the packet enters together (`None` inside: the intersector has no
        // packet form).
        let mut shear: Option<Option<PacketShear>> = None;
        let (mut packet_tmax, mut tmax_found) = (f32::INFINITY, u32::MAX);
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::<Pending>::new(&mut storage);
        let mut cur = Pending::root(soa.rays);
        'walk: loop {
            if cur.rays.count_ones() <= HYBRID_RAYS || cur.child.child.is_leaf() {
                // A leaf's references (an identity instance's walked by the packet), or a
                // child few rays entered: each ray on its own.
                let mut improved = 0u64;
                // The rays' walks are written out here rather than passed as closures: a
                // closure is compiled with its defining function's instruction set, the
                // baseline's, and would call every intrinsic of the walk out of line.
                if !cur.child.child.is_leaf() {
                    for i in each_ray(cur.rays) {
                        let (ray, before) = (&rays[i], best[i].t);
                        let prepared = (&WideRay::new(ray), &I::prepare(ray));
                        self.closest_from::<K, I, NoStats, true>(
                            cur.child,
                            ray,
                            prepared,
                            &mut best[i],
                            &mut NoStats,
                        );
                        improved |= follow_closer_hit(i, before, &best, &mut soa);
                    }
                } else {
                    for k in cur.child.child.slots() {
                        if self.leaves[k].is_identity() && cur.rays.count_ones() > HYBRID_RAYS {
                            // The world rays are the instance's: the packet walks on into
                            // its BLAS.
                            let shear = shear.get_or_insert_with(|| {
                                // SAFETY: as above.
                                I::PACKET_TEST.then(|| unsafe { PacketShear::new::<K>(&soa) })
                            });
                            // SAFETY: as above.
                            improved |= unsafe {
                                self.enter_closest_packet::<K, I>(
                                    k,
                                    cur.rays,
                                    rays,
                                    (&mut soa, shear.as_ref(), interval.as_ref()),
                                    &mut best,
                                )
                            };
                        } else {
                            // The world ray's data only serve an identity instance, and
                            // are made there.
                            for i in each_ray(cur.rays) {
                                let before = best[i].t;
                                self.enter_closest::<K, I, NoStats, true>(
                                    k,
                                    &rays[i],
                                    None,
                                    &mut best[i],
                                    &mut NoStats,
                                );
                                improved |= follow_closer_hit(i, before, &best, &mut soa);
                            }
                        }
                    }
                }
                if improved != 0 {
                    found += 1;
                }
            } else {
                let index = cur.child.child.node_index();
                let node = &self.tlas.nodes[index];
                let cull = interval.as_ref().map(|iv| {
                    if tmax_found != found {
                        packet_tmax = soa.largest_tmax();
                        tmax_found = found;
                    }
                    (iv, packet_tmax)
                });
                // SAFETY: as above.
                let nearest = unsafe {
                    enter_children::<K, 8>(node, index, &soa, cur.rays, cull, found, &mut stack)
                };
                if let Some(nearest) = nearest {
                    cur = nearest;
                    continue 'walk;
                }
            }
            // The next child some ray still enters before its best hit.
            // SAFETY: as above.
            match unsafe {
                next_pending::<K, 8>(&self.tlas.nodes, &soa, interval.as_ref(), found, &mut stack)
            } {
                Some(next) => cur = next,
                None => break 'walk,
            }
        }
        for (o, b) in out[..n].iter_mut().zip(&best) {
            *o = b.hit();
        }
    }

    /// The packet rays of `mask` into the reference in TLAS leaf slot `k`, an identity
    /// instance's, together: the BVH8's packet walk from the reference's subtree, each ray
    /// searching up to its best hit so far. Offers the hits to `best` under their flattened
    /// numbers and shrinks the rays' box-test limits; returns the rays that found one.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    unsafe fn enter_closest_packet<K: PacketKernels<8>, I: Intersector>(
        &self,
        k: usize,
        mask: u64,
        rays: &[Ray],
        (soa, shear, interval): (&mut RayPacket, Option<&PacketShear>, Option<&WideInterval>),
        best: &mut [BestHit; PACKET_RAYS],
    ) -> u64 {
        let leaf = &self.leaves[k];
        let blas = &self.blases[leaf.blas as usize];
        let limit = std::array::from_fn(|i| best[i].limit);
        // SAFETY: the caller guarantees K's instruction set.
        let found = unsafe {
            blas.closest_packet_from::<K, I>(leaf.subtree, mask, rays, soa, shear, interval, &limit)
        };
        let first = self.first_triangle[leaf.instance() as usize];
        for i in each_ray(found.found) {
            let hit = TriangleHit {
                t: found.t[i],
                u: found.u[i],
                v: found.v[i],
            };
            best[i].offer(hit, first + u64::from(found.triangle[i]));
            soa.tmax[i] = best[i].t * T_SCALE;
        }
        found.found
    }
}

/// After ray `i` walked on its own from its best hit `before`: whether it found a closer
/// one (the ray's bit), in which case its box-test limit follows.
#[inline(always)]
fn follow_closer_hit(
    i: usize,
    before: f32,
    best: &[BestHit; PACKET_RAYS],
    soa: &mut RayPacket,
) -> u64 {
    if best[i].t == before {
        return 0;
    }
    soa.tmax[i] = best[i].t * T_SCALE;
    1 << i
}
