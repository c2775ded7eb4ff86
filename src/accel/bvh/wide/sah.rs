//! A wide BVH straight from binned SAH: the splits the BVH2's binned SAH makes, grouped W
//! to a node as they are made, with no BVH2 in between.
//!
//! A node's triangles are split as the BVH2 splits them (`Builder::split`: the same
//! buckets, costs and leaf rule), and then, while the node has lanes free, one of its
//! children is split again: first a child of a leaf's size or less that the SAH splits all
//! the same (smallest first: left whole, it would become a node of a few leaves), then the
//! child of largest box, as Embree's wide builders open their nodes. A child the SAH keeps
//! whole is a leaf. So the tree has the BVH2's leaves, and its nodes group the BVH2's
//! splits greedily, where the collapse chooses the grouping (and merges small subtrees
//! into leaves) by dynamic programming over the whole BVH2 for the least SAH cost: the
//! build skips the BVH2 and the collapse, and the tree costs a little more (the build
//! report gives its SAH cost).
//!
//! Large subtrees are laid out as parts of their own (`part`), each handed to another
//! thread the moment its node is split, while the top of the tree goes on splitting.

use super::WideBvh;
use super::collapse::MAX_REFERENCES;
use super::leaf::BlockPacker;
use super::node::{Lanes, MAX_NODE, NodeWidth, Subtree, WideNode};
use super::part::{Part, part_size};
use crate::accel::bvh::TraversalOrder;
use crate::accel::bvh::build::{
    BuildError, BuildParams, Builder, NodeInfo, PrimRef, Split, TopSplitClock, whole_references,
};
use crate::accel::bvh::report::BuildPhases;
use crate::accel::progress::BuildProgress;
use crate::geometry::Triangle;
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::Instant;

/// A child of a node being opened: its references, their bounds, its depth in the BVH2
/// the splits make, and whether the SAH keeps it whole.
#[derive(Default)]
struct Kid<'r> {
    refs: &'r mut [PrimRef],
    info: NodeInfo,
    /// The surface area of its box (`opening_order` compares it often).
    area: f32,
    depth: u32,
    leaf: bool,
}

/// A subtree laid out as a part of its own: found `order`-th by the top, under lane
/// `lane` of the top's node `node`.
struct CutPart<const W: usize>
where
    Lanes<W>: NodeWidth,
{
    order: usize,
    node: usize,
    lane: usize,
    part: Part<W>,
}

/// What every node's layout needs: the triangles, the splits' rule, and the size of the
/// subtrees laid out apart (`None` inside a part).
#[derive(Clone, Copy)]
struct Splitter<'a> {
    triangles: &'a [Triangle],
    builder: Builder<'a>,
    cut: Option<usize>,
}

/// A part's working memory: its leaves' packer and the triangles of the leaf being placed.
#[derive(Default)]
struct Desk {
    packer: BlockPacker,
    leaf: Vec<(Triangle, u32)>,
}

impl<const W: usize> WideBvh<W>
where
    Lanes<W>: NodeWidth,
{
    /// The wide tree over `triangles` straight from binned SAH with `params` (buckets,
    /// costs, leaf size), counting placed triangles into `progress`. Returns the time of its
    /// phases.
    pub fn binned_sah(
        triangles: &[Triangle],
        params: &BuildParams,
        progress: &BuildProgress,
    ) -> Result<(Self, BuildPhases), BuildError> {
        params.validate()?;
        if triangles.len() > MAX_REFERENCES {
            return Err(BuildError::TooManyForWide(triangles.len()));
        }
        if let Some(i) = triangles.par_iter().position_any(|t| !t.is_finite()) {
            return Err(BuildError::NonFinite(i));
        }
        let mut phases = BuildPhases::default();
        let start = Instant::now();
        let mut refs = whole_references(triangles);
        phases.add("references", start.elapsed());
        let start = Instant::now();
        let clock = TopSplitClock::default();
        let splitter = Splitter {
            triangles,
            builder: Builder {
                params,
                clock: &clock,
                progress,
            },
            cut: part_size(triangles.len()),
        };
        let whole = splitter.tree::<W>(&mut refs);
        clock.add_phases(&mut phases);
        phases.add("wide nodes", start.elapsed());
        Ok((
            whole.into_tree(triangles.len(), TraversalOrder::default()),
            phases,
        ))
    }
}

