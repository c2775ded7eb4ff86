//! Treelet restructuring (Karras and Aila 2013, §4): walk the tree bottom-up; at each node grow
//! a treelet of n leaves by repeatedly opening the treelet leaf with the largest surface area,
//! find the topology over those leaves with the lowest SAH cost by dynamic programming over
//! leaf subsets, and rebuild the treelet that way, reusing its internal nodes. A node is only
//! rewritten when that is strictly cheaper, so the SAH cost of the tree never goes up.
//!
//! In parallel: the tree is in preorder, every subtree a contiguous range, so the two
//! children's ranges are restructured by `rayon::join` before their parent, the same order
//! as the paper's per-node counters (the second child to finish continues upwards) but
//! deterministic by construction.

use super::MAX_DEPTH;
use super::PARALLEL_SUBTREE;
use super::linked_tree::{LinkedNode, LinkedTree, SahCost};
use super::partitions;
use super::subset_terms::SubsetTerms;
use crate::geometry::Aabb;
use crate::geometry::simd::SimdLevel;
use std::cell::RefCell;

/// Treelet sizes the restructuring supports.
pub const MIN_TREELET: usize = 5;
pub const MAX_TREELET: usize = 9;
const SUBSETS: usize = 1 << MAX_TREELET;

/// One round over `tree`, which must be in preorder: every node with at least `gamma`
/// primitives roots a treelet of up to `size` leaves.
pub fn restructure(tree: &mut LinkedTree, size: usize, gamma: u32, sah: &SahCost) {
    let size = size.clamp(MIN_TREELET, MAX_TREELET);
    let round = Round { size, gamma, sah };
    round.subtree(&mut tree.nodes, 0, 0);
}

struct Round<'a> {
    size: usize,
    gamma: u32,
    sah: &'a SahCost,
}

impl Round<'_> {
    /// Restructures the subtree in `nodes` (node `base` at `nodes[0]`, at `depth` below the
    /// root): first both children's subtrees, then the treelet rooted here.
    fn subtree(&self, nodes: &mut [LinkedNode], base: u32, depth: u32) {
        let n = nodes[0];
        // A subtree smaller than γ holds no node that roots a treelet: nothing in it changes.
        if n.is_leaf() || n.count < self.gamma.max(3) {
            return;
        }
        debug_assert_eq!(n.left, base + 1, "the tree is in preorder");
        let left_size = nodes[1].size();
        {
            let (lo, ro) = nodes[1..].split_at_mut(left_size);
            let (left, right) = (n.left, n.right);
            let mut l = || self.subtree(lo, left, depth + 1);
            let mut r = || self.subtree(ro, right, depth + 1);
            if n.count as usize >= PARALLEL_SUBTREE {
                rayon::join(l, r);
            } else {
                l();
                r();
            }
        }
        // The children may have changed cost and height (never their boxes).
        let (l, r) = (nodes[1], nodes[1 + left_size]);
        nodes[0] = LinkedNode::interior(n.left, &l, n.right, &r, self.sah);
        if n.count >= self.gamma.max(3) {
            // Any height up to what the depth bound leaves below this node is allowed, and
            // beyond that no more than the node already has: the tree never gets deeper
            // than `MAX_DEPTH` unless it already was.
            let budget = (MAX_DEPTH as u32).saturating_sub(depth);
            self.treelet(nodes, base, budget);
        }
    }

    /// Forms the treelet rooted at `nodes[0]` and rebuilds it with the optimal topology if
    /// that is cheaper. Kept out of line so that its arrays do not sit in every frame of the
    /// recursion.
    #[inline(never)]
    fn treelet(&self, nodes: &mut [LinkedNode], base: u32, height_budget: u32) {
        let t = Treelet::grow(nodes, base, self.size);
        if t.m < 3 {
            return;
        }
        TABLES.with_borrow_mut(|opt| {
            opt.solve(t.leaf_nodes(), self.sah);
            self.rebuild(nodes, base, height_budget, &t, opt);
        });
    }

    /// Rebuilds treelet `t` rooted at `nodes[0]` with the topology `opt` found, if that is
    /// cheaper and no higher than allowed.
    fn rebuild(
        &self,
        nodes: &mut [LinkedNode],
        base: u32,
        height_budget: u32,
        t: &Treelet,
        opt: &Optimal,
    ) {
        let at = |id: u32| (id - base) as usize;
        let root = nodes[0];
        let (leaves, internal) = (&t.leaves[..t.m], &t.internal);
        let full = (1u32 << t.m) - 1;
        let cost = opt.cost[full as usize];
        if cost >= root.cost || opt.height(full, t.leaf_nodes()) > height_budget.max(root.height) {
            return;
        }
        // Rebuild, parents before children: subset `full` at the root, every other subset
        // of two or more leaves in the next of the treelet's internal nodes.
        // (subset, node, left child, right child)
        let mut placed = [(0u32, 0u32, 0u32, 0u32); MAX_TREELET - 1];
        placed[0] = (full, base, 0, 0);
        let mut count = 1;
        let mut k = 0;
        while k < count {
            let s = placed[k].0;
            let p = opt.split_of(s);
            let mut ids = [0u32; 2];
            for (side, part) in [p, s ^ p].into_iter().enumerate() {
                ids[side] = if part.is_power_of_two() {
                    leaves[part.trailing_zeros() as usize]
                } else {
                    placed[count] = (part, internal[count], 0, 0);
                    count += 1;
                    internal[count - 1]
                };
            }
            (placed[k].2, placed[k].3) = (ids[0], ids[1]);
            k += 1;
        }
        debug_assert_eq!(count, t.m - 1);
        // Children before parents, so each node is computed from its final children.
        for &(s, id, li, ri) in placed[..count].iter().rev() {
            let (l, r) = (nodes[at(li)], nodes[at(ri)]);
            nodes[at(id)] = LinkedNode::interior(li, &l, ri, &r, self.sah);
            debug_assert_eq!(nodes[at(id)].cost, opt.cost[s as usize]);
        }
    }
}

