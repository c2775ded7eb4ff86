//! A binary tree held as child links, one primitive per leaf, with each node's box, primitive
//! count, height and SAH cost: the form LBVH builds and treelet restructuring rewrites. At the
//! end the SAH decides which subtrees become leaves, and the tree is laid out as the
//! canonical BVH2.

use super::PARALLEL_SUBTREE;
use crate::accel::bvh::node::{Node, Nodes};
use crate::geometry::Aabb;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

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
    /// sorted order. Two passes over the links, each parallel over large subtrees: the
    /// size of every subtree's BVH2, then the nodes written where those sizes put them
    /// (children in pairs, each pair's subtrees after it, left first), the leaves in order.
    pub fn to_bvh_nodes(&self, sah: &SahCost) -> (Nodes, Vec<u32>) {
        let sizes: Vec<AtomicU32> = (0..self.nodes.len())
            .into_par_iter()
            .map(|_| AtomicU32::new(0))
            .collect();
        let layout = Layout {
            nodes: &self.nodes,
            sah,
            sizes: &sizes,
        };
        let total = layout.size(0) as usize;
        let mut out = Vec::with_capacity(total);
        out.par_extend(rayon::iter::repeat_n(Node::default(), total));
        let mut order = vec![0u32; self.root().count as usize];
        let (root, rest) = out.split_at_mut(1);
        layout.fill(0, &mut root[0], rest, 1, &mut order, 0);
        (Nodes::from_flat(&out), order)
    }
}

/// `to_bvh_nodes`' passes over the links.
struct Layout<'a> {
    nodes: &'a [LinkedNode],
    sah: &'a SahCost,
    /// The BVH2 nodes each subtree becomes, once `size` has seen it.
    sizes: &'a [AtomicU32],
}

