//! A wide leaf: its triangles in blocks of four stored as structures of arrays
//! (`TriangleBlock`), tested a block at a time by one SIMD triangle test; lanes of a block
//! that belong to other leaves are masked off.
//!
//! The answer is the scalar test's, triangle by triangle: the block test's hits are checked
//! against the best hit as it shrinks, lane by lane in leaf order, and a lane the block test
//! hands back (`retest`) is tested by the scalar test with the best hit of that moment.

use super::node::{Subtree, WideNode};
use super::{Lanes, NodeWidth, WideBvh};
use crate::accel::replay::Step;
use crate::accel::stats::record;
use crate::accel::{BestHit, Stats};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::simd::{BLOCK, BlockHits, SimdLevel, TriangleBlock, TriangleKernel, prefetch};
use crate::geometry::{Intersector, Ray, Triangle};

/// The index of a padding lane (a lane of no leaf, NaN).
pub const PADDING: u32 = u32::MAX;

/// A leaf: its first slot (slot = block · 4 + lane) and its triangle count; its slots are
/// contiguous and span no more blocks than its count needs.
#[derive(Clone, Copy)]
pub(super) struct Leaf {
    pub first: u32,
    pub count: u32,
}

impl Leaf {
    /// The leaf a lane's word names (a leaf's word).
    #[inline(always)]
    pub(super) fn of(child: Subtree) -> Leaf {
        Leaf {
            first: child.leaf_first(),
            count: child.leaf_count(),
        }
    }

    /// The leaf's blocks, each with the mask of the lanes holding its triangles: all four
    /// but in the first block (lanes from `first` on) and the last (lanes before the end).
    #[inline(always)]
    pub(super) fn blocks(self) -> impl Iterator<Item = (usize, u32)> {
        const ALL: u32 = (1 << BLOCK) - 1;
        let first = self.first as usize;
        let end = first + self.count as usize;
        let (first_block, end_block) = (first / BLOCK, end.div_ceil(BLOCK));
        let head = ALL << (first % BLOCK) & ALL;
        let tail = ALL >> ((BLOCK - end % BLOCK) % BLOCK);
        (first_block..end_block).map(move |b| {
            let head = if b == first_block { head } else { ALL };
            let tail = if b + 1 == end_block { tail } else { ALL };
            (b, head & tail)
        })
    }

    /// The block and lanes of a leaf that lies in one block (a leaf of four triangles or
    /// fewer, the commonest): the leaf test then needs no loop over blocks.
    #[inline(always)]
    pub(super) fn single_block(self) -> Option<(usize, u32)> {
        let lane = self.first as usize % BLOCK;
        (lane + self.count as usize <= BLOCK)
            .then(|| (self.first as usize / BLOCK, ((1 << self.count) - 1) << lane))
    }

    /// Whether the slots span exactly the blocks the count needs.
    pub fn is_compact(self) -> bool {
        let (first, end) = (self.first as usize, (self.first + self.count) as usize);
        end.div_ceil(BLOCK) - first / BLOCK == (self.count as usize).div_ceil(BLOCK)
    }
}

/// Lays leaves out in blocks so that blocks fill up: a leaf of at most four triangles goes
/// into the block with the fewest free lanes that still holds it (best fit), a larger one
/// into new blocks, whose last free lanes are then open to small leaves. Every leaf spans
/// as few blocks as its count needs, so a ray tests no more blocks than with padded leaves.
#[derive(Default)]
pub(super) struct BlockPacker {
    /// `open[f]`: blocks whose last f lanes are free.
    open: [Vec<usize>; BLOCK],
}

impl BlockPacker {
    /// Places a leaf's triangles (with their scene indices); returns its first slot.
    pub fn place(
        &mut self,
        blocks: &mut Vec<TriangleBlock>,
        indices: &mut Vec<u32>,
        tris: &[(Triangle, u32)],
    ) -> u32 {
        let mut end = blocks.len();
        let first = self.reserve(tris.len(), &mut end);
        blocks.resize(end, TriangleBlock::EMPTY);
        indices.resize(end * BLOCK, PADDING);
        for (k, (tri, index)) in tris.iter().enumerate() {
            let slot = first + k;
            blocks[slot / BLOCK].set(slot % BLOCK, tri);
            indices[slot] = *index;
        }
        first as u32
    }

