//! A part of a wide tree: nodes, leaf blocks and slots laid out as if they were a whole
//! tree, so that subtrees can be laid out side by side on several threads and then placed
//! one after another (`append`). The collapse and the direct build both lay out in parts.

use super::leaf::BlockPacker;
use super::node::{LaneKind, Lanes, MAX_LEAF_COUNT, NodeWidth, Subtree, WideNode};
use crate::geometry::simd::TriangleBlock;
use crate::geometry::{Aabb, Triangle};

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
    /// Where the parts appended to it begin (`WideBvh::parts`).
    pub parts: Vec<u32>,
}

impl<const W: usize> Part<W>
where
    Lanes<W>: NodeWidth,
{
    /// Places `part` after this one: its node indices and slots move by this one's counts.
    pub fn append(&mut self, part: Part<W>) {
        let (node_base, slot_base) = (self.nodes.len() as u32, self.prim_indices.len() as u32);
        debug_assert!(part.parts.is_empty(), "parts do not nest");
        self.parts.push(node_base);
        self.nodes.extend(part.nodes.into_iter().map(|mut n| {
            for lane in 0..n.child_count() {
                n.child[lane] = match n.lane_kind(lane) {
                    LaneKind::Interior(c) => Subtree::node(c + node_base),
                    LaneKind::Leaf { first, count } => Subtree::leaf(first + slot_base, count),
                    LaneKind::Unused => Subtree::UNUSED,
                };
            }
            n
        }));
        self.blocks.extend(part.blocks);
        self.prim_indices.extend(part.prim_indices);
        self.depth = self.depth.max(part.depth);
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
