//! Packet traversal of a wide BVH for coherent rays (a tile of 8 × 8 primary rays): the 64
//! rays walk the tree together, stored as structures of arrays (`RayPacket`), and carry down
//! the tree the mask of the rays still active.
//!
//! - Early miss: when the rays share an origin and a direction octant, one SIMD interval
//!   test (`IntervalSlab`) over the packet's range of directions tells which of the W
//!   children no ray can enter.
//! - Each remaining child box is tested against all active rays at once, SIMD across the
//!   rays (`PacketSlab`): 16 rays per instruction with AVX-512, 8 with AVX2. Each ray's answer
//!   is its own scalar slab test, so a child gets the exact mask of the rays that enter it.
//!   Rays from one origin into one octant find each plane's offset from the origin once.
//! - The entered children are pushed with their masks, nearest first by the smallest entry
//!   distance of their rays. A popped child whose rays may have found closer hits since it
//!   was pushed is tested once more, which drops the rays that now stop before it.
//! - In a leaf each triangle is tested against the mask's rays at once, SIMD across the rays
//!   (`PacketTriangleKernel`, the watertight test), and each ray keeps its closest hit and
//!   shrinks its box-test limit. A group of rays none of which is inside the triangle's
//!   edges or on one stops after the edge functions. An intersector without that form tests
//!   ray by ray with the single rays' block test.
//! - Hybrid traversal (as Embree's): once at most `HYBRID_RAYS` rays are left in a subtree,
//!   each of them finishes it with the single-ray traversal, which tests the W children of a
//!   node at once, SIMD across boxes.
//!
//! The hits are exactly those of `closest_hit` ray by ray: every ray tests the boxes it
//! meets with its own slab test and the triangles with its own watertight test (lane for
//! lane the same operations), and of hits at equal distances the lowest triangle index wins
//! (`BestHit`), so the order of the visit does not matter.

use super::WideBvh;
use super::leaf::Leaf;
use super::node::{Lanes, NodeWidth, Subtree, WideNode};
use super::stack::{Entry, Stack};
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::{BestHit, Hit, NoStats};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::simd::packet::BoxPlanes;
use crate::geometry::simd::packet_triangle::TriangleVertices;
use crate::geometry::simd::{
    BLOCK, IntervalSlab, PACKET_RAYS, PacketBest, PacketHits, PacketShear, PacketSlab,
    PacketTriangleKernel, RayLoad, RayPacket, TriangleKernel, WideInterval, WideRay, WideSlab,
};
use crate::geometry::{Intersector, Ray};
use std::mem::MaybeUninit;

/// A subtree that at most this many rays of a packet enter is traced ray by ray: testing
/// one box against the packet costs about as much as testing all W boxes against one ray.
pub const HYBRID_RAYS: u32 = 2;

/// The traits a SIMD level's kernels implement for the packet traversal.
pub trait PacketKernels<const W: usize>:
    WideSlab<W> + IntervalSlab<W> + TriangleKernel + RayLoad + PacketSlab + PacketTriangleKernel
{
}

impl<const W: usize, K> PacketKernels<W> for K where
    K: WideSlab<W> + IntervalSlab<W> + TriangleKernel + RayLoad + PacketSlab + PacketTriangleKernel
{
}

/// A child still to visit: the child, the packet rays that entered it and where to find its
/// box again.
#[derive(Clone, Copy)]
pub(crate) struct Pending {
    /// The child, with the smallest entry distance of its rays.
    pub(crate) child: Entry,
    pub(crate) rays: u64,
    /// The node and lane holding the child's box.
    pub(crate) node: u32,
    pub(crate) lane: u32,
    /// The packet's count of improved hits when the mask was found: while it is unchanged,
    /// no ray's limit has shrunk and the mask still holds.
    pub(crate) found: u32,
}

impl Pending {
    /// The walk's start: the root, entered by every ray of the packet.
    pub(crate) fn root(rays: u64) -> Self {
        Pending {
            child: Entry {
                child: Subtree::ROOT,
                entry: f32::NEG_INFINITY,
            },
            rays,
            node: 0,
            lane: 0,
            found: 0,
        }
    }
}

