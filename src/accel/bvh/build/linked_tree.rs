//! A binary tree held as child links, one primitive per leaf, with each node's box, primitive
//! count, height and SAH cost: the form LBVH builds and treelet restructuring rewrites. At the
//! end the SAH decides which subtrees become leaves, and the tree is laid out as the
//! canonical BVH2.

use super::PARALLEL_SUBTREE;
use crate::accel::bvh::node::{Node, Nodes};
use crate::geometry::Aabb;

/// The `right` of a leaf.
const LEAF: u32 = u32::MAX;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkedNode {
    pub bounds: Aabb,
    /// Interior: the left child. Leaf: the primitive's position in the sorted order.
    pub left: u32,
    /// Interior: the right child. Leaf: `LEAF`.
    pub right: u32,
    /// Primitives in the subtree.
    pub count: u32,
    /// Edges on the longest path down to a leaf.
    pub height: u32,
    /// SAH cost of the subtree in units of area, with every subtree that is cheaper as one
    /// leaf counted as that leaf (Karras and Aila 2013, eq. 2).
    pub cost: f64,
}

/// The SAH of Karras and Aila (2013, eq. 2): C(n) = C_isect·A(n)·N(n) for a leaf;
/// C(n) = min(C_isect·A(n)·N(n), C_trav·A(n) + C(left) + C(right)) for an interior node,
/// the first term only when N(n) fits in a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SahCost {
    pub c_trav: f64,
    pub c_isect: f64,
    pub max_leaf_size: u32,
}

impl SahCost {
    pub fn leaf(&self, area: f64, count: u32) -> f64 {
        self.c_isect * area * count as f64
    }

    /// The cost of a node over `count` primitives in a box of `area` whose two children
    /// together cost `children`.
    pub fn interior(&self, area: f64, count: u32, children: f64) -> f64 {
        let split = self.c_trav * area + children;
        if count <= self.max_leaf_size {
            split.min(self.leaf(area, count))
        } else {
            split
        }
    }

    /// Whether the node is cheaper as a leaf than with its children (ties become leaves).
    fn collapses(&self, n: &LinkedNode, children: f64) -> bool {
        let area = n.bounds.surface_area() as f64;
        n.count <= self.max_leaf_size && self.leaf(area, n.count) <= self.c_trav * area + children
    }
}

impl LinkedNode {
    pub fn leaf(bounds: Aabb, position: u32, sah: &SahCost) -> Self {
        LinkedNode {
            bounds,
            left: position,
            right: LEAF,
            count: 1,
            height: 0,
            cost: sah.leaf(bounds.surface_area() as f64, 1),
        }
    }

    /// The interior node with children `l` (id `left`) and `r` (id `right`).
    pub fn interior(left: u32, l: &LinkedNode, right: u32, r: &LinkedNode, sah: &SahCost) -> Self {
        let bounds = l.bounds.union(r.bounds);
        let count = l.count + r.count;
        LinkedNode {
            bounds,
            left,
            right,
            count,
            height: 1 + l.height.max(r.height),
            cost: sah.interior(bounds.surface_area() as f64, count, l.cost + r.cost),
        }
    }

    pub fn is_leaf(&self) -> bool {
        self.right == LEAF
    }

    /// Nodes in the subtree (every interior node has two children).
    pub fn size(&self) -> usize {
        2 * self.count as usize - 1
    }
}

/// The tree; node 0 is the root. `preorder` lays it out so that every subtree is a
/// contiguous range starting at its root, left subtree first.
#[derive(Clone, Debug)]
pub struct LinkedTree {
    pub nodes: Vec<LinkedNode>,
}

impl LinkedTree {
    pub fn root(&self) -> &LinkedNode {
        &self.nodes[0]
    }

    /// The tree's SAH cost, normalised by the root's area as `Bvh::sah_cost` is.
    pub fn sah_cost(&self, sah: &SahCost) -> f64 {
        let root = self.root();
        let area = root.bounds.surface_area() as f64;
        if area <= 0.0 {
            sah.c_isect * root.count as f64
        } else {
            root.cost / area
        }
    }

    /// The same tree with its nodes in preorder.
    pub fn preorder(&self) -> LinkedTree {
        let mut out = vec![self.nodes[0]; self.nodes.len()];
        copy_preorder(&self.nodes, 0, &mut out, 0);
        LinkedTree { nodes: out }
    }

    /// The canonical BVH2: a subtree becomes one leaf where the SAH says it is no dearer
    /// (`SahCost::collapses`). Returns the nodes and the leaf order as positions in the
    /// sorted order.
    pub fn to_bvh_nodes(&self, sah: &SahCost) -> (Nodes, Vec<u32>) {
        let nodes = &self.nodes;
        let mut out = vec![Node::default()];
        let mut order = Vec::with_capacity(self.root().count as usize);
        let mut stack = vec![(0u32, 0usize)];
        let mut gather = Vec::new();
        while let Some((id, slot)) = stack.pop() {
            let n = &nodes[id as usize];
            let collapse = n.is_leaf() || {
                let (l, r) = (&nodes[n.left as usize], &nodes[n.right as usize]);
                sah.collapses(n, l.cost + r.cost)
            };
            if collapse {
                let first = order.len() as u32;
                gather.push(id);
                while let Some(g) = gather.pop() {
                    let m = &nodes[g as usize];
                    if m.is_leaf() {
                        order.push(m.left);
                    } else {
                        gather.push(m.right);
                        gather.push(m.left);
                    }
                }
                out[slot] = Node::leaf(n.bounds, first, n.count);
            } else {
                let pair = out.len();
                out.extend([Node::default(); 2]);
                out[slot] = Node::interior(n.bounds, pair as u32);
                stack.push((n.right, pair + 1));
                stack.push((n.left, pair));
            }
        }
        (Nodes::from_flat(&out), order)
    }
}

/// Copies the subtree of `old[id]` into `out` in preorder, `out[0]` being node `base`.
fn copy_preorder(old: &[LinkedNode], id: u32, out: &mut [LinkedNode], base: u32) {
    let n = old[id as usize];
    if n.is_leaf() {
        out[0] = n;
        return;
    }
    let left_size = old[n.left as usize].size();
    let (head, rest) = out.split_at_mut(1);
    let (lo, ro) = rest.split_at_mut(left_size);
    let (left, right) = (base + 1, base + 1 + left_size as u32);
    let mut l = || copy_preorder(old, n.left, lo, left);
    let mut r = || copy_preorder(old, n.right, ro, right);
    if n.count as usize >= PARALLEL_SUBTREE {
        rayon::join(l, r);
    } else {
        l();
        r();
    }
    head[0] = LinkedNode { left, right, ..n };
}
