//! The levels view and the tree walk over what the worker outlined: one structure's nodes,
//! or under the two levels the top level's nodes with the selected instance's BLAS below
//! them. The levels run 0..=the top level's depth, then the BLAS's levels follow one by
//! one; in the walk a top-level leaf that holds one of the instance's references has that
//! reference's subtree as its only child (the BLAS's root for an instance left whole; an
//! opened instance's nodes above its references are in the levels but not on the walk, as
//! no ray visits them). Walk nodes are numbered as the outline numbers its nodes, the
//! BLAS's after them.

use crate::accel::Outline;
use crate::accel::two_level::InstanceOutline;

/// A node of the walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkNode {
    /// A node of the outline (under the two levels, of the top level).
    Top(usize),
    /// A node of the selected instance's BLAS.
    Bottom(usize),
}

/// The outline and, under the two levels, the selected instance's BLAS.
#[derive(Clone, Copy)]
pub struct Levels<'a> {
    pub outline: &'a Outline,
    pub instance: Option<&'a InstanceOutline>,
}

impl<'a> Levels<'a> {
    pub fn new(outline: &'a Outline, instance: Option<&'a InstanceOutline>) -> Self {
        // A BLAS hangs below a top-level leaf only: without one it is not part of the tree.
        let instance = instance.filter(|i| {
            !i.entries.is_empty()
                && i.entries.iter().all(|e| {
                    outline
                        .nodes
                        .get(e.tlas_leaf as usize)
                        .is_some_and(|n| n.is_leaf())
                        && (e.blas_node as usize) < i.blas.nodes.len()
                })
        });
        Levels { outline, instance }
    }

    /// The deepest level of the outline alone.
    pub fn top_depth(&self) -> u32 {
        self.outline.max_depth()
    }

    /// The level of the BLAS's root: one below the top level's deepest.
    pub fn first_bottom_level(&self) -> u32 {
        self.top_depth() + 1
    }

    pub fn max_depth(&self) -> u32 {
        match self.instance {
            Some(i) => self.first_bottom_level() + i.blas.max_depth(),
            None => self.top_depth(),
        }
    }

    /// The nodes at level `depth`.
    pub fn level(&self, depth: u32) -> Vec<WalkNode> {
        if depth <= self.top_depth() {
            return self.outline.level(depth).map(WalkNode::Top).collect();
        }
        match self.instance {
            Some(i) => i
                .blas
                .level(depth - self.first_bottom_level())
                .map(WalkNode::Bottom)
                .collect(),
            None => Vec::new(),
        }
    }

    pub fn node(&self, id: u32) -> Option<WalkNode> {
        let id = id as usize;
        let top = self.outline.nodes.len();
        if id < top {
            return Some(WalkNode::Top(id));
        }
        let i = self.instance?;
        (id - top < i.blas.nodes.len()).then_some(WalkNode::Bottom(id - top))
    }

    pub fn id(&self, node: WalkNode) -> u32 {
        match node {
            WalkNode::Top(k) => k as u32,
            WalkNode::Bottom(k) => (self.outline.nodes.len() + k) as u32,
        }
    }

    /// The node's level in the levels view.
    pub fn depth(&self, node: WalkNode) -> u32 {
        match node {
            WalkNode::Top(k) => self.outline.nodes[k].depth,
            WalkNode::Bottom(k) => {
                self.first_bottom_level() + self.instance.map_or(0, |i| i.blas.nodes[k].depth)
            }
        }
    }

    pub fn parent(&self, node: WalkNode) -> Option<WalkNode> {
        match node {
            WalkNode::Top(k) => {
                let p = self.outline.nodes[k].parent;
                (p != u32::MAX).then_some(WalkNode::Top(p as usize))
            }
            WalkNode::Bottom(k) => {
                let i = self.instance?;
                if let Some(leaf) = i.leaf_above(k as u32) {
                    return Some(WalkNode::Top(leaf as usize));
                }
                match i.blas.nodes[k].parent {
                    u32::MAX => None,
                    p => Some(WalkNode::Bottom(p as usize)),
                }
            }
        }
    }

    pub fn children(&self, node: WalkNode) -> Vec<WalkNode> {
        match node {
            WalkNode::Top(k) => {
                let n = &self.outline.nodes[k];
                let entry = self.instance.and_then(|i| i.entry_below(k as u32));
                match entry {
                    Some(b) if n.is_leaf() => vec![WalkNode::Bottom(b as usize)],
                    _ => n.children().map(WalkNode::Top).collect(),
                }
            }
            WalkNode::Bottom(k) => self.instance.map_or(Vec::new(), |i| {
                i.blas.nodes[k].children().map(WalkNode::Bottom).collect()
            }),
        }
    }
}

impl Levels<'_> {
    /// The top-level leaf a walk node of the BLAS hangs below (the node itself if it is of
    /// the top level).
    pub fn top_above(&self, node: WalkNode) -> Option<usize> {
        let mut at = node;
        loop {
            match at {
                WalkNode::Top(k) => return Some(k),
                WalkNode::Bottom(_) => at = self.parent(at)?,
            }
        }
    }
}
