//! Refit of a wide BVH after motion: the same topology, every child box recomputed bottom-up
//! (a leaf lane from its triangles, an interior lane from its node's children), so the app's
//! drag keeps the fastest tree instead of falling back to the BVH2.

use super::LaneSums;
use super::WideBvh;
use super::leaf::PADDING;
use super::node::{Lanes, NodeWidth, WideNode};
use crate::accel::bvh::refit::{RefitError, RefitIndex, RefitReport, slots_of};
#[cfg(target_arch = "x86_64")]
use crate::geometry::simd::SimdLevel;
use crate::geometry::simd::{BLOCK, TriangleBlock, prefetch};
use crate::geometry::{Aabb, Triangle};
use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;
use std::ops::Range;

/// Below this many triangles a refit runs on one thread (spawning costs more).
const PARALLEL_REFIT: usize = 1 << 15;

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The leaf lanes' boxes of `node`, from the triangle blocks.
    fn refit_leaves(node: &mut WideNode<W>, blocks: &[TriangleBlock]) {
        for lane in 0..node.child_count() {
            if !node.is_interior(lane) {
                let b = node.child[lane].slots().fold(Aabb::EMPTY, |b, slot| {
                    b.union(blocks[slot / BLOCK].triangle(slot % BLOCK).bounds())
                });
                node.set_child_bounds(lane, b);
            }
        }
    }

    /// The interior lanes' boxes of node `i`, from its children (which come after it).
    fn refit_interior(&mut self, i: usize) {
        let (head, tail) = self.nodes.split_at_mut(i + 1);
        let node = &mut head[i];
        for lane in 0..node.child_count() {
            if let Some(c) = node.interior(lane) {
                let child = c - (i + 1);
                node.set_child_bounds(lane, tail[child].bounds());
            }
        }
    }

    /// Takes the moved triangles (`scene` in scene order, the count the tree was built over)
    /// and updates every box, in two passes over each part the tree was laid out in. First
    /// the part's blocks, in slot order: each block's four triangles gathered (prefetched a
    /// few blocks ahead, since a leaf's triangles lie anywhere in scene order) and written
    /// whole. Then the part's nodes, children before parents: a leaf lane bounds its
    /// triangles from the blocks just written, still in the cache (one or two lane by lane,
    /// more four lanes at a time), and an interior lane takes its child's box. The nodes are
    /// swept from the last to the first (children come after their parents). The parts are
    /// parallel tasks; the top of the tree comes last.
    ///
    /// The SAH cost before and after is summed in the same pass (each lane's old box is
    /// read before it is overwritten); `refit_boxes` is the same refit without it.
    pub fn refit(
        &mut self,
        scene: &[Triangle],
        c_trav: f32,
        c_isect: f32,
    ) -> Result<RefitReport, RefitError> {
        let costs = Costs {
            trav: c_trav as f64,
            isect: c_isect as f64,
        };
        let root_before = self.nodes[0].bounds().surface_area() as f64;
        let sums = self.refit_with::<true>(scene, costs)?;
        let root_after = self.nodes[0].bounds().surface_area() as f64;
        let sah = |root: f64, lanes: f64| {
            if root <= 0.0 {
                costs.isect * self.triangle_count as f64
            } else {
                (costs.trav * root + lanes) / root
            }
        };
        Ok(RefitReport {
            sah_before: sah(root_before, sums.before),
            sah_after: sah(root_after, sums.after),
        })
    }

    /// `refit` without the SAH report: the same boxes and blocks, bit for bit, for a scene
    /// refitted every frame, which has no use for the cost (its two areas per lane and the
    /// sums are about a tenth of the refit's time, docs/wide-bvh.md).
    pub fn refit_boxes(&mut self, scene: &[Triangle]) -> Result<(), RefitError> {
        let costs = Costs {
            trav: 0.0,
            isect: 0.0,
        };
        self.refit_with::<false>(scene, costs).map(|_| ())
    }

    /// The refit of `refit` and `refit_boxes`; the sums of the whole tree when `REPORT`.
    fn refit_with<const REPORT: bool>(
        &mut self,
        scene: &[Triangle],
        costs: Costs,
    ) -> Result<RefitSums, RefitError> {
        if scene.len() != self.triangle_count {
            return Err(RefitError {
                built: self.triangle_count,
                given: scene.len(),
            });
        }
        // What each node hands its parent, in this thread's array, kept from refit to refit:
        // a fresh one of 40 bytes a node, filled, then freed, cost each refit its page
        // faults (the array is large enough to be mapped and unmapped each time). Every
        // entry is written before it is read (a node after its children), so its old
        // contents never matter.
        let mut done = DONE.take();
        if done.len() < self.nodes.len() {
            done.resize(self.nodes.len(), Refitted::default());
        }
        let tree = SharedTree {
            nodes: self.nodes.as_mut_ptr(),
            done: done.as_mut_ptr(),
        };
        let parallel = scene.len() >= PARALLEL_REFIT;
        // A tree laid out in one part fills its blocks on every thread first.
        let one_piece = self.parts.is_empty();
        // The top of the tree and the parts the collapse laid out apart, each a whole
        // subtree of its own nodes and blocks: a task fills a part's blocks and refits its
        // nodes. The parts in parallel; then the top, whose lanes reach the parts' roots.
        let mut pieces = pieces(self.pieces(), &mut self.blocks, &self.prim_indices);
        let top = pieces.remove(0);
        let refit_piece = |p: Piece<'_>| {
            if parallel && one_piece {
                fill_blocks_parallel(p.blocks, p.indices, scene);
                // SAFETY: as in `refit_piece`.
                unsafe { tree.refit_range::<REPORT>(p.nodes, p.blocks, p.first_block, costs) };
            } else {
                // SAFETY: a piece's nodes (and their `done` entries) are written by its
                // task alone and its nodes' children lie inside it (`validate` checks it),
                // so the tasks touch disjoint nodes; the top runs after them all.
                // `self.nodes` and `done` stay borrowed for the whole pass.
                unsafe { tree.refit_piece::<REPORT>(p, scene, costs) };
            }
        };
        if parallel {
            pieces.into_par_iter().for_each(refit_piece);
        } else {
            pieces.into_iter().for_each(refit_piece);
        }
        refit_piece(top);
        let sums = done[0].sums;
        DONE.set(done);
        Ok(sums)
    }

    /// Refit after only the scene triangles `moved` changed: the wide nodes holding their
    /// leaves and those nodes' ancestors. Gives the same boxes as `refit`.
    pub fn refit_moved(
        &mut self,
        index: &mut RefitIndex,
        scene: &[Triangle],
        moved: &[u32],
        c_trav: f32,
        c_isect: f32,
    ) -> Result<RefitReport, RefitError> {
        if scene.len() != self.triangle_count || index.triangles() != scene.len() {
            return Err(RefitError {
                built: self.triangle_count,
                given: scene.len(),
            });
        }
        // The SAH cost before and after from the lane sums: as the last refit through this
        // index left them (unless the root box says the tree changed otherwise since), and
        // updated by the nodes this refit changes, rather than two passes over every lane.
        let root_before = self.nodes[0].bounds();
        let mut sums = match index.lane_sums {
            Some((root, sums)) if root == root_before => sums,
            _ => LaneSums::of(&self.nodes),
        };
        let sah_before = sums.sah_cost(root_before, c_trav, c_isect, self.triangle_count);
        let blocks = &mut self.blocks;
        let dirty = index.dirty_nodes(moved, |slot, t| {
            blocks[slot / BLOCK].set(slot % BLOCK, &scene[t]);
        });
        for i in dirty {
            sums.take(&self.nodes[i]);
            Self::refit_leaves(&mut self.nodes[i], &self.blocks);
            self.refit_interior(i);
            sums.add(&self.nodes[i]);
        }
        let root_after = self.nodes[0].bounds();
        index.lane_sums = Some((root_after, sums));
        Ok(RefitReport {
            sah_before,
            sah_after: sums.sah_cost(root_after, c_trav, c_isect, self.triangle_count),
        })
    }
}

