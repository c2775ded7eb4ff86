//! A wide BVH straight from the Morton order: the LBVH's radix tree, grouped into wide nodes
//! as it is found, for scenes that move and must be rebuilt every frame.
//!
//! The LBVH of the lecture makes three trees: the radix tree (a link per triangle), the
//! canonical BVH2, and the wide tree collapsed from it. Here the triangles are sorted along
//! the Morton curve as there, and then one top-down pass makes the wide nodes: a node's
//! range of sorted triangles is split where the radix tree splits it (the highest bit in
//! which its first and last codes differ), and its largest part split again, until it has
//! W parts or every part is a leaf of at most `leaf_size` triangles. The boxes are found on
//! the way back up. No SAH is evaluated: the tree follows the curve.
//!
//! Large subtrees are laid out as parts of their own, in parallel; the tree is the same
//! for any number of threads. Each part is counted first and then written straight into
//! its place in the tree's arrays (`in_place`), not laid out apart and copied as the
//! collapse's parts are.
//!
//! Fresh memory is what a build from nothing pays most for on this project's machines (the
//! kernel zeroes each new page, and a virtual machine's host may have to find it first), so
//! the build keeps only what it must beside the tree: the sorted keys and their sort's
//! buffer (16 bytes a triangle). The triangles are read through the keys, not copied into
//! Morton order; the parts' boxes are not kept but made again. For 10^7 triangles that cut
//! the build's fresh memory from about 2.1 GB to 0.9 GB (the tree itself is 0.7).
//!
//! A scene that moves is built again every frame. `rebuild_morton` builds into the memory
//! of the tree it replaces and of a `MortonScratch` kept beside it: built into fresh
//! memory, a third of the time went to the kernel zeroing pages for arrays of the same
//! sizes as those the frame before had just freed.

use super::WideBvh;
use super::collapse::MAX_REFERENCES;
use super::in_place::{Counter, InPlace, Layout, Shape};
use super::leaf::BlockPacker;
use super::node::{LaneKind, Lanes, MAX_LEAF_COUNT, MAX_NODE, NodeWidth, Subtree, WideNode};
use super::part::{Part, part_size, pieces_of};
use crate::accel::bvh::TraversalOrder;
use crate::accel::bvh::build::{BuildError, radix_sort_from_with, triangle_codes_into};
use crate::accel::bvh::report::BuildPhases;
use crate::geometry::simd::BLOCK;
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;
use std::ops::Range;
use std::time::Instant;

/// Bits of the Morton codes the triangles are sorted by (10 per axis).
const CODE_BITS: u32 = 30;

/// The triangles in Morton order, and the leaf size.
struct Sorted<'a> {
    /// Each a code above the scene index of its triangle, sorted.
    keys: &'a [u64],
    /// The scene's triangles, read through the keys' indices as the leaves are placed.
    triangles: &'a [Triangle],
    /// The triangles of a part, gathered in sorted order before it is laid out (a tight
    /// loop of loads, which keeps many cache misses in flight where the layout's own reads
    /// would wait on each), from sorted position `first` on.
    gathered: &'a [(Triangle, u32)],
    first: usize,
    leaf_size: usize,
    /// Subtrees of at most this many triangles are left as parts of their own.
    cut: Option<usize>,
}

/// A subtree left to be laid out as a part: the range under lane `lane` of node `node`.
struct Cut {
    node: usize,
    lane: usize,
    range: Range<usize>,
    depth: u32,
}

/// What the direct build keeps from one build to the next, so that a tree rebuilt every
/// frame writes over memory it already has: the sorted keys and their sort's buffer, the
/// top of the tree, and each part's record of its nodes' children.
pub struct MortonScratch<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    keys: Vec<u64>,
    sort_buffer: Vec<u64>,
    /// The top of the tree, down to the cuts.
    top: Part<W>,
    /// Each part's nodes' children, as its count found them.
    shapes: Vec<Vec<Shape<W>>>,
}

