//! Which node of a structure's outline (the tree the explorer and the hierarchy diagram
//! draw) a replay's visit step is. The traversals name what they visit in their own
//! numbering: a BVH2 or octree node by its index, which the outline keeps; a wide BVH's
//! interior node by its index and its leaf by its first triangle slot; a k-d tree's node
//! by its index, which the outline renumbers breadth first. The two-level structure's
//! outline is its top level, so only the top level's visits are in it.

use super::bvh::wide::{Lanes, NodeWidth, WideBvh};
use super::replay::{Level, Step, Visited};
use super::structure::Structure;
use std::collections::HashMap;

/// Maps the visits of one built structure to its outline's nodes.
#[derive(Clone, Debug)]
pub struct VisitIndex {
    /// The level whose visits the outline shows.
    level: Level,
    numbering: Numbering,
}

#[derive(Clone, Debug)]
enum Numbering {
    /// The outline keeps the structure's numbers (BVH2, octree).
    Same(usize),
    /// Nodes through a table; a wide BVH's leaves through a table of their own, by the
    /// first slot their visits carry.
    Table {
        nodes: Vec<u32>,
        leaves: Option<HashMap<u32, u32>>,
    },
    /// No hierarchy to show (grid, brute force).
    Nothing,
}

impl VisitIndex {
    pub fn of(structure: &Structure) -> Self {
        let (level, numbering) = match structure {
            Structure::Bvh(b) => (Level::Single, Numbering::Same(b.nodes.len())),
            Structure::Octree(o) => (Level::Single, Numbering::Same(o.nodes.len())),
            Structure::Bvh4(w) => (Level::Single, wide(w)),
            Structure::Bvh8(w) => (Level::Single, wide(w)),
            Structure::TwoLevel(t) => (Level::Top, wide(&t.tlas)),
            Structure::KdTree(k) => {
                let nodes = k.outline_index();
                (
                    Level::Single,
                    Numbering::Table {
                        nodes,
                        leaves: None,
                    },
                )
            }
            Structure::Grid(_) | Structure::BruteForce(_) => (Level::Single, Numbering::Nothing),
        };
        VisitIndex { level, numbering }
    }

    /// The outline node `step` visits, or `None` for a step that is not a visit, a visit
    /// of another level (a BLAS's node), or a structure without a hierarchy.
    pub fn node(&self, step: &Step) -> Option<u32> {
        let Step::Visit {
            node, what, level, ..
        } = *step
        else {
            return None;
        };
        if level != self.level {
            return None;
        }
        match &self.numbering {
            Numbering::Same(n) => ((node as usize) < *n).then_some(node),
            Numbering::Table {
                leaves: Some(leaves),
                ..
            } if what == Visited::Leaf => leaves.get(&node).copied(),
            Numbering::Table { nodes, .. } => {
                nodes.get(node as usize).copied().filter(|&i| i != u32::MAX)
            }
            Numbering::Nothing => None,
        }
    }

    /// The outline nodes of `steps`' visits, in the order they were visited.
    pub fn path(&self, steps: &[Step]) -> Vec<u32> {
        steps.iter().filter_map(|s| self.node(s)).collect()
    }
}

/// A wide BVH: interior nodes by the outline's breadth-first numbering, leaves by their
/// first slot (which the outline's leaf keeps as its references' start).
fn wide<const W: usize>(w: &WideBvh<W>) -> Numbering
where
    Lanes<W>: NodeWidth,
{
    let outline = w.outline();
    let leaves = outline
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.is_leaf())
        .map(|(k, n)| (n.refs.0, k as u32))
        .collect();
    Numbering::Table {
        nodes: w.outline_index(),
        leaves: Some(leaves),
    }
}
