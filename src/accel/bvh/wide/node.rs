//! The wide node: up to W children whose boxes are stored as structures of arrays, so one
//! SIMD instruction loads the same plane of all W boxes, and one row of W words that say
//! what each lane holds. Seven rows of W · 4 bytes: a BVH8 node is 224 bytes, a BVH4 node
//! 112, stored at that stride and aligned to one row, so that no row straddles two cache
//! lines (a row's size divides 64). A BVH8 node then touches four lines, as a 256-byte one
//! did, and the tree is an eighth smaller.

use crate::geometry::Aabb;
use glam::Vec4;
use std::fmt::Debug;
use std::ops::Range;

/// High bits of a lane's word: 0 for an interior child, one more than its triangle count
/// for a leaf.
pub const COUNT_BITS: u32 = 4;
/// Low bits of a lane's word: the child node's first row (index · `ROWS`), or the leaf's
/// first slot.
pub const INDEX_BITS: u32 = 32 - COUNT_BITS;
/// The largest triangle count a lane holds; the collapse lays out a larger BVH2 leaf as a
/// small subtree of leaves of at most this many.
pub const MAX_LEAF_COUNT: u32 = (1 << COUNT_BITS) - 2;
/// The largest value of a lane's low bits (the collapse checks the tree fits first).
pub const MAX_INDEX: u32 = (1 << INDEX_BITS) - 1;
/// Rows of a node: six of box planes, one of lane words.
pub const ROWS: u32 = 7;
/// The largest node index a lane holds: an interior child's word counts rows, not nodes.
pub const MAX_NODE: u32 = MAX_INDEX / ROWS;

// The collapse's default leaves (at most 8 triangles) fit the count field.
const _: () = assert!(MAX_LEAF_COUNT >= 8);

/// What a lane of a wide node points to, packed into one word: an interior child (high
/// bits 0, low bits the row where the node starts, its index · `ROWS`: the walk finds the
/// node with a shift of the word, not a multiply by 224) or a leaf (high bits its
/// triangle count + 1, low bits its first slot in leaf order). An unused lane holds a leaf
/// of no triangles, which a ray that enters its empty box (a degenerate ray) tests at no
/// cost. A traversal can start at any subtree as at the root.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(transparent)]
pub struct Subtree(u32);

/// Subtrees in order of index (node or first slot), a leaf before the node of the same
/// index, whatever the packing of their words.
impl Ord for Subtree {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        let key = |s: &Subtree| (s.index(), if s.is_leaf() { s.count() } else { u32::MAX });
        key(self).cmp(&key(other))
    }
}

impl PartialOrd for Subtree {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// A lane of a wide node, unpacked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaneKind {
    Unused,
    Interior(u32),
    Leaf { first: u32, count: u32 },
}

impl Subtree {
    /// The whole tree: node 0.
    pub const ROOT: Subtree = Subtree(0);
    /// The word of an unused lane: a leaf of no triangles.
    pub const UNUSED: Subtree = Subtree(1 << INDEX_BITS);

    /// The interior child `index` (at most `MAX_NODE`).
    pub fn node(index: u32) -> Subtree {
        assert!(index <= MAX_NODE, "node {index} is past {MAX_NODE}");
        Subtree(index * ROWS)
    }

    /// The leaf of `count` triangles (1..=`MAX_LEAF_COUNT`) from slot `first` on.
    pub fn leaf(first: u32, count: u32) -> Subtree {
        assert!(first <= MAX_INDEX, "slot {first} is past {MAX_INDEX}");
        assert!(
            (1..=MAX_LEAF_COUNT).contains(&count),
            "a leaf of {count} triangles (a lane holds 1..={MAX_LEAF_COUNT})"
        );
        Subtree((count + 1) << INDEX_BITS | first)
    }

    /// The packed word, as a node's row stores it.
    pub fn word(self) -> u32 {
        self.0
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.0 > MAX_INDEX
    }

    /// An interior child's node index.
    #[inline(always)]
    pub fn node_index(self) -> usize {
        debug_assert!(!self.is_leaf());
        (self.0 / ROWS) as usize
    }

    /// An interior child's first row: its word itself, no bits to clear.
    #[inline(always)]
    pub fn node_row(self) -> usize {
        debug_assert!(!self.is_leaf());
        self.0 as usize
    }

    /// The node's index (an interior child) or the first slot (a leaf).
    #[inline(always)]
    pub fn index(self) -> u32 {
        match self.is_leaf() {
            true => self.0 & MAX_INDEX,
            false => self.0 / ROWS,
        }
    }

    /// The leaf's triangle count; 0 for an interior child.
    #[inline(always)]
    pub fn count(self) -> u32 {
        (self.0 >> INDEX_BITS).saturating_sub(1)
    }

    /// The first slot of a lane known to hold a leaf.
    #[inline(always)]
    pub fn leaf_first(self) -> u32 {
        debug_assert!(self.is_leaf());
        self.0 & MAX_INDEX
    }

