//! Collapsing the BVH2 into a wide BVH: every wide node takes up to W descendants of a BVH2
//! node as its children, folding the levels in between.
//!
//! Which descendants become children (and which subtrees become leaves) is chosen to
//! minimise the SAH cost of the wide tree, by dynamic programming bottom-up over the BVH2
//! (Ylitie, Karras and Laine 2017, §3.1) rather than greedily opening the largest child:
//! C(n, i) is the least cost of the subtree under n when it may take i slots of its wide
//! parent:
//! - C(n, 1) = min(leaf: A(n)·C_isect·N(n), node: A(n)·C_trav + D(n, W)),
//! - C(n, i) = min(C(n, i − 1), D(n, i)) for i ≥ 2,
//! - D(n, i) = min over k of C(left, k) + C(right, i − k): n opened, its slots shared.
//!
//! A leaf costs its triangles, although its blocks of four are tested whole: counting the
//! blocks' lanes instead makes fewer, fuller leaves and saves 4–10 % of the memory, but was
//! measured slower (conference: 15–30 % fewer Mrays/s), since the larger leaves' boxes cull
//! less. Triangles are copied in the order of the wide leaves into blocks of four (`leaf`),
//! so each leaf's triangles are contiguous whatever builder made the BVH2.
//!
//! A lane holds a leaf of at most `MAX_LEAF_COUNT` triangles (its count shares the lane's
//! word with its first slot); a larger BVH2 leaf (`--max-leaf` above it) is laid out as a
//! small subtree of such leaves, in leaf order.

use super::WideBvh;
use super::leaf::BlockPacker;
use super::node::{Lanes, MAX_INDEX, MAX_NODE, NodeWidth, ROWS, Subtree, WideNode};
use super::part::{Part, part_size};
use super::source::Source;
use crate::accel::bvh::{BuildError, Bvh};
use crate::geometry::Triangle;
use crate::geometry::simd::{BLOCK, prefetch};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// The costs the collapse minimises, and the largest leaf it may form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollapseParams {
    pub c_trav: f32,
    pub c_isect: f32,
    /// A subtree becomes a leaf only if it holds at most this many triangles (a BVH2 leaf
    /// stays a leaf whatever its size).
    pub max_leaf_size: u32,
}

impl Default for CollapseParams {
    fn default() -> Self {
        CollapseParams {
            c_trav: 1.0,
            c_isect: 1.0,
            max_leaf_size: 8,
        }
    }
}

/// The dynamic program's table over the BVH2's nodes.
struct Costs<const W: usize> {
    /// `cost[n][i - 1]` = C(n, i).
    cost: Vec<[f32; W]>,
    /// Whether C(n, 1) makes n a leaf.
    leaf: Vec<bool>,
    /// The triangle references under n.
    tris: Vec<u32>,
}

impl<const W: usize> Costs<W> {
    fn new(bvh: &Bvh, p: &CollapseParams) -> Self {
        let n = bvh.nodes.len();
        let mut costs = Costs {
            cost: vec![[0.0f32; W]; n],
            leaf: vec![false; n],
            tris: vec![0u32; n],
        };
        let mut table = Table {
            cost: &mut costs.cost,
            leaf: &mut costs.leaf,
            tris: &mut costs.tris,
            base: 0,
        };
        // The builders' compacted layouts keep each subtree's descendants in one range
        // after its children: the two halves of a range are filled in parallel. Any other
        // layout (or a check failing on the way) is filled by one backward pass.
        let root = &bvh.nodes[0];
        // (On one thread the single pass is faster: 3.5 against 4.6 ms on conference.)
        let in_ranges = n >= 2 * TABLE_TASK
            && rayon::current_num_threads() > 1
            && !root.is_leaf()
            && root.left_first == 1
            && table.split_at(1).1.fill(bvh, p);
        if in_ranges {
            table.set(bvh, p, 0);
        } else {
            // Children come after their parents: one backward pass sees children first.
            for i in (0..n).rev() {
                table.set(bvh, p, i);
            }
        }
        costs
    }
}

/// Below this many nodes a range of the table is filled by one backward pass.
const TABLE_TASK: usize = 8192;