/// The SAH's cost weights, in the precision the sums are kept in.
#[derive(Clone, Copy)]
struct Costs {
    trav: f64,
    isect: f64,
}

impl Costs {
    /// The cost weight of a lane: an interior child's, or a leaf's of `count` triangles.
    fn of(self, interior: bool, count: u32) -> f64 {
        if interior {
            self.trav
        } else {
            self.isect * count as f64
        }
    }
}

/// The area-weighted lane costs of a subtree, with the boxes before and after the refit.
#[derive(Clone, Copy, Default)]
struct RefitSums {
    before: f64,
    after: f64,
}

impl std::ops::Add for RefitSums {
    type Output = RefitSums;
    fn add(self, o: RefitSums) -> RefitSums {
        RefitSums {
            before: self.before + o.before,
            after: self.after + o.after,
        }
    }
}

/// Blocks filled per task of the block pass: a few hundred tasks for 10^6 triangles.
const FILL_CHUNK: usize = 1024;

/// How many blocks ahead of the one being filled its triangles are asked for: enough to
/// cover the latency of a gather from anywhere in the scene.
const FILL_AHEAD: usize = 32;

/// The triangle of a padding lane: NaN, as the collapse leaves it.
const PADDING_TRIANGLE: Triangle = Triangle { v: [Vec3::NAN; 3] };