impl<const W: usize> Default for MortonScratch<W>
where
    Lanes<W>: NodeWidth,
{
    fn default() -> Self {
        MortonScratch {
            keys: Vec::new(),
            sort_buffer: Vec::new(),
            top: Part::new(1),
            shapes: Vec::new(),
        }
    }
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The wide tree over `triangles` straight from their Morton order, with leaves of at
    /// most `leaf_size` triangles (1..=`MAX_LEAF_COUNT`). Returns the time of its phases.
    pub fn morton(
        triangles: &[Triangle],
        leaf_size: u32,
    ) -> Result<(Self, BuildPhases), BuildError> {
        let mut tree = Part::new(1).into_tree(0, TraversalOrder::default());
        let phases = tree.rebuild_morton(triangles, leaf_size, &mut MortonScratch::default())?;
        Ok((tree, phases))
    }

    /// Builds this tree again over `triangles` (the scene moved), as `morton` builds it,
    /// into its own memory and `scratch`'s: the same tree, without the fresh pages. The
    /// traversal order and kernel stay. On an error the tree is as it was.
    pub fn rebuild_morton(
        &mut self,
        triangles: &[Triangle],
        leaf_size: u32,
        scratch: &mut MortonScratch<W>,
    ) -> Result<BuildPhases, BuildError> {
        if triangles.len() > MAX_REFERENCES {
            return Err(BuildError::TooManyForWide(triangles.len()));
        }
        if let Some(i) = triangles.par_iter().position_any(|t| !t.is_finite()) {
            return Err(BuildError::NonFinite(i));
        }
        let leaf_size = leaf_size.clamp(1, MAX_LEAF_COUNT) as usize;
        let mut phases = BuildPhases::default();
        sort_along_the_curve(triangles, scratch, &mut phases);

        let start = Instant::now();
        let n = triangles.len();
        let sorted = Sorted {
            keys: &scratch.keys,
            triangles,
            gathered: &[],
            first: 0,
            leaf_size,
            cut: part_size(n),
        };
        let mut whole = Part {
            nodes: std::mem::take(&mut self.nodes),
            blocks: std::mem::take(&mut self.blocks),
            prim_indices: std::mem::take(&mut self.prim_indices),
            depth: 1,
            parts: std::mem::take(&mut self.parts),
            part_blocks: std::mem::take(&mut self.part_blocks),
        };
        sorted.lay_out_tree_into(&mut scratch.top, &mut scratch.shapes, &mut whole);
        self.nodes = whole.nodes;
        self.blocks = whole.blocks;
        self.prim_indices = whole.prim_indices;
        self.parts = whole.parts;
        self.part_blocks = whole.part_blocks;
        self.depth = whole.depth;
        self.triangle_count = n;
        self.lanes = Default::default();
        phases.add("wide nodes", start.elapsed());
        Ok(phases)
    }
}

/// Sorts the triangles along the Morton curve through their boxes' centroids: `s.keys`
/// sorted, each the code's top 30 bits (10 per axis, as Embree's Morton builder) above the
/// triangle's index, eight bytes sorted in four passes where the full code and an index take
/// sixteen in eight. The triangles themselves are not copied into that order (400 MB of
/// fresh pages for 10^7 of them, when built from nothing): the leaves read them through the
/// keys, in the same order the copy would have.
fn sort_along_the_curve<const W: usize>(
    triangles: &[Triangle],
    s: &mut MortonScratch<W>,
    phases: &mut BuildPhases,
) where
    Lanes<W>: NodeWidth,
{
    let start = Instant::now();
    triangle_codes_into(triangles, &mut s.keys, |code, i| {
        (code >> (63 - CODE_BITS)) << 32 | u64::from(i)
    });
    phases.add("Morton codes", start.elapsed());
    let start = Instant::now();
    radix_sort_from_with(&mut s.keys, &mut s.sort_buffer, 32);
    phases.add("radix sort", start.elapsed());
}

