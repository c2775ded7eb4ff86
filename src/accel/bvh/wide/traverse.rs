//! Traversal of a wide BVH: at each node one SIMD slab test of all W children; the children
//! the ray enters are pushed farthest first, so the nearest is visited next (front to back),
//! and, as in the BVH2, a popped entry beyond the best hit so far is skipped.
//!
//! The traversal is written once, generic over the slab kernel; each SIMD level gets an
//! entry point compiled for its instruction set (`#[target_feature]`), into which the
//! generic code and the kernel are inlined. Counting: a wide node or a leaf popped is one
//! node visited, each child of a visited node one box test, and each triangle of a leaf's
//! blocks one triangle test (the block tests them at once; `leaf`).

use super::leaf::Leaf;
use super::order::{
    key, key_of_ordered, lane_of, nearest_first3, nearest_first4, nearest_first8, ordered,
};
use super::stack::{Entry, EntryRow, Stack};
use super::{Lanes, NodeWidth, Subtree, WideBvh, WideNode};
use crate::accel::bvh::packet::PACKET_SIZE;
use crate::accel::bvh::traverse::T_SCALE;
use crate::accel::replay::{Child, Level, Order, Step, Visited};
use crate::accel::stats::record;
use crate::accel::{Accel, BestHit, Hit, Stats, TraversalOrder};
use crate::geometry::simd::slab::{Avx2, Avx512, Portable, Sse41, WideSlab, slab_test};
use crate::geometry::simd::{IntervalSlab, SimdLevel, TriangleKernel, WideRay, prefetch_packet};
use crate::geometry::{Intersector, Ray};
use std::mem::MaybeUninit;

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    #[inline(always)]
    fn closest_with<
        K: WideSlab<W> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
    >(
        &self,
        start: Subtree,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        let wray = WideRay::new(ray);
        let data = I::prepare(ray);
        self.closest_prepared::<K, I, S, ORDERED>(start, ray, &wray, &data, stats)
    }

    /// The walk of `closest_with` with the ray's slab and intersector data made already
    /// (`wray`, `data`): from a ray of `ray`'s origin and direction, whatever its interval.
    /// The two levels walk an identity instance's BLAS with the world ray's.
    #[inline(always)]
    pub(crate) fn closest_prepared<
        K: WideSlab<W> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
    >(
        &self,
        start: Subtree,
        ray: &Ray,
        wray: &WideRay,
        data: &I::RayData,
        stats: &mut S,
    ) -> Option<Hit> {
        let mut best = BestHit::new(ray);
        let root = Entry {
            child: start,
            entry: ray.tmin,
        };
        self.closest_from::<K, I, S, ORDERED>(root, wray, data, ray, &mut best, stats);
        best.hit()
    }

    /// The closest hit in the subtree `start` (the root, or a child a packet hands over to
    /// one of its rays), kept in `best`, which may already hold a hit. A kernel with a fused
    /// slab form walks with it when the ray's fused constants are usable (`FusedPlanes`).
    #[inline(always)]
    pub(super) fn closest_from<
        K: WideSlab<W> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
    >(
        &self,
        start: Entry,
        wray: &WideRay,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) {
        let args = (start, wray, data, ray);
        match K::FUSED && wray.fused_usable() {
            true => self.closest_walk::<K, I, S, ORDERED, true>(args, best, stats),
            false => self.closest_walk::<K, I, S, ORDERED, false>(args, best, stats),
        }
    }

    #[inline(always)]
    fn closest_walk<
        K: WideSlab<W> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const ORDERED: bool,
        const FUSED: bool,
    >(
        &self,
        (start, wray, data, ray): (Entry, &WideRay, &I::RayData, &Ray),
        best: &mut BestHit,
        stats: &mut S,
    ) {
        let mut box_tmax = best.t * T_SCALE;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::new(&mut storage);
        let mut row = EntryRow([0.0; W]);
        let entry = &mut row.0;
        let mut cur = start;
        loop {
            stats.node_visit();
            record(stats, || self.visit_step(cur));
            if cur.child.is_leaf() {
                // SAFETY: a tree only selects a kernel its CPU supports (`set_simd`), and
                // the entry points below are compiled for it.
                if unsafe { self.leaf_closest_called::<K, I, S>(cur.child, data, ray, best, stats) }
                {
                    box_tmax = best.t * T_SCALE;
                }
            } else {
                let node = WideNode::of_row(&self.nodes, cur.child);
                if S::COUNTING {
                    stats.box_tests(node.child_count() as u32);
                }
                // SAFETY: a tree only selects a kernel its CPU supports (`set_simd`), and
                // the entry points below are compiled for it.
                let mut mask = unsafe {
                    slab_test::<W, K, FUSED>(&node.bounds, wray, ray.tmin, box_tmax, entry)
                };
                let order = if ORDERED {
                    Order::Nearest
                } else {
                    Order::Fixed
                };
                record(stats, || self.children_step(cur.child, mask, entry, order));
                if mask != 0 {
                    // Lanes are below W, a power of two: `% W` spares the bounds checks.
                    let lane = |i: u32| Entry {
                        child: node.child[i as usize % W],
                        entry: entry[i as usize % W],
                    };
                    if mask & (mask - 1) == 0 {
                        cur = lane(mask.trailing_zeros());
                        continue;
                    }
                    let second = mask & (mask - 1);
                    let third = second & (second - 1);
                    if ORDERED && third == 0 {
                        // Two children, the commonest case: one compare, no sort.
                        let a = lane(mask.trailing_zeros());
                        let b = lane(second.trailing_zeros());
                        let (near, far) = if b.entry < a.entry { (b, a) } else { (a, b) };
                        record(stats, || push_step(far));
                        self.prefetch_entry(far);
                        stack.push(far);
                        cur = near;
                        continue;
                    }
                    if ORDERED && !S::RECORDING {
                        // Three to W children: ordered by their keys in registers, pushed
                        // farthest first (a replay records the pushes and the sort on the
                        // stack).
                        // Every lane's distance bits at once (the loop is vectorised).
                        let bits: [u32; W] = std::array::from_fn(|i| ordered(entry[i]));
                        let key_of = |m: u32| {
                            let i = m.trailing_zeros();
                            key_of_ordered(bits[i as usize % W], i)
                        };
                        let mut push = |k: u64| {
                            let e = lane(lane_of::<W>(k) as u32);
                            self.prefetch_entry(e);
                            stack.push(e);
                        };
                        let fourth = third & (third - 1);
                        let nearest = if fourth == 0 {
                            let [a, b, c] =
                                nearest_first3([key_of(mask), key_of(second), key_of(third)]);
                            push(c);
                            push(b);
                            a
                        } else if fourth & (fourth - 1) == 0 {
                            let [a, b, c, d] = nearest_first4([
                                key_of(mask),
                                key_of(second),
                                key_of(third),
                                key_of(fourth),
                            ]);
                            push(d);
                            push(c);
                            push(b);
                            a
                        } else {
                            // Five to eight: ordered out of line, pushed here, so that the
                            // stack never leaves this function and its length stays in a
                            // register (passed to a call, it lived in memory, and every
                            // pop waited for the store of the push before it).
                            let sorted = nearest_first_many::<W>(mask, entry);
                            let n = (mask.count_ones() as usize).min(8);
                            for &k in sorted[1..n].iter().rev() {
                                push(k);
                            }
                            sorted[0]
                        };
                        cur = lane(lane_of::<W>(nearest) as u32);
                        continue;
                    }
                    if ORDERED {
                        let mut n = 0;
                        while mask != 0 {
                            record(stats, || push_step(lane(mask.trailing_zeros())));
                            self.prefetch_entry(lane(mask.trailing_zeros()));
                            stack.push(lane(mask.trailing_zeros()));
                            mask &= mask - 1;
                            n += 1;
                        }
                        stack.sort_top(n);
                    } else {
                        // Naive order: the first child on top.
                        while mask != 0 {
                            let i = 31 - mask.leading_zeros();
                            record(stats, || push_step(lane(i)));
                            self.prefetch_entry(lane(i));
                            stack.push(lane(i));
                            mask &= !(1 << i);
                        }
                    }
                    if let Some(e) = stack.pop() {
                        record(stats, || pop_step(e));
                        cur = e;
                        continue;
                    }
                }
            }
            // Pop the next child the ray can still reach before the best hit.
            loop {
                match stack.pop() {
                    None => return,
                    Some(e) if e.entry <= box_tmax => {
                        record(stats, || pop_step(e));
                        cur = e;
                        break;
                    }
                    Some(e) => record(stats, || skip_step(e, best.t)),
                }
            }
        }
    }

    #[inline(always)]
    fn occluded_with<K: WideSlab<W> + TriangleKernel, I: Intersector, S: Stats>(
        &self,
        start: Subtree,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        let wray = WideRay::new(ray);
        let data = I::prepare(ray);
        self.occluded_prepared::<K, I, S>(start, ray, &wray, &data, stats)
    }

    /// The walk of `occluded_with` with the ray's data made already (see
    /// `closest_prepared`).
    #[inline(always)]
    pub(crate) fn occluded_prepared<K: WideSlab<W> + TriangleKernel, I: Intersector, S: Stats>(
        &self,
        start: Subtree,
        ray: &Ray,
        wray: &WideRay,
        data: &I::RayData,
        stats: &mut S,
    ) -> bool {
        let args = (start, ray, wray, data);
        match K::FUSED && wray.fused_usable() {
            true => self.occluded_walk::<K, I, S, true>(args, stats),
            false => self.occluded_walk::<K, I, S, false>(args, stats),
        }
    }

    #[inline(always)]
    fn occluded_walk<
        K: WideSlab<W> + TriangleKernel,
        I: Intersector,
        S: Stats,
        const FUSED: bool,
    >(
        &self,
        (start, ray, wray, data): (Subtree, &Ray, &WideRay, &I::RayData),
        stats: &mut S,
    ) -> bool {
        let mut tmax = ray.tmax * T_SCALE;
        let mut storage = MaybeUninit::uninit();
        let mut stack = Stack::new(&mut storage);
        let mut row = EntryRow([0.0; W]);
        let entry = &mut row.0;
        let mut cur = Entry {
            child: start,
            entry: ray.tmin,
        };
        loop {
            // Down through interior nodes to a leaf, which is tested after this loop.
            while !cur.child.is_leaf() {
                stats.node_visit();
                record(stats, || self.visit_step(cur));
                let node = WideNode::of_row(&self.nodes, cur.child);
                if S::COUNTING {
                    stats.box_tests(node.child_count() as u32);
                }
                // SAFETY: as in `closest_with`.
                let mut mask =
                    unsafe { slab_test::<W, K, FUSED>(&node.bounds, wray, ray.tmin, tmax, entry) };
                record(stats, || {
                    self.children_step(cur.child, mask, entry, Order::AnyHit)
                });
                let lane = |i: usize| Entry {
                    child: node.child[i % W],
                    entry: entry[i % W],
                };
                if mask != 0 {
                    // The highest entered lane first, then the others from the highest down
                    // (pushed lowest first), as Embree's any-hit walk and the two levels'
                    // do: on the standard views' shadow rays this visits 3–7 % fewer nodes
                    // and up to a fifth fewer triangles than the lowest lane first, for the
                    // same instructions per node (docs/wide-bvh.md).
                    let last = (31 - mask.leading_zeros()) as usize;
                    mask &= !(1 << last);
                    while mask != 0 {
                        let e = lane(mask.trailing_zeros() as usize);
                        mask &= mask - 1;
                        record(stats, || push_step(e));
                        self.prefetch_entry(e);
                        stack.push(e);
                    }
                    cur = lane(last);
                    continue;
                }
                match stack.pop() {
                    None => return false,
                    Some(e) => {
                        record(stats, || pop_step(e));
                        cur = e;
                    }
                }
            }
            stats.node_visit();
            record(stats, || self.visit_step(cur));
            let leaf = Leaf::of(cur.child);
            // A leaf in one block is tested right here: in the any-hit walk that costs the
            // node loop one instruction of register pressure and saves the call's 26
            // (measured; the closest-hit walk, whose loop holds more, lost as much at its
            // nodes as it saved at its leaves, and calls). Larger leaves, and a replay's
            // leaves, are called.
            // SAFETY (both arms): as in `closest_with`.
            let hit = match leaf.single_block() {
                Some((b, used)) if !S::RECORDING => unsafe {
                    self.block_any::<K, I, S>(b, used, data, ray, stats)
                },
                _ => unsafe { self.leaf_any_called::<K, I, S>(leaf, data, ray, stats) },
            };
            if hit {
                return true;
            }
            // The interval's end passes through an opaque copy after each leaf, as the best
            // hit's does in the closest-hit walk: the compiler then keeps the node test's
            // constants in vector registers through the loop and reloads them after the
            // leaf's call, instead of reading them from the stack at every node (measured:
            // 49 instructions a node test before, 39 after).
            tmax = std::hint::black_box(tmax);
            match stack.pop() {
                None => return false,
                Some(e) => {
                    record(stats, || pop_step(e));
                    cur = e;
                }
            }
        }
    }
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// Prefetches a child as it is pushed, so its data arrives while its siblings are
    /// visited (a child visited at once gains little, and is not prefetched).
    #[inline(always)]
    fn prefetch_entry(&self, e: Entry) {
        self.prefetch_child(e.child);
    }
}

