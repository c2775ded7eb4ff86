//! A part of a wide tree: nodes, leaf blocks and slots laid out as if they were a whole
//! tree, so that subtrees can be laid out side by side on several threads and then placed
//! one after another (`concat`). The collapse and the direct build both lay out in parts.

use super::WideBvh;
use super::leaf::BlockPacker;
use super::node::{LaneKind, Lanes, MAX_LEAF_COUNT, NodeWidth, Subtree, WideNode};
use crate::accel::bvh::TraversalOrder;
use crate::geometry::simd::SimdLevel;
use crate::geometry::simd::TriangleBlock;
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;

/// Subtrees of at most this many triangles are laid out as parts of their own, in parallel
/// (none for a small tree, where the parts would cost more than they save). The cut
/// depends on the triangle count alone, so the tree is the same for any number of threads.
pub fn part_size(triangles: usize) -> Option<usize> {
    (triangles >= 1 << 15).then(|| (triangles / 32).max(1 << 12))
}

/// A part of the wide tree laid out as if it were a whole tree: its first node is its root,
/// its leaves' slots start at 0.
pub(super) struct Part<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    pub nodes: Vec<WideNode<W>>,
    pub blocks: Vec<TriangleBlock>,
    pub prim_indices: Vec<u32>,
    /// The depth of its deepest node in the whole tree.
    pub depth: u32,
    /// Where the parts placed after it begin (`WideBvh::parts`).
    pub parts: Vec<u32>,
}

impl<const W: usize> Part<W>
where
    Lanes<W>: NodeWidth,
{
    /// The wide tree this part, laid out as a whole tree, is: over `triangle_count`
    /// triangles, traced in `order` with the widest kernel this CPU has.
    pub fn into_tree(self, triangle_count: usize, order: TraversalOrder) -> WideBvh<W> {
        WideBvh {
            nodes: self.nodes,
            blocks: self.blocks,
            prim_indices: self.prim_indices,
            triangle_count,
            order,
            simd: SimdLevel::detect(),
            depth: self.depth,
            lanes: Default::default(),
            parts: self.parts,
        }
    }

    /// This part (the top of the tree) and `parts` placed after it in order, as one: each
    /// part's node indices and slots moved by the counts before it. Every node, block and
    /// slot is written once, in place, on every thread (a copy of a large tree is mostly
    /// the first touch of its pages). Where each part's nodes begin is the result's `parts`.
    pub fn concat(self, parts: Vec<Part<W>>) -> Part<W> {
        // Where each piece (the top, then the parts) begins in the three arrays.
        let mut starts = Vec::with_capacity(parts.len() + 1);
        let (mut n, mut b, mut s) = (0, 0, 0);
        for p in std::iter::once(&self).chain(&parts) {
            debug_assert!(p.parts.is_empty(), "parts do not nest");
            starts.push([n, b, s]);
            n += p.nodes.len();
            b += p.blocks.len();
            s += p.prim_indices.len();
        }
        let pieces: Vec<&Part<W>> = std::iter::once(&self).chain(&parts).collect();
        // Element i of array a: its piece (the last starting at or before i) and offset.
        let locate = |a: usize, i: usize| {
            let k = starts.partition_point(|st| st[a] <= i) - 1;
            (k, i - starts[k][a])
        };
        let mut nodes = Vec::with_capacity(n);
        nodes.par_extend((0..n).into_par_iter().map(|i| {
            let (k, j) = locate(0, i);
            let [node_base, _, slot_base] = starts[k].map(|x| x as u32);
            let mut node = pieces[k].nodes[j];
            for lane in 0..node.child_count() {
                node.child[lane] = match node.lane_kind(lane) {
                    LaneKind::Interior(c) => Subtree::node(c + node_base),
                    LaneKind::Leaf { first, count } => Subtree::leaf(first + slot_base, count),
                    LaneKind::Unused => Subtree::UNUSED,
                };
            }
            node
        }));
        let mut blocks = Vec::with_capacity(b);
        blocks.par_extend((0..b).into_par_iter().map(|i| {
            let (k, j) = locate(1, i);
            pieces[k].blocks[j]
        }));
        let mut prim_indices = Vec::with_capacity(s);
        prim_indices.par_extend((0..s).into_par_iter().map(|i| {
            let (k, j) = locate(2, i);
            pieces[k].prim_indices[j]
        }));
        Part {
            nodes,
            blocks,
            prim_indices,
            depth: pieces.iter().map(|p| p.depth).max().unwrap_or(1),
            parts: starts[1..].iter().map(|st| st[0] as u32).collect(),
        }
    }
}

impl<const W: usize> Part<W>
where
    Lanes<W>: NodeWidth,
{
    /// Places a leaf's triangles (in leaf order) and returns its lane's word. A leaf of more
    /// than `MAX_LEAF_COUNT` becomes a subtree of leaves of at most that many, up to W to a
    /// node, whose box (returned with it) is the union of theirs: each the box of its
    /// triangles, within `clip` (the BVH2 leaf's box, where references were split).
    pub fn place_leaf(
        &mut self,
        packer: &mut BlockPacker,
        tris: &[(Triangle, u32)],
        clip: Option<Aabb>,
        depth: u32,
    ) -> (Subtree, Option<Aabb>) {
        let n = tris.len() as u32;
        if n <= MAX_LEAF_COUNT {
            let first = packer.place(&mut self.blocks, &mut self.prim_indices, tris);
            return (Subtree::leaf(first, n), None);
        }
        self.depth = self.depth.max(depth);
        // Leaves under each lane: W^(levels − 1) of them, levels as few as hold them all.
        let leaves = n.div_ceil(MAX_LEAF_COUNT) as usize;
        let mut per_lane = 1;
        while per_lane * W < leaves {
            per_lane *= W;
        }
        let index = self.nodes.len();
        self.nodes.push(WideNode::default());
        let mut node = WideNode::<W>::default();
        for (lane, group) in tris.chunks(per_lane * MAX_LEAF_COUNT as usize).enumerate() {
            let (child, bounds) = self.place_leaf(packer, group, clip, depth + 1);
            let bounds = bounds.unwrap_or_else(|| {
                let b = group.iter().fold(Aabb::EMPTY, |b, t| b.union(t.0.bounds()));
                clip.map_or(b, |c| Aabb::new(b.min.max(c.min), b.max.min(c.max)))
            });
            node.child[lane] = child;
            node.set_child_bounds(lane, bounds);
        }
        let bounds = node.bounds();
        self.nodes[index] = node;
        (Subtree::node(index as u32), Some(bounds))
    }
}