    /// Where a leaf of `n` triangles goes, of blocks of which the first `end` are in use:
    /// its first slot, with `end` moved past the blocks it opens (to be filled with
    /// padding). What `place` does, without writing, so that a layout can be counted
    /// before it is written.
    pub fn reserve(&mut self, n: usize, end: &mut usize) -> usize {
        let fit = (n.max(1)..BLOCK)
            .filter(|_| n < BLOCK)
            .find_map(|f| self.open[f].pop().map(|b| (b, f)));
        match fit {
            Some((b, free)) => {
                if free > n {
                    self.open[free - n].push(b);
                }
                b * BLOCK + BLOCK - free
            }
            None => {
                let b = *end;
                let count = n.div_ceil(BLOCK);
                *end += count;
                let free = count * BLOCK - n;
                if free > 0 {
                    self.open[free].push(b + count - 1);
                }
                b * BLOCK
            }
        }
    }
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The leaf's triangles against the ray, keeping the best hit; whether one was found.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub(super) unsafe fn leaf_closest<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        leaf: Leaf,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) -> bool {
        if S::RECORDING {
            return self.leaf_recorded::<I, S>(leaf, data, ray, Some(best), stats);
        }
        // SAFETY (both calls): the caller guarantees K's instruction set.
        if let Some((b, used)) = leaf.single_block() {
            return unsafe { self.block_closest::<K, I, S>(b, used, data, ray, best, stats) };
        }
        unsafe { self.leaf_closest_blocks_called::<K, I, S>(leaf, data, ray, best, stats) }
    }

    /// `leaf_closest` of a leaf over several blocks, block by block.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    unsafe fn leaf_closest_blocks<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        leaf: Leaf,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) -> bool {
        let mut found = false;
        for (b, used) in leaf.blocks() {
            // SAFETY: the caller guarantees K's instruction set.
            found |= unsafe { self.block_closest::<K, I, S>(b, used, data, ray, best, stats) };
        }
        found
    }

    /// The lanes `used` of block `b` against the ray, keeping the best hit; whether one was
    /// found.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    unsafe fn block_closest<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        b: usize,
        used: u32,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) -> bool {
        let block = &self.blocks[b];
        for _ in 0..used.count_ones() {
            stats.triangle_test();
        }
        // SAFETY: the caller guarantees K's instruction set.
        let h = unsafe { I::intersect_block::<K>(data, ray, block, ray.tmin, best.limit) };
        if h.retest & used != 0 {
            return self.lanes_closest::<I>(&h, b, used, data, ray, best);
        }
        // Only the block test's hits: no call, so the leaf's entry saves fewer registers.
        let mut lanes = h.hit & used;
        let mut found = false;
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if h.t[lane] < best.limit {
                let hit = TriangleHit {
                    t: h.t[lane],
                    u: h.u[lane],
                    v: h.v[lane],
                };
                best.offer(hit, self.prim_indices[b * BLOCK + lane]);
                found = true;
            }
        }
        found
    }

    /// The hit and handed-back lanes `used` of block `b` in lane order, keeping the best
    /// hit; whether one was found. Rare (a lane on an edge or close to the origin), and out
    /// of line: its scalar test is a call, which would make every leaf call save registers.
    #[cold]
    #[inline(never)]
    fn lanes_closest<I: Intersector>(
        &self,
        h: &BlockHits,
        b: usize,
        used: u32,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
    ) -> bool {
        let block = &self.blocks[b];
        let mut lanes = (h.hit | h.retest) & used;
        let mut found = false;
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if let Some(hit) = lane_hit::<I>(h, block, lane, data, ray, best.limit) {
                best.offer(hit, self.prim_indices[b * BLOCK + lane]);
                found = true;
            }
        }
        found
    }

    /// Whether the ray hits any of the leaf's triangles within (tmin, tmax).
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub(super) unsafe fn leaf_any<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        leaf: Leaf,
        data: &I::RayData,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        if S::RECORDING {
            return self.leaf_recorded::<I, S>(leaf, data, ray, None, stats);
        }
        // SAFETY (both calls): the caller guarantees K's instruction set.
        if let Some((b, used)) = leaf.single_block() {
            return unsafe { self.block_any::<K, I, S>(b, used, data, ray, stats) };
        }
        leaf.blocks()
            .any(|(b, used)| unsafe { self.block_any::<K, I, S>(b, used, data, ray, stats) })
    }

    /// Whether the ray hits any of the lanes `used` of block `b` within (tmin, tmax).
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub(super) unsafe fn block_any<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        b: usize,
        used: u32,
        data: &I::RayData,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        let block = &self.blocks[b];
        for _ in 0..used.count_ones() {
            stats.triangle_test();
        }
        // SAFETY: the caller guarantees K's instruction set.
        let h = unsafe { I::intersect_block::<K>(data, ray, block, ray.tmin, ray.tmax) };
        if h.hit & used != 0 {
            return true;
        }
        let mut lanes = h.retest & used;
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let hit = if I::BLOCK_TEST {
                retest::<I>(block, lane, data, ray, ray.tmax)
            } else {
                I::intersect(data, ray, &block.triangle(lane), ray.tmin, ray.tmax)
            };
            if hit.is_some() {
                return true;
            }
        }
        false
    }
}