// A padding lane's index lies past the scene of every tree a layout accepts (`fill_blocks`).
const _: () = assert!(PADDING as usize >= super::collapse::MAX_REFERENCES);

/// A piece of the tree a refit task takes whole: the top or one part, its nodes and the
/// blocks its leaves hold (with their slots' triangle indices).
struct Piece<'a> {
    nodes: Range<usize>,
    blocks: &'a mut [TriangleBlock],
    indices: &'a [u32],
    /// The index of `blocks[0]` in the tree's blocks.
    first_block: usize,
}

/// The pieces of the tree (`WideBvh::pieces`), each with its blocks and their slots' indices.
fn pieces<'a>(
    ranges: Vec<(Range<usize>, Range<usize>)>,
    mut blocks: &'a mut [TriangleBlock],
    indices: &'a [u32],
) -> Vec<Piece<'a>> {
    ranges
        .into_iter()
        .map(|(nodes, b)| {
            let (mine, rest) = std::mem::take(&mut blocks).split_at_mut(b.len());
            blocks = rest;
            Piece {
                nodes,
                blocks: mine,
                indices: &indices[b.start * BLOCK..b.end * BLOCK],
                first_block: b.start,
            }
        })
        .collect()
}

/// Writes every block from the scene, in parallel over runs of blocks (`fill_blocks`).
fn fill_blocks_parallel(blocks: &mut [TriangleBlock], indices: &[u32], scene: &[Triangle]) {
    blocks
        .par_chunks_mut(FILL_CHUNK)
        .zip(indices.par_chunks(FILL_CHUNK * BLOCK))
        .for_each(|(blocks, indices)| fill_blocks(blocks, indices, scene));
}