/// Five to eight entered children (`mask`): their keys ordered nearest first by the network
/// of eight, the missed lanes' `u64::MAX` after them. Out of line: the eight keys need more
/// registers than the loop can spare, which it would otherwise spill at every node, and the
/// case is rare.
#[inline(never)]
fn nearest_first_many<const W: usize>(mask: u32, entry: &[f32; W]) -> [u64; 8] {
    const { assert!(W <= 8) };
    // Every lane's key, `u64::MAX` (last) where the ray misses: the array then stays in
    // registers.
    let keys: [u64; 8] = std::array::from_fn(|i| {
        if i < W && mask >> i & 1 == 1 {
            key(entry[i % W], i as u32)
        } else {
            u64::MAX
        }
    });
    nearest_first8(keys)
}

// The steps of the walk, for a recording sink. A child is named by its node index, a leaf
// by its first triangle slot.
fn push_step(e: Entry) -> Step {
    Step::Push {
        node: e.child.index(),
        leaf: e.child.is_leaf(),
        entry: e.entry,
    }
}

fn pop_step(e: Entry) -> Step {
    Step::Pop {
        node: e.child.index(),
        leaf: e.child.is_leaf(),
        entry: Some(e.entry),
    }
}

fn skip_step(e: Entry, best: f32) -> Step {
    Step::Skip {
        node: e.child.index(),
        leaf: e.child.is_leaf(),
        entry: e.entry,
        best,
    }
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The box of a child to visit: the root's, or that of the lane that holds it.
    fn visit_step(&self, e: Entry) -> Step {
        self.visit_step_at(e.child, Level::Single)
    }

    /// The visit of the child `child` as the lanes name it, at `level` of a two-level
    /// structure.
    pub(crate) fn visit_step_at(&self, child: Subtree, level: Level) -> Step {
        let leaf = child.is_leaf();
        let bounds = if child == Subtree::ROOT {
            self.nodes[0].bounds()
        } else {
            let lanes = self.lanes.get_or_init(|| {
                let mut lanes = std::collections::HashMap::new();
                for (i, n) in self.nodes.iter().enumerate() {
                    for l in 0..n.child_count() {
                        lanes.entry(n.child[l]).or_insert((i as u32, l as u8));
                    }
                }
                std::sync::Arc::new(lanes)
            });
            lanes
                .get(&child)
                .map_or(crate::geometry::Aabb::EMPTY, |&(n, l)| {
                    self.nodes[n as usize].child_bounds(l as usize)
                })
        };
        let what = if leaf { Visited::Leaf } else { Visited::Node };
        Step::visit(child.index() as usize, what, level, bounds)
    }

    /// The children of node `parent` in lane order: where the ray enters those in `mask`.
    pub(crate) fn children_step(
        &self,
        parent: Subtree,
        mask: u32,
        entry: &[f32; W],
        order: Order,
    ) -> Step {
        let node = &self.nodes[parent.node_index()];
        let children: Vec<Child> = (0..node.child_count())
            .map(|l| Child {
                node: node.child[l].index(),
                leaf: !node.is_interior(l),
                entry: (mask >> l & 1 == 1).then_some(entry[l]),
                bounds: node.child_bounds(l),
            })
            .collect();
        // Front to back the nearest entered child is taken first (of equal ones, the lower
        // lane of two, the higher of more, as the sort leaves them); any hit takes the
        // highest lane first; naive order the lowest.
        let entered: Vec<(f32, u32)> = children
            .iter()
            .filter_map(|c| Some((c.entry?, c.node)))
            .collect();
        let nearest = |a: &&(f32, u32), b: &&(f32, u32)| a.0.total_cmp(&b.0);
        let first = match order {
            Order::Nearest if entered.len() > 2 => entered.iter().rev().min_by(nearest),
            Order::Nearest => entered.iter().min_by(nearest),
            Order::AnyHit => entered.last(),
            _ => entered.first(),
        }
        .map(|c| c.1);
        Step::Children {
            children,
            first,
            order,
        }
    }
}

