//! Refit of a wide BVH after motion: the same topology, every child box recomputed bottom-up
//! (a leaf lane from its triangles, an interior lane from its node's children), so the app's
//! drag keeps the fastest tree instead of falling back to the BVH2.

use super::WideBvh;
use super::leaf::PADDING;
use super::node::WideNode;
use crate::accel::bvh::refit::{RefitError, RefitIndex, RefitReport, slots_of};
use crate::geometry::simd::{BLOCK, TriangleBlock};
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;

/// Below this many triangles a refit runs on one thread (spawning costs more).
const PARALLEL_REFIT: usize = 1 << 15;

impl<const W: usize> WideBvh<W> {
    /// The leaf lanes' boxes of `node`, from the triangle blocks.
    fn refit_leaves(node: &mut WideNode<W>, blocks: &[TriangleBlock]) {
        for lane in 0..node.child_count() {
            if !node.is_interior(lane) {
                let first = node.child[lane] as usize;
                let b = (first..first + node.count[lane] as usize).fold(Aabb::EMPTY, |b, slot| {
                    b.union(blocks[slot / BLOCK].triangle(slot % BLOCK).bounds())
                });
                node.set_child_bounds(lane, b);
            }
        }
    }

    /// Copies the scene's triangles into a block's lanes (`index` its slots' indices).
    fn refill(block: &mut TriangleBlock, index: &[u32], scene: &[Triangle]) {
        for (lane, &t) in index.iter().enumerate() {
            if t != PADDING {
                block.set(lane, &scene[t as usize]);
            }
        }
    }

    /// The interior lanes' boxes of node `i`, from its children (which come after it).
    fn refit_interior(&mut self, i: usize) {
        let (head, tail) = self.nodes.split_at_mut(i + 1);
        let node = &mut head[i];
        for lane in 0..node.child_count() {
            if node.is_interior(lane) {
                let child = node.child[lane] as usize - (i + 1);
                node.set_child_bounds(lane, tail[child].bounds());
            }
        }
    }

    /// Takes the moved triangles (`scene` in scene order, the count the tree was built over)
    /// and updates every box: triangles and leaf boxes in parallel, then one backward pass
    /// over the nodes for the interior boxes.
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
        let sah_before = self.sah_cost(c_trav, c_isect);
        let parallel = scene.len() >= PARALLEL_REFIT;
        let blocks = &mut self.blocks;
        if parallel {
            blocks
                .par_iter_mut()
                .zip(self.prim_indices.par_chunks(BLOCK))
                .with_min_len(1024)
                .for_each(|(b, index)| Self::refill(b, index, scene));
            let blocks = &self.blocks;
            self.nodes
                .par_iter_mut()
                .with_min_len(256)
                .for_each(|n| Self::refit_leaves(n, blocks));
        } else {
            blocks
                .iter_mut()
                .zip(self.prim_indices.chunks(BLOCK))
                .for_each(|(b, index)| Self::refill(b, index, scene));
            let blocks = &self.blocks;
            self.nodes
                .iter_mut()
                .for_each(|n| Self::refit_leaves(n, blocks));
        }
        for i in (0..self.nodes.len()).rev() {
            self.refit_interior(i);
        }
        Ok(RefitReport {
            sah_before,
            sah_after: self.sah_cost(c_trav, c_isect),
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
        let sah_before = self.sah_cost(c_trav, c_isect);
        let blocks = &mut self.blocks;
        let dirty = index.dirty_nodes(moved, |slot, t| {
            blocks[slot / BLOCK].set(slot % BLOCK, &scene[t]);
        });
        for i in dirty {
            Self::refit_leaves(&mut self.nodes[i], &self.blocks);
            self.refit_interior(i);
        }
        Ok(RefitReport {
            sah_before,
            sah_after: self.sah_cost(c_trav, c_isect),
        })
    }
}

impl RefitIndex {
    /// The index of a wide tree: a slot's "leaf" is the wide node whose lane holds it.
    pub fn for_wide<const W: usize>(tree: &WideBvh<W>) -> Self {
        let n = tree.prim_indices.len();
        let (first_slot, slots) = slots_of(&tree.prim_indices, tree.triangle_count);
        let mut leaf_of = vec![0u32; n];
        let mut parent = vec![u32::MAX; tree.nodes.len()];
        for (i, node) in tree.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                let c = node.child[lane] as usize;
                if node.is_interior(lane) {
                    parent[c] = i as u32;
                } else {
                    leaf_of[c..c + node.count[lane] as usize].fill(i as u32);
                }
            }
        }
        RefitIndex {
            first_slot,
            slots,
            leaf_of,
            parent,
            queued: vec![false; tree.nodes.len()],
        }
    }
}