/// Writes the blocks from the scene: each block's four triangles gathered by their slots'
/// indices (a padding lane stays NaN) and transposed into the block's rows, which are
/// written whole.
#[inline(always)]
fn fill_blocks(blocks: &mut [TriangleBlock], indices: &[u32], scene: &[Triangle]) {
    for (b, block) in blocks.iter_mut().enumerate() {
        let ahead = (b + FILL_AHEAD) * BLOCK;
        // A padding lane's index asks for an address past the scene, which a prefetch
        // may (it never faults): no branch on the lanes.
        for &t in indices.get(ahead..ahead + BLOCK).unwrap_or_default() {
            prefetch(scene.as_ptr().wrapping_add(t as usize));
        }
        // A padding lane's index (`PADDING`) lies past every scene: one compare per lane
        // picks the scene's triangle or the padding's.
        let tris: [&Triangle; BLOCK] = std::array::from_fn(|lane| {
            let t = indices[b * BLOCK + lane];
            scene.get(t as usize).unwrap_or(&PADDING_TRIANGLE)
        });
        // Vertex k of the four triangles, one per column, transposed: its x, y and z
        // rows (shuffles move the floats' bits unchanged, NaN included).
        let mut v = [[[0.0; BLOCK]; 3]; 3];
        for (k, rows) in v.iter_mut().enumerate() {
            let [t0, t1, t2, t3] = tris.map(|t| t.v[k].extend(0.0));
            let m = Mat4::from_cols(t0, t1, t2, t3).transpose();
            for (axis, row) in rows.iter_mut().enumerate() {
                *row = m.col(axis).to_array();
            }
        }
        *block = TriangleBlock { v };
    }
}

/// The box of one lane's triangle, as `Triangle::bounds` folds its vertices.
#[inline(always)]
fn lane_box(block: &TriangleBlock, lane: usize) -> (Vec4, Vec4) {
    // Read in place (a `map` over the rows copied the whole block to the stack first).
    let p = |k: usize| {
        let v = &block.v[k];
        Vec4::new(v[0][lane], v[1][lane], v[2][lane], 0.0)
    };
    let (p0, p1, p2) = (p(0), p(1), p(2));
    (p0.min(p1).min(p2), p0.max(p1).max(p2))
}

/// The box of the lanes `lanes` (a range within 0..BLOCK) of a block, as the union of
/// their triangles' boxes in lane order gives it. Four lanes at a time: each lane's
/// triangle box (v0, v1, v2 folded as `Triangle::bounds` folds them), the other lanes set
/// to the empty box's planes (a padding lane's NaN must not count), then the four lanes
/// folded in pairs that keep their order: `min(a, b)` is `a < b ? a : b`, which on
/// numbers (not NaN) is associative (it keeps the last of equal values, so +0 and −0 come
/// out as in a fold lane by lane), so the result is the one-by-one union's, bit for bit.
#[inline(always)]
fn lanes_box(block: &TriangleBlock, lanes: std::ops::Range<usize>) -> (Vec4, Vec4) {
    let lane = Vec4::new(0.0, 1.0, 2.0, 3.0);
    let used =
        lane.cmpge(Vec4::splat(lanes.start as f32)) & lane.cmplt(Vec4::splat(lanes.end as f32));
    let row = |k: usize, axis: usize| Vec4::from_array(block.v[k][axis]);
    // Lane 0 of the result: ((l0, l1), (l2, l3)) folded by `f`.
    let fold = |v: Vec4, f: fn(Vec4, Vec4) -> Vec4| {
        let v = f(v, Vec4::new(v.y, v.x, v.w, v.z));
        f(v, Vec4::new(v.z, v.w, v.x, v.y)).x
    };
    let least = |axis| {
        let m = row(0, axis).min(row(1, axis)).min(row(2, axis));
        fold(Vec4::select(used, m, Vec4::INFINITY), Vec4::min)
    };
    let greatest = |axis| {
        let m = row(0, axis).max(row(1, axis)).max(row(2, axis));
        fold(Vec4::select(used, m, Vec4::NEG_INFINITY), Vec4::max)
    };
    (
        Vec4::new(least(0), least(1), least(2), 0.0),
        Vec4::new(greatest(0), greatest(1), greatest(2), 0.0),
    )
}

/// The surface areas of a node's lanes, written four lanes at a time and read lane by lane:
/// aligned, so that no vector store straddles two cache lines (which the loads after it
/// cannot take forwarded: docs/wide-bvh.md, "A measurement hazard, found").
#[repr(C, align(32))]
struct LaneAreas<const W: usize>([f32; W]);

