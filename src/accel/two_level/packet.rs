//! Packets through the two levels: a tile of 8 × 8 primary rays walks the top level
//! together, as through a wide BVH (`bvh::wide::packet`): one interval test over the
//! packet's directions culls the children no ray can enter, each remaining child box is
//! tested against all active rays at once (SIMD across the rays), and the entered children
//! are pushed with the mask of their rays, nearest first. The top level is where a packet's
//! rays agree longest: they look over the same part of the island, and only near its
//! leaves do they part for different trees. At a leaf, each ray of the mask enters the
//! reference's BLAS on its own (the rays of one instance are as coherent as the world's, but
//! a BLAS walk starts from a subtree, under each ray's own best hit, and most references are
//! entered by few of the packet's rays). A child entered by at most `HYBRID_RAYS` rays is
//! finished ray by ray with the single-ray walk.
//!
//! The hits are exactly those of `closest_hit` ray by ray: every ray tests each box with its
//! own slab test and enters every reference whose box it reaches before its best hit, and
//! the closest-hit rule (lowest triangle on equal t) does not depend on the order.

use super::TwoLevel;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::bvh::wide::node::{INTERIOR, WideNode};
use crate::accel::bvh::wide::packet::HYBRID_RAYS;
use crate::accel::bvh::wide::stack::{Entry, Stack};
use crate::accel::{BestHit, Hit, NoStats};
use crate::geometry::simd::packet::BoxPlanes;
use crate::geometry::simd::{
    IntervalSlab, PACKET_RAYS, PacketSlab, RayLoad, RayPacket, TriangleKernel, WideInterval,
    WideRay, WideSlab,
};
use crate::geometry::{Intersector, Ray};
use std::mem::MaybeUninit;

/// The kernels the top level's packet walk uses.
pub(super) trait TopPacketKernels:
    WideSlab<8> + IntervalSlab<8> + TriangleKernel + RayLoad + PacketSlab
{
}

impl<K> TopPacketKernels for K where
    K: WideSlab<8> + IntervalSlab<8> + TriangleKernel + RayLoad + PacketSlab
{
}

/// A TLAS child still to visit: the child, the rays that entered it, where its box is,
/// and the packet's count of improved hits when its mask was found (while unchanged, no
/// ray's limit has shrunk and the mask still holds).
#[derive(Clone, Copy)]
struct Pending {
    child: Entry,
    rays: u64,
    node: u32,
    lane: u32,
    found: u32,
}

#[inline(always)]
fn planes(node: &WideNode<8>, lane: usize) -> BoxPlanes {
    std::array::from_fn(|row| node.bounds[row][lane])
}

/// The rays of a mask, lowest first.
#[inline(always)]
fn each_ray(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

impl TwoLevel {
    /// The closest hit of each ray of `rays` (at most `PACKET_RAYS`).
    #[inline(always)]
    pub(super) fn trace_packet<K: TopPacketKernels, I: Intersector>(
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
        let (mut packet_tmax, mut tmax_found) = (f32::INFINITY, u32::MAX);
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::<Pending>::new(&mut storage);
        let mut cur = Pending {
            child: Entry {
                child: 0,
                count: INTERIOR,
                entry: f32::NEG_INFINITY,
            },
            rays: soa.rays,
            node: 0,
            lane: 0,
            found: 0,
        };
        'walk: loop {
            if cur.rays.count_ones() <= HYBRID_RAYS || cur.child.count != INTERIOR {
                // A leaf, or a child few rays entered: each ray on its own.
                let mut improved = 0u64;
                for i in each_ray(cur.rays) {
                    let ray = &rays[i];
                    let before = best[i].t;
                    let prepared = (&WideRay::new(ray), &I::prepare(ray));
                    if cur.child.count == INTERIOR {
                        self.closest_from::<K, I, NoStats, true>(
                            cur.child,
                            ray,
                            prepared,
                            &mut best[i],
                            &mut NoStats,
                        );
                    } else {
                        let tlas = &self.tlas;
                        for k in cur.child.child..cur.child.child + cur.child.count {
                            let r = tlas.prim_indices[k as usize] as usize;
                            self.enter_closest::<K, I, NoStats, true>(
                                r,
                                ray,
                                prepared,
                                &mut best[i],
                                &mut NoStats,
                            );
                        }
                    }
                    if best[i].t != before {
                        soa.tmax[i] = best[i].t * T_SCALE;
                        improved |= 1 << i;
                    }
                }
                if improved != 0 {
                    found += 1;
                }
            } else {
                let index = cur.child.child as usize;
                let node = &self.tlas.nodes[index];
                let mut entered = [(0.0f32, 0u64, 0usize); 8];
                let mut k = 0;
                let mut lanes = (1u32 << node.child_count()) - 1;
                if let Some(iv) = &interval {
                    if tmax_found != found {
                        packet_tmax = soa.largest_tmax();
                        tmax_found = found;
                    }
                    // SAFETY: as above.
                    lanes &= unsafe { K::maybe_entered(&node.bounds, iv, packet_tmax) };
                }
                while lanes != 0 {
                    let lane = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    // SAFETY: as above.
                    let (hit, d) =
                        unsafe { K::packet_entries(&planes(node, lane), &soa, cur.rays) };
                    if hit != 0 {
                        entered[k] = (d, hit, lane);
                        k += 1;
                    }
                }
                if k > 0 {
                    // Farthest first, so the nearest is pushed last (insertion sort: k ≤ 8).
                    let entered = &mut entered[..k];
                    for a in 1..k {
                        let e = entered[a];
                        let mut j = a;
                        while j > 0 && entered[j - 1].0 < e.0 {
                            entered[j] = entered[j - 1];
                            j -= 1;
                        }
                        entered[j] = e;
                    }
                    let pending = |&(d, hit, lane): &(f32, u64, usize)| Pending {
                        child: Entry {
                            child: node.child[lane],
                            count: node.count[lane],
                            entry: d,
                        },
                        rays: hit,
                        node: index as u32,
                        lane: lane as u32,
                        found,
                    };
                    for e in &entered[..k - 1] {
                        stack.push(pending(e));
                    }
                    cur = pending(&entered[k - 1]);
                    continue 'walk;
                }
            }
            // The next child some ray still enters before its best hit.
            loop {
                let Some(mut next) = stack.pop() else {
                    break 'walk;
                };
                if next.found != found {
                    let node = &self.tlas.nodes[next.node as usize];
                    // SAFETY: as above.
                    next.rays = unsafe {
                        K::packet_entries(&planes(node, next.lane as usize), &soa, next.rays)
                    }
                    .0;
                    if next.rays == 0 {
                        continue;
                    }
                }
                cur = next;
                break;
            }
        }
        for (o, b) in out[..n].iter_mut().zip(&best) {
            *o = b.hit();
        }
    }
}