/// A range of the cost table, from node `base` on: what one task of `Costs::new` fills.
struct Table<'a, const W: usize> {
    cost: &'a mut [[f32; W]],
    leaf: &'a mut [bool],
    tris: &'a mut [u32],
    base: usize,
}

impl<const W: usize> Table<'_, W> {
    fn end(&self) -> usize {
        self.base + self.tris.len()
    }

    /// The range split before node `mid`.
    fn split_at(&mut self, mid: usize) -> (Table<'_, W>, Table<'_, W>) {
        let k = mid - self.base;
        let (c0, c1) = self.cost.split_at_mut(k);
        let (l0, l1) = self.leaf.split_at_mut(k);
        let (t0, t1) = self.tris.split_at_mut(k);
        (
            Table {
                cost: c0,
                leaf: l0,
                tris: t0,
                base: self.base,
            },
            Table {
                cost: c1,
                leaf: l1,
                tris: t1,
                base: mid,
            },
        )
    }

    /// Fills a range that holds the descendants of one node, its two children first:
    /// the children's own descendants follow as two ranges (the left's first), filled in
    /// parallel, then the children. False if the layout is not so (nothing is read
    /// outside the range then, and the caller fills the table in one pass).
    fn fill(mut self, bvh: &Bvh, p: &CollapseParams) -> bool {
        let (s, e) = (self.base, self.end());
        if e - s < TABLE_TASK {
            return self.backward(bvh, p);
        }
        let (left, right) = (&bvh.nodes[s], &bvh.nodes[s + 1]);
        // Where the right child's descendants begin (its children), or the range's end.
        let mid = if right.is_leaf() {
            e
        } else {
            right.left_first as usize
        };
        let left_ok = if left.is_leaf() {
            mid == s + 2
        } else {
            left.left_first as usize == s + 2 && mid >= s + 4
        };
        let right_ok = right.is_leaf() || (mid >= s + 2 && mid + 2 <= e);
        if !(left_ok && right_ok) {
            return false;
        }
        let ok = {
            let (_, mut rest) = self.split_at(s + 2);
            let (l, r) = rest.split_at(mid);
            let (a, b) = rayon::join(|| l.fill(bvh, p), || r.fill(bvh, p));
            a && b
        };
        if ok {
            self.set(bvh, p, s + 1);
            self.set(bvh, p, s);
        }
        ok
    }

    /// Fills the range from its last node to its first, if every interior node's children
    /// lie after it in the range.
    fn backward(&mut self, bvh: &Bvh, p: &CollapseParams) -> bool {
        let end = self.end();
        for i in (self.base..end).rev() {
            let node = &bvh.nodes[i];
            if !node.is_leaf() {
                let c = node.left_first as usize;
                if c <= i || c + 1 >= end {
                    return false;
                }
            }
            self.set(bvh, p, i);
        }
        true
    }

    /// C(i, ·), node `i`'s triangle count and leaf choice, from its children's entries
    /// (which lie in this range and are filled).
    #[inline(always)]
    fn set(&mut self, bvh: &Bvh, p: &CollapseParams, i: usize) {
        let node = &bvh.nodes[i];
        let area = node.bounds().surface_area();
        let at = i - self.base;
        if node.is_leaf() {
            self.tris[at] = node.count;
            self.cost[at] = [area * p.c_isect * node.count as f32; W];
            self.leaf[at] = true;
            return;
        }
        let l = node.left_first as usize - self.base;
        let r = l + 1;
        let tris = self.tris[l] + self.tris[r];
        self.tris[at] = tris;
        let (cl, cr) = (&self.cost[l], &self.cost[r]);
        let d = |slots: usize| distribute(cl, cr, slots).0;
        // D(n, W) serves both C(n, 1) and C(n, W): evaluated once.
        let d_w = d(W);
        let as_node = area * p.c_trav + d_w;
        let as_leaf = if tris <= p.max_leaf_size {
            area * p.c_isect * tris as f32
        } else {
            f32::INFINITY
        };
        let mut c = [0.0f32; W];
        c[0] = as_leaf.min(as_node);
        for slots in 2..=W {
            let d_slots = if slots == W { d_w } else { d(slots) };
            c[slots - 1] = c[slots - 2].min(d_slots);
        }
        self.leaf[at] = as_leaf <= as_node;
        self.cost[at] = c;
    }
}