/// The surface area of every lane's box, four lanes at a time, as `Aabb::surface_area`
/// computes it (an empty box has area 0).
#[inline(always)]
fn lane_areas<const W: usize>(rows: &[[f32; W]; 6]) -> LaneAreas<W> {
    let mut areas = LaneAreas([0.0; W]);
    for c in (0..W).step_by(4) {
        let row = |r: usize| Vec4::from_slice(&rows[r][c..c + 4]);
        let (lo, hi) = ([row(0), row(1), row(2)], [row(3), row(4), row(5)]);
        let empty = lo[0].cmpgt(hi[0]) | lo[1].cmpgt(hi[1]) | lo[2].cmpgt(hi[2]);
        let e = |axis: usize| Vec4::select(empty, Vec4::ZERO, hi[axis] - lo[axis]);
        let (x, y, z) = (e(0), e(1), e(2));
        (2.0 * (x * y + y * z + z * x)).write_to_slice(&mut areas.0[c..c + 4]);
    }
    areas
}

/// What a refitted node hands its parent: its box (the union of its lanes, which the
/// parent's lane takes) and its subtree's sums, in one cache line rather than the node's
/// four.
#[derive(Clone, Copy, Default)]
struct Refitted {
    bounds: Aabb,
    sums: RefitSums,
}

thread_local! {
    /// The `Refitted` array of this thread's last full refit (`refit_with`), reused.
    static DONE: std::cell::Cell<Vec<Refitted>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The tree as the refit's tasks share it: the nodes and what each hands its parent through
/// raw pointers, because parallel tasks write different nodes of one array.
struct SharedTree<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    nodes: *mut WideNode<W>,
    done: *mut Refitted,
}

// SAFETY: the pointers are only written at nodes owned by one task (see `refit_range`).
unsafe impl<const W: usize> Sync for SharedTree<W> where Lanes<W>: NodeWidth {}