impl<'a> Sorted<'a> {
    /// Where the radix tree splits `r` (of two triangles or more): the first position
    /// whose code differs from the first code in their highest differing bit; the middle
    /// where all codes are equal.
    fn split(&self, r: &Range<usize>) -> usize {
        let (first, last) = (self.code(r.start), self.code(r.end - 1));
        if first == last {
            return r.start + r.len() / 2;
        }
        let prefix = (first ^ last).leading_zeros();
        r.start
            + self.keys[r.clone()]
                .partition_point(|&k| ((k >> 32) ^ first).leading_zeros() > prefix)
    }

    /// The length of the code prefix shared by the range: the shorter, the larger the
    /// Morton cell that holds its centroids.
    fn prefix(&self, r: &Range<usize>) -> u32 {
        (self.code(r.start) ^ self.code(r.end - 1)).leading_zeros()
    }

    /// The code of the triangle at sorted position `i`.
    fn code(&self, i: usize) -> u64 {
        self.keys[i] >> 32
    }

    /// The triangles at the sorted positions `r` (a leaf's, at most `MAX_LEAF_COUNT`) with
    /// their scene indices, gathered into `buffer`, and their box.
    fn leaf<'b>(&self, r: Range<usize>, buffer: &'b mut LeafBuffer) -> (&'b [(Triangle, u32)], Aabb)
    where
        'a: 'b,
    {
        let local = r.start.checked_sub(self.first);
        if let Some(tris) = local.and_then(|s| self.gathered.get(s..s + r.len())) {
            let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.0.bounds()));
            return (tris, bounds);
        }
        let tris = &mut buffer[..r.len()];
        let mut bounds = Aabb::EMPTY;
        for (t, &k) in tris.iter_mut().zip(&self.keys[r]) {
            *t = (self.triangles[k as u32 as usize], k as u32);
            bounds = bounds.union(t.0.bounds());
        }
        (tris, bounds)
    }

    /// The ranges the node over `r` takes as children, in Morton order: `r` split, then
    /// the largest part over a leaf's size split again, while the node has lanes free.
    fn children<const W: usize>(&self, r: Range<usize>) -> ([Range<usize>; W], usize) {
        let mut kids: [Range<usize>; W] = std::array::from_fn(|_| 0..0);
        kids[0] = r;
        let mut count = 1;
        while count < W {
            let Some(k) = (0..count)
                .filter(|&k| kids[k].len() > self.leaf_size)
                .min_by_key(|&k| (self.prefix(&kids[k]), usize::MAX - kids[k].len(), k))
            else {
                break;
            };
            let whole = kids[k].clone();
            let s = self.split(&whole);
            for j in (k + 1..count).rev() {
                kids[j + 1] = kids[j].clone();
            }
            kids[k] = whole.start..s;
            kids[k + 1] = s..whole.end;
            count += 1;
        }
        (kids, count)
    }

    /// The whole tree, written into `whole`: its top down to the cuts (laid out in `top`),
    /// then the parts below the cuts in parallel, each counted first and then written
    /// straight into its place after the top, in the order of their cuts (`in_place`); the
    /// top's boxes are completed from theirs.
    fn lay_out_tree_into<const W: usize>(
        &self,
        top: &mut Part<W>,
        shapes: &mut Vec<Vec<Shape<W>>>,
        whole: &mut Part<W>,
    ) where
        Lanes<W>: NodeWidth,
    {
        top.reset(1);
        let all = 0..self.keys.len();
        let mut packer = BlockPacker::default();
        let mut cuts = Vec::new();
        if all.len() <= self.leaf_size {
            // One lane: a leaf of every triangle (or none).
            let mut root = WideNode::<W>::default();
            if !all.is_empty() {
                let mut buffer = EMPTY_LEAF;
                let n = all.len();
                let (tris, bounds) = self.leaf(all, &mut buffer);
                root.child[0] = top.leaf(&mut packer, n, tris);
                root.set_child_bounds(0, bounds);
            }
            top.nodes.push(root);
            top.place_into(&[], whole);
            return;
        }
        self.node(top, &mut packer, all, 1, &mut cuts);
        let solo = Sorted { cut: None, ..*self };
        if shapes.len() < cuts.len() {
            shapes.resize_with(cuts.len(), Vec::new);
        }
        let counts: Vec<Counter<W>> = cuts
            .par_iter()
            .zip(&mut shapes[..])
            .map(|(c, shapes)| {
                let mut count = Counter::new(std::mem::take(shapes));
                let (r, depth) = (c.range.clone(), c.depth);
                solo.node::<W, _>(
                    &mut count,
                    &mut BlockPacker::default(),
                    r,
                    depth,
                    &mut vec![],
                );
                count
            })
            .collect();
        // The pieces' lengths, the top's first, and where the parts begin.
        let node_lengths: Vec<usize> = std::iter::once(top.nodes.len())
            .chain(counts.iter().map(|c| c.nodes))
            .collect();
        let block_lengths: Vec<usize> = std::iter::once(top.blocks.len())
            .chain(counts.iter().map(|c| c.blocks))
            .collect();
        let part_starts = |lengths: &[usize]| -> Vec<u32> {
            (lengths[..lengths.len() - 1].iter())
                .scan(0, |sum, &n| {
                    *sum += n as u32;
                    Some(*sum)
                })
                .collect()
        };
        whole.parts = part_starts(&node_lengths);
        whole.part_blocks = part_starts(&block_lengths);
        let node_count: usize = node_lengths.iter().sum();
        let block_count: usize = block_lengths.iter().sum();
        let nodes = pieces_of(&mut whole.nodes, node_lengths.into_iter());
        let blocks = pieces_of(&mut whole.blocks, block_lengths.iter().copied());
        let slots = pieces_of(
            &mut whole.prim_indices,
            block_lengths.iter().map(|b| b * BLOCK),
        );
        let mut pieces = nodes.into_iter().zip(blocks).zip(slots);
        let ((top_nodes, top_blocks), top_slots) = pieces.next().expect("the top's piece");
        top_nodes.write_copy_of_slice(&top.nodes);
        top_blocks.write_copy_of_slice(&top.blocks);
        top_slots.write_copy_of_slice(&top.prim_indices);
        let laid: Vec<(Aabb, u32)> = pieces
            .collect::<Vec<_>>()
            .into_par_iter()
            .zip(cuts.par_iter().zip(&counts))
            .zip(whole.parts.par_iter().zip(&whole.part_blocks))
            .map_init(
                Vec::new,
                |gathered, ((((n, b), s), (c, count)), (&nb, &bb))| {
                    gathered.clear();
                    gathered.extend(
                        self.keys[c.range.clone()]
                            .iter()
                            .map(|&k| (self.triangles[k as u32 as usize], k as u32)),
                    );
                    let solo = Sorted {
                        gathered,
                        first: c.range.start,
                        ..solo
                    };
                    let mut out = InPlace::new((n, b, s), &count.shapes, (nb, bb), c.depth);
                    let (r, depth) = (c.range.clone(), c.depth);
                    let bounds =
                        solo.node(&mut out, &mut BlockPacker::default(), r, depth, &mut vec![]);
                    let depth = out.depth;
                    out.finish();
                    (bounds, depth)
                },
            )
            .collect();
        // SAFETY: the pieces cover the first elements of each vector's capacity up to the
        // lengths below, and every piece was written whole (the top's copied, each part's
        // checked by `finish`); a panic above leaves the vectors empty.
        unsafe {
            whole.nodes.set_len(node_count);
            whole.blocks.set_len(block_count);
            whole.prim_indices.set_len(block_count * BLOCK);
        }
        for (kept, count) in shapes.iter_mut().zip(counts) {
            *kept = count.shapes;
        }
        whole.depth = laid.iter().map(|l| l.1).fold(top.depth, u32::max);
        let top = top.nodes.len();
        for ((c, &base), (b, _)) in cuts.iter().zip(&whole.parts).zip(laid) {
            let node = &mut whole.nodes[c.node];
            node.child[c.lane] = Subtree::node(base);
            node.set_child_bounds(c.lane, b);
        }
        // The top's boxes over the cuts, children (after their parents) first.
        for i in (0..top).rev() {
            for lane in 0..W {
                if let LaneKind::Interior(c) = whole.nodes[i].lane_kind(lane)
                    && (c as usize) < top
                {
                    let b = whole.nodes[c as usize].bounds();
                    whole.nodes[i].set_child_bounds(lane, b);
                }
            }
        }
    }

    /// Lays out the node over `r` (more than a leaf's triangles) at depth `depth` into
    /// `out`, and all below it depth first, but for subtrees within the cut, left in
    /// `cuts`; returns its box (missing the cut subtrees', which the caller adds; empty
    /// where `out` keeps no boxes).
    fn node<const W: usize, L: Layout<W>>(
        &self,
        out: &mut L,
        packer: &mut BlockPacker,
        r: Range<usize>,
        depth: u32,
        cuts: &mut Vec<Cut>,
    ) -> Aabb
    where
        Lanes<W>: NodeWidth,
    {
        out.deepen(depth);
        let index = out.open_node();
        let (kids, count) = out.children(&r, || self.children::<W>(r.clone()));
        let mut node = WideNode::<W>::default();
        let mut buffer = EMPTY_LEAF;
        for (lane, k) in kids[..count].iter().enumerate() {
            if k.len() <= self.leaf_size {
                if L::WRITES {
                    let (tris, bounds) = self.leaf(k.clone(), &mut buffer);
                    node.child[lane] = out.leaf(packer, k.len(), tris);
                    node.set_child_bounds(lane, bounds);
                } else {
                    out.leaf(packer, k.len(), &[]);
                }
            } else if self.cut.is_some_and(|c| k.len() <= c) {
                // The part's first node, once the parts are placed.
                node.child[lane] = Subtree::node(MAX_NODE);
                cuts.push(Cut {
                    node: index as usize,
                    lane,
                    range: k.clone(),
                    depth: depth + 1,
                });
            } else {
                node.child[lane] = out.node_word(out.next_node());
                let b = self.node(out, packer, k.clone(), depth + 1, cuts);
                node.set_child_bounds(lane, b);
            }
        }
        if !L::WRITES {
            return Aabb::EMPTY;
        }
        let bounds = node.bounds();
        out.close_node(index, node);
        bounds
    }
}