/// D(n, slots): the best split of `slots` between the two children, and the left's share.
#[inline(always)]
fn distribute<const W: usize>(left: &[f32; W], right: &[f32; W], slots: usize) -> (f32, usize) {
    let mut best = (f32::INFINITY, 1);
    for k in 1..slots {
        let c = left[k - 1] + right[slots - k - 1];
        if c < best.0 {
            best = (c, k);
        }
    }
    best
}

/// The most triangle references a wide tree is collapsed from: each takes at most four
/// slots (a leaf leaves at most three lanes of its last block free), and the tree has
/// fewer nodes than references (each node has two lanes or more), so every slot and every
/// node's first row fits a lane's `INDEX_BITS`.
pub const MAX_REFERENCES: usize = (MAX_INDEX as usize + 1) / ROWS as usize;

const _: () = assert!(4 * MAX_REFERENCES <= MAX_INDEX as usize + 1);
// Scenes of tens of millions of triangles (3.8 · 10^7) collapse.
const _: () = assert!(MAX_REFERENCES >= 30_000_000);

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The wide tree of minimal SAH cost over the same leaves' triangles as `bvh`.
    ///
    /// # Panics
    /// If `bvh` holds more than `MAX_REFERENCES` references (`collapse_timed` returns the
    /// error instead).
    pub fn collapse(bvh: &Bvh, params: &CollapseParams) -> Self {
        match Self::collapse_timed(bvh, params) {
            Ok((tree, _)) => tree,
            Err(e) => panic!("{e}"),
        }
    }

    /// The collapse, with the time of its two phases: the dynamic program's cost table, and
    /// the layout of the wide nodes and leaf blocks.
    ///
    /// The layout runs in parallel: the top of the tree is laid out first, down to subtrees
    /// of at most `part_size` triangles, which are then laid out as parts of their own, side
    /// by side, and placed after it. Where the cut falls depends on the triangle count
    /// alone, so the tree is the same for any number of threads.
    pub fn collapse_timed(
        bvh: &Bvh,
        params: &CollapseParams,
    ) -> Result<(Self, CollapsePhases), BuildError> {
        Self::collapse_from(bvh, Source::leaf_order(bvh), params)
    }

    /// `collapse_timed` of a BVH2 built without its copy of the triangles in leaf order
    /// (`bvh::build_shape_with_progress`): each leaf's triangles are read from `scene`, the
    /// triangles it was built over, through its `prim_indices`.
    pub fn collapse_over(
        bvh: &Bvh,
        scene: &[Triangle],
        params: &CollapseParams,
    ) -> Result<(Self, CollapsePhases), BuildError> {
        Self::collapse_from(bvh, Source::Scene(scene), params)
    }

    fn collapse_from(
        bvh: &Bvh,
        source: Source,
        params: &CollapseParams,
    ) -> Result<(Self, CollapsePhases), BuildError> {
        let references = bvh.prim_indices.len();
        if references > MAX_REFERENCES {
            return Err(BuildError::TooManyForWide(references));
        }
        let start = Instant::now();
        let costs = Costs::<W>::new(bvh, params);
        let table = start.elapsed();
        let start = Instant::now();
        let tree =
            Layout::lay_out_tree(bvh, source, &costs, part_size(references).map(|c| c as u32));
        let out = tree.into_tree(bvh.triangle_count, bvh.order);
        let layout = start.elapsed();
        Ok((out, CollapsePhases { table, layout }))
    }
}

/// A subtree left to be laid out as a part: the BVH2 node `slot` under lane `lane` of wide
/// node `node`, at depth `depth`.
struct Cut {
    node: usize,
    lane: usize,
    slot: usize,
    depth: u32,
}

/// What laying out a part needs: the BVH2 and its triangles, the collapse's choices, and
/// where to cut.
#[derive(Clone, Copy)]
struct Layout<'a, const W: usize>
where
    Lanes<W>: NodeWidth,
{
    bvh: &'a Bvh,
    source: Source<'a>,
    costs: &'a Costs<W>,
    cut: Option<u32>,
}