/// A treelet: its leaves (node ids, and what the dynamic program needs of them) and its
/// internal nodes, the root first.
struct Treelet {
    m: usize,
    leaves: [u32; MAX_TREELET],
    leaf_nodes: [TreeletLeaf; MAX_TREELET],
    internal: [u32; MAX_TREELET - 1],
}

impl Treelet {
    /// Grows the treelet rooted at `nodes[0]` (node `base`) from its two children by
    /// opening the treelet leaf with the largest surface area until it has `size` leaves
    /// or none can be opened.
    fn grow(nodes: &[LinkedNode], base: u32, size: usize) -> Treelet {
        let at = |id: u32| (id - base) as usize;
        let root = &nodes[0];
        let mut leaves = [0u32; MAX_TREELET];
        let mut internal = [0u32; MAX_TREELET - 1];
        leaves[0] = root.left;
        leaves[1] = root.right;
        internal[0] = base;
        let mut m = 2;
        while m < size {
            let mut best: Option<(usize, f32)> = None;
            for (k, &id) in leaves[..m].iter().enumerate() {
                let node = &nodes[at(id)];
                if !node.is_leaf() {
                    let area = node.bounds.surface_area();
                    if best.is_none_or(|(_, a)| area > a) {
                        best = Some((k, area));
                    }
                }
            }
            let Some((k, _)) = best else { break };
            let opened = &nodes[at(leaves[k])];
            internal[m - 1] = leaves[k];
            leaves[k] = opened.left;
            leaves[m] = opened.right;
            m += 1;
        }
        let leaf_nodes = std::array::from_fn(|k| {
            let node = &nodes[at(leaves[k.min(m - 1)])];
            TreeletLeaf {
                bounds: node.bounds,
                count: node.count,
                cost: node.cost,
                height: node.height,
            }
        });
        Treelet {
            m,
            leaves,
            leaf_nodes,
            internal,
        }
    }

    fn leaf_nodes(&self) -> &[TreeletLeaf] {
        &self.leaf_nodes[..self.m]
    }
}

/// What the dynamic program needs to know of a treelet leaf (a whole subtree below it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeletLeaf {
    pub bounds: Aabb,
    pub count: u32,
    /// The subtree's SAH cost (`LinkedNode::cost`).
    pub cost: f64,
    pub height: u32,
}

