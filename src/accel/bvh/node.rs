//! The 32-byte BVH2 node: a box and either the index of the first of two adjacent children
//! or the range of a leaf's triangles. Two nodes fill one 64-byte cache line.

use crate::geometry::Aabb;
use crate::geometry::simd::prefetch;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Node {
    /// The box as its two corners, [min, max]: the slab test picks each axis's near plane
    /// by index instead of by comparison.
    pub corners: [Vec3; 2],
    /// Interior: index of the left child (the right child follows it).
    /// Leaf: index of the first triangle in leaf order.
    pub left_first: u32,
    /// Number of triangles of a leaf; `INTERIOR` marks an interior node. (A leaf may hold
    /// zero triangles: the root of an empty scene.)
    pub count: u32,
}

/// The `count` of an interior node.
pub const INTERIOR: u32 = u32::MAX;

impl Default for Node {
    fn default() -> Self {
        Node::interior(Aabb::EMPTY, 0)
    }
}

impl Node {
    pub fn leaf(bounds: Aabb, first: u32, count: u32) -> Self {
        Node {
            corners: [bounds.min, bounds.max],
            left_first: first,
            count,
        }
    }

    pub fn interior(bounds: Aabb, left: u32) -> Self {
        Node {
            corners: [bounds.min, bounds.max],
            left_first: left,
            count: INTERIOR,
        }
    }

    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count != INTERIOR
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.corners[0], self.corners[1])
    }

    pub fn set_bounds(&mut self, b: Aabb) {
        self.corners = [b.min, b.max];
    }

    /// The leaf's triangles as a range of leaf-order indices.
    pub fn prim_range(&self) -> std::ops::Range<usize> {
        self.left_first as usize..(self.left_first + self.count) as usize
    }
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

/// Two sibling nodes: one 64-byte cache line, so a traversal step that tests both children
/// of a node touches one line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct NodePair(pub [Node; 2]);

/// The nodes of a tree, numbered from 0 (the root); every interior node's children are the
/// pair at odd index `left_first` and `left_first + 1`, stored as one aligned `NodePair`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Nodes {
    root: Node,
    pairs: Vec<NodePair>,
}

impl Nodes {
    /// From nodes in the flat numbering (root, then children pairs from index 1).
    pub fn from_flat(flat: &[Node]) -> Self {
        let (root, rest) = flat
            .split_first()
            .map_or((Node::default(), &[][..]), |(r, rest)| (*r, rest));
        Nodes {
            root,
            pairs: rest
                .chunks_exact(2)
                .map(|c| NodePair([c[0], c[1]]))
                .collect(),
        }
    }

    /// The reachable nodes of `slots` (a tree numbered as `Nodes` is, with unused slots
    /// between), copied into depth-first order with each pair of children adjacent,
    /// dropping the unused slots. Parents keep coming before their children. The pairs go
    /// straight into the tree's `Nodes` (copied there from a flat array once more, they took a
    /// third as long again), and a pair's children's pair is asked for as it is copied: the
    /// slots are read in their order, but with gaps the hardware does not follow.
    pub fn compact(slots: &[Node]) -> Nodes {
        let mut out = Nodes::with_capacity(slots[0], slots.len() / 2);
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = out[i];
            if node.is_leaf() {
                continue;
            }
            let old = node.left_first as usize;
            let pair = [slots[old], slots[old + 1]];
            for child in pair.iter().filter(|c| !c.is_leaf()) {
                prefetch(slots.as_ptr().wrapping_add(child.left_first as usize));
            }
            let new = out.push_pair(pair);
            out[i].left_first = new as u32;
            stack.push(new + 1);
            stack.push(new);
        }
        out
    }

    /// A tree of `root` alone, with room for `pairs` sibling pairs to be pushed below it.
    fn with_capacity(root: Node, pairs: usize) -> Self {
        Nodes {
            root,
            pairs: Vec::with_capacity(pairs),
        }
    }

    /// Appends a sibling pair; returns the index of its first node.
    fn push_pair(&mut self, pair: [Node; 2]) -> usize {
        self.pairs.push(NodePair(pair));
        2 * self.pairs.len() - 1
    }

    pub fn len(&self) -> usize {
        1 + 2 * self.pairs.len()
    }

    pub fn is_empty(&self) -> bool {
        false
    }

    /// Every node but the root, as sibling pairs.
    pub fn pairs(&self) -> &[NodePair] {
        &self.pairs
    }

    /// The children of an interior node whose `left_first` is `left`.
    #[inline(always)]
    pub fn pair(&self, left: usize) -> &[Node; 2] {
        &self.pairs[(left - 1) >> 1].0
    }

    pub fn iter(&self) -> impl Iterator<Item = &Node> {
        std::iter::once(&self.root).chain(self.pairs.iter().flat_map(|p| p.0.iter()))
    }
}

impl std::ops::Index<usize> for Nodes {
    type Output = Node;

    #[inline(always)]
    fn index(&self, i: usize) -> &Node {
        if i == 0 {
            &self.root
        } else {
            &self.pairs[(i - 1) >> 1].0[(i - 1) & 1]
        }
    }
}

impl std::ops::IndexMut<usize> for Nodes {
    fn index_mut(&mut self, i: usize) -> &mut Node {
        if i == 0 {
            &mut self.root
        } else {
            &mut self.pairs[(i - 1) >> 1].0[(i - 1) & 1]
        }
    }
}
