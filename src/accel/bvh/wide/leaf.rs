//! A wide leaf: its triangles in blocks of four stored as structures of arrays
//! (`TriangleBlock`), tested a block at a time by one SIMD triangle test. A leaf starts a
//! block of its own; the lanes past its last triangle are padding (NaN, index `PADDING`).
//!
//! The answer is the scalar test's, triangle by triangle: the block test's hits are checked
//! against the best hit as it shrinks, lane by lane in leaf order, and a lane the block test
//! hands back (`retest`) is tested by the scalar test with the best hit of that moment.

use super::WideBvh;
use crate::accel::{BestHit, Stats};
use crate::geometry::intersect::TriangleHit;
use crate::geometry::simd::{BLOCK, TriangleBlock, TriangleKernel};
use crate::geometry::{Intersector, Ray};

/// The index of a padding lane.
pub const PADDING: u32 = u32::MAX;

/// The lanes a leaf of `count` triangles occupies: whole blocks.
pub fn leaf_lanes(count: u32) -> u32 {
    count.div_ceil(BLOCK as u32) * BLOCK as u32
}

/// A leaf: its first slot (a block boundary) and its triangle count.
#[derive(Clone, Copy)]
pub(super) struct Leaf {
    pub first: u32,
    pub count: u32,
}

impl Leaf {
    /// The leaf's blocks, each with the mask of the lanes holding its triangles.
    #[inline(always)]
    fn blocks(self) -> impl Iterator<Item = (usize, u32)> {
        let first = self.first as usize / BLOCK;
        let end = self.first as usize + self.count as usize;
        (first..end.div_ceil(BLOCK)).map(move |b| {
            let used = (end - b * BLOCK).min(BLOCK);
            (b, (1u32 << used) - 1)
        })
    }
}

impl<const W: usize> WideBvh<W> {
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
        let mut found = false;
        for (b, used) in leaf.blocks() {
            let block = &self.blocks[b];
            for _ in 0..used.count_ones() {
                stats.triangle_test();
            }
            // SAFETY: the caller guarantees K's instruction set.
            let h = unsafe { I::intersect_block::<K>(data, ray, block, ray.tmin, best.limit) };
            let mut lanes = (h.hit | h.retest) & used;
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                if let Some(hit) = lane_hit::<I>(&h, block, lane, data, ray, best.limit) {
                    best.offer(hit, self.prim_indices[b * BLOCK + lane]);
                    found = true;
                }
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
        for (b, used) in leaf.blocks() {
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
                let tri = block.triangle(lane);
                if I::intersect(data, ray, &tri, ray.tmin, ray.tmax).is_some() {
                    return true;
                }
            }
        }
        false
    }
}

/// The hit of one lane below `limit`: the block test's, or the scalar test's for a lane
/// handed back. A block hit depends on the limit only through t < limit, so checking it
/// against the limit of this moment gives what the scalar test would.
#[inline(always)]
fn lane_hit<I: Intersector>(
    h: &crate::geometry::simd::BlockHits,
    block: &TriangleBlock,
    lane: usize,
    data: &I::RayData,
    ray: &Ray,
    limit: f32,
) -> Option<TriangleHit> {
    if h.retest >> lane & 1 == 1 {
        return I::intersect(data, ray, &block.triangle(lane), ray.tmin, limit);
    }
    (h.t[lane] < limit).then(|| TriangleHit {
        t: h.t[lane],
        u: h.u[lane],
        v: h.v[lane],
    })
}