impl<'a, const W: usize> Layout<'a, W>
where
    Lanes<W>: NodeWidth,
{
    /// The whole wide tree: its top laid out down to the cuts, then the parts below the cuts
    /// in parallel, placed after the top in the order of their cuts.
    fn lay_out_tree(
        bvh: &'a Bvh,
        source: Source<'a>,
        costs: &'a Costs<W>,
        cut: Option<u32>,
    ) -> Part<W> {
        let root = &bvh.nodes[0];
        let root_slots = if root.is_leaf() {
            vec![0]
        } else {
            let mut s = Vec::with_capacity(W);
            open(bvh, costs, 0, W, &mut s);
            s
        };
        let mut layout = Layout {
            bvh,
            source,
            costs,
            cut,
        };
        let (tree, cuts) = layout.lay_out(root_slots, 1);
        layout.cut = None;
        let parts: Vec<Part<W>> = cuts
            .par_iter()
            .map(|c| {
                let mut slots = Vec::with_capacity(W);
                open(bvh, costs, c.slot, W, &mut slots);
                layout.lay_out(slots, c.depth).0
            })
            .collect();
        let mut tree = tree.concat(parts);
        for (c, &base) in cuts.iter().zip(&tree.parts) {
            tree.nodes[c.node].child[c.lane] = Subtree::node(base);
        }
        tree
    }

    /// Lays out the wide node over the BVH2 nodes `root_slots`, at depth `depth`, and all
    /// below it, depth first; interior children of at most `cut` triangles are left as cuts.
    fn lay_out(&self, root_slots: Vec<usize>, depth: u32) -> (Part<W>, Vec<Cut>) {
        let (bvh, costs) = (self.bvh, self.costs);
        let split = bvh.duplicated_references() > 0;
        // A part's arrays sized for what its references usually make (a block per two or
        // fewer, a node per six or fewer), not grown by doubling: each doubling copied what
        // it held (1.5–2 % of conference's build). The top, laid out down to the cuts, is
        // small.
        let refs: usize = if self.cut.is_none() {
            root_slots.iter().map(|&s| costs.tris[s] as usize).sum()
        } else {
            0
        };
        let mut nodes = Vec::with_capacity(1 + refs / 6);
        nodes.push(WideNode::default());
        let mut part = Part {
            nodes,
            blocks: Vec::with_capacity(refs / 2),
            prim_indices: Vec::with_capacity(refs / 2 * BLOCK),
            depth,
            parts: Vec::new(),
            part_blocks: Vec::new(),
        };
        let mut cuts = Vec::new();
        let mut packer = BlockPacker::default();
        // Buffers reused by every leaf: one allocation each instead of one per leaf.
        let (mut under, mut stack, mut tris) = (Vec::new(), Vec::new(), Vec::new());
        // (wide node index, its BVH2 slots, depth), filled depth first.
        let mut work = vec![(0usize, root_slots, depth)];
        while let Some((index, mut slots, depth)) = work.pop() {
            part.depth = part.depth.max(depth);
            // An empty subtree (a BVH2 leaf of no triangles) would read as an unused lane.
            slots.retain(|&s| costs.tris[s] > 0);
            let mut node = WideNode::<W>::default();
            for (lane, &s) in slots.iter().enumerate() {
                node.set_child_bounds(lane, bvh.nodes[s].bounds());
                if costs.leaf[s] {
                    tris.clear();
                    bvh.leaf_order_under(s, &mut stack, &mut under);
                    for &t in &under {
                        // Two parts of a split triangle folded into one leaf: one test does.
                        let id = bvh.prim_indices[t];
                        if split && tris.iter().any(|&(_, i)| i == id) {
                            continue;
                        }
                        tris.push((self.source.get(bvh, t), id));
                    }
                    let clip = split.then(|| bvh.nodes[s].bounds());
                    let (leaf, bounds) = part.place_leaf(&mut packer, &tris, clip, depth + 1);
                    node.child[lane] = leaf;
                    if let Some(b) = bounds {
                        node.set_child_bounds(lane, b);
                    }
                } else {
                    if self.cut.is_some_and(|c| costs.tris[s] <= c) {
                        // The part's first node, once the parts are placed.
                        node.child[lane] = Subtree::node(MAX_NODE);
                        cuts.push(Cut {
                            node: index,
                            lane,
                            slot: s,
                            depth: depth + 1,
                        });
                        continue;
                    }
                    let child = part.nodes.len();
                    part.nodes.push(WideNode::default());
                    node.child[lane] = Subtree::node(child as u32);
                    let mut s2 = Vec::with_capacity(W);
                    open(bvh, costs, s, W, &mut s2);
                    for &c in &s2 {
                        prefetch(&bvh.nodes[c]);
                    }
                    work.push((child, s2, depth + 1));
                }
            }
            part.nodes[index] = node;
            if let Some((_, next, _)) = work.last() {
                self.prefetch_leaves(next);
            }
        }
        (part, cuts)
    }

    /// Asks for the triangles of the leaf lanes among `slots` (the node laid out next)
    /// while this one is finished: a wide node's leaves lie anywhere in the BVH2's leaf
    /// order, and their first reads waited on memory (half of the layout's time).
    fn prefetch_leaves(&self, slots: &[usize]) {
        let bvh = self.bvh;
        for &s in slots {
            if !self.costs.leaf[s] {
                continue;
            }
            let node = &bvh.nodes[s];
            let first = if node.is_leaf() {
                node.left_first as usize
            } else {
                // A subtree made a leaf: its triangles begin at its leftmost leaf's.
                prefetch(&bvh.nodes[node.left_first as usize]);
                continue;
            };
            prefetch(bvh.prim_indices.as_ptr().wrapping_add(first));
            self.source.prefetch(bvh, first, node.count as usize);
        }
    }
}

