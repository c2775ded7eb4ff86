//! Refit of the top level after one instance moved: the same TLAS, the leaf box of each of
//! the instance's references replaced by its new world box and each box above them
//! recomputed from its node's children, up to the root: a few dozen boxes per reference
//! (or, for an instance opened into very many, one pass over every node), where a rebuild
//! sorts every reference again. The tree keeps its shape (and the references stay as they
//! were opened), so a long drag loosens it until the next rebuild.

use crate::accel::bvh::Bvh8;
use crate::geometry::Aabb;
use std::collections::BTreeSet;

/// Where each reference and each TLAS node sits in its parent: made with the TLAS.
#[derive(Clone, Debug, Default)]
pub struct TopLevelIndex {
    /// Per reference: the (node, lane) whose leaf holds it.
    slot: Vec<(u32, u8)>,
    /// Per reference: its index in `prim_indices` (its `TwoLevel::leaves` entry).
    leaf_slot: Vec<u32>,
    /// Per TLAS node: the (node, lane) that points to it (the root's is unused).
    parent: Vec<(u32, u8)>,
}

impl TopLevelIndex {
    pub fn new(tlas: &Bvh8, references: usize) -> Self {
        let mut slot = vec![(u32::MAX, 0u8); references];
        let mut leaf_slot = vec![u32::MAX; references];
        let mut parent = vec![(u32::MAX, 0u8); tlas.nodes.len()];
        for (n, node) in tlas.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                if let Some(c) = node.interior(lane) {
                    parent[c] = (n as u32, lane as u8);
                } else {
                    for k in node.child[lane].slots() {
                        let r = tlas.prim_indices[k] as usize;
                        slot[r] = (n as u32, lane as u8);
                        leaf_slot[r] = k as u32;
                    }
                }
            }
        }
        TopLevelIndex {
            slot,
            leaf_slot,
            parent,
        }
    }

    /// The index in the TLAS's `prim_indices` of reference `r`.
    pub fn leaf_slot_of(&self, r: usize) -> Option<usize> {
        self.leaf_slot
            .get(r)
            .filter(|&&k| k != u32::MAX)
            .map(|&k| k as usize)
    }

    /// The TLAS (node, lane) whose leaf holds reference `r`.
    pub fn slot_of(&self, r: usize) -> Option<(u32, u8)> {
        self.slot.get(r).copied().filter(|s| s.0 != u32::MAX)
    }
}

/// A moved instance's reference: its new world box, and where the TLAS holds it
/// (`slot_of`) and its leaf slot (`leaf_slot_of`), looked up with the box.
#[derive(Clone, Copy, Debug)]
pub struct MovedReference {
    pub bounds: Aabb,
    pub slot: Option<(u32, u8)>,
    pub reference: u32,
    pub leaf_slot: Option<u32>,
}

/// Puts the new world boxes of the references in `moved` into `tlas` and widens or shrinks
/// every box above them. `index` must have been made for `tlas`.
pub fn refit_references(tlas: &mut Bvh8, index: &TopLevelIndex, moved: &[MovedReference]) {
    // One reference a leaf, as built: its box is the leaf's.
    let leaves = || moved.iter().filter_map(|m| Some((m.slot?, m.bounds)));
    for ((node, lane), bounds) in leaves() {
        tlas.nodes[node as usize].set_child_bounds(lane as usize, bounds);
    }
    if moved.len() * FULL_PASS > tlas.nodes.len() {
        // So many leaves moved that most nodes lie above one: one pass over every node,
        // children before parents, costs less than the paths one by one.
        // Each node's box is set in its parent's lane once its own lanes are final.
        for n in (1..tlas.nodes.len()).rev() {
            let (p, l) = index.parent[n];
            let bounds = tlas.nodes[n].bounds();
            tlas.nodes[p as usize].set_child_bounds(l as usize, bounds);
        }
        return;
    }
    // Nodes whose boxes changed: their parents' lanes are set from them, deepest first
    // (children come after their parents, so the largest index first).
    let mut changed: BTreeSet<u32> = leaves().map(|((node, _), _)| node).collect();
    while let Some(node) = changed.pop_last() {
        if node == 0 {
            continue;
        }
        let (p, l) = index.parent[node as usize];
        let bounds = tlas.nodes[node as usize].bounds();
        tlas.nodes[p as usize].set_child_bounds(l as usize, bounds);
        changed.insert(p);
    }
}

/// Past one moved leaf per this many TLAS nodes, the refit recomputes every node.
const FULL_PASS: usize = 16;