    /// The triangle count of a lane known to hold a leaf.
    #[inline(always)]
    pub fn leaf_count(self) -> u32 {
        debug_assert!(self.is_leaf());
        (self.0 >> INDEX_BITS) - 1
    }

    /// The leaf's slots (none for an interior child).
    pub fn slots(self) -> Range<usize> {
        let first = self.index() as usize;
        first..first + self.count() as usize
    }

    /// The lane this word fills, as a node's row reads it.
    pub fn kind(self) -> LaneKind {
        match (self == Subtree::UNUSED, self.is_leaf()) {
            (true, _) => LaneKind::Unused,
            (false, false) => LaneKind::Interior(self.index()),
            (false, true) => LaneKind::Leaf {
                first: self.index(),
                count: self.count(),
            },
        }
    }
}

/// Node widths that have a node layout: their row alignment (one row of W floats).
pub trait NodeWidth {
    type Row: Copy + Debug + PartialEq + Send + Sync;
}

/// The width W as a type, to name its row alignment (`Lanes<W>: NodeWidth`).
pub struct Lanes<const W: usize>;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(16))]
pub struct Row4;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(32))]
pub struct Row8;

impl NodeWidth for Lanes<4> {
    type Row = Row4;
}

impl NodeWidth for Lanes<8> {
    type Row = Row8;
}

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct WideNode<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    /// Aligns the node to one row (no bytes).
    align: [<Lanes<W> as NodeWidth>::Row; 0],
    /// Rows min x, min y, min z, max x, max y, max z; lane i is child i. An unused lane holds
    /// the empty box (+∞ min, −∞ max), which no ray enters.
    pub bounds: [[f32; W]; 6],
    /// What each lane points to (`Subtree::UNUSED` for an unused lane).
    pub child: [Subtree; W],
}

const _: () = assert!(std::mem::size_of::<WideNode<4>>() == 112);
const _: () = assert!(std::mem::align_of::<WideNode<4>>() == 16);
const _: () = assert!(std::mem::size_of::<WideNode<8>>() == 224);
const _: () = assert!(std::mem::align_of::<WideNode<8>>() == 32);

impl<const W: usize> Default for WideNode<W>
where
    Lanes<W>: NodeWidth,
{
    fn default() -> Self {
        let inf = [f32::INFINITY; W];
        let neg = [f32::NEG_INFINITY; W];
        WideNode {
            align: [],
            bounds: [inf, inf, inf, neg, neg, neg],
            child: [Subtree::UNUSED; W],
        }
    }
}