/// Where the collapse spent its time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CollapsePhases {
    /// The table of C(n, i) over the BVH2's nodes.
    pub table: Duration,
    /// The wide nodes and the triangles packed into blocks.
    pub layout: Duration,
}

/// The BVH2 nodes that become the wide children when `n` is opened with `slots` slots.
fn open<const W: usize>(bvh: &Bvh, costs: &Costs<W>, n: usize, slots: usize, out: &mut Vec<usize>) {
    let l = bvh.nodes[n].left_first as usize;
    let (_, k) = distribute(&costs.cost[l], &costs.cost[l + 1], slots);
    take(bvh, costs, l, k, out);
    take(bvh, costs, l + 1, slots - k, out);
}

/// Adds the subtree `n` given `slots` slots: itself if one suffices, else opened.
fn take<const W: usize>(
    bvh: &Bvh,
    costs: &Costs<W>,
    n: usize,
    mut slots: usize,
    out: &mut Vec<usize>,
) {
    // Fewer slots when they cost no more (C(n, i) = C(n, i − 1)).
    while slots > 1 && costs.cost[n][slots - 1] == costs.cost[n][slots - 2] {
        slots -= 1;
    }
    if slots == 1 {
        out.push(n);
    } else {
        open(bvh, costs, n, slots, out);
    }
}

impl Bvh {
    /// Leaf-order triangle indices under node `index`, left subtree first.
    pub fn triangles_under_leaf_order(&self, index: usize) -> Vec<usize> {
        let (mut stack, mut out) = (Vec::new(), Vec::new());
        self.leaf_order_under(index, &mut stack, &mut out);
        out
    }

