//! Wide BVHs, BVH4 and BVH8: the BVH2 with levels folded together so that each node holds up
//! to W children, whose W boxes one SIMD instruction tests at once. Fewer, wider steps: a
//! BVH4 is roughly the BVH2 with every other level folded in, a BVH8 with two of three.
//!
//! The BVH2 stays the teaching tree and the one every builder produces; a wide tree is its
//! collapse (`collapse`), traced by one traversal (`traverse`) generic over the SIMD slab
//! kernel chosen at run time (`crate::geometry::simd`), whose leaves hold their triangles in
//! blocks of four tested by one SIMD watertight test (`leaf`). Hits equal the BVH2's bit for
//! bit.

pub mod collapse;
mod in_place;
pub mod leaf;
pub mod morton;
pub mod node;
mod order;
pub mod packet;
mod part;
pub mod refit;
pub mod sah;
mod source;
pub(crate) mod stack;
pub mod traverse;

pub use collapse::CollapseParams;
pub use leaf::PADDING;
pub use morton::MortonScratch;
pub use node::{LaneKind, Lanes, NodeWidth, Subtree, WideNode};

use super::TraversalOrder;
use super::build::{BuildError, BuildParams, Strategy};
use super::report::BuildPhases;
use crate::accel::progress::BuildProgress;
use crate::accel::{Outline, OutlineNode};
use crate::geometry::simd::{BLOCK, SimdLevel, TriangleBlock};
use crate::geometry::{Aabb, Triangle};

#[derive(Clone, Debug)]
pub struct WideBvh<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    /// Node 0 is the root; every node's interior children come after it.
    pub nodes: Vec<WideNode<W>>,
    /// The leaves' triangles in blocks of four (slot = block · 4 + lane), each leaf's slots
    /// contiguous.
    pub blocks: Vec<TriangleBlock>,
    /// Slot → scene triangle index (`PADDING` for a padding lane; repeated for a triangle
    /// with split references).
    pub prim_indices: Vec<u32>,
    /// Distinct scene triangles the tree was built over.
    pub triangle_count: usize,
    pub order: TraversalOrder,
    /// The slab kernel the traversal runs. Private: the traversal's `unsafe` kernels rely on
    /// it naming a level this CPU supports, which `set_simd` checks.
    simd: SimdLevel,
    /// Levels of wide nodes (the root alone is 1).
    pub depth: u32,
    /// Where each child sits (its node and lane), made at the first recorded visit: a
    /// replay's visit names a child, and its box is in the parent's lane. Moves keep it.
    pub(crate) lanes:
        std::sync::OnceLock<std::sync::Arc<std::collections::HashMap<Subtree, (u32, u8)>>>,
    /// Where the parts the collapse laid out apart begin: `parts[k]..parts[k + 1]` (the
    /// last up to the end) is a whole subtree, its nodes' children all inside it; the nodes
    /// before `parts[0]` are the top of the tree. Empty for a tree laid out in one part.
    pub(crate) parts: Vec<u32>,
    /// Where each part's blocks begin, as `parts` where its nodes do: a part's leaves hold
    /// slots of its own blocks only, so a refit can fill a part's blocks and bound its
    /// leaves while they are in the cache.
    pub(crate) part_blocks: Vec<u32>,
}

/// The sums over a wide tree's lanes the SAH cost is made of, apart from the costs: the
/// areas of the interior lanes, and the areas times triangles of the leaf lanes. A partial
/// refit updates them from the nodes it changes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LaneSums {
    interior_area: f64,
    leaf_area_triangles: f64,
}

impl LaneSums {
    pub(crate) fn of<const W: usize>(nodes: &[WideNode<W>]) -> Self
    where
        Lanes<W>: NodeWidth,
    {
        let mut sums = LaneSums::default();
        for n in nodes {
            sums.add(n);
        }
        sums
    }

    /// C = (C_trav · (S_root + Σ S_interior) + C_isect · Σ S_leaf · N_leaf) / S_root.
    pub(crate) fn sah_cost(&self, root: Aabb, c_trav: f32, c_isect: f32, triangles: usize) -> f64 {
        let root_area = root.surface_area() as f64;
        if root_area <= 0.0 {
            return c_isect as f64 * triangles as f64;
        }
        (c_trav as f64 * (root_area + self.interior_area)
            + c_isect as f64 * self.leaf_area_triangles)
            / root_area
    }

    /// Σ of the interior lanes' surface areas (the nodes below the root).
    pub(crate) fn interior_area(&self) -> f64 {
        self.interior_area
    }