/// One interior node of a packet walk (the wide BVH's, or the two levels' top): the
/// children some ray of `rays` enters, after the interval test `cull` (with the packet's
/// largest box-test limit) has dropped those no ray can, each tested against the rays at
/// once. All but the nearest are pushed, farthest first; the nearest is returned.
///
/// # Safety
/// The CPU supports K's instruction set.
#[inline(always)]
pub(crate) unsafe fn enter_children<K: PacketSlab + IntervalSlab<W>, const W: usize>(
    node: &WideNode<W>,
    index: usize,
    soa: &RayPacket,
    rays: u64,
    cull: Option<(&WideInterval, f32)>,
    found: u32,
    stack: &mut Stack<Pending>,
) -> Option<Pending>
where
    Lanes<W>: NodeWidth,
{
    // The children some ray enters, with their rays and nearest entry.
    let mut entered = [(0.0f32, 0u64, 0usize); W];
    let mut k = 0;
    let mut lanes = (1u32 << node.child_count()) - 1;
    if let Some((iv, packet_tmax)) = cull {
        // SAFETY: the caller guarantees K's instruction set.
        lanes &= unsafe { K::maybe_entered(&node.bounds, iv, packet_tmax) };
    }
    while lanes != 0 {
        let lane = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        let b = planes(node, lane);
        // SAFETY: as above.
        let (hit, d) = unsafe {
            match cull {
                // One origin and octant: each plane's offset from the origin once.
                Some((iv, _)) => K::packet_entries_shared(&b, iv, soa, rays),
                None => K::packet_entries(&b, soa, rays),
            }
        };
        if hit != 0 {
            entered[k] = (d, hit, lane);
            k += 1;
        }
    }
    if k == 0 {
        return None;
    }
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
    Some(pending(&entered[k - 1]))
}

/// The next child some ray still enters before its best hit: a child pushed before some
/// ray's limit shrank (`found` moved on) is tested again, and dropped if no ray is left.
///
/// # Safety
/// The CPU supports K's instruction set.
#[inline(always)]
pub(crate) unsafe fn next_pending<K: PacketSlab, const W: usize>(
    nodes: &[WideNode<W>],
    soa: &RayPacket,
    interval: Option<&WideInterval>,
    found: u32,
    stack: &mut Stack<Pending>,
) -> Option<Pending>
where
    Lanes<W>: NodeWidth,
{
    loop {
        let mut next = stack.pop()?;
        if next.found != found {
            let b = planes(&nodes[next.node as usize], next.lane as usize);
            // SAFETY: the caller guarantees K's instruction set.
            next.rays = unsafe {
                match interval {
                    Some(iv) => K::packet_entries_shared(&b, iv, soa, next.rays),
                    None => K::packet_entries(&b, soa, next.rays),
                }
            }
            .0;
            if next.rays == 0 {
                continue;
            }
        }
        return Some(next);
    }
}

#[inline(always)]
pub(crate) fn planes<const W: usize>(node: &WideNode<W>, lane: usize) -> BoxPlanes
where
    Lanes<W>: NodeWidth,
{
    std::array::from_fn(|row| node.bounds[row][lane])
}

/// The rays of a mask, lowest first.
#[inline(always)]
pub(crate) fn each_ray(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// A packet on its way through the tree: its rays, each ray's closest hit so far and the
/// watertight test's per-ray values.
struct Packet<'a> {
    rays: &'a [Ray],
    /// The rays as arrays, with each ray's box-test limit: its best distance widened by
    /// the rounding of the box test.
    soa: &'a mut RayPacket,
    best: PacketBest,
    /// Each ray's shear, when the intersector is the watertight test.
    shear: Option<&'a PacketShear>,
    /// The last triangle's answers left to one-ray-at-a-time decisions.
    hits: PacketHits,
    /// Incremented whenever some ray's limit shrinks.
    found: u32,
}