/// The leaf tests compiled for each instruction set and kept out of the traversal loop:
/// the block test needs most vector registers, and inlined it pushed the ray's slab
/// constants out of theirs at every node; called, it leaves the node loop small.
macro_rules! leaf_entry_points {
    ($closest:ident, $blocks:ident, $any:ident, $kernel:ty, $features:literal) => {
        impl<const W: usize> WideBvh<W>
        where
            Lanes<W>: NodeWidth,
        {
            /// Takes the leaf's word, not the leaf: one argument fewer, so that all are
            /// passed in registers.
            #[target_feature(enable = $features)]
            #[inline(never)]
            fn $closest<I: Intersector, S: Stats>(
                &self,
                child: Subtree,
                data: &I::RayData,
                ray: &Ray,
                best: &mut BestHit,
                stats: &mut S,
            ) -> bool {
                let leaf = Leaf::of(child);
                // SAFETY: this function is compiled for the kernel's instruction set.
                unsafe { self.leaf_closest::<$kernel, I, S>(leaf, data, ray, best, stats) }
            }

            /// A leaf over several blocks, kept out of the one-block leaf's entry point (the
            /// commonest leaf), which then saves fewer registers at every call.
            #[target_feature(enable = $features)]
            #[inline(never)]
            fn $blocks<I: Intersector, S: Stats>(
                &self,
                leaf: Leaf,
                data: &I::RayData,
                ray: &Ray,
                best: &mut BestHit,
                stats: &mut S,
            ) -> bool {
                // SAFETY: as above.
                unsafe { self.leaf_closest_blocks::<$kernel, I, S>(leaf, data, ray, best, stats) }
            }

            #[target_feature(enable = $features)]
            #[inline(never)]
            fn $any<I: Intersector, S: Stats>(
                &self,
                leaf: Leaf,
                data: &I::RayData,
                ray: &Ray,
                stats: &mut S,
            ) -> bool {
                // SAFETY: as above.
                unsafe { self.leaf_any::<$kernel, I, S>(leaf, data, ray, stats) }
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
leaf_entry_points!(
    leaf_closest_sse41,
    leaf_closest_blocks_sse41,
    leaf_any_sse41,
    crate::geometry::simd::slab::Sse41,
    "sse4.1"
);
#[cfg(target_arch = "x86_64")]
leaf_entry_points!(
    leaf_closest_avx2,
    leaf_closest_blocks_avx2,
    leaf_any_avx2,
    crate::geometry::simd::slab::Avx2,
    "avx2,popcnt,bmi1,lzcnt"
);
#[cfg(target_arch = "x86_64")]
leaf_entry_points!(
    leaf_closest_avx512,
    leaf_closest_blocks_avx512,
    leaf_any_avx512,
    crate::geometry::simd::slab::Avx512,
    "avx512f,avx512vl,popcnt,bmi1,lzcnt"
);

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// `leaf_closest` through the out-of-line copy compiled for K's instruction set (the
    /// match is decided when the traversal is compiled).
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub(super) unsafe fn leaf_closest_called<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        child: Subtree,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) -> bool {
        // SAFETY: the caller guarantees K's instruction set, which each arm's copy is
        // compiled for.
        unsafe {
            match K::LEVEL {
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Sse41 => self.leaf_closest_sse41::<I, S>(child, data, ray, best, stats),
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx2 => self.leaf_closest_avx2::<I, S>(child, data, ray, best, stats),
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx512 => {
                    self.leaf_closest_avx512::<I, S>(child, data, ray, best, stats)
                }
                _ => self.leaf_closest::<K, I, S>(Leaf::of(child), data, ray, best, stats),
            }
        }
    }

    /// `leaf_closest_blocks` through the out-of-line copy compiled for K's instruction set.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    unsafe fn leaf_closest_blocks_called<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        leaf: Leaf,
        data: &I::RayData,
        ray: &Ray,
        best: &mut BestHit,
        stats: &mut S,
    ) -> bool {
        // SAFETY: as in `leaf_closest_called`.
        unsafe {
            match K::LEVEL {
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Sse41 => {
                    self.leaf_closest_blocks_sse41::<I, S>(leaf, data, ray, best, stats)
                }
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx2 => {
                    self.leaf_closest_blocks_avx2::<I, S>(leaf, data, ray, best, stats)
                }
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx512 => {
                    self.leaf_closest_blocks_avx512::<I, S>(leaf, data, ray, best, stats)
                }
                _ => self.leaf_closest_blocks::<K, I, S>(leaf, data, ray, best, stats),
            }
        }
    }

    /// `leaf_any` through the out-of-line copy compiled for K's instruction set.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub(super) unsafe fn leaf_any_called<K: TriangleKernel, I: Intersector, S: Stats>(
        &self,
        leaf: Leaf,
        data: &I::RayData,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        // SAFETY: as in `leaf_closest_called`.
        unsafe {
            match K::LEVEL {
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Sse41 => self.leaf_any_sse41::<I, S>(leaf, data, ray, stats),
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx2 => self.leaf_any_avx2::<I, S>(leaf, data, ray, stats),
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx512 => self.leaf_any_avx512::<I, S>(leaf, data, ray, stats),
                _ => self.leaf_any::<K, I, S>(leaf, data, ray, stats),
            }
        }
    }

    /// Starts loading a child before it is visited: a leaf's first block of triangles, or an
    /// interior node's lines. A walk calls it for the children it pushes, so their data
    /// arrives while their siblings are visited; the two levels call it for the subtree a
    /// ray enters, while the ray is carried into the instance's space. Prefetching interior
    /// children gains nothing while a tree fits the L2 (sponza), but a ray through the
    /// island's BLASes meets cold nodes all the way down (docs/two-level.md, "Interior
    /// children prefetched").
    #[inline(always)]
    pub(crate) fn prefetch_child(&self, child: Subtree) {
        const LINE: usize = 64;
        if child.is_leaf() {
            // A block (144 bytes, 16-byte aligned) touches at most three lines: those of its
            // first byte, of the byte a line further and of its last byte.
            let p = self
                .blocks
                .as_ptr()
                .wrapping_add(child.index() as usize / BLOCK);
            let p = p.cast::<u8>();
            prefetch(p);
            prefetch(p.wrapping_add(LINE));
            prefetch(p.wrapping_add(std::mem::size_of::<TriangleBlock>() - 1));
        } else {
            // A node's rows start anywhere in a line: every line from its first byte's, and
            // its last byte's.
            let size = std::mem::size_of::<WideNode<W>>();
            let p = self
                .nodes
                .as_ptr()
                .cast::<[f32; W]>()
                .wrapping_add(child.node_row())
                .cast::<u8>();
            for line in 0..size.div_ceil(LINE) {
                prefetch(p.wrapping_add(line * LINE));
            }
            prefetch(p.wrapping_add(size - 1));
        }
    }
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// A replay's leaf: each used lane by the scalar test (whose hits the block test equals
    /// bit for bit), in lane order, one recorded step each. Closest hit with `best`, any
    /// hit (stopping after the block that hits, as the block test does) without.
    fn leaf_recorded<I: Intersector, S: Stats>(
        &self,
        leaf: Leaf,
        data: &I::RayData,
        ray: &Ray,
        mut best: Option<&mut BestHit>,
        stats: &mut S,
    ) -> bool {
        let mut found = false;
        for (b, used) in leaf.blocks() {
            let block = &self.blocks[b];
            let mut lanes = used;
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let index = self.prim_indices[b * BLOCK + lane];
                let limit = best.as_ref().map_or(ray.tmax, |b| b.limit);
                stats.triangle_test();
                let hit = I::intersect(data, ray, &block.triangle(lane), ray.tmin, limit);
                record(stats, || Step::Triangle {
                    triangle: index.into(),
                    t: hit.map(|h| h.t),
                });
                if let Some(h) = hit {
                    found = true;
                    if let Some(best) = best.as_mut() {
                        best.offer(h, index);
                    }
                }
            }
            if found && best.is_none() {
                return true;
            }
        }
        found
    }
}