/// Entry points compiled for each instruction set: the generic traversal and its kernel
/// are inlined into them, so the whole loop uses the set's instructions.
macro_rules! entry_points {
    ($closest:ident, $occluded:ident, $packets:ident, $kernel:ty, $features:literal) => {
        impl<const W: usize> WideBvh<W>
        where
            Lanes<W>: NodeWidth,
            $kernel: super::packet::PacketKernels<W>,
        {
            #[target_feature(enable = $features)]
            fn $closest<I: Intersector, S: Stats, const ORDERED: bool>(
                &self,
                start: Subtree,
                ray: &Ray,
                stats: &mut S,
            ) -> Option<Hit> {
                self.closest_with::<$kernel, I, S, ORDERED>(start, ray, stats)
            }

            #[target_feature(enable = $features)]
            fn $occluded<I: Intersector, S: Stats>(
                &self,
                start: Subtree,
                ray: &Ray,
                stats: &mut S,
            ) -> bool {
                self.occluded_with::<$kernel, I, S>(start, ray, stats)
            }

            #[target_feature(enable = $features)]
            fn $packets<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
                let packets = rays.chunks(PACKET_SIZE).zip(hits.chunks_mut(PACKET_SIZE));
                for (k, (packet, hits)) in packets.enumerate() {
                    prefetch_packet(rays.as_ptr().wrapping_add((k + 1) * PACKET_SIZE));
                    self.trace_packet::<$kernel, I>(packet, hits);
                }
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

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
    Portable: WideSlab<W> + IntervalSlab<W>,
    Sse41: WideSlab<W> + IntervalSlab<W>,
    Avx2: WideSlab<W> + IntervalSlab<W>,
    Avx512: WideSlab<W> + IntervalSlab<W>,
{
    #[inline(always)]
    fn closest_dispatch<I: Intersector, S: Stats, const ORDERED: bool>(
        &self,
        start: Subtree,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` only holds a level this CPU supports (`set_simd`).
            SimdLevel::Sse41 => unsafe { self.closest_sse41::<I, S, ORDERED>(start, ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx2 => unsafe { self.closest_avx2::<I, S, ORDERED>(start, ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.closest_avx512::<I, S, ORDERED>(start, ray, stats) },
            _ => self.closest_with::<Portable, I, S, ORDERED>(start, ray, stats),
        }
    }

    #[inline(always)]
    fn occluded_dispatch<I: Intersector, S: Stats>(
        &self,
        start: Subtree,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` only holds a level this CPU supports (`set_simd`).
            SimdLevel::Sse41 => unsafe { self.occluded_sse41::<I, S>(start, ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx2 => unsafe { self.occluded_avx2::<I, S>(start, ray, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.occluded_avx512::<I, S>(start, ray, stats) },
            _ => self.occluded_with::<Portable, I, S>(start, ray, stats),
        }
    }

    /// The closest hit of `ray` among the triangles of subtree `start` alone, walked from
    /// there as from a root: how the two levels walk a BLAS below a top-level reference.
    pub fn closest_hit_in<I: Intersector, S: Stats>(
        &self,
        start: Subtree,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        crate::accel::stats::count_locally(stats, |local| match self.order {
            TraversalOrder::FrontToBack => self.closest_dispatch::<I, S, true>(start, ray, local),
            TraversalOrder::Naive => self.closest_dispatch::<I, S, false>(start, ray, local),
        })
    }

    /// Whether `ray` hits a triangle of subtree `start`.
    pub fn any_hit_in<I: Intersector, S: Stats>(
        &self,
        start: Subtree,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        crate::accel::stats::count_locally(stats, |local| {
            self.occluded_dispatch::<I, S>(start, ray, local)
        })
    }
}

impl<const W: usize> Accel for WideBvh<W>
where
    Lanes<W>: NodeWidth,
    Portable: WideSlab<W> + IntervalSlab<W>,
    Sse41: WideSlab<W> + IntervalSlab<W>,
    Avx2: WideSlab<W> + IntervalSlab<W>,
    Avx512: WideSlab<W> + IntervalSlab<W>,
{
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        self.closest_hit_in::<I, S>(Subtree::ROOT, ray, stats)
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        self.any_hit_in::<I, S>(Subtree::ROOT, ray, stats)
    }

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
                for (rays, hits) in rays.chunks(PACKET_SIZE).zip(hits.chunks_mut(PACKET_SIZE)) {
                    self.trace_packet::<Portable, I>(rays, hits);
                }
            }
        }
    }
}