    pub(crate) fn add<const W: usize>(&mut self, node: &WideNode<W>)
    where
        Lanes<W>: NodeWidth,
    {
        self.sum(node, 1.0);
    }

    /// Takes a node's lanes out of the sums (before its boxes change).
    pub(crate) fn take<const W: usize>(&mut self, node: &WideNode<W>)
    where
        Lanes<W>: NodeWidth,
    {
        self.sum(node, -1.0);
    }

    fn sum<const W: usize>(&mut self, node: &WideNode<W>, sign: f64)
    where
        Lanes<W>: NodeWidth,
    {
        for lane in 0..node.child_count() {
            let area = sign * node.child_bounds(lane).surface_area() as f64;
            if node.is_interior(lane) {
                self.interior_area += area;
            } else {
                self.leaf_area_triangles += area * node.leaf_count(lane) as f64;
            }
        }
    }
}

pub type Bvh4 = WideBvh<4>;
pub type Bvh8 = WideBvh<8>;

#[derive(Debug, thiserror::Error, PartialEq)]
#[error("this CPU has no {} instructions (it has: {})", .0.label(), SimdLevel::available().iter().map(|l| l.label()).collect::<Vec<_>>().join(", "))]
pub struct UnsupportedSimd(pub SimdLevel);

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// Chooses the slab kernel; an instruction set this CPU lacks is an error and changes
    /// nothing.
    /// The slab kernel the traversal runs.
    pub fn simd(&self) -> SimdLevel {
        self.simd
    }

    /// The wide tree built straight from the builder's splits, with no BVH2 in between
    /// (`BuildParams::builds_direct_wide`): from the Morton order for the LBVH (`morton`),
    /// from binned SAH's splits otherwise (`binned_sah`).
    pub fn direct(
        triangles: &[Triangle],
        params: &BuildParams,
        progress: &BuildProgress,
    ) -> Result<(Self, BuildPhases), BuildError> {
        if params.strategy == Strategy::Lbvh {
            params.validate()?;
            let built = Self::morton(triangles, params.direct_wide_leaf_size())?;
            progress.add(triangles.len());
            Ok(built)
        } else {
            Self::binned_sah(triangles, params, progress)
        }
    }

    pub fn set_simd(&mut self, level: SimdLevel) -> Result<(), UnsupportedSimd> {
        if !level.supported() {
            return Err(UnsupportedSimd(level));
        }
        self.simd = level;
        Ok(())
    }

    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode<W>>()
            + self.blocks.len() * std::mem::size_of::<TriangleBlock>()
            + self.prim_indices.len() * std::mem::size_of::<u32>()
    }

    /// Triangle references in the leaves: one per used lane (a triangle with split
    /// references counts once per leaf it is in; padding lanes not at all).
    pub fn references(&self) -> usize {
        self.prim_indices.iter().filter(|&&t| t != PADDING).count()
    }

    /// Wide nodes and leaves (a leaf is a lane holding triangles).
    pub fn leaf_count(&self) -> usize {
        self.nodes
            .iter()
            .flat_map(|n| n.child.iter())
            .filter(|&&c| c.is_leaf() && c != Subtree::UNUSED)
            .count()
    }

    /// The SAH cost of the wide tree, as the collapse minimised it: C_trav per interior node
    /// and C_isect per triangle, each weighted by its box's area relative to the root's.
    pub fn sah_cost(&self, c_trav: f32, c_isect: f32) -> f64 {
        LaneSums::of(&self.nodes).sah_cost(
            self.nodes[0].bounds(),
            c_trav,
            c_isect,
            self.triangle_count,
        )
    }

    /// The pieces the tree was laid out in, the top first and then each part: the range of
    /// its nodes and the range of its blocks. One piece (the whole tree) when it has no parts.
    pub(crate) fn pieces(&self) -> Vec<(std::ops::Range<usize>, std::ops::Range<usize>)> {
        // Every layout records both (`Part::place_into`); a part left out would be skipped.
        assert_eq!(
            self.parts.len(),
            self.part_blocks.len(),
            "parts and their blocks"
        );
        let ranges = |starts: &[u32], end: usize| {
            let starts = std::iter::once(0).chain(starts.iter().map(|&s| s as usize));
            let ends = starts.clone().skip(1).chain([end]);
            starts.zip(ends).map(|(a, b)| a..b).collect::<Vec<_>>()
        };
        let nodes = ranges(&self.parts, self.nodes.len());
        let blocks = ranges(&self.part_blocks, self.blocks.len());
        nodes.into_iter().zip(blocks).collect()
    }

    /// Checks that each triangle is in some leaf (exactly one unless its reference was split,
    /// and then its references' boxes cover it), every leaf spans no more blocks than it
    /// needs and holds a triangle once, every lane of no leaf is padding, every child box is
    /// exactly the union of its subtree's boxes or triangles (a leaf with split references:
    /// within it), and interior children come after their parent.
    pub fn validate(&self) -> Result<(), String> {
        let slots = self.blocks.len() * BLOCK;
        if self.prim_indices.len() != slots {
            return Err(format!(
                "{} indices for {slots} slots",
                self.prim_indices.len()
            ));
        }
        let references =
            super::validate::references_per_triangle(&self.prim_indices, self.triangle_count)?;
        let mut slot_box = vec![Aabb::EMPTY; slots];
        let mut owned = vec![false; slots];
        // The part each node is in (0: the top), whose subtree its children must not leave.
        let part_of = |i: usize| self.parts.partition_point(|&p| p as usize <= i);
        if !self.parts.is_sorted()
            || self
                .parts
                .last()
                .is_some_and(|&p| p as usize >= self.nodes.len())
        {
            return Err(format!(
                "parts {:?} of {} nodes",
                self.parts,
                self.nodes.len()
            ));
        }
        // The slots of the part each node is in: its own blocks, which a refit fills just
        // before it bounds the part's leaves.
        if self.part_blocks.len() != self.parts.len()
            || !self.part_blocks.is_sorted()
            || self
                .part_blocks
                .last()
                .is_some_and(|&b| b as usize > self.blocks.len())
        {
            return Err(format!(
                "part blocks {:?} of {} blocks",
                self.part_blocks,
                self.blocks.len()
            ));
        }
        let part_blocks: Vec<_> = self.pieces().into_iter().map(|(_, b)| b).collect();
        let part_slots = |k: usize| {
            let b: &std::ops::Range<usize> = &part_blocks[k];
            b.start * BLOCK..b.end * BLOCK
        };
        for (i, node) in self.nodes.iter().enumerate() {
            let used = node.child_count();
            if node.child[used..].iter().any(|&c| c != Subtree::UNUSED) {
                return Err(format!("node {i} has a used lane after an unused one"));
            }
            for lane in 0..used {
                let b = node.child_bounds(lane);
                let c = node.child[lane].index() as usize;
                let (inside, split) = if node.is_interior(lane) {
                    if c <= i || c >= self.nodes.len() {
                        return Err(format!("node {i} lane {lane} points to node {c}"));
                    }
                    // Only the top reaches into a part, at the part's root.
                    let (from, to) = (part_of(i), part_of(c));
                    if from != to && (from != 0 || self.parts[to - 1] as usize != c) {
                        return Err(format!("node {i} lane {lane} leaves its part for node {c}"));
                    }
                    (self.nodes[c].bounds(), false)
                } else {
                    let leaf = leaf::Leaf {
                        first: c as u32,
                        count: node.leaf_count(lane),
                    };
                    let range = node.child[lane].slots();
                    if range.end > slots || !leaf.is_compact() {
                        return Err(format!("node {i} lane {lane}: leaf {range:?} of {slots}"));
                    }
                    let own = part_slots(part_of(i));
                    if range.start < own.start || range.end > own.end {
                        return Err(format!(
                            "node {i} lane {lane}: leaf {range:?} outside its part's slots {own:?}"
                        ));
                    }
                    let ids = &self.prim_indices[range.clone()];
                    if (1..ids.len()).any(|a| ids[..a].contains(&ids[a])) {
                        return Err(format!("node {i} lane {lane} holds a triangle twice"));
                    }
                    let mut whole = Aabb::EMPTY;
                    for slot in range.clone() {
                        if std::mem::replace(&mut owned[slot], true)
                            || self.prim_indices[slot] == PADDING
                        {
                            return Err(format!("node {i} lane {lane}: slot {slot} taken"));
                        }
                        whole = whole.union(self.slot_triangle(slot).bounds());
                    }
                    slot_box[range].fill(b);
                    let split = ids.iter().any(|&t| references[t as usize] > 1);
                    (whole, split)
                };
                // Exactly: a child's box is the union of what lies under it, no larger. A
                // leaf holding parts of split triangles has a box within their boxes.
                let fits = if split {
                    inside.contains(&b)
                } else {
                    b == inside
                };
                if !fits {
                    return Err(format!("node {i} lane {lane}: {b:?} is not {inside:?}"));
                }
            }
        }
        for (slot, _) in owned.iter().enumerate().filter(|(_, o)| !**o) {
            if self.prim_indices[slot] != PADDING
                || !self.blocks[slot / BLOCK].is_padding(slot % BLOCK)
            {
                return Err(format!("slot {slot} of no leaf is not padding"));
            }
        }
        let slot_triangles: Vec<Triangle> = (0..slots).map(|k| self.slot_triangle(k)).collect();
        super::validate::check_split_coverage(
            &self.prim_indices,
            &slot_triangles,
            &slot_box,
            &references,
        )
    }

    /// The triangle in slot `slot` (block · 4 + lane).
    pub fn slot_triangle(&self, slot: usize) -> Triangle {
        self.blocks[slot / BLOCK].triangle(slot % BLOCK)
    }

    /// The subtrees below `s` (its node's lanes; none for a leaf).
    pub fn subtree_children(&self, s: Subtree) -> impl Iterator<Item = Subtree> + '_ {
        let node = &self.nodes[if s.is_leaf() { 0 } else { s.index() as usize }];
        let lanes = if s.is_leaf() { 0 } else { node.child_count() };
        node.child[..lanes].iter().copied()
    }

    /// The slots of the leaves under `s`, leaf by leaf, depth first.
    pub fn subtree_slots(&self, s: Subtree) -> Vec<usize> {
        let mut out = Vec::new();
        let mut stack = vec![s];
        while let Some(s) = stack.pop() {
            if s.is_leaf() {
                out.extend(s.slots());
            } else {
                stack.extend(self.subtree_children(s));
            }
        }
        out
    }

    /// The scene triangles under `s`, sorted, each once.
    pub fn subtree_triangles(&self, s: Subtree) -> Vec<u32> {
        let mut out: Vec<u32> = self
            .subtree_slots(s)
            .into_iter()
            .map(|k| self.prim_indices[k])
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Per node, the triangle references of the leaves under it (a split triangle counts
    /// once per leaf that holds a part of it).
    pub fn triangles_per_node(&self) -> Vec<u32> {
        let mut under = vec![0u32; self.nodes.len()];
        // Children come after their parents: one backward pass sees children first.
        for n in (0..self.nodes.len()).rev() {
            let node = &self.nodes[n];
            under[n] = (0..node.child_count())
                .map(|l| match node.lane_kind(l) {
                    LaneKind::Interior(c) => under[c as usize],
                    _ => node.leaf_count(l),
                })
                .sum();
        }
        under
    }

    /// Per wide node, the index of its node in `outline()` (the root's is 0).
    pub fn outline_index(&self) -> Vec<u32> {
        let mut index = vec![u32::MAX; self.nodes.len()];
        index[0] = 0;
        let mut next = 1u32;
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(wide) = queue.pop_front() {
            let w = &self.nodes[wide];
            for lane in 0..w.child_count() {
                if let Some(c) = w.interior(lane) {
                    index[c] = next;
                    queue.push_back(c);
                }
                next += 1;
            }
        }
        index
    }

    /// The tree for the explorer: wide nodes and their leaves, children contiguous.
    pub fn outline(&self) -> Outline {
        let root = &self.nodes[0];
        let mut nodes = vec![OutlineNode {
            bounds: root.bounds(),
            depth: 0,
            parent: u32::MAX,
            first_child: 0,
            child_count: 0,
            refs: (0, 0),
            plane: None,
        }];
        // (outline index, wide node index), breadth first so siblings are contiguous.
        let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
        while let Some((at, wide)) = queue.pop_front() {
            let w = &self.nodes[wide];
            let first = nodes.len();
            for lane in 0..w.child_count() {
                let interior = w.interior(lane);
                if let Some(c) = interior {
                    queue.push_back((nodes.len(), c));
                }
                nodes.push(OutlineNode {
                    bounds: w.child_bounds(lane),
                    depth: nodes[at].depth + 1,
                    parent: at as u32,
                    first_child: 0,
                    child_count: 0,
                    refs: w.leaf(lane).unwrap_or((0, 0)),
                    plane: None,
                });
            }
            nodes[at].first_child = first as u32;
            nodes[at].child_count = (nodes.len() - first) as u32;
        }
        Outline {
            nodes,
            refs: self.prim_indices.clone(),
        }
    }
}