    /// `triangles_under_leaf_order` into `out`, with `stack` as the walk's stack.
    fn leaf_order_under(&self, index: usize, stack: &mut Vec<usize>, out: &mut Vec<usize>) {
        out.clear();
        stack.clear();
        stack.push(index);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if n.is_leaf() {
                out.extend(n.prim_range());
            } else {
                stack.push(n.left_first as usize + 1);
                stack.push(n.left_first as usize);
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::accel::bvh::{self, BuildParams};
    use crate::scene::builtin;

    /// The subtree under `lane` of node `n`, written out depth first: boxes, counts and the
    /// scene triangles of each leaf, with no node index or slot in it.
    fn canonical<const W: usize>(t: &WideBvh<W>, n: usize, out: &mut Vec<u64>)
    where
        Lanes<W>: NodeWidth,
    {
        let node = &t.nodes[n];
        out.push(node.child_count() as u64);
        for lane in 0..node.child_count() {
            out.extend(node.child_bounds(lane).bits().map(u64::from));
            out.push(node.leaf_count(lane) as u64);
            match node.interior(lane) {
                Some(c) => canonical(t, c, out),
                None => {
                    let slots = node.child[lane].slots();
                    out.extend(slots.map(|s| t.prim_indices[s] as u64));
                }
            }
        }
    }

    /// The tree made with the parts cut at each of `cuts` triangles is the tree made in
    /// one piece (`tree(None)`), and every one is valid.
    pub(in crate::accel::bvh::wide) fn assert_cuts_agree(
        spec: &str,
        cuts: &[usize],
        tree: impl Fn(Option<usize>) -> WideBvh<8>,
    ) {
        let whole = |cut| {
            let t = tree(cut);
            t.validate()
                .unwrap_or_else(|e| panic!("{spec}, cut {cut:?}: {e}"));
            let mut c = Vec::new();
            canonical(&t, 0, &mut c);
            (c, t.depth, t.nodes.len())
        };
        let one_piece = whole(None);
        for &cut in cuts {
            assert_eq!(whole(Some(cut)), one_piece, "{spec}, cut {cut}");
        }
    }

    /// The table filled range by range in parallel is the one backward pass's, bit for
    /// bit: over the builders' layouts, which take the ranges, and over a valid layout
    /// that does not (the root's grandchildren moved), which falls back to the pass.
    #[test]
    fn the_table_in_ranges_is_the_backward_pass() {
        use crate::accel::bvh::build::Strategy;
        let scene = builtin::by_name("sphere:40000").unwrap().unwrap();
        let build = |strategy| {
            let params = BuildParams {
                strategy,
                ..BuildParams::default()
            };
            bvh::build(&scene.triangles, &params).unwrap().0
        };
        // The binned tree laid out level by level: children still come after their
        // parents, but a subtree's descendants are spread over every level below it.
        let mut moved = build(Strategy::SahBinned);
        let old = moved.nodes.clone();
        let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
        let mut next = 1;
        while let Some((from, to)) = queue.pop_front() {
            let mut node = old[from];
            if !node.is_leaf() {
                let c = node.left_first as usize;
                queue.extend([(c, next), (c + 1, next + 1)]);
                node.left_first = next as u32;
                next += 2;
            }
            moved.nodes[to] = node;
        }
        let cases = [
            ("binned SAH", build(Strategy::SahBinned), true),
            ("LBVH", build(Strategy::Lbvh), true),
            ("level by level", moved, false),
        ];
        for (name, b2, in_ranges) in cases {
            let strategy = name;
            let n = b2.nodes.len();
            assert!(n >= 2 * TABLE_TASK, "{n} nodes: too few for the ranges");
            let p = CollapseParams::default();
            let got = Costs::<8>::new(&b2, &p);
            let mut want = Costs::<8> {
                cost: vec![[0.0; 8]; n],
                leaf: vec![false; n],
                tris: vec![0; n],
            };
            let mut table = Table {
                cost: &mut want.cost,
                leaf: &mut want.leaf,
                tris: &mut want.tris,
                base: 0,
            };
            assert!(table.backward(&b2, &p));
            assert_eq!(table.split_at(1).1.fill(&b2, &p), in_ranges, "{strategy:?}");
            let bits = |c: &Costs<8>| {
                let cost: Vec<[u32; 8]> = c.cost.iter().map(|r| r.map(f32::to_bits)).collect();
                (cost, c.leaf.clone(), c.tris.clone())
            };
            assert_eq!(bits(&got), bits(&want), "{strategy:?}");
        }
    }

    /// A BVH2 of more references than the lanes' indices can address is refused with an
    /// error, before any node is laid out (the references here are zeros the allocator
    /// hands out untouched, so the test costs no memory traffic).
    #[test]
    fn a_tree_past_the_lane_indices_is_an_error() {
        let scene = builtin::by_name("soup:100").unwrap().unwrap();
        let (mut b2, _) = bvh::build(&scene.triangles, &BuildParams::default()).unwrap();
        for n in [MAX_REFERENCES + 1, 4 * MAX_REFERENCES] {
            b2.prim_indices = vec![0; n];
            let got = WideBvh::<8>::collapse_timed(&b2, &CollapseParams::default());
            assert_eq!(got.err(), Some(BuildError::TooManyForWide(n)));
            let got = WideBvh::<4>::collapse_timed(&b2, &CollapseParams::default());
            let message = got.err().unwrap().to_string();
            assert!(message.contains(&MAX_REFERENCES.to_string()), "{message}");
        }
        // The largest slot and node such a tree could need still fits a lane.
        assert!(4 * MAX_REFERENCES - 1 <= MAX_INDEX as usize);
        assert!(MAX_REFERENCES - 1 <= MAX_NODE as usize);
    }

    /// A BVH2 built without its copy of the triangles in leaf order, collapsed over the
    /// scene's triangles, gives the tree the full BVH2's collapse gives, to the last bit of
    /// every box, block and slot: in one piece and in parts (40 000 triangles are cut into
    /// parts), with references split by the SBVH and by pre-splitting.
    #[test]
    fn a_tree_collapsed_over_the_scene_is_the_tree_collapsed_from_the_copy() {
        use crate::accel::bvh::build::Strategy;
        use crate::accel::progress::BuildProgress;
        let bits = |t: &WideBvh<8>| {
            let blocks: Vec<u32> = t
                .blocks
                .iter()
                .flat_map(|b| {
                    b.v.as_flattened()
                        .as_flattened()
                        .iter()
                        .map(|x| x.to_bits())
                })
                .collect();
            let nodes: Vec<[u32; 8]> = t.nodes.iter().map(|n| n.child.map(|c| c.word())).collect();
            let boxes: Vec<Vec<u32>> = (0..t.nodes.len())
                .flat_map(|n| (0..8).map(move |l| (n, l)))
                .map(|(n, l)| t.nodes[n].child_bounds(l).bits().to_vec())
                .collect();
            (blocks, nodes, boxes, t.prim_indices.clone(), t.depth)
        };
        let params = [
            BuildParams::default(),
            BuildParams {
                strategy: Strategy::Sbvh,
                ..BuildParams::default()
            },
            BuildParams {
                presplit: 0.3,
                ..BuildParams::default()
            },
        ];
        for spec in ["sphere:40000", "teapot-in-stadium", "walls-rotated"] {
            let scene = builtin::by_name(spec).unwrap().unwrap();
            let tris = &scene.triangles;
            for p in &params {
                let (full, _) = bvh::build(tris, p).unwrap();
                let (shape, _, _) =
                    bvh::build_shape_with_progress(tris, p, &BuildProgress::default()).unwrap();
                assert!(shape.triangles.is_empty());
                assert_eq!(shape.nodes, full.nodes, "{spec}, {:?}", p.strategy);
                assert_eq!(shape.prim_indices, full.prim_indices, "{spec}");
                let c = CollapseParams::default();
                let want = WideBvh::<8>::collapse(&full, &c);
                let (got, _) = WideBvh::<8>::collapse_over(&shape, tris, &c).unwrap();
                got.validate().unwrap();
                assert!(bits(&got) == bits(&want), "{spec}, {:?}", p.strategy);
            }
        }
    }

    /// Laying the tree out in parts, at any cut, gives the tree laid out in one piece: the
    /// same nodes, boxes and leaves, only stored in another order.
    #[test]
    fn parts_laid_out_apart_make_the_same_tree() {
        for spec in [
            "soup:6000",
            "sphere:5000",
            "teapot-in-stadium",
            "same-centroid",
        ] {
            let scene = builtin::by_name(spec).unwrap().unwrap();
            let (b2, _) = bvh::build(&scene.triangles, &BuildParams::default()).unwrap();
            let costs = Costs::<8>::new(&b2, &CollapseParams::default());
            assert_cuts_agree(spec, &[1, 8, 50, 400, 3000, 1 << 20], |cut| {
                let source = Source::leaf_order(&b2);
                let part = Layout::lay_out_tree(&b2, source, &costs, cut.map(|c| c as u32));
                part.into_tree(b2.triangle_count, b2.order)
            });
        }
    }
}
