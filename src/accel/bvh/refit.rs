//! Refit after motion: keep the tree's topology, recompute every box bottom-up. O(nodes),
//! far cheaper than a rebuild, and exact — but the boxes of a tree built for the old
//! positions may now overlap more, which the SAH cost before and after shows.

use super::Bvh;
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
        if scene.len() != self.triangles.len() {
            return Err(RefitError {
                built: self.triangles.len(),
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
/// slot of each scene triangle, the leaf of each slot and the parent of each node. Valid as
/// long as the tree's topology is (refits keep it; a rebuild needs a new one).
#[derive(Clone, Debug, Default)]
pub struct RefitIndex {
    /// Scene triangle → its leaf-order slot.
    pub(crate) slot_of: Vec<u32>,
    /// Slot → the node whose leaf holds it.
    pub(crate) leaf_of: Vec<u32>,
    /// Node → its parent (`u32::MAX` for the root).
    pub(crate) parent: Vec<u32>,
    /// Scratch: which nodes are already queued.
    pub(crate) queued: Vec<bool>,
}

impl RefitIndex {
    pub fn new(bvh: &Bvh) -> Self {
        let mut slot_of = vec![0u32; bvh.prim_indices.len()];
        for (slot, &t) in bvh.prim_indices.iter().enumerate() {
            slot_of[t as usize] = slot as u32;
        }
        let mut leaf_of = vec![0u32; bvh.prim_indices.len()];
        for (i, n) in bvh.nodes.iter().enumerate() {
            if n.is_leaf() {
                for slot in n.prim_range() {
                    leaf_of[slot] = i as u32;
                }
            }
        }
        RefitIndex {
            slot_of,
            leaf_of,
            parent: bvh.parents(),
            queued: vec![false; bvh.nodes.len()],
        }
    }
}

impl RefitIndex {
    /// Hands each `moved` scene triangle and its slot to `copy` (slot, scene index) and
    /// returns the nodes whose boxes change (their leaves and every ancestor), children
    /// before parents: nodes come after their parents, so high index to low is bottom-up.
    pub(crate) fn dirty_nodes(
        &mut self,
        moved: &[u32],
        mut copy: impl FnMut(usize, usize),
    ) -> Vec<usize> {
        let mut dirty = Vec::new();
        for &t in moved {
            let Some(&slot) = self.slot_of.get(t as usize) else {
                continue;
            };
            copy(slot as usize, t as usize);
            // Queue the leaf and every ancestor not queued yet.
            let mut node = self.leaf_of[slot as usize];
            while node != u32::MAX && !self.queued[node as usize] {
                self.queued[node as usize] = true;
                dirty.push(node as usize);
                node = self.parent[node as usize];
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
        if scene.len() != self.triangles.len() || index.slot_of.len() != scene.len() {
            return Err(RefitError {
                built: self.triangles.len(),
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
