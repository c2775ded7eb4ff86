//! A part of a wide tree: nodes, leaf blocks and slots laid out as if they were a whole
//! tree, so that subtrees can be laid out side by side on several threads and then placed
//! one after another (`concat`). The collapse and the direct build both lay out in parts.

use super::WideBvh;
use super::leaf::BlockPacker;
use super::node::{LaneKind, Lanes, MAX_LEAF_COUNT, NodeWidth, Subtree, WideNode};
use crate::accel::bvh::TraversalOrder;
use crate::geometry::simd::SimdLevel;
use crate::geometry::simd::{BLOCK, TriangleBlock};
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;
use std::mem::MaybeUninit;

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
    /// Where those parts' blocks begin (`WideBvh::part_blocks`).
    pub part_blocks: Vec<u32>,
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
            part_blocks: self.part_blocks,
        }
    }

    /// An empty part whose root sits at depth `depth` of the whole tree.
    pub fn new(depth: u32) -> Self {
        Part {
            nodes: Vec::new(),
            blocks: Vec::new(),
            prim_indices: Vec::new(),
            depth,
            parts: Vec::new(),
            part_blocks: Vec::new(),
        }
    }

    /// Empties the part for a new subtree at depth `depth`, keeping its memory.
    pub fn reset(&mut self, depth: u32) {
        self.nodes.clear();
        self.blocks.clear();
        self.prim_indices.clear();
        self.parts.clear();
        self.part_blocks.clear();
        self.depth = depth;
    }

    /// This part (the top of the tree) and `parts` placed after it in order, as one: each
    /// part's node indices and slots moved by the counts before it (`place_into`).
    pub fn concat(self, parts: Vec<Part<W>>) -> Part<W> {
        let mut whole = Part::new(1);
        self.place_into(&parts, &mut whole);
        whole
    }

    /// Writes this part (the top of the tree) and `parts` after it, in order, into `out`
    /// (its memory kept): each part's node indices and slots moved by the counts before
    /// it. Each piece is copied whole into its place, the pieces on every thread, and its
    /// nodes' lanes moved there. Where each part's nodes begin is `out.parts`, where its
    /// blocks begin `out.part_blocks`.
    pub fn place_into(&self, parts: &[Part<W>], out: &mut Part<W>) {
        let pieces: Vec<&Part<W>> = std::iter::once(self).chain(parts).collect();
        out.depth = pieces.iter().map(|p| p.depth).max().unwrap_or(1);
        out.parts.clear();
        out.part_blocks.clear();
        let (mut nodes, mut slots) = (0u32, 0u32);
        let mut bases = Vec::with_capacity(pieces.len());
        for (k, p) in pieces.iter().enumerate() {
            debug_assert!(p.parts.is_empty(), "parts do not nest");
            if k > 0 {
                out.parts.push(nodes);
                out.part_blocks.push(slots / BLOCK as u32);
            }
            bases.push((nodes, slots));
            nodes += p.nodes.len() as u32;
            slots += p.prim_indices.len() as u32;
        }
        let lengths = |f: fn(&Part<W>) -> usize| pieces.iter().map(move |p| f(p));
        let node_pieces = pieces_of(&mut out.nodes, lengths(|p| p.nodes.len()));
        let block_pieces = pieces_of(&mut out.blocks, lengths(|p| p.blocks.len()));
        let slot_pieces = pieces_of(&mut out.prim_indices, lengths(|p| p.prim_indices.len()));
        node_pieces
            .into_par_iter()
            .zip(block_pieces)
            .zip(slot_pieces)
            .zip(pieces.par_iter().zip(&bases))
            .for_each(|(((nodes, blocks), slots), (p, &(node_base, slot_base)))| {
                let nodes = nodes.write_copy_of_slice(&p.nodes);
                blocks.write_copy_of_slice(&p.blocks);
                slots.write_copy_of_slice(&p.prim_indices);
                if node_base == 0 && slot_base == 0 {
                    return;
                }
                for node in nodes {
                    for lane in 0..node.child_count() {
                        node.child[lane] = match node.lane_kind(lane) {
                            LaneKind::Interior(c) => Subtree::node(c + node_base),
                            LaneKind::Leaf { first, count } => {
                                Subtree::leaf(first + slot_base, count)
                            }
                            LaneKind::Unused => Subtree::UNUSED,
                        };
                    }
                }
            });
        // SAFETY: the pieces cover the first `total` elements of each vector's capacity,
        // and every piece was written whole above (a panic there leaves the vectors empty).
        unsafe {
            out.nodes.set_len(nodes as usize);
            out.blocks
                .set_len(pieces.iter().map(|p| p.blocks.len()).sum());
            out.prim_indices.set_len(slots as usize);
        }
    }
}

/// `v` emptied (its memory kept) and its capacity, as long as the sum of `lengths`, cut
/// into consecutive pieces of those lengths, to be written before `v`'s length is set.
/// Nothing is written twice: neither a fill nor the copy of a vector that grew.
pub(super) fn pieces_of<T: Copy>(
    v: &mut Vec<T>,
    lengths: impl Iterator<Item = usize> + Clone,
) -> Vec<&mut [MaybeUninit<T>]> {
    v.clear();
    let total = lengths.clone().sum();
    v.reserve(total);
    let mut rest = &mut v.spare_capacity_mut()[..total];
    lengths
        .map(|n| {
            let (piece, tail) = std::mem::take(&mut rest).split_at_mut(n);
            rest = tail;
            piece
        })
        .collect()
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
