//! Packet traversal of a wide BVH for coherent rays (a tile of 8 × 8 primary rays): the 64
//! rays walk the tree together, stored as structures of arrays (`RayPacket`), and carry down
//! the tree the mask of the rays still active.
//!
//! - At each node every child box is tested against all active rays of the packet at once,
//!   SIMD across the rays (`PacketSlab`): 16 rays per instruction with AVX-512, 8 with AVX2.
//!   Each ray's answer is its own scalar slab test, so a child gets the exact mask of the
//!   rays that enter it, and a child no ray enters is culled.
//! - The entered children are pushed with their masks, nearest first by the smallest entry
//!   distance of their rays. A popped child whose rays may have found closer hits since it
//!   was pushed is tested once more, which drops the rays that now stop before it.
//! - In a leaf each ray of the mask tests the triangles alone, with the SIMD block test of
//!   single rays, and its box-test limit shrinks with each hit it finds.
//! - Hybrid traversal (as Embree's): once at most `HYBRID_RAYS` rays are left in a subtree,
//!   each of them finishes it with the single-ray traversal, which tests the W children of a
//!   node at once, SIMD across boxes.
//!
//! The hits are exactly those of `closest_hit` ray by ray: every ray tests the boxes it
//! meets with its own slab test, and `BestHit` keeps, of equal distances, the lowest
//! triangle index, so the order of the visit does not matter.

use super::WideBvh;
use super::leaf::Leaf;
use super::node::{INTERIOR, WideNode};
use super::stack::{Entry, Stack};
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::{BestHit, Hit, NoStats};
use crate::geometry::simd::packet::BoxPlanes;
use crate::geometry::simd::{
    PACKET_RAYS, PacketSlab, RayPacket, TriangleKernel, WideRay, WideSlab,
};
use crate::geometry::{Intersector, Ray};
use std::mem::MaybeUninit;

/// A subtree that at most this many rays of a packet enter is traced ray by ray: testing
/// one box against the packet costs about as much as testing all W boxes against one ray.
pub const HYBRID_RAYS: u32 = 2;

/// A child still to visit: the child, the packet rays that entered it and where to find its
/// box again.
#[derive(Clone, Copy)]
struct Pending {
    /// The child, with the smallest entry distance of its rays.
    child: Entry,
    rays: u64,
    /// The node and lane holding the child's box.
    node: u32,
    lane: u32,
    /// The packet's count of improved hits when the mask was found: while it is unchanged,
    /// no ray's limit has shrunk and the mask still holds.
    found: u32,
}

#[inline(always)]
fn planes<const W: usize>(node: &WideNode<W>, lane: usize) -> BoxPlanes {
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

impl<const W: usize> WideBvh<W> {
    /// The closest hit of each ray of `rays` (at most `PACKET_RAYS`).
    #[inline(always)]
    pub(super) fn trace_packet<K, I>(&self, rays: &[Ray], out: &mut [Option<Hit>])
    where
        K: WideSlab<W> + TriangleKernel + PacketSlab,
        I: Intersector,
    {
        let n = rays.len().min(PACKET_RAYS).min(out.len());
        if n == 0 {
            return;
        }
        let rays = &rays[..n];
        let mut packet = RayPacket::new(rays, |r| r.tmax * T_SCALE);
        // Unused slots copy the last ray; only the first `n` are ever read.
        let ray = |i: usize| &rays[i.min(n - 1)];
        let data: [I::RayData; PACKET_RAYS] = std::array::from_fn(|i| I::prepare(ray(i)));
        let mut best: [BestHit; PACKET_RAYS] = std::array::from_fn(|i| BestHit::new(ray(i)));
        let mut found = 0u32;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::<Pending>::new(&mut storage);
        let mut cur = Pending {
            child: Entry {
                child: 0,
                count: INTERIOR,
                entry: f32::NEG_INFINITY,
            },
            rays: packet.rays,
            node: 0,
            lane: 0,
            found,
        };
        'walk: loop {
            if cur.rays.count_ones() <= HYBRID_RAYS {
                for i in each_ray(cur.rays) {
                    let before = best[i].t;
                    let wray = WideRay::new(&rays[i]);
                    self.closest_from::<K, I, NoStats, true>(
                        cur.child,
                        &wray,
                        &data[i],
                        &rays[i],
                        &mut best[i],
                        &mut NoStats,
                    );
                    if best[i].t != before {
                        packet.tmax[i] = best[i].t * T_SCALE;
                        found += 1;
                    }
                }
            } else if cur.child.count == INTERIOR {
                let index = cur.child.child as usize;
                let node = &self.nodes[index];
                // The children some ray enters, with their rays and nearest entry.
                let mut entered = [(0.0f32, 0u64, 0usize); W];
                let mut k = 0;
                for lane in 0..W {
                    if node.count[lane] == 0 {
                        break;
                    }
                    // SAFETY: a tree only selects a kernel its CPU supports (`set_simd`),
                    // and the entry points are compiled for it.
                    let (hit, d) =
                        unsafe { K::packet_entries(&planes(node, lane), &packet, cur.rays) };
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
            } else {
                let leaf = Leaf {
                    first: cur.child.child,
                    count: cur.child.count,
                };
                for i in each_ray(cur.rays) {
                    // SAFETY: as above.
                    let hit = unsafe {
                        self.leaf_closest::<K, I, _>(
                            leaf,
                            &data[i],
                            &rays[i],
                            &mut best[i],
                            &mut NoStats,
                        )
                    };
                    if hit {
                        packet.tmax[i] = best[i].t * T_SCALE;
                        found += 1;
                    }
                }
            }
            // The next child some ray still enters before its best hit.
            loop {
                let Some(mut next) = stack.pop() else {
                    break 'walk;
                };
                if next.found != found {
                    let node = &self.nodes[next.node as usize];
                    // SAFETY: as above.
                    next.rays = unsafe {
                        K::packet_entries(&planes(node, next.lane as usize), &packet, next.rays)
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
        for (o, b) in out.iter_mut().zip(&best[..n]) {
            *o = b.hit();
        }
    }
}
