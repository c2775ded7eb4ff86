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

use super::WideBvh;
use super::leaf::BlockPacker;
use super::node::{INTERIOR, WideNode};
use crate::accel::bvh::Bvh;
use crate::geometry::simd::{BLOCK, SimdLevel};
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
}

impl<const W: usize> Costs<W> {
    fn new(bvh: &Bvh, p: &CollapseParams) -> Self {
        let nodes = &bvh.nodes;
        let n = nodes.len();
        let mut tris = vec![0u32; n];
        let mut cost = vec![[0.0f32; W]; n];
        let mut leaf = vec![false; n];
        // Children come after their parents: one backward pass sees children first.
        for i in (0..n).rev() {
            let node = &nodes[i];
            let area = node.bounds().surface_area();
            if node.is_leaf() {
                tris[i] = node.count;
                cost[i] = [area * p.c_isect * node.count as f32; W];
                leaf[i] = true;
                continue;
            }
            let (l, r) = (node.left_first as usize, node.left_first as usize + 1);
            tris[i] = tris[l] + tris[r];
            let d = |slots: usize| distribute(&cost[l], &cost[r], slots).0;
            let as_node = area * p.c_trav + d(W);
            let as_leaf = if tris[i] <= p.max_leaf_size {
                area * p.c_isect * tris[i] as f32
            } else {
                f32::INFINITY
            };
            let mut c = [0.0f32; W];
            leaf[i] = as_leaf <= as_node;
            c[0] = as_leaf.min(as_node);
            for slots in 2..=W {
                c[slots - 1] = c[slots - 2].min(d(slots));
            }
            cost[i] = c;
        }
        Costs { cost, leaf }
    }
}

/// D(n, slots): the best split of `slots` between the two children, and the left's share.
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

impl<const W: usize> WideBvh<W> {
    /// The wide tree of minimal SAH cost over the same leaves' triangles as `bvh`.
    pub fn collapse(bvh: &Bvh, params: &CollapseParams) -> Self {
        Self::collapse_timed(bvh, params).0
    }

    /// The collapse, with the time of its two phases: the dynamic program's cost table, and
    /// the layout of the wide nodes and leaf blocks.
    pub fn collapse_timed(bvh: &Bvh, params: &CollapseParams) -> (Self, CollapsePhases) {
        let start = Instant::now();
        let costs = Costs::<W>::new(bvh, params);
        let table = start.elapsed();
        let start = Instant::now();
        let split = bvh.duplicated_references() > 0;
        let mut out = WideBvh {
            nodes: vec![WideNode::default()],
            blocks: Vec::with_capacity(bvh.triangles.len().div_ceil(BLOCK)),
            prim_indices: Vec::with_capacity(bvh.prim_indices.len()),
            triangle_count: bvh.triangle_count,
            order: bvh.order,
            simd: SimdLevel::detect(),
            depth: 1,
        };
        let root = &bvh.nodes[0];
        let root_slots = if root.is_leaf() {
            if root.count == 0 { vec![] } else { vec![0] }
        } else {
            let mut s = Vec::with_capacity(W);
            open(bvh, &costs, 0, W, &mut s);
            s
        };
        let mut packer = BlockPacker::default();
        // Buffers reused by every leaf: one allocation each instead of one per leaf.
        let (mut under, mut stack, mut tris) = (Vec::new(), Vec::new(), Vec::new());
        // (wide node index, its BVH2 slots, depth), filled depth first.
        let mut work = vec![(0usize, root_slots, 1u32)];
        while let Some((index, slots, depth)) = work.pop() {
            out.depth = out.depth.max(depth);
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
                        tris.push((bvh.triangles[t], id));
                    }
                    node.child[lane] = packer.place(&mut out.blocks, &mut out.prim_indices, &tris);
                    node.count[lane] = tris.len() as u32;
                } else {
                    let child = out.nodes.len();
                    out.nodes.push(WideNode::default());
                    node.child[lane] = child as u32;
                    node.count[lane] = INTERIOR;
                    let mut s2 = Vec::with_capacity(W);
                    open(bvh, &costs, s, W, &mut s2);
                    work.push((child, s2, depth + 1));
                }
            }
            // An empty leaf (a BVH2 leaf of an empty subtree) would read as an unused lane.
            let mut lanes: Vec<usize> = (0..slots.len()).filter(|&l| node.count[l] != 0).collect();
            if lanes.len() != slots.len() {
                let mut packed = WideNode::<W>::default();
                for (to, from) in lanes.drain(..).enumerate() {
                    packed.set_child_bounds(to, node.child_bounds(from));
                    packed.child[to] = node.child[from];
                    packed.count[to] = node.count[from];
                }
                node = packed;
            }
            out.nodes[index] = node;
        }
        let layout = start.elapsed();
        (out, CollapsePhases { table, layout })
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