/// The hit of one lane below `limit`: the block test's, or the scalar test's for a lane
/// handed back. A block hit depends on the limit only through t < limit, so checking it
/// against the limit of this moment gives what the scalar test would.
#[inline(always)]
fn lane_hit<I: Intersector>(
    h: &BlockHits,
    block: &TriangleBlock,
    lane: usize,
    data: &I::RayData,
    ray: &Ray,
    limit: f32,
) -> Option<TriangleHit> {
    if h.retest >> lane & 1 == 1 {
        return if I::BLOCK_TEST {
            retest::<I>(block, lane, data, ray, limit)
        } else {
            I::intersect(data, ray, &block.triangle(lane), ray.tmin, limit)
        };
    }
    (h.t[lane] < limit).then(|| TriangleHit {
        t: h.t[lane],
        u: h.u[lane],
        v: h.v[lane],
    })
}

/// The scalar test of a lane a block test hands back: rare, and kept out of line so that
/// its registers do not crowd the block test's.
#[cold]
#[inline(never)]
fn retest<I: Intersector>(
    block: &TriangleBlock,
    lane: usize,
    data: &I::RayData,
    ray: &Ray,
    limit: f32,
) -> Option<TriangleHit> {
    I::intersect(data, ray, &block.triangle(lane), ray.tmin, limit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each block's mask as the slots say: the lanes of that block between first and end.
    fn by_slots(leaf: Leaf) -> Vec<(usize, u32)> {
        let (first, end) = (leaf.first as usize, (leaf.first + leaf.count) as usize);
        (first / BLOCK..end.div_ceil(BLOCK))
            .map(|b| {
                let lanes = (0..BLOCK).filter(|&l| (first..end).contains(&(b * BLOCK + l)));
                (b, lanes.fold(0, |m, l| m | 1 << l))
            })
            .collect()
    }

    #[test]
    fn block_masks_hold_exactly_the_leafs_slots() {
        for first in 0..12 {
            for count in 0..20 {
                let leaf = Leaf { first, count };
                assert_eq!(
                    leaf.blocks().collect::<Vec<_>>(),
                    by_slots(leaf),
                    "first {first}, count {count}"
                );
                // A leaf in one block is that block's lanes (none for an empty leaf).
                match leaf.single_block() {
                    Some((b, used)) if used != 0 => {
                        assert_eq!(
                            by_slots(leaf),
                            vec![(b, used)],
                            "first {first}, count {count}"
                        )
                    }
                    Some(_) => assert_eq!(count, 0),
                    None => assert!(by_slots(leaf).len() > 1, "first {first}, count {count}"),
                }
            }
        }
    }
}
