//! Where a layout writes its nodes and leaves. The Morton order's tree is laid out top down
//! into one of three sinks:
//!
//! - a `Part` of its own (vectors that grow, as the collapse's parts are laid out);
//! - a `Counter`, which writes nothing and counts the nodes and blocks the layout makes;
//! - `InPlace`: the part's own stretch of the whole tree's arrays, found from the counts.
//!
//! A part laid out on its own must then be copied into the whole tree (`Part::place_into`),
//! which writes every node and block twice, the second time into fresh memory: for a build
//! of 10^7 triangles from nothing that copy's 700 MB of new pages cost more than the layout
//! itself. The Morton tree's shape follows from the sorted codes alone, so each part is
//! counted first (the same recursion, without the triangles, recording each node's
//! children as it finds them), the parts are placed one after another from the counts, and
//! each is then written straight into its place, its nodes' children replayed from the
//! record rather than found again (finding them is most of the count's time).

use super::leaf::{BlockPacker, PADDING};
use super::node::{Lanes, NodeWidth, Subtree, WideNode};
use super::part::Part;
use crate::geometry::Triangle;
use crate::geometry::simd::{BLOCK, TriangleBlock};
use std::mem::MaybeUninit;
use std::ops::Range;

/// A node's children as ranges of sorted positions, in order, and how many there are.
pub(super) type Children<const W: usize> = ([Range<usize>; W], usize);

/// A node's children as a count recorded them: where each ends (the first begins where the
/// node's range does).
#[derive(Clone, Copy)]
pub(super) struct Shape<const W: usize> {
    ends: [u32; W],
    count: u32,
}

/// A sink for a layout: nodes are opened (their index taken) before their children are laid
/// out and closed with their lanes after; a leaf's triangles are placed by a block packer.
pub(super) trait Layout<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    /// Whether nodes and leaves are kept: a counter needs neither triangles nor boxes.
    const WRITES: bool;
    /// Notes a node at depth `depth` of the whole tree.
    fn deepen(&mut self, depth: u32);
    /// The children of the node over `r` opened last: found by `find` (and recorded, by a
    /// counter), or replayed from the record.
    fn children(&mut self, r: &Range<usize>, find: impl FnOnce() -> Children<W>) -> Children<W>;
    /// The index (within the sink) the next node opened takes.
    fn next_node(&self) -> u32;
    /// Takes the next node's index.
    fn open_node(&mut self) -> u32;
    /// Writes node `index`, opened before.
    fn close_node(&mut self, index: u32, node: WideNode<W>);
    /// The lane word of the sink's node `index`, as the whole tree will read it.
    fn node_word(&self, index: u32) -> Subtree;
    /// Places a leaf of `n` triangles (`tris`, with their scene indices, where `WRITES`)
    /// and returns its lane word.
    fn leaf(&mut self, packer: &mut BlockPacker, n: usize, tris: &[(Triangle, u32)]) -> Subtree;
}

impl<const W: usize> Layout<W> for Part<W>
where
    Lanes<W>: NodeWidth,
{
    const WRITES: bool = true;

    fn deepen(&mut self, depth: u32) {
        self.depth = self.depth.max(depth);
    }

    fn children(&mut self, _: &Range<usize>, find: impl FnOnce() -> Children<W>) -> Children<W> {
        find()
    }

    fn next_node(&self) -> u32 {
        self.nodes.len() as u32
    }

    fn open_node(&mut self) -> u32 {
        self.nodes.push(WideNode::default());
        self.nodes.len() as u32 - 1
    }

    fn close_node(&mut self, index: u32, node: WideNode<W>) {
        self.nodes[index as usize] = node;
    }

    fn node_word(&self, index: u32) -> Subtree {
        Subtree::node(index)
    }

    fn leaf(&mut self, packer: &mut BlockPacker, n: usize, tris: &[(Triangle, u32)]) -> Subtree {
        let first = packer.place(&mut self.blocks, &mut self.prim_indices, tris);
        Subtree::leaf(first, n as u32)
    }
}

/// Counts the nodes and blocks of a layout, writing nothing but each node's children, in
/// the order the nodes are opened.
pub(super) struct Counter<const W: usize> {
    pub nodes: usize,
    pub blocks: usize,
    pub shapes: Vec<Shape<W>>,
}

impl<const W: usize> Counter<W> {
    /// A count that records into `shapes` (emptied; its memory kept).
    pub fn new(mut shapes: Vec<Shape<W>>) -> Self {
        shapes.clear();
        Counter {
            nodes: 0,
            blocks: 0,
            shapes,
        }
    }
}