thread_local! {
    /// One set of tables per thread: treelets are many and small, their tables are not.
    static TABLES: RefCell<Box<Optimal>> = RefCell::new(Box::new(Optimal::EMPTY));
}

/// The optimal treelet topology over up to 9 leaves (Karras and Aila 2013, Algorithm 2):
/// for every subset S of the leaves, in increasing order so that its subsets come first,
/// C(S) = C_trav·A(S) + min over partitions {P, S∖P} of C(P) + C(S∖P), or the cost of S as
/// one leaf when that is lower.
pub struct Optimal {
    /// `cost[S]`: the lowest cost of a subtree over subset S of the leaves.
    pub cost: [f64; SUBSETS],
    /// `split[S]`: the part P of S that goes left in that subtree. Filled by `new`; after
    /// `solve` alone, `split_of` finds it for the few subsets a rebuild needs.
    pub split: [u16; SUBSETS],
    /// `children[S]`: the lowest C(P) + C(S∖P), which `split_of` searches for again.
    children: [f64; SUBSETS],
    /// What of each subset's cost does not depend on its partitions.
    terms: SubsetTerms,
}

impl Optimal {
    const EMPTY: Optimal = Optimal {
        cost: [0.0; SUBSETS],
        split: [0; SUBSETS],
        children: [0.0; SUBSETS],
        terms: SubsetTerms::EMPTY,
    };

    /// The tables for `leaves`, `split` included.
    pub fn new(leaves: &[TreeletLeaf], sah: &SahCost) -> Box<Self> {
        let mut opt = Box::new(Optimal::EMPTY);
        opt.solve(leaves, sah);
        for s in 1u32..(1 << leaves.len()) {
            if !s.is_power_of_two() {
                opt.split[s as usize] = opt.split_of(s) as u16;
            }
        }
        opt
    }

    /// Fills `cost` for `leaves` (and `cost[0]`, the empty set, with infinity); entries of
    /// subsets beyond them are left as they were.
    ///
    /// Only the minimum is kept per subset, not where it was found: all but a handful of
    /// subsets are never part of the rebuilt treelet, so their split is not worth tracking
    /// in the hot loop (`split_of` finds the few needed afterwards).
    pub fn solve(&mut self, leaves: &[TreeletLeaf], sah: &SahCost) {
        let m = leaves.len();
        assert!((1..=MAX_TREELET).contains(&m), "{m} treelet leaves");
        let Optimal {
            cost,
            children,
            terms,
            ..
        } = self;
        // Every subset's box, area and count first, in one pass with no serial dependence;
        // then, subsets in increasing order, only the partitions.
        let level = SimdLevel::detect();
        terms.fill_with(level, leaves, sah);
        for (k, leaf) in leaves.iter().enumerate() {
            cost[1 << k] = leaf.cost;
        }
        partitions::solve(level, m, cost, children, terms);
    }

    /// The split of subset `s` (of two or more leaves) the last `solve` chose: the first
    /// partition, in the order P = 1, 2, … over subsets of S without its lowest leaf, whose
    /// C(P) + C(S∖P) is the minimum.
    pub fn split_of(&self, s: u32) -> u32 {
        let best = self.children[s as usize];
        // No partition below infinity (or only NaNs): the scan never took one.
        if best.is_nan() || best == f64::INFINITY {
            return 0;
        }
        let delta = (s - 1) & s;
        let mut p = delta & delta.wrapping_neg();
        while p != 0 {
            let c = self.cost[p as usize] + self.cost[(s ^ p) as usize];
            // Nothing is below the minimum, so this is the first partition equal to it: the
            // one a scan keeping only strictly lower values ends with.
            if c <= best {
                return p;
            }
            p = p.wrapping_sub(delta) & s;
        }
        unreachable!("the minimum of subset {s:#b} is one of its partitions")
    }

    /// The height of the optimal subtree over `s`.
    pub fn height(&self, s: u32, leaves: &[TreeletLeaf]) -> u32 {
        if s.is_power_of_two() {
            return leaves[s.trailing_zeros() as usize].height;
        }
        let p = self.split_of(s);
        1 + self.height(p, leaves).max(self.height(s ^ p, leaves))
    }
}