/// Room for a leaf's triangles and their scene indices.
type LeafBuffer = [(Triangle, u32); MAX_LEAF_COUNT as usize];

const EMPTY_LEAF: LeafBuffer = [(
    Triangle {
        v: [glam::Vec3::ZERO; 3],
    },
    0,
); MAX_LEAF_COUNT as usize];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::wide::collapse::tests::assert_cuts_agree;
    use crate::accel::bvh::wide::leaf::PADDING;
    use crate::scene::builtin;

    /// The tree over `tris` with the parts cut at `cut` triangles (`None`: one piece).
    fn tree(tris: &[Triangle], cut: Option<usize>) -> WideBvh<8> {
        let mut scratch = MortonScratch::<8>::default();
        sort_along_the_curve(tris, &mut scratch, &mut BuildPhases::default());
        let s = Sorted {
            keys: &scratch.keys,
            triangles: tris,
            gathered: &[],
            first: 0,
            leaf_size: 4,
            cut,
        };
        let mut whole = Part::new(1);
        s.lay_out_tree_into(&mut Part::new(1), &mut Vec::new(), &mut whole);
        whole.into_tree(tris.len(), TraversalOrder::default())
    }

    /// Laying the tree out in parts, at any cut, gives the tree laid out in one piece, and
    /// that tree holds every triangle once, in leaves of at most four, inside its boxes.
    #[test]
    fn parts_laid_out_apart_make_the_same_tree() {
        for spec in [
            "soup:6000",
            "sphere:5000",
            "teapot-in-stadium",
            "same-centroid",
        ] {
            let tris = builtin::by_name(spec).unwrap().unwrap().triangles;
            assert_cuts_agree(spec, &[5, 8, 50, 400, 3000, 1 << 20], |cut| {
                tree(&tris, cut)
            });
            let t = tree(&tris, None);
            let mut held: Vec<u32> = t
                .prim_indices
                .iter()
                .copied()
                .filter(|&i| i != PADDING)
                .collect();
            held.sort_unstable();
            assert!(held.iter().copied().eq(0..tris.len() as u32), "{spec}");
            let largest = t
                .nodes
                .iter()
                .flat_map(|n| (0..8).map(|l| n.leaf_count(l)))
                .max();
            assert!(largest <= Some(4), "{spec}: {largest:?}");
        }
    }

    /// Everything a tree holds, as text (padding lanes hold NaN, which `==` refuses).
    fn contents(t: &WideBvh<8>) -> String {
        format!(
            "{:?} {:?} {:?} {} {} {:?} {:?}",
            t.nodes, t.blocks, t.prim_indices, t.triangle_count, t.depth, t.parts, t.part_blocks
        )
    }

    /// Rebuilt in its own memory over scenes of other sizes in turn, and over a scene that
    /// moved, with the scratch of the builds before, the tree is the one built fresh:
    /// nothing of an earlier tree or part stays behind. A refused rebuild leaves the tree.
    #[test]
    fn a_tree_rebuilt_in_its_own_memory_is_the_tree_built_fresh() {
        let scene = |spec: &str| builtin::by_name(spec).unwrap().unwrap().triangles;
        let mut moved = scene("soup:60000");
        for (i, t) in moved.iter_mut().enumerate() {
            let shift = glam::Vec3::new((i % 7) as f32, 0.5, -(i as f32) * 1e-4);
            *t = Triangle::new(t.v[0] + shift, t.v[1] - shift, t.v[2] + 0.5 * shift);
        }
        let scenes = [
            scene("soup:60000"),
            scene("sphere:5000"),
            moved,
            scene("cornell"),
            scene("soup:2"),
            Vec::new(),
            scene("soup:40000"),
        ];
        let (mut tree, _) = WideBvh::<8>::morton(&scenes[0], 4).unwrap();
        let mut scratch = MortonScratch::default();
        for (k, tris) in scenes.iter().enumerate() {
            for leaf in [4, 1] {
                tree.rebuild_morton(tris, leaf, &mut scratch).unwrap();
                let (fresh, _) = WideBvh::<8>::morton(tris, leaf).unwrap();
                assert!(
                    contents(&tree) == contents(&fresh),
                    "scene {k}, leaf {leaf}"
                );
                tree.validate().unwrap();
            }
        }
        let before = contents(&tree);
        let mut bad = scenes[6].clone();
        bad[123].v[1].y = f32::NAN;
        let got = tree.rebuild_morton(&bad, 4, &mut scratch);
        assert_eq!(got.err(), Some(BuildError::NonFinite(123)));
        assert!(contents(&tree) == before);
    }

    /// A range splits where the radix tree splits it: before the first code that differs
    /// from the range's first in their highest differing bit; equal codes are halved.
    #[test]
    fn ranges_split_at_the_radix_trees_split() {
        let codes: [u64; 11] = [1, 2, 4, 5, 5, 5, 19, 24, 25, 30, 30];
        let keys: Vec<u64> = codes.iter().zip(0..).map(|(c, i)| c << 32 | i).collect();
        let s = Sorted {
            keys: &keys,
            triangles: &[],
            gathered: &[],
            first: 0,
            leaf_size: 1,
            cut: None,
        };
        assert_eq!(s.split(&(0..11)), 6); // 19 = 0b10011 starts the half with bit 4 set.
        assert_eq!(s.split(&(0..6)), 2); // 4 = 0b100 starts bit 2.
        assert_eq!(s.split(&(3..6)), 4); // Three equal codes: halved.
        assert_eq!(s.split(&(9..11)), 10);
        // The node opens the part of the largest cell first (19..30 differ from bit 3 on,
        // 1..5 from bit 2), then, of equal cells, the larger part: 19 is split off, then
        // 1..5 (six codes) before 24..30 (four).
        let (kids, count) = s.children::<4>(0..11);
        assert_eq!(count, 4);
        assert_eq!(kids.to_vec(), vec![0..2, 2..6, 6..7, 7..11]);
    }
}