impl Packet<'_> {
    /// Ray `i`'s best hit as `BestHit` keeps it (for the single-ray code).
    fn best_hit(&self, i: usize) -> BestHit {
        // Before a hit here the ray ends at its limit: its tmax, or, under the two levels,
        // just past its best hit in the BLASes walked before this one.
        let mut b = BestHit::new(&Ray {
            tmax: self.best.limit[i],
            ..self.rays[i]
        });
        if self.best.found >> i & 1 == 1 {
            let h = TriangleHit {
                t: self.best.t[i],
                u: self.best.u[i],
                v: self.best.v[i],
            };
            b.offer(h, self.best.triangle[i]);
        }
        b
    }

    /// Takes ray `i`'s best hit back from the single-ray code.
    fn set_best_hit(&mut self, i: usize, b: &BestHit) {
        let had = self.best.found >> i & 1 == 1;
        if let Some(h) = b.hit()
            && (!had || h.t != self.best.t[i] || h.triangle != u64::from(self.best.triangle[i]))
        {
            let best = &mut self.best;
            (best.t[i], best.limit[i], best.u[i], best.v[i]) = (b.t, b.limit, h.u, h.v);
            best.triangle[i] = h.triangle as u32;
            best.found |= 1 << i;
            self.improved(1 << i);
        }
    }

    /// The rays of `mask` found closer hits: their box-test limits shrink.
    #[inline(always)]
    fn improved(&mut self, mask: u64) {
        for i in each_ray(mask) {
            self.soa.tmax[i] = self.best.t[i] * T_SCALE;
        }
        if mask != 0 {
            self.found += 1;
        }
    }
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The closest hit of each ray of `rays` (at most `PACKET_RAYS`).
    #[inline(always)]
    pub(super) fn trace_packet<K: PacketKernels<W>, I: Intersector>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
    ) {
        let n = rays.len().min(PACKET_RAYS).min(out.len());
        if n == 0 {
            return;
        }
        let rays = &rays[..n];
        // SAFETY: a tree only selects a kernel its CPU supports (`set_simd`), and the entry
        // points are compiled for it.
        // Bound where they are made: a packet is 3 KiB, and returning the pair from a block
        // copied it.
        let mut soa = unsafe { RayPacket::load::<K>(rays, T_SCALE) };
        // The watertight test has a form that tests one triangle against many rays.
        // SAFETY: as above.
        let shear = I::PACKET_TEST.then(|| unsafe { PacketShear::new::<K>(&soa) });
        // Rays from one origin into one octant: the interval test culls children first.
        let interval = WideInterval::of_packet(&soa);
        let mut p = Packet {
            rays,
            shear: shear.as_ref(),
            best: PacketBest::new(&soa),
            soa: &mut soa,
            hits: PacketHits::default(),
            found: 0,
        };
        let root = Pending::root(p.soa.rays);
        // SAFETY: as above.
        unsafe { self.walk::<K, I>(root, &mut p, interval.as_ref()) };
        let best = &p.best;
        for (i, o) in out[..n].iter_mut().enumerate() {
            *o = (best.found >> i & 1 == 1).then(|| Hit {
                t: best.t[i],
                u: best.u[i],
                v: best.v[i],
                triangle: best.triangle[i].into(),
            });
        }
    }

    /// The closest hits in subtree `start` of the packet rays of `mask`, rays already in
    /// this tree's space (under the two levels, an identity instance's BLAS), each searched
    /// up to its own `limit` (exclusive, as `BestHit::limit`). The rays' box-test limits in
    /// `soa` shrink with the hits found. Returns the hits found here, numbered as in this
    /// tree; `found` marks the rays that have one.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn closest_packet_from<K: PacketKernels<W>, I: Intersector>(
        &self,
        start: Subtree,
        mask: u64,
        rays: &[Ray],
        soa: &mut RayPacket,
        shear: Option<&PacketShear>,
        interval: Option<&WideInterval>,
        limit: &[f32; PACKET_RAYS],
    ) -> PacketBest {
        let mut p = Packet {
            rays,
            shear,
            best: PacketBest {
                t: *limit,
                limit: *limit,
                ..PacketBest::new(soa)
            },
            soa,
            hits: PacketHits::default(),
            found: 0,
        };
        let start = Pending {
            child: Entry {
                child: start,
                entry: f32::NEG_INFINITY,
            },
            ..Pending::root(mask)
        };
        // SAFETY: the caller guarantees K's instruction set.
        unsafe { self.walk::<K, I>(start, &mut p, interval) };
        p.best
    }

    /// The packet's walk from `start` until no child is left that a ray enters before its
    /// best hit.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    unsafe fn walk<K: PacketKernels<W>, I: Intersector>(
        &self,
        start: Pending,
        p: &mut Packet<'_>,
        interval: Option<&WideInterval>,
    ) {
        let rays = p.rays;
        // The largest box-test limit of the packet, and the hit count it was taken at.
        let (mut packet_tmax, mut tmax_found) = (f32::INFINITY, u32::MAX);
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::<Pending>::new(&mut storage);
        let mut cur = start;
        'walk: loop {
            if cur.rays.count_ones() <= HYBRID_RAYS {
                for i in each_ray(cur.rays) {
                    let ray = &rays[i];
                    let mut best = p.best_hit(i);
                    self.closest_from::<K, I, NoStats, true>(
                        cur.child,
                        &WideRay::new(ray),
                        &I::prepare(ray),
                        ray,
                        &mut best,
                        &mut NoStats,
                    );
                    p.set_best_hit(i, &best);
                }
            } else if !cur.child.child.is_leaf() {
                let index = cur.child.child.node_index();
                let node = &self.nodes[index];
                let cull = interval.map(|iv| {
                    if tmax_found != p.found {
                        packet_tmax = p.soa.largest_tmax();
                        tmax_found = p.found;
                    }
                    (iv, packet_tmax)
                });
                // SAFETY: a tree only selects a kernel its CPU supports (`set_simd`), and the
                // entry points are compiled for it.
                let nearest = unsafe {
                    enter_children::<K, W>(node, index, p.soa, cur.rays, cull, p.found, &mut stack)
                };
                if let Some(nearest) = nearest {
                    cur = nearest;
                    continue 'walk;
                }
            } else {
                let leaf = Leaf::of(cur.child.child);
                if p.shear.is_some() {
                    // SAFETY: as above.
                    unsafe { self.leaf_packet::<K, I>(leaf, cur.rays, p) };
                } else {
                    for i in each_ray(cur.rays) {
                        let ray = &rays[i];
                        let mut best = p.best_hit(i);
                        // SAFETY: as above.
                        unsafe {
                            self.leaf_closest::<K, I, _>(
                                leaf,
                                &I::prepare(ray),
                                ray,
                                &mut best,
                                &mut NoStats,
                            )
                        };
                        p.set_best_hit(i, &best);
                    }
                }
            }
            // The next child some ray still enters before its best hit.
            // SAFETY: as above.
            match unsafe { next_pending::<K, W>(&self.nodes, p.soa, interval, p.found, &mut stack) }
            {
                Some(next) => cur = next,
                None => break 'walk,
            }
        }
    }

    /// A leaf's triangles, each tested against the rays of `rays` at once (a call per
    /// shear permutation among them).
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    unsafe fn leaf_packet<K: PacketTriangleKernel, I: Intersector>(
        &self,
        leaf: Leaf,
        rays: u64,
        p: &mut Packet<'_>,
    ) {
        let Some(shear) = p.shear else { return };
        let mut improved = 0;
        for (b, used) in leaf.blocks() {
            let block = &self.blocks[b];
            let mut lanes = used;
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let tri: TriangleVertices =
                    std::array::from_fn(|k| std::array::from_fn(|axis| block.v[k][axis][lane]));
                let index = self.prim_indices[b * BLOCK + lane];
                for kz in 0..3 {
                    let active = rays & shear.by_axis[kz];
                    if active == 0 {
                        continue;
                    }
                    // SAFETY: the caller guarantees K's instruction set.
                    improved |= unsafe {
                        K::closest_packet(
                            &tri,
                            index,
                            kz,
                            shear,
                            p.soa,
                            &mut p.best,
                            active,
                            &mut p.hits,
                        )
                    };
                    // Ties and lanes handed back, one ray at a time.
                    let h = &p.hits;
                    for i in each_ray(h.rest) {
                        let ray = &p.rays[i];
                        let hit = if h.retest >> i & 1 == 1 {
                            let tri = block.triangle(lane);
                            I::intersect(&I::prepare(ray), ray, &tri, ray.tmin, p.best.limit[i])
                        } else {
                            Some(TriangleHit {
                                t: h.t[i],
                                u: h.u[i],
                                v: h.v[i],
                            })
                        };
                        if let Some(hit) = hit
                            && p.best.offer(i, hit.t, hit.u, hit.v, index)
                        {
                            improved |= 1 << i;
                        }
                    }
                }
            }
        }
        p.improved(improved);
    }
}