impl<'a> Splitter<'a> {
    /// The whole tree: its top, laid out here, and the parts below the cuts, laid out by
    /// other tasks as the top finds them, placed after the top in the order found.
    fn tree<const W: usize>(&self, refs: &mut [PrimRef]) -> Part<W>
    where
        Lanes<W>: NodeWidth,
    {
        let mut top = Part::new(1);
        let mut desk = Desk::default();
        let cuts = Mutex::new(Vec::new());
        let info = NodeInfo::of(refs);
        let n = refs.len();
        rayon::scope(|scope| match self.builder.split(refs, &info, 0) {
            Some(split) => {
                let mut found = 0;
                let cuts = &cuts;
                self.node(
                    &mut top, &mut desk, refs, split, 0, 1, scope, cuts, &mut found,
                );
            }
            None => {
                // One lane: a leaf of every triangle (or none).
                let mut root = WideNode::<W>::default();
                if n > 0 {
                    root.child[0] = self.leaf(&mut top, &mut desk, refs, 2);
                    root.set_child_bounds(0, info.bounds.to_aabb());
                }
                top.nodes.push(root);
            }
        });
        if self.cut.is_none() {
            self.builder.progress.add(n);
        }
        let mut cuts = cuts.into_inner().unwrap_or_else(|e| e.into_inner());
        cuts.sort_unstable_by_key(|c| c.order);
        let (lanes, parts): (Vec<(usize, usize)>, Vec<Part<W>>) =
            cuts.into_iter().map(|c| ((c.node, c.lane), c.part)).unzip();
        let mut whole = Part::new(1);
        top.place_into(&parts, &mut whole);
        for (&(node, lane), &base) in lanes.iter().zip(&whole.parts) {
            whole.nodes[node].child[lane] = Subtree::node(base);
        }
        whole
    }