impl<const W: usize> Layout<W> for Counter<W>
where
    Lanes<W>: NodeWidth,
{
    const WRITES: bool = false;

    fn deepen(&mut self, _: u32) {}

    fn children(&mut self, _: &Range<usize>, find: impl FnOnce() -> Children<W>) -> Children<W> {
        let (kids, count) = find();
        self.shapes.push(Shape {
            ends: std::array::from_fn(|k| kids[k].end as u32),
            count: count as u32,
        });
        (kids, count)
    }

    fn next_node(&self) -> u32 {
        self.nodes as u32
    }

    fn open_node(&mut self) -> u32 {
        self.nodes += 1;
        self.nodes as u32 - 1
    }

    fn close_node(&mut self, _: u32, _: WideNode<W>) {}

    fn node_word(&self, _: u32) -> Subtree {
        Subtree::UNUSED
    }

    fn leaf(&mut self, packer: &mut BlockPacker, n: usize, _: &[(Triangle, u32)]) -> Subtree {
        packer.reserve(n, &mut self.blocks);
        Subtree::UNUSED
    }
}

/// A part's stretches of the tree's nodes, blocks and slots, not yet written.
pub(super) type Pieces<'s, const W: usize> = (
    &'s mut [MaybeUninit<WideNode<W>>],
    &'s mut [MaybeUninit<TriangleBlock>],
    &'s mut [MaybeUninit<u32>],
);

/// A part written straight into its stretch of the whole tree's arrays: its nodes from
/// `node_base` on, its blocks from `block_base` on (and their slots from `BLOCK` times
/// that), each piece exactly as long as the part's count, its nodes' children replayed
/// from `shapes`.
pub(super) struct InPlace<'s, const W: usize>
where
    Lanes<W>: NodeWidth,
{
    nodes: &'s mut [MaybeUninit<WideNode<W>>],
    blocks: &'s mut [MaybeUninit<TriangleBlock>],
    slots: &'s mut [MaybeUninit<u32>],
    shapes: &'s [Shape<W>],
    node_base: u32,
    block_base: u32,
    /// Nodes opened and blocks begun so far (blocks below this are written).
    opened: usize,
    closed: usize,
    begun: usize,
    /// The depth of its deepest node in the whole tree.
    pub depth: u32,
}

impl<'s, const W: usize> InPlace<'s, W>
where
    Lanes<W>: NodeWidth,
{
    pub fn new(
        (nodes, blocks, slots): Pieces<'s, W>,
        shapes: &'s [Shape<W>],
        (node_base, block_base): (u32, u32),
        depth: u32,
    ) -> Self {
        InPlace {
            nodes,
            blocks,
            slots,
            shapes,
            node_base,
            block_base,
            opened: 0,
            closed: 0,
            begun: 0,
            depth,
        }
    }

    /// Checks that the part filled its pieces exactly, as counted: every node written,
    /// every block and slot. The caller may then take the pieces as written.
    pub fn finish(self) {
        assert!(
            self.opened == self.nodes.len()
                && self.closed == self.opened
                && self.begun == self.blocks.len()
                && self.slots.len() == self.blocks.len() * BLOCK
                && self.shapes.len() == self.opened,
            "a part laid out in place differs from its count"
        );
    }
}

impl<const W: usize> Layout<W> for InPlace<'_, W>
where
    Lanes<W>: NodeWidth,
{
    const WRITES: bool = true;

    fn deepen(&mut self, depth: u32) {
        self.depth = self.depth.max(depth);
    }

    fn children(&mut self, r: &Range<usize>, _: impl FnOnce() -> Children<W>) -> Children<W> {
        let shape = self.shapes[self.opened - 1];
        let mut start = r.start;
        let kids = std::array::from_fn(|k| {
            let end = (k < shape.count as usize).then_some(shape.ends[k] as usize);
            let kid = start..end.unwrap_or(start);
            start = kid.end;
            kid
        });
        (kids, shape.count as usize)
    }

    fn next_node(&self) -> u32 {
        self.opened as u32
    }

    fn open_node(&mut self) -> u32 {
        self.opened += 1;
        self.opened as u32 - 1
    }

    fn close_node(&mut self, index: u32, node: WideNode<W>) {
        self.nodes[index as usize].write(node);
        self.closed += 1;
    }

    fn node_word(&self, index: u32) -> Subtree {
        Subtree::node(self.node_base + index)
    }

    fn leaf(&mut self, packer: &mut BlockPacker, n: usize, tris: &[(Triangle, u32)]) -> Subtree {
        let mut end = self.begun;
        let first = packer.reserve(n, &mut end);
        for b in self.begun..end {
            self.blocks[b].write(TriangleBlock::EMPTY);
            for slot in &mut self.slots[b * BLOCK..(b + 1) * BLOCK] {
                slot.write(PADDING);
            }
        }
        self.begun = end;
        for (k, (tri, index)) in tris.iter().enumerate() {
            let slot = first + k;
            // SAFETY: the leaf's slots lie in blocks below `begun`, all written above or
            // by an earlier leaf.
            unsafe { self.blocks[slot / BLOCK].assume_init_mut() }.set(slot % BLOCK, tri);
            self.slots[slot].write(*index);
        }
        Subtree::leaf(self.block_base * BLOCK as u32 + first as u32, n as u32)
    }
}