impl<const W: usize> SharedTree<W>
where
    Lanes<W>: NodeWidth,
{
    /// Fills a piece's blocks and refits its nodes, compiled for AVX2 where the CPU has it:
    /// the same operations (no fused multiply-add, so the same bits) in three-operand VEX
    /// forms, which spare the copies between registers that the SSE2 forms need (4–5 % of
    /// the refit's time, docs/wide-bvh.md).
    ///
    /// # Safety
    /// As `refit_range`.
    unsafe fn refit_piece<const REPORT: bool>(
        &self,
        p: Piece<'_>,
        scene: &[Triangle],
        costs: Costs,
    ) {
        #[cfg(target_arch = "x86_64")]
        if SimdLevel::Avx2.supported() {
            // SAFETY: the CPU has AVX2; the rest is the caller's contract.
            return unsafe { self.refit_piece_avx2::<REPORT>(p, scene, costs) };
        }
        // SAFETY: the caller's contract.
        unsafe { self.fill_and_refit::<REPORT>(p, scene, costs) }
    }

    /// `refit_piece` compiled for AVX2.
    ///
    /// # Safety
    /// As `refit_range`; the CPU has AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn refit_piece_avx2<const REPORT: bool>(
        &self,
        p: Piece<'_>,
        scene: &[Triangle],
        costs: Costs,
    ) {
        // SAFETY: the caller's contract.
        unsafe { self.fill_and_refit::<REPORT>(p, scene, costs) }
    }

    /// # Safety
    /// As `refit_range`.
    #[inline(always)]
    unsafe fn fill_and_refit<const REPORT: bool>(
        &self,
        p: Piece<'_>,
        scene: &[Triangle],
        costs: Costs,
    ) {
        fill_blocks(p.blocks, p.indices, scene);
        // SAFETY: the caller's contract.
        unsafe { self.refit_range::<REPORT>(p.nodes, p.blocks, p.first_block, costs) };
    }

    /// Refits the nodes `range` from the last to the first: a node's interior children come
    /// after it, so each is refitted (and its sums known) before its parent reads it. One
    /// sweep down the array, with no recursion: the nodes stream in, and the reads of one
    /// node's blocks overlap those of the next. Its leaves' slots lie in `blocks`, whose
    /// first is block `first_block` of the tree.
    ///
    /// # Safety
    /// No other task may touch the nodes of `range`, and the children of its nodes must lie
    /// in it or be refitted already.
    #[inline(always)]
    unsafe fn refit_range<const REPORT: bool>(
        &self,
        range: Range<usize>,
        blocks: &[TriangleBlock],
        first_block: usize,
        costs: Costs,
    ) {
        for i in range.rev() {
            // SAFETY: the caller's contract.
            unsafe { self.refit_node::<REPORT>(i, blocks, first_block, costs) };
        }
    }

    /// Refits node `i` from its triangles' blocks and its refitted children, and stores the
    /// lane sums of its subtree. The sums are added lane by lane, each child's subtree sum
    /// before its own lane: the order the recursive refit (and its reference) add them in.
    ///
    /// # Safety
    /// As `refit_range`.
    #[inline(always)]
    unsafe fn refit_node<const REPORT: bool>(
        &self,
        i: usize,
        blocks: &[TriangleBlock],
        first_block: usize,
        costs: Costs,
    ) {
        // SAFETY: node `i` is this task's alone (the caller's contract).
        let node = unsafe { &mut *self.nodes.add(i) };
        let lanes = node.child_count();
        let words = node.child;
        // The old areas are read before the lanes are overwritten (none without a report).
        let old = match REPORT {
            true => lane_areas(&node.bounds),
            false => LaneAreas([0.0; W]),
        };
        // The lanes are set in place (a copy of the rows out and back was two calls of
        // `memcpy` a node).
        let rows = &mut node.bounds;
        let mut set = |l: usize, lo: Vec4, hi: Vec4| {
            for axis in 0..3 {
                rows[axis][l] = lo[axis];
                rows[axis + 3][l] = hi[axis];
            }
        };
        let mut child_sums = [RefitSums::default(); W];
        for (l, word) in words[..lanes].iter().enumerate() {
            if word.is_leaf() {
                let (mut lo, mut hi) = (Vec4::INFINITY, Vec4::NEG_INFINITY);
                let slots = word.slots();
                let slots = slots.start - first_block * BLOCK..slots.end - first_block * BLOCK;
                if slots.len() <= 2 {
                    // Most leaves hold one or two triangles: cheaper one lane at a time.
                    for slot in slots {
                        let (l2, h2) = lane_box(&blocks[slot / BLOCK], slot % BLOCK);
                        (lo, hi) = (lo.min(l2), hi.max(h2));
                    }
                } else {
                    let first = slots.start / BLOCK;
                    let under = &blocks[first..slots.end.div_ceil(BLOCK)];
                    for (b, block) in (first..).zip(under) {
                        let start = slots.start.max(b * BLOCK) - b * BLOCK;
                        let end = slots.end.min(b * BLOCK + BLOCK) - b * BLOCK;
                        let (l2, h2) = lanes_box(block, start..end);
                        (lo, hi) = (lo.min(l2), hi.max(h2));
                    }
                }
                set(l, lo, hi);
            } else {
                // SAFETY: the child was refitted before (it comes after `i`); nothing
                // writes it now.
                let child = unsafe { *self.done.add(word.node_index()) };
                let b = child.bounds;
                set(l, b.min.extend(0.0), b.max.extend(0.0));
                child_sums[l] = child.sums;
            }
        }
        let mut sums = RefitSums::default();
        if REPORT {
            let new = lane_areas(&node.bounds);
            for (l, child) in child_sums.iter().enumerate().take(lanes) {
                let weight = costs.of(!words[l].is_leaf(), words[l].count());
                sums = sums
                    + *child
                    + RefitSums {
                        before: weight * old.0[l] as f64,
                        after: weight * new.0[l] as f64,
                    };
            }
        }
        let bounds = node.bounds();
        // SAFETY: node `i`'s entry is this task's alone.
        unsafe { *self.done.add(i) = Refitted { bounds, sums } };
    }
}