    /// Lays out, at depth `depth`, the node over `refs`, split first by `split` (at BVH2
    /// depth `depth2`), and all below it depth first; subtrees within the cut are handed
    /// to `scope` and land in `cuts`, numbered from `found` on.
    #[allow(clippy::too_many_arguments)]
    fn node<'s, const W: usize>(
        self,
        part: &mut Part<W>,
        desk: &mut Desk,
        refs: &'s mut [PrimRef],
        split: Split,
        depth2: u32,
        depth: u32,
        scope: &rayon::Scope<'s>,
        cuts: &'s Mutex<Vec<CutPart<W>>>,
        found: &mut usize,
    ) where
        Lanes<W>: NodeWidth,
        'a: 's,
    {
        part.depth = part.depth.max(depth);
        let index = part.nodes.len();
        part.nodes.push(WideNode::default());
        let mut kids: [Kid<'s>; W] = std::array::from_fn(|_| Kid::default());
        let (m, left, right) = split;
        let (l, r) = refs.split_at_mut(m);
        kids[0] = Kid::new(l, left, depth2 + 1);
        kids[1] = Kid::new(r, right, depth2 + 1);
        let mut count = 2;
        let max_leaf = self.builder.params.max_leaf_size as usize;
        // Open the children the SAH splits, while lanes are free (`opening_order`).
        while count < W {
            let Some(k) = (0..count)
                .filter(|&k| !kids[k].leaf && kids[k].refs.len() > 1)
                .max_by(|&a, &b| kids[a].opening_order(&kids[b], max_leaf).then(b.cmp(&a)))
            else {
                break;
            };
            let kid = &mut kids[k];
            let Some((m, left, right)) = self.builder.split(kid.refs, &kid.info, kid.depth) else {
                kid.leaf = true;
                continue;
            };
            let whole = std::mem::take(kid);
            let (l, r) = whole.refs.split_at_mut(m);
            kids[k..=count].rotate_right(1);
            kids[k] = Kid::new(l, left, whole.depth + 1);
            kids[k + 1] = Kid::new(r, right, whole.depth + 1);
            count += 1;
        }
        let mut node = WideNode::<W>::default();
        for (lane, kid) in kids[..count].iter_mut().enumerate() {
            let kid = std::mem::take(kid);
            node.set_child_bounds(lane, kid.info.bounds.to_aabb());
            node.child[lane] = if kid.leaf {
                self.leaf(part, desk, kid.refs, depth + 1)
            } else {
                match self.builder.split(kid.refs, &kid.info, kid.depth) {
                    None => self.leaf(part, desk, kid.refs, depth + 1),
                    Some(split) if self.cut.is_some_and(|c| kid.refs.len() <= c) => {
                        let order = *found;
                        *found += 1;
                        // Laid out whole by the task: no cuts inside a part.
                        let solo = Splitter { cut: None, ..self };
                        scope.spawn(move |scope| {
                            let n = kid.refs.len();
                            let mut sub = Part::new(depth + 1);
                            // About what the scenes measured need (a node per ten
                            // triangles, blocks three quarters full), so the arrays
                            // seldom grow and copy.
                            sub.nodes.reserve(n / 8);
                            sub.blocks.reserve(n / 3 + 1);
                            sub.prim_indices.reserve(4 * (n / 3 + 1));
                            let mut desk = Desk::default();
                            let (refs, d2) = (kid.refs, kid.depth);
                            solo.node(
                                &mut sub,
                                &mut desk,
                                refs,
                                split,
                                d2,
                                depth + 1,
                                scope,
                                cuts,
                                &mut 0,
                            );
                            solo.builder.progress.add(n);
                            let cut = CutPart {
                                order,
                                node: index,
                                lane,
                                part: sub,
                            };
                            cuts.lock().unwrap_or_else(|e| e.into_inner()).push(cut);
                        });
                        // The part's first node, once the parts are placed.
                        Subtree::node(MAX_NODE)
                    }
                    Some(split) => {
                        let child = Subtree::node(part.nodes.len() as u32);
                        self.node(
                            part,
                            desk,
                            kid.refs,
                            split,
                            kid.depth,
                            depth + 1,
                            scope,
                            cuts,
                            found,
                        );
                        child
                    }
                }
            };
        }
        part.nodes[index] = node;
    }

    /// Places a leaf of `refs`'s triangles in `part`; returns its lane's word.
    fn leaf<const W: usize>(
        &self,
        part: &mut Part<W>,
        desk: &mut Desk,
        refs: &[PrimRef],
        depth: u32,
    ) -> Subtree
    where
        Lanes<W>: NodeWidth,
    {
        desk.leaf.clear();
        desk.leaf.extend(
            refs.iter()
                .map(|r| (self.triangles[r.index as usize], r.index)),
        );
        if self.cut.is_some() {
            // A leaf of the top; a part's leaves are counted by its task.
            self.builder.progress.add(refs.len());
        }
        part.place_leaf(&mut desk.packer, &desk.leaf, None, depth).0
    }
}

impl<'r> Kid<'r> {
    fn new(refs: &'r mut [PrimRef], info: NodeInfo, depth: u32) -> Self {
        Kid {
            refs,
            area: info.bounds.surface_area(),
            info,
            depth,
            leaf: false,
        }
    }