impl<const W: usize> WideNode<W>
where
    Lanes<W>: NodeWidth,
{
    pub fn child_bounds(&self, lane: usize) -> Aabb {
        let b = &self.bounds;
        Aabb::new(
            glam::Vec3::new(b[0][lane], b[1][lane], b[2][lane]),
            glam::Vec3::new(b[3][lane], b[4][lane], b[5][lane]),
        )
    }

    pub fn set_child_bounds(&mut self, lane: usize, bounds: Aabb) {
        let (lo, hi) = (bounds.min, bounds.max);
        for axis in 0..3 {
            self.bounds[axis][lane] = lo[axis];
            self.bounds[axis + 3][lane] = hi[axis];
        }
    }

    pub fn lane_kind(&self, lane: usize) -> LaneKind {
        self.child[lane].kind()
    }

    pub fn is_used(&self, lane: usize) -> bool {
        self.child[lane] != Subtree::UNUSED
    }

    pub fn is_interior(&self, lane: usize) -> bool {
        !self.child[lane].is_leaf()
    }

    /// The child node's index, if the lane holds an interior child.
    pub fn interior(&self, lane: usize) -> Option<usize> {
        match self.lane_kind(lane) {
            LaneKind::Interior(n) => Some(n as usize),
            _ => None,
        }
    }

    /// The leaf's first slot and triangle count, if the lane holds a leaf.
    pub fn leaf(&self, lane: usize) -> Option<(u32, u32)> {
        match self.lane_kind(lane) {
            LaneKind::Leaf { first, count } => Some((first, count)),
            _ => None,
        }
    }

    /// The leaf's triangle count, 0 for an interior or unused lane.
    pub fn leaf_count(&self, lane: usize) -> u32 {
        self.child[lane].count()
    }

    /// Lanes in use: children come first, unused lanes last.
    pub fn child_count(&self) -> usize {
        self.child
            .iter()
            .take_while(|&&c| c != Subtree::UNUSED)
            .count()
    }

    /// The node an interior lane's word names in `nodes`, found from the word's row
    /// count by a shift (a multiply by a node's size would lengthen every step of a walk).
    #[inline(always)]
    pub fn of_row(nodes: &[WideNode<W>], child: Subtree) -> &WideNode<W> {
        let row = child.node_row();
        assert!(row + ROWS as usize <= nodes.len() * ROWS as usize);
        // SAFETY: the row's node lies inside `nodes` (checked above); a node is exactly
        // `ROWS` rows with no padding (asserted sizes) and aligned to one row, so any row
        // is a node's start as far as alignment goes, and every bit pattern is a node's.
        unsafe {
            &*nodes
                .as_ptr()
                .cast::<[f32; W]>()
                .add(row)
                .cast::<WideNode<W>>()
        }
    }

    /// The union of the children's boxes: each row's least (or greatest) value over all
    /// lanes, as an unused lane's empty box changes neither.
    pub fn bounds(&self) -> Aabb {
        // Four lanes at a time, then across the four (W is a multiple of 4); boxes hold
        // no NaN, so the SIMD minimum is the minimum.
        const { assert!(W.is_multiple_of(4)) };
        let b = &self.bounds;
        let least = |row: &[f32; W]| {
            let four = row.chunks_exact(4).map(Vec4::from_slice);
            four.fold(Vec4::INFINITY, Vec4::min).min_element()
        };
        let greatest = |row: &[f32; W]| {
            let four = row.chunks_exact(4).map(Vec4::from_slice);
            four.fold(Vec4::NEG_INFINITY, Vec4::max).max_element()
        };
        Aabb::new(
            glam::Vec3::new(least(&b[0]), least(&b[1]), least(&b[2])),
            glam::Vec3::new(greatest(&b[3]), greatest(&b[4]), greatest(&b[5])),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The rows' extremes are the union of the used lanes' boxes, for every count of
    /// lanes in use.
    #[test]
    fn bounds_are_the_union_of_the_used_lanes() {
        let mut rng = crate::random::Rng(0x853c_49e6_748f_ea9b);
        let mut next = || rng.unit() as f32 * 16.0 - 8.0;
        for used in 0..=8 {
            for _ in 0..200 {
                let mut node = WideNode::<8>::default();
                let mut want = Aabb::EMPTY;
                for lane in 0..used {
                    let (a, b) = (
                        Vec3::new(next(), next(), next()),
                        Vec3::new(next(), next(), next()),
                    );
                    let b = Aabb::new(a.min(b), a.max(b));
                    node.set_child_bounds(lane, b);
                    node.child[lane] = Subtree::leaf(lane as u32, 1);
                    want = want.union(b);
                }
                let got = node.bounds();
                assert_eq!((got.min, got.max), (want.min, want.max), "{used} lanes");
            }
        }
    }

    /// Every lane word unpacks to what was packed, up to the field limits, and the
    /// limits' edges are kept apart: the largest index with the largest count, a leaf of
    /// one triangle at slot 0, and an interior child at the last index.
    #[test]
    fn lane_words_unpack_to_what_was_packed() {
        for first in [0, 1, 7, 1 << 20, MAX_INDEX - 1, MAX_INDEX] {
            for count in 1..=MAX_LEAF_COUNT {
                let s = Subtree::leaf(first, count);
                assert_eq!(s.kind(), LaneKind::Leaf { first, count });
                assert!(s.is_leaf());
                assert_eq!(s.slots(), first as usize..(first + count) as usize);
            }
            if first > 0 && first <= MAX_NODE {
                let s = Subtree::node(first);
                assert_eq!(s.kind(), LaneKind::Interior(first));
                assert!(!s.is_leaf() && s.count() == 0);
            }
        }
        assert_eq!(Subtree::UNUSED.kind(), LaneKind::Unused);
        assert_eq!(Subtree::UNUSED.slots(), 0..0);
        assert_eq!(Subtree::ROOT.kind(), LaneKind::Interior(0));
        let mut node = WideNode::<4>::default();
        assert_eq!(node.child_count(), 0);
        node.child[0] = Subtree::node(3);
        node.child[1] = Subtree::leaf(9, 2);
        assert_eq!(node.child_count(), 2);
        assert_eq!((node.interior(0), node.leaf(0)), (Some(3), None));
        assert_eq!((node.interior(1), node.leaf(1)), (None, Some((9, 2))));
        assert!(!node.is_used(2) && !node.is_interior(2));
    }

    /// A leaf count or index past its field is refused, not wrapped into another lane.
    #[test]
    #[should_panic(expected = "a lane holds")]
    fn a_leaf_past_the_count_field_is_refused() {
        Subtree::leaf(0, MAX_LEAF_COUNT + 1);
    }

    #[test]
    #[should_panic(expected = "is past")]
    fn a_slot_past_the_index_field_is_refused() {
        Subtree::leaf(MAX_INDEX + 1, 1);
    }

    #[test]
    #[should_panic(expected = "is past")]
    fn a_node_past_the_index_field_is_refused() {
        Subtree::node(MAX_NODE + 1);
    }

    /// Rows of a node never straddle a cache line, wherever the node lies in its array.
    #[test]
    fn rows_stay_in_one_cache_line() {
        let nodes = vec![WideNode::<8>::default(); 17];
        for n in &nodes {
            for row in n.bounds.iter().map(|r| r.as_ptr() as usize) {
                assert_eq!(row / 64, (row + 31) / 64);
            }
            let c = n.child.as_ptr() as usize;
            assert_eq!(c / 64, (c + 31) / 64);
        }
    }
}
