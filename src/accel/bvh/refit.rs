//! Refit after motion: keep the tree's topology, recompute every box bottom-up. O(nodes),
//! far cheaper than a rebuild, and exact — but the boxes of a tree built for the old
//! positions may now overlap more, which the SAH cost before and after shows.
//!
//! A leaf's box is refitted to its triangles' whole boxes. For a tree with split references
//! (SBVH, pre-splitting) that is larger than the clipped box the build gave the leaf: still
//! correct, since every box still holds what lies under it, but the spatial splits' gain is
//! lost until the next rebuild.

use super::Bvh;
use super::wide::LaneSums;
use crate::geometry::{Aabb, Triangle};

/// SAH cost of the tree before and after a refit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefitReport {
    pub sah_before: f64,
    pub sah_after: f64,
}

impl Bvh {
    /// Recomputes node `i`'s box from its triangles or from its children's boxes.
    fn refit_node(&mut self, i: usize) {
        let node = self.nodes[i];
        let bounds = if node.is_leaf() {
            self.triangles[node.prim_range()]
                .iter()
                .fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
        } else {
            let l = node.left_first as usize;
            self.nodes[l].bounds().union(self.nodes[l + 1].bounds())
        };
        self.nodes[i].set_bounds(bounds);
    }
}

/// A refit keeps the topology, so it needs exactly the triangles the tree was built over.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("refit needs the {built} triangles the tree was built over, got {given}: rebuild instead")]
pub struct RefitError {
    pub built: usize,
    pub given: usize,
}

impl Bvh {
    /// Takes the moved triangles (`scene` in scene order, the same count as at build time)
    /// and updates every box. Children come after their parents in `nodes`, so one pass from
    /// the back sees both children of a node before the node itself.
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
        for (dst, &src) in self.triangles.iter_mut().zip(&self.prim_indices) {
            *dst = scene[src as usize];
        }
        for i in (0..self.nodes.len()).rev() {
            self.refit_node(i);
        }
        Ok(RefitReport {
            sah_before,
            sah_after: self.sah_cost(c_trav, c_isect),
        })
    }
}

/// What a partial refit needs to find the boxes a moved triangle touches: the leaf-order
/// slots of each scene triangle, the leaf of each slot and the parent of each node. Valid as
/// long as the tree's topology is (refits keep it; a rebuild needs a new one).
#[derive(Clone, Debug, Default)]
pub struct RefitIndex {
    /// Scene triangle t's leaf-order slots are `slots[first_slot[t]..first_slot[t + 1]]`:
    /// one, or several when its reference was split.
    pub(crate) first_slot: Vec<u32>,
    pub(crate) slots: Vec<u32>,
    /// Slot → the node whose leaf holds it.
    pub(crate) leaf_of: Vec<u32>,
    /// Node → its parent (`u32::MAX` for the root).
    pub(crate) parent: Vec<u32>,
    /// Scratch: which nodes are already queued.
    pub(crate) queued: Vec<bool>,
    /// A wide tree's SAH sums as the last partial refit through this index left them, with
    /// the root box then: the next refit updates them from the nodes it changes instead of
    /// summing every lane twice (see `WideBvh::refit_moved`).
    pub(crate) lane_sums: Option<(Aabb, LaneSums)>,
}

impl RefitIndex {
    pub fn new(bvh: &Bvh) -> Self {
        let (first_slot, slots) = slots_of(&bvh.prim_indices, bvh.triangle_count);
        let mut leaf_of = vec![0u32; bvh.prim_indices.len()];
        for (i, n) in bvh.nodes.iter().enumerate() {
            if n.is_leaf() {
                for slot in n.prim_range() {
                    leaf_of[slot] = i as u32;
                }
            }
        }
        RefitIndex {
            first_slot,
            slots,
            leaf_of,
            parent: bvh.parents(),
            queued: vec![false; bvh.nodes.len()],
            lane_sums: None,
        }
    }
}

/// Groups the leaf-order slots by scene triangle (a counting sort over `prim_indices`).
pub(crate) fn slots_of(prim_indices: &[u32], triangles: usize) -> (Vec<u32>, Vec<u32>) {
    // Indices past `triangles` (a wide leaf block's padding lanes) have no triangle.
    let mut first = vec![0u32; triangles + 1];
    for &t in prim_indices.iter().filter(|&&t| (t as usize) < triangles) {
        first[t as usize + 1] += 1;
    }
    for t in 0..triangles {
        first[t + 1] += first[t];
    }
    let mut next = first.clone();
    let mut slots = vec![0u32; first[triangles] as usize];
    for (slot, &t) in prim_indices.iter().enumerate() {
        if t as usize >= triangles {
            continue;
        }
        slots[next[t as usize] as usize] = slot as u32;
        next[t as usize] += 1;
    }
    (first, slots)
}

impl RefitIndex {
    /// Scene triangles the index was made for.
    pub(crate) fn triangles(&self) -> usize {
        self.first_slot.len().saturating_sub(1)
    }

    /// Hands each `moved` scene triangle and each of its slots to `copy` (slot, scene index) and
    /// returns the nodes whose boxes change (their leaves and every ancestor), children
    /// before parents: nodes come after their parents, so high index to low is bottom-up.
    pub(crate) fn dirty_nodes(
        &mut self,
        moved: &[u32],
        mut copy: impl FnMut(usize, usize),
    ) -> Vec<usize> {
        let mut dirty = Vec::new();
        for &t in moved {
            let t = t as usize;
            if t >= self.triangles() {
                continue;
            }
            let range = self.first_slot[t] as usize..self.first_slot[t + 1] as usize;
            for &slot in &self.slots[range] {
                copy(slot as usize, t);
                // Queue the leaf and every ancestor not queued yet.
                let mut node = self.leaf_of[slot as usize];
                while node != u32::MAX && !self.queued[node as usize] {
                    self.queued[node as usize] = true;
                    dirty.push(node as usize);
                    node = self.parent[node as usize];
                }
            }
        }
        dirty.sort_unstable_by(|a, b| b.cmp(a));
        for &i in &dirty {
            self.queued[i] = false;
        }
        dirty
    }
}

impl Bvh {
    /// Refit after only the scene triangles `moved` changed: their leaves and the nodes
    /// above them, O(moved · depth) instead of O(nodes). Gives the same boxes as `refit`.
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
        let triangles = &mut self.triangles;
        let dirty = index.dirty_nodes(moved, |slot, t| triangles[slot] = scene[t]);
        for i in dirty {
            self.refit_node(i);
        }
        Ok(RefitReport {
            sah_before,
            sah_after: self.sah_cost(c_trav, c_isect),
        })
    }
}