impl Layout<'_> {
    fn becomes_leaf(&self, n: &LinkedNode) -> bool {
        n.is_leaf() || {
            let (l, r) = (&self.nodes[n.left as usize], &self.nodes[n.right as usize]);
            self.sah.collapses(n, l.cost + r.cost)
        }
    }

    /// The BVH2 nodes the subtree of `id` becomes, kept for `fill`.
    fn size(&self, id: u32) -> u32 {
        let n = &self.nodes[id as usize];
        let size = if self.becomes_leaf(n) {
            1
        } else if n.count as usize >= PARALLEL_SUBTREE {
            let (l, r) = rayon::join(|| self.size(n.left), || self.size(n.right));
            1 + l + r
        } else {
            1 + self.size(n.left) + self.size(n.right)
        };
        self.sizes[id as usize].store(size, Ordering::Relaxed);
        size
    }

    /// The positions of the leaves under `id`, left first, into `order` (one per leaf): a
    /// recursion as deep as the links (at most the radix tree's 97 levels, which treelet
    /// restructuring never deepens past the traversal stack), with no allocation per leaf.
    fn leaves_under(&self, id: u32, order: &mut [u32]) {
        let n = &self.nodes[id as usize];
        if n.is_leaf() {
            order[0] = n.left;
            return;
        }
        let left_count = self.nodes[n.left as usize].count as usize;
        let (left, right) = order.split_at_mut(left_count);
        self.leaves_under(n.left, left);
        self.leaves_under(n.right, right);
    }

    /// Writes the subtree of `id`: its node into `slot`, its descendants into `below`
    /// (whose first is node `base`), and its leaves' positions into `order` (which starts
    /// at position `first` of the leaf order).
    fn fill(
        &self,
        id: u32,
        slot: &mut Node,
        below: &mut [Node],
        base: usize,
        order: &mut [u32],
        first: u32,
    ) {
        let n = &self.nodes[id as usize];
        if self.becomes_leaf(n) {
            *slot = Node::leaf(n.bounds, first, n.count);
            self.leaves_under(id, order);
            return;
        }
        *slot = Node::interior(n.bounds, base as u32);
        let (pair, rest) = below.split_at_mut(2);
        let (left_slot, right_slot) = pair.split_at_mut(1);
        let left_below = self.sizes[n.left as usize].load(Ordering::Relaxed) as usize - 1;
        let (left_rest, right_rest) = rest.split_at_mut(left_below);
        let left_count = self.nodes[n.left as usize].count;
        let (left_order, right_order) = order.split_at_mut(left_count as usize);
        let mut left = || {
            let slot = &mut left_slot[0];
            self.fill(n.left, slot, left_rest, base + 2, left_order, first)
        };
        let mut right = || {
            let (slot, at) = (&mut right_slot[0], base + 2 + left_below);
            self.fill(
                n.right,
                slot,
                right_rest,
                at,
                right_order,
                first + left_count,
            )
        };
        if n.count as usize >= PARALLEL_SUBTREE {
            rayon::join(left, right);
        } else {
            left();
            right();
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Rng;
    use glam::Vec3;

    /// A tree over `bounds` (positions `first..` of the order) split at the middle, its
    /// nodes appended to `out` in preorder; returns its root.
    fn halves(bounds: &[Aabb], first: u32, out: &mut Vec<LinkedNode>, sah: &SahCost) -> u32 {
        let id = out.len() as u32;
        if bounds.len() == 1 {
            out.push(LinkedNode::leaf(bounds[0], first, sah));
            return id;
        }
        out.push(LinkedNode::leaf(Aabb::EMPTY, 0, sah));
        let m = bounds.len() / 2;
        let left = halves(&bounds[..m], first, out, sah);
        let right = halves(&bounds[m..], first + m as u32, out, sah);
        let (l, r) = (out[left as usize], out[right as usize]);
        out[id as usize] = LinkedNode::interior(left, &l, right, &r, sah);
        id
    }

    /// The BVH2 under `i`, written out depth first: boxes, leaf ranges and the leaves'
    /// positions, with no node index in it.
    fn canonical(nodes: &Nodes, order: &[u32], i: usize, out: &mut Vec<u64>) {
        let n = nodes[i];
        out.extend(n.bounds().bits().map(u64::from));
        if n.is_leaf() {
            out.push(n.count as u64);
            out.extend(n.prim_range().map(|k| order[k] as u64));
        } else {
            canonical(nodes, order, n.left_first as usize, out);
            canonical(nodes, order, n.left_first as usize + 1, out);
        }
    }

    /// The parallel layout makes the tree of one walk down the links: the same leaves
    /// where the SAH collapses subtrees, the same boxes and leaf order, on a tree large
    /// enough for both passes to run their subtrees in parallel.
    #[test]
    fn the_parallel_layout_matches_a_walk_down_the_links() {
        let sah = SahCost {
            c_trav: 1.0,
            c_isect: 1.0,
            max_leaf_size: 8,
        };
        let mut rng = Rng::for_case(7, 0);
        let n = 5 * PARALLEL_SUBTREE + 123;
        let bounds: Vec<Aabb> = (0..n)
            .map(|i| {
                // Boxes along a line, some of them large: leaves of several sizes.
                let lo = Vec3::new(i as f32, rng.unit() as f32, 0.0);
                let size = if rng.below(5) == 0 { 40.0 } else { 0.5 };
                Aabb::new(lo, lo + Vec3::splat(size * rng.unit() as f32))
            })
            .collect();
        let mut nodes = Vec::new();
        halves(&bounds, 0, &mut nodes, &sah);
        let tree = LinkedTree { nodes };
        let (got, order) = tree.to_bvh_nodes(&sah);
        // The walk: a stack of (link, its BVH2 slot), children appended in pairs.
        let mut flat = vec![Node::default()];
        let mut walk_order = Vec::new();
        let mut stack = vec![(0u32, 0usize)];
        while let Some((id, slot)) = stack.pop() {
            let n = &tree.nodes[id as usize];
            let leaf = n.is_leaf() || {
                let (l, r) = (&tree.nodes[n.left as usize], &tree.nodes[n.right as usize]);
                sah.collapses(n, l.cost + r.cost)
            };
            if leaf {
                let first = walk_order.len() as u32;
                let mut under = vec![id];
                while let Some(g) = under.pop() {
                    let m = &tree.nodes[g as usize];
                    if m.is_leaf() {
                        walk_order.push(m.left);
                    } else {
                        under.push(m.right);
                        under.push(m.left);
                    }
                }
                flat[slot] = Node::leaf(n.bounds, first, n.count);
            } else {
                let pair = flat.len();
                flat.extend([Node::default(); 2]);
                flat[slot] = Node::interior(n.bounds, pair as u32);
                stack.push((n.right, pair + 1));
                stack.push((n.left, pair));
            }
        }
        let walked = Nodes::from_flat(&flat);
        assert_eq!(order, walk_order);
        assert_eq!(got.len(), walked.len());
        let leaves = (0..got.len()).filter(|&i| got[i].is_leaf()).count();
        assert!(
            leaves > 1000 && leaves < n,
            "{leaves} leaves: some subtrees collapse"
        );
        let (mut a, mut b) = (Vec::new(), Vec::new());
        canonical(&got, &order, 0, &mut a);
        canonical(&walked, &walk_order, 0, &mut b);
        assert_eq!(a, b);
    }
}
