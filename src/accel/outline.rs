//! What the explorer draws of a built structure: its nodes (BVH nodes, k-d tree cells,
//! octree cells, grid cells) as boxes with their depth, children and triangles. A "level"
//! is whatever the structure's nodes at one depth are; the app draws what it is given.

use crate::geometry::Aabb;

/// One node as the explorer sees it. Children are contiguous in `Outline::nodes`.
#[derive(Clone, Debug, PartialEq)]
pub struct OutlineNode {
    /// The node's box (a BVH node's bounds, a k-d or octree cell, a grid cell).
    pub bounds: Aabb,
    pub depth: u32,
    /// `u32::MAX` for the root.
    pub parent: u32,
    pub first_child: u32,
    /// 0 for a leaf.
    pub child_count: u32,
    /// A leaf's triangle references: `Outline::refs[refs.0..refs.0 + refs.1]`.
    pub refs: (u32, u32),
    /// The split plane of a k-d tree node, as a flat box spanning the node's cell.
    pub plane: Option<Aabb>,
}

impl OutlineNode {
    pub fn is_leaf(&self) -> bool {
        self.child_count == 0
    }

    pub fn children(&self) -> std::ops::Range<usize> {
        self.first_child as usize..(self.first_child + self.child_count) as usize
    }
}

/// A structure's nodes for the levels view and the tree walk. Node 0 is the root.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outline {
    pub nodes: Vec<OutlineNode>,
    pub refs: Vec<u32>,
}

impl Outline {
    pub fn max_depth(&self) -> u32 {
        self.nodes.iter().map(|n| n.depth).max().unwrap_or(0)
    }

    /// Indices of the nodes at `depth`.
    pub fn level(&self, depth: u32) -> impl Iterator<Item = usize> + '_ {
        (0..self.nodes.len()).filter(move |&i| self.nodes[i].depth == depth)
    }

    /// A leaf's triangle references.
    pub fn leaf_refs(&self, node: usize) -> &[u32] {
        let (start, count) = self.nodes[node].refs;
        &self.refs[start as usize..(start + count) as usize]
    }

    /// The distinct scene triangles referenced under `node`, sorted.
    pub fn triangles_under(&self, node: usize) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![node];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if n.is_leaf() {
                out.extend_from_slice(self.leaf_refs(i));
            } else {
                stack.extend(n.children());
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The SAH cost of the tree these nodes are: Σ SA(n)/SA(root) · C(n), with C_trav for an
    /// interior node and C_isect for each reference in a leaf; every node weighs as the
    /// root under a flat root. A structure's own SAH cost is this of its outline.
    pub fn sah_cost(&self, c_trav: f32, c_isect: f32) -> f64 {
        let root = self
            .nodes
            .first()
            .map_or(0.0, |r| r.bounds.surface_area() as f64);
        self.nodes
            .iter()
            .map(|n| {
                let p = if root > 0.0 {
                    n.bounds.surface_area() as f64 / root
                } else {
                    1.0
                };
                p * if n.is_leaf() {
                    f64::from(c_isect) * f64::from(n.refs.1)
                } else {
                    f64::from(c_trav)
                }
            })
            .sum()
    }

    /// Checks the shape: children after their parent and pointing back to it, depths one
    /// more than the parent's, references in range. For tests of every structure.
    pub fn validate(&self) -> Result<(), String> {
        for (i, n) in self.nodes.iter().enumerate() {
            for c in n.children() {
                let child = self
                    .nodes
                    .get(c)
                    .ok_or(format!("node {i}: child {c} missing"))?;
                if child.parent as usize != i || c <= i || child.depth != n.depth + 1 {
                    return Err(format!("node {i}: child {c} does not point back"));
                }
            }
            if n.is_leaf() && (n.refs.0 + n.refs.1) as usize > self.refs.len() {
                return Err(format!("node {i}: references out of range"));
            }
        }
        Ok(())
    }
}
