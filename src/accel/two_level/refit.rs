//! Refit of the top level after one instance moved: the same TLAS, the leaf box of each of
//! the instance's references replaced by its new world box and each box above them
//! recomputed from its node's children, up to the root. A few dozen boxes per reference,
//! where a rebuild sorts every reference again; the tree keeps its shape (and the
//! references stay as they were opened), so a long drag loosens it until the next rebuild.

use super::Reference;
use crate::accel::bvh::Bvh8;
use crate::scene::Instance;
use std::collections::BTreeSet;

/// Where each reference and each TLAS node sits in its parent: made with the TLAS.
#[derive(Clone, Debug, Default)]
pub struct TopLevelIndex {
    /// Per reference: the (node, lane) whose leaf holds it.
    slot: Vec<(u32, u8)>,
    /// Per TLAS node: the (node, lane) that points to it (the root's is unused).
    parent: Vec<(u32, u8)>,
}

impl TopLevelIndex {
    pub fn new(tlas: &Bvh8, references: usize) -> Self {
        let mut slot = vec![(u32::MAX, 0u8); references];
        let mut parent = vec![(u32::MAX, 0u8); tlas.nodes.len()];
        for (n, node) in tlas.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                let c = node.child[lane] as usize;
                if node.is_interior(lane) {
                    parent[c] = (n as u32, lane as u8);
                } else {
                    for &r in &tlas.prim_indices[c..c + node.count[lane] as usize] {
                        slot[r as usize] = (n as u32, lane as u8);
                    }
                }
            }
        }
        TopLevelIndex { slot, parent }
    }

    /// The TLAS (node, lane) whose leaf holds reference `r`.
    pub fn slot_of(&self, r: usize) -> Option<(u32, u8)> {
        self.slot.get(r).copied().filter(|s| s.0 != u32::MAX)
    }
}

/// Puts the new world boxes of references `moved` into `tlas` and widens or shrinks every
/// box above them. `index` must have been made for `tlas` and `references`.
pub fn refit_references(
    tlas: &mut Bvh8,
    index: &TopLevelIndex,
    blases: &[Bvh8],
    instances: &[Instance],
    references: &[Reference],
    moved: std::ops::Range<usize>,
) {
    // Nodes whose boxes changed: their parents' lanes are set from them, deepest first
    // (children come after their parents, so the largest index first).
    let mut changed = BTreeSet::new();
    for r in moved {
        let Some((node, lane)) = index.slot_of(r) else {
            continue;
        };
        // The leaf lane's box: its reference's box (one reference a leaf, as built).
        let n = &tlas.nodes[node as usize];
        let first = n.child[lane as usize] as usize;
        let count = n.count[lane as usize] as usize;
        let leaf = tlas.prim_indices[first..first + count]
            .iter()
            .fold(crate::geometry::Aabb::EMPTY, |b, &k| {
                b.union(references[k as usize].world_box(instances, blases))
            });
        tlas.nodes[node as usize].set_child_bounds(lane as usize, leaf);
        changed.insert(node);
    }
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
