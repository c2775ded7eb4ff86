//! Packet traversal of a wide BVH for coherent rays (a tile of primary rays), as the BVH2's
//! packets do it (`bvh::packet`): the packet walks the tree together, and at each node the
//! packet's first active ray is tested against all W children in one SIMD slab test. A child
//! that ray misses is culled for the whole packet by the interval test, or else the other
//! rays are tested one by one. Children are visited in the order the first ray enters them.
//!
//! The hits are exactly those of `closest_hit` ray by ray (`BestHit` keeps, of equal
//! distances, the lowest triangle index, so the order of the visit does not matter).

use super::WideBvh;
use super::leaf::Leaf;
use super::node::WideNode;
use crate::accel::NoStats;
use crate::accel::bvh::packet::PACKET_SIZE;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::{BestHit, Hit};
use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::frustum::RayInterval;
use crate::geometry::simd::slab::WideSlab;
use crate::geometry::simd::{TriangleKernel, WideRay};
use crate::geometry::{Intersector, Ray};
use glam::Vec3;

/// The per-ray state of a packet.
struct PacketRays<'a, I: Intersector> {
    rays: &'a [Ray],
    slabs: [SlabRay; PACKET_SIZE],
    wide: [WideRay; PACKET_SIZE],
    data: [I::RayData; PACKET_SIZE],
    best: [BestHit; PACKET_SIZE],
    /// Each ray's box-test limit: its best t, widened by the rounding of the box test.
    box_tmax: [f32; PACKET_SIZE],
}

impl<I: Intersector> PacketRays<'_, I> {
    #[inline(always)]
    fn enters(&self, corners: &[Vec3; 2], i: usize) -> bool {
        slab_entry(corners, &self.slabs[i], self.rays[i].tmin, self.box_tmax[i]) != f32::INFINITY
    }

    fn packet_tmax(&self) -> f32 {
        let n = self.rays.len();
        self.box_tmax[..n]
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max)
    }
}

/// A child still to visit: its parent node and lane, and the packet's first ray that may
/// enter it (the rays before it are known to miss it).
#[derive(Clone, Copy)]
struct Pending {
    node: u32,
    lane: u32,
    first: u32,
    /// The packet's hit count when the first ray was found to enter the child
    /// (`u32::MAX`: not known to); while no hit is found since, it still enters.
    entered_at: u32,
}

fn corners<const W: usize>(node: &WideNode<W>, lane: usize) -> [Vec3; 2] {
    let b = node.child_bounds(lane);
    [b.min, b.max]
}

impl<const W: usize> WideBvh<W> {
    /// The closest hit of each ray of `rays` (at most `PACKET_SIZE`).
    #[inline(always)]
    pub(super) fn trace_packet<K: WideSlab<W> + TriangleKernel, I: Intersector>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
    ) {
        let n = rays.len().min(PACKET_SIZE).min(out.len());
        if n == 0 {
            return;
        }
        let ray = |i: usize| &rays[i.min(n - 1)];
        let mut p = PacketRays::<I> {
            rays: &rays[..n],
            slabs: std::array::from_fn(|i| SlabRay::new(ray(i))),
            wide: std::array::from_fn(|i| WideRay::new(ray(i))),
            data: std::array::from_fn(|i| I::prepare(ray(i))),
            best: std::array::from_fn(|i| BestHit::new(ray(i))),
            box_tmax: std::array::from_fn(|i| ray(i).tmax * T_SCALE),
        };
        let interval = RayInterval::new(&rays[..n]);
        let mut packet_tmax = p.packet_tmax();
        // At most W − 1 pending children per level of a tree no deeper than the BVH2's.
        let mut stack: Vec<Pending> = Vec::with_capacity(64);
        let mut entry = [0.0f32; W];
        // Hits found so far by the whole packet: a ray's box-test limit only changes with one.
        let mut found = 0u32;
        // The node to open and its first ray that may enter it.
        let mut open = Some((0usize, 0usize));
        loop {
            if let Some((index, f)) = open.take() {
                let node = &self.nodes[index];
                let r = &p.rays[f];
                // SAFETY: a tree only selects a kernel its CPU supports (`set_simd`), and
                // the entry points are compiled for it.
                let mask = unsafe {
                    K::entries(&node.bounds, &p.wide[f], r.tmin, p.box_tmax[f], &mut entry)
                };
                // Children the first ray enters, nearest first, then the others it misses
                // that some later ray may still enter.
                let mut order: [(f32, u32, u32); 8] = [(0.0, 0, 0); 8];
                let k = node.child_count();
                for (lane, (slot, &d)) in order.iter_mut().zip(&entry).take(k).enumerate() {
                    let d = if mask >> lane & 1 == 1 {
                        d
                    } else {
                        f32::INFINITY
                    };
                    *slot = (d, lane as u32, f as u32);
                }
                // Farthest first, so the nearest is pushed last (insertion sort: k ≤ 8).
                let order = &mut order[..k];
                for i in 1..k {
                    let e = order[i];
                    let mut j = i;
                    while j > 0 && order[j - 1].0 < e.0 {
                        order[j] = order[j - 1];
                        j -= 1;
                    }
                    order[j] = e;
                }
                for &(d, lane, first) in order.iter() {
                    if d == f32::INFINITY {
                        // Not entered by the first ray: culled for the whole packet, or
                        // left to a later ray (found when the child is popped).
                        let c = corners(node, lane as usize);
                        if first as usize + 1 == n
                            || interval.is_some_and(|iv| iv.misses(&c, packet_tmax))
                        {
                            continue;
                        }
                        stack.push(Pending {
                            node: index as u32,
                            lane,
                            first: first + 1,
                            entered_at: u32::MAX,
                        });
                    } else {
                        stack.push(Pending {
                            node: index as u32,
                            lane,
                            first,
                            entered_at: found,
                        });
                    }
                }
            }
            let Some(next) = stack.pop() else { break };
            let node = &self.nodes[next.node as usize];
            let lane = next.lane as usize;
            let c = corners(node, lane);
            // The first ray may have found a closer hit since the child was pushed.
            let f = next.first as usize;
            let active = if next.entered_at == found || p.enters(&c, f) {
                Some(f)
            } else if interval.is_some_and(|iv| iv.misses(&c, packet_tmax)) {
                None
            } else {
                (f + 1..n).find(|&i| p.enters(&c, i))
            };
            let Some(f) = active else { continue };
            if node.is_interior(lane) {
                open = Some((node.child[lane] as usize, f));
                continue;
            }
            let leaf = Leaf {
                first: node.child[lane],
                count: node.count[lane],
            };
            for i in f..n {
                if i != f && !p.enters(&c, i) {
                    continue;
                }
                let r = &p.rays[i];
                // SAFETY: as above.
                let hit = unsafe {
                    self.leaf_closest::<K, I, _>(leaf, &p.data[i], r, &mut p.best[i], &mut NoStats)
                };
                if hit {
                    p.box_tmax[i] = p.best[i].t * T_SCALE;
                    found += 1;
                }
            }
            packet_tmax = p.packet_tmax();
        }
        for (o, b) in out.iter_mut().zip(&p.best[..n]) {
            *o = b.hit();
        }
    }
}
