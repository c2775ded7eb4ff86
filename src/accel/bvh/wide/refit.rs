//! Refit of a wide BVH after motion: the same topology, every child box recomputed bottom-up
//! (a leaf lane from its triangles, an interior lane from its node's children), so the app's
//! drag keeps the fastest tree instead of falling back to the BVH2.

use super::LaneSums;
use super::WideBvh;
use super::leaf::PADDING;
use super::node::{Lanes, NodeWidth, WideNode};
use crate::accel::bvh::refit::{RefitError, RefitIndex, RefitReport, slots_of};
use crate::geometry::simd::{BLOCK, TriangleBlock};
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;

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
    /// and updates every box in one pass, children before parents: a leaf lane copies its
    /// triangles into their block lanes and bounds them while they are in registers, an
    /// interior lane takes its child's box. The SAH cost before and after is summed in the
    /// same pass (each lane's old box is read before it is overwritten), so a refit reads
    /// the nodes once and the triangles once. Subtrees near the root run as parallel tasks.
    pub fn refit(
        &mut self,
        scene: &[Triangle],
        c_trav: f32,
        c_isect: f32,
    ) -> Result<RefitReport, RefitError> {
        if scene.len() != self.triangle_count {
            return Err(RefitError {
                built: self.triangle_count,
                given: scene.len(),
            });
        }
        let root_before = self.nodes[0].bounds().surface_area() as f64;
        let costs = Costs {
            trav: c_trav as f64,
            isect: c_isect as f64,
        };
        let tree = SharedTree {
            nodes: self.nodes.as_mut_ptr(),
            blocks: self.blocks.as_mut_ptr(),
            indices: &self.prim_indices,
            scene,
        };
        let parallel_depth = if scene.len() >= PARALLEL_REFIT { 4 } else { 0 };
        // SAFETY: every node but the root has exactly one parent lane and every slot exactly
        // one leaf lane (what `validate` checks), so the tasks of `refit_subtree` write
        // disjoint nodes and disjoint block lanes; `self` stays borrowed for the whole pass.
        let sums = unsafe { tree.refit_subtree(0, parallel_depth, costs) };
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

/// The tree as the refit's tasks share it: raw pointers, because parallel tasks write
/// different nodes and different lanes of the same block array.
struct SharedTree<'a, const W: usize>
where
    Lanes<W>: NodeWidth,
{
    nodes: *mut WideNode<W>,
    blocks: *mut TriangleBlock,
    indices: &'a [u32],
    scene: &'a [Triangle],
}

// SAFETY: the pointers are only written at nodes and block lanes owned by one task (see
// `refit_subtree`).
unsafe impl<const W: usize> Sync for SharedTree<'_, W> where Lanes<W>: NodeWidth {}

impl<const W: usize> SharedTree<'_, W>
where
    Lanes<W>: NodeWidth,
{
    /// Refits node `i`'s subtree and returns its lane sums; subtrees start as parallel tasks
    /// while `parallel_depth` > 0.
    ///
    /// # Safety
    /// No other task may touch `i`'s subtree, its nodes or its leaves' slots.
    unsafe fn refit_subtree(&self, i: usize, parallel_depth: u32, costs: Costs) -> RefitSums {
        // SAFETY: node `i` is this task's alone (the caller's contract).
        let node = unsafe { &mut *self.nodes.add(i) };
        let lanes = node.child_count();
        // Children's sums first: every interior child is refitted before its box is read.
        let mut child_sums = [RefitSums::default(); W];
        if parallel_depth > 0 {
            let interior: Vec<(usize, usize)> = (0..lanes)
                .filter_map(|l| Some((l, node.interior(l)?)))
                .collect();
            let sums: Vec<RefitSums> = interior
                .par_iter()
                // SAFETY: distinct children own disjoint subtrees.
                .map(|&(_, c)| unsafe { self.refit_subtree(c, parallel_depth - 1, costs) })
                .collect();
            for (&(l, _), s) in interior.iter().zip(sums) {
                child_sums[l] = s;
            }
        } else {
            for (l, sum) in child_sums.iter_mut().enumerate().take(lanes) {
                if let Some(c) = node.interior(l) {
                    // SAFETY: as above.
                    *sum = unsafe { self.refit_subtree(c, 0, costs) };
                }
            }
        }
        let mut sums = RefitSums::default();
        for (l, child) in child_sums.iter().enumerate().take(lanes) {
            let old = node.child_bounds(l).surface_area() as f64;
            let new = match node.interior(l) {
                // SAFETY: the child's task has finished; nothing else writes it.
                Some(c) => unsafe { &*self.nodes.add(c) }.bounds(),
                // SAFETY: this leaf lane's slots belong to no other lane.
                None => unsafe { self.refill_leaf(node.child[l].slots()) },
            };
            node.set_child_bounds(l, new);
            let weight = costs.of(node.is_interior(l), node.leaf_count(l));
            sums = sums
                + *child
                + RefitSums {
                    before: weight * old,
                    after: weight * new.surface_area() as f64,
                };
        }
        sums
    }

    /// Copies a leaf's triangles from the scene into their block lanes and returns their box.
    ///
    /// # Safety
    /// The slots must be this leaf's alone.
    unsafe fn refill_leaf(&self, slots: std::ops::Range<usize>) -> Aabb {
        let mut b = Aabb::EMPTY;
        for slot in slots {
            let t = self.indices[slot];
            if t == PADDING {
                continue;
            }
            let tri = &self.scene[t as usize];
            // SAFETY: lane `slot % BLOCK` of this block is written by this leaf only; other
            // lanes of the block are not touched (`set_lane` writes one lane's floats).
            unsafe { set_lane(self.blocks.add(slot / BLOCK), slot % BLOCK, tri) };
            b = b.union(tri.bounds());
        }
        b
    }
}

/// Writes one lane of a block through a raw pointer, touching no other lane's floats.
///
/// # Safety
/// `block` must point into the live block array, and no one else may access this lane.
unsafe fn set_lane(block: *mut TriangleBlock, lane: usize, tri: &Triangle) {
    // SAFETY: the caller's contract; `addr_of_mut!` makes no reference to the whole block,
    // and its `v` is 3 · 3 · BLOCK contiguous floats (vertex, axis, lane).
    let floats = unsafe { std::ptr::addr_of_mut!((*block).v) } as *mut f32;
    for (k, p) in tri.v.iter().enumerate() {
        for (axis, value) in [p.x, p.y, p.z].into_iter().enumerate() {
            // SAFETY: k < 3, axis < 3, lane < BLOCK: inside the block, in this lane.
            unsafe { floats.add((k * 3 + axis) * BLOCK + lane).write(value) };
        }
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