    /// Which of two children a node opens first (the greater): one of a leaf's size or
    /// less that the SAH splits all the same, smallest first, since it would otherwise
    /// become a node of a few leaves below this one; then the one of larger box.
    fn opening_order(&self, other: &Kid, max_leaf: usize) -> std::cmp::Ordering {
        let small = |k: &Kid| (k.refs.len() <= max_leaf).then_some(std::cmp::Reverse(k.refs.len()));
        small(self)
            .cmp(&small(other))
            .then(self.area.total_cmp(&other.area))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::wide::{CollapseParams, LaneKind, PADDING};
    use crate::accel::bvh::{Bvh, build};
    use crate::scene::builtin;

    /// Each leaf's triangles, sorted, and the leaves sorted.
    fn leaves_of_bvh2(b2: &Bvh) -> Vec<Vec<u32>> {
        let mut leaves: Vec<Vec<u32>> = (0..b2.nodes.len())
            .map(|i| b2.nodes[i])
            .filter(|n| n.is_leaf() && n.count > 0)
            .map(|n| {
                let mut l = b2.prim_indices[n.prim_range()].to_vec();
                l.sort_unstable();
                l
            })
            .collect();
        leaves.sort_unstable();
        leaves
    }

    fn leaves_of_wide<const W: usize>(w: &WideBvh<W>) -> Vec<Vec<u32>>
    where
        Lanes<W>: NodeWidth,
    {
        let mut leaves: Vec<Vec<u32>> = w
            .nodes
            .iter()
            .flat_map(|n| (0..W).map(|lane| n.lane_kind(lane)))
            .filter_map(|k| match k {
                LaneKind::Leaf { first, count } => {
                    let slots = first as usize..(first + count) as usize;
                    let mut l: Vec<u32> = w.prim_indices[slots].to_vec();
                    assert!(!l.contains(&PADDING));
                    l.sort_unstable();
                    Some(l)
                }
                _ => None,
            })
            .collect();
        leaves.sort_unstable();
        leaves
    }

    /// The tree straight from binned SAH has exactly the BVH2's leaves (its splits are the
    /// BVH2's, grouped), whatever the leaf size, buckets and costs; it is a grouping of the
    /// BVH2 the SAH-optimal collapse could have chosen, so it costs no less than that.
    #[test]
    fn the_tree_groups_the_bvh2s_splits() {
        let p0 = BuildParams::default();
        let params = [
            p0,
            BuildParams {
                max_leaf_size: 1,
                ..p0
            },
            BuildParams {
                buckets: 4,
                c_trav: 3.0,
                max_leaf_size: 12,
                ..p0
            },
        ];
        for spec in [
            "soup:3000",
            "sphere:2000",
            "teapot-in-stadium",
            "same-centroid",
            "cornell",
            "soup:40000",
        ] {
            let tris = builtin::by_name(spec).unwrap().unwrap().triangles;
            for p in &params {
                let what = format!("{spec}, {p:?}");
                let (b2, _) = build(&tris, p).unwrap();
                let (w8, _) =
                    WideBvh::<8>::binned_sah(&tris, p, &BuildProgress::default()).unwrap();
                let (w4, _) =
                    WideBvh::<4>::binned_sah(&tris, p, &BuildProgress::default()).unwrap();
                w8.validate().unwrap_or_else(|e| panic!("{what}: {e}"));
                w4.validate().unwrap_or_else(|e| panic!("{what}: {e}"));
                let expected = leaves_of_bvh2(&b2);
                assert!(leaves_of_wide(&w8) == expected, "{what}: BVH8");
                assert!(leaves_of_wide(&w4) == expected, "{what}: BVH4");
                let collapse = CollapseParams {
                    c_trav: p.c_trav,
                    c_isect: p.c_isect,
                    max_leaf_size: 1,
                };
                let best = WideBvh::<8>::collapse(&b2, &collapse).sah_cost(p.c_trav, p.c_isect);
                let ours = w8.sah_cost(p.c_trav, p.c_isect);
                assert!(ours >= best * (1.0 - 1e-5), "{what}: {ours} < {best}");
            }
        }
        let (empty, _) = WideBvh::<8>::binned_sah(&[], &p0, &BuildProgress::default()).unwrap();
        empty.validate().unwrap();
        assert_eq!(empty.nodes.len(), 1);
    }
}