impl RefitIndex {
    /// The index of a wide tree: a slot's "leaf" is the wide node whose lane holds it.
    pub fn for_wide<const W: usize>(tree: &WideBvh<W>) -> Self
    where
        Lanes<W>: NodeWidth,
    {
        let n = tree.prim_indices.len();
        let (first_slot, slots) = slots_of(&tree.prim_indices, tree.triangle_count);
        let mut leaf_of = vec![0u32; n];
        let mut parent = vec![u32::MAX; tree.nodes.len()];
        for (i, node) in tree.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                match node.interior(lane) {
                    Some(c) => parent[c] = i as u32,
                    None => leaf_of[node.child[lane].slots()].fill(i as u32),
                }
            }
        }
        RefitIndex {
            first_slot,
            slots,
            leaf_of,
            parent,
            queued: vec![false; tree.nodes.len()],
            lane_sums: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::{self, BuildParams};
    use crate::random::Rng;

    /// Triangles on a coarse grid, so that many share their least and greatest planes, with
    /// every zero coordinate given a random sign: a box of several of them is +0 or −0 as
    /// the last of the equal values in leaf order says.
    fn grid_soup(n: usize, seed: u64) -> Vec<Triangle> {
        let mut rng = Rng(seed);
        let mut triangle = || {
            let base: [i64; 3] = std::array::from_fn(|_| rng.below(9) as i64 - 4);
            let mut coord = |axis: usize| {
                let c = (base[axis] + rng.below(2) as i64) as f32;
                if c == 0.0 && rng.below(2) == 0 {
                    -0.0
                } else {
                    c
                }
            };
            let mut v = || Vec3::new(coord(0), coord(1), coord(2));
            Triangle::new(v(), v(), v())
        };
        (0..n).map(|_| triangle()).collect()
    }

    /// The refit as it was first written, one lane and one triangle at a time: each slot's
    /// lane set from the scene, each leaf's box the union of its triangles' boxes in slot
    /// order, the lane sums added children first as `refit` adds them.
    fn reference<const W: usize>(t: &mut WideBvh<W>, scene: &[Triangle], costs: Costs) -> (f64, f64)
    where
        Lanes<W>: NodeWidth,
    {
        fn walk<const W: usize>(
            t: &mut WideBvh<W>,
            i: usize,
            scene: &[Triangle],
            costs: Costs,
        ) -> RefitSums
        where
            Lanes<W>: NodeWidth,
        {
            let lanes = t.nodes[i].child_count();
            let mut child = [RefitSums::default(); W];
            for (l, sums) in child.iter_mut().enumerate().take(lanes) {
                if let Some(c) = t.nodes[i].interior(l) {
                    *sums = walk(t, c, scene, costs);
                }
            }
            let mut sums = RefitSums::default();
            for (l, child) in child.iter().enumerate().take(lanes) {
                let node = &t.nodes[i];
                let old = node.child_bounds(l).surface_area() as f64;
                let new = match node.interior(l) {
                    Some(c) => t.nodes[c].bounds(),
                    None => node.child[l].slots().fold(Aabb::EMPTY, |b, slot| {
                        b.union(scene[t.prim_indices[slot] as usize].bounds())
                    }),
                };
                let weight = costs.of(node.is_interior(l), node.leaf_count(l));
                t.nodes[i].set_child_bounds(l, new);
                sums = sums
                    + *child
                    + RefitSums {
                        before: weight * old,
                        after: weight * new.surface_area() as f64,
                    };
            }
            sums
        }
        for (slot, &index) in t.prim_indices.iter().enumerate() {
            if index != PADDING {
                t.blocks[slot / BLOCK].set(slot % BLOCK, &scene[index as usize]);
            }
        }
        let root_before = t.nodes[0].bounds().surface_area() as f64;
        let sums = walk(t, 0, scene, costs);
        let root_after = t.nodes[0].bounds().surface_area() as f64;
        let sah = |root: f64, lanes: f64| (costs.trav * root + lanes) / root;
        (sah(root_before, sums.before), sah(root_after, sums.after))
    }

    /// The full refit (parallel, blocks written whole, leaves bounded four lanes at a time)
    /// gives the one-by-one refit's boxes, blocks (padding lanes' NaN included) and SAH
    /// costs bit for bit, signs of zero included; without the report, the same boxes and
    /// blocks.
    #[test]
    fn full_refit_equals_the_lane_by_lane_refit_bit_for_bit() {
        fn check<const W: usize>(seed: u64)
        where
            Lanes<W>: NodeWidth,
        {
            let n = PARALLEL_REFIT + 5000;
            let built = grid_soup(n, seed);
            let b2 = bvh::build(&built, &BuildParams::default()).unwrap().0;
            let mut fast = WideBvh::<W>::collapse(&b2, &super::super::CollapseParams::default());
            let mut slow = fast.clone();
            let mut boxes_only = fast.clone();
            assert!(fast.parts.len() > 4, "the parts refitted in parallel");
            let moved = grid_soup(n, seed + 1);
            let costs = Costs {
                trav: 1.0,
                isect: 2.0,
            };
            let report = fast.refit(&moved, 1.0, 2.0).unwrap();
            boxes_only.refit_boxes(&moved).unwrap();
            let (before, after) = reference(&mut slow, &moved, costs);
            let bits = |t: &WideBvh<W>| {
                let nodes = t.nodes.iter().flat_map(|n| {
                    let rows = n.bounds.iter().flatten().map(|f| f.to_bits());
                    rows.chain(n.child.iter().map(|c| c.word()))
                        .collect::<Vec<_>>()
                });
                let blocks = t
                    .blocks
                    .iter()
                    .flat_map(|b| b.v.iter().flatten().flatten().map(|f| f.to_bits()));
                nodes.chain(blocks).collect::<Vec<u32>>()
            };
            assert!(
                bits(&fast) == bits(&slow),
                "BVH{W}: the refits' bits differ"
            );
            assert!(
                bits(&boxes_only) == bits(&slow),
                "BVH{W}: the refit without a report differs"
            );
            assert_eq!(
                (report.sah_before.to_bits(), report.sah_after.to_bits()),
                (before.to_bits(), after.to_bits()),
                "BVH{W}"
            );
            // The scene does hold boxes bounded by −0 on one side.
            let negative_zero = fast.nodes.iter().flat_map(|n| n.bounds.iter().flatten());
            assert!(
                negative_zero
                    .filter(|f| f.to_bits() == (-0.0f32).to_bits())
                    .count()
                    > 10
            );
        }
        check::<4>(3);
        check::<8>(4);
    }

    /// The refit fills a part's blocks and then bounds the part's leaves from them alone, so
    /// a leaf must hold slots of its own part's blocks: `validate` checks it.
    #[test]
    fn each_part_holds_its_own_blocks() {
        let built = grid_soup(PARALLEL_REFIT + 5000, 7);
        let b2 = bvh::build(&built, &BuildParams::default()).unwrap().0;
        let tree = WideBvh::<8>::collapse(&b2, &super::super::CollapseParams::default());
        assert!(tree.parts.len() > 4);
        assert_eq!(tree.part_blocks.len(), tree.parts.len());
        tree.validate().unwrap();
        for k in 0..tree.part_blocks.len() {
            let mut moved = tree.clone();
            moved.part_blocks[k] += 1;
            let error = moved.validate().unwrap_err();
            assert!(error.contains("outside its part's slots"), "{error}");
        }
    }
}
