//! k-d tree construction: a pure function of (triangles, parameters) → tree + report.
//!
//! The recursion of the lecture: find the cheapest plane by the SAH, make a leaf if no plane
//! is cheaper than testing every triangle (allowing a few "bad refines" that may pay off
//! deeper, as pbrt does), else send each reference to the side(s) it touches, clipping the
//! triangles that straddle the plane to each child's cell, and recurse. A depth bound
//! (≤ 64, so the recursion and the traversal stack stay small) and a cap on the total
//! number of references stop it on any input.

use super::events::{self, Events, Side};
use super::node::KdNode;
use super::split::{KdRef, Split, best_split};
use super::{KdError, KdParams, KdSplit, KdTree, MAX_TRIANGLES};
use crate::accel::StructureReport;
use crate::accel::progress::BuildProgress;
use crate::geometry::clip::clipped_bounds;
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Subtrees over at least this many references are built in parallel.
const PARALLEL_SUBTREE: usize = 4096;
/// pbrt's allowance of splits that cost more than a leaf on one path down the tree.
const MAX_BAD_REFINES: u32 = 3;

/// Builds a k-d tree over `triangles`. Triangle indices in hits are indices into `triangles`.
pub fn build(
    triangles: &[Triangle],
    params: &KdParams,
) -> Result<(KdTree, StructureReport), KdError> {
    build_with_progress(triangles, params, &BuildProgress::default())
}

/// `build`; an abandoned build (`progress`) makes every node it has not split yet a leaf.
pub fn build_with_progress(
    triangles: &[Triangle],
    params: &KdParams,
    progress: &BuildProgress,
) -> Result<(KdTree, StructureReport), KdError> {
    build_keeping_events(triangles, params, progress, true)
}

/// `build_with_progress`; the exact sweep carries its sorted events from the root down
/// (`events`) if `keep_events`, else sorts them afresh at every node (the tests' reference).
fn build_keeping_events(
    triangles: &[Triangle],
    params: &KdParams,
    progress: &BuildProgress,
    keep_events: bool,
) -> Result<(KdTree, StructureReport), KdError> {
    params.validate()?;
    if triangles.len() > MAX_TRIANGLES {
        return Err(KdError::TooMany(triangles.len()));
    }
    if let Some(i) = triangles.par_iter().position_any(|t| !t.is_finite()) {
        return Err(KdError::NonFinite(i));
    }
    let start = Instant::now();
    let n = triangles.len();
    let refs: Vec<KdRef> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| KdRef {
            bounds: t.bounds(),
            tri: i as u32,
        })
        .collect();
    let bounds = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds));
    let builder = Builder {
        triangles,
        params,
        progress,
        max_depth: params.depth_bound(n),
        depth_cap_hit: AtomicBool::new(false),
        refs_cap_hit: AtomicBool::new(false),
    };
    // Leaves address their references with 32-bit offsets.
    let budget = ((params.max_references_factor as f64 * n as f64) as usize)
        .min(u32::MAX as usize)
        .max(n);
    // The exact sweep keeps its events sorted from the root down (`events`).
    let events = (keep_events && params.split == KdSplit::Sweep).then(|| Events::of(&refs));
    let (tree, _) = builder.subtree(refs, events, bounds, 0, 0, budget);
    let (nodes, leaf_refs) = flatten(&tree);
    drop_in_background(tree);
    let kd = KdTree {
        nodes,
        refs: leaf_refs,
        triangles: triangles.to_vec(),
        bounds,
        mailbox: params.mailbox,
        c_trav: params.c_trav,
        c_isect: params.c_isect,
        depth_bound: builder.max_depth,
    };
    let build_time = start.elapsed();
    let mut caps_hit = Vec::new();
    if builder.depth_cap_hit.load(Ordering::Relaxed) {
        caps_hit.push(format!(
            "depth bound {} stopped a split the SAH wanted",
            builder.max_depth
        ));
    }
    if builder.refs_cap_hit.load(Ordering::Relaxed) {
        caps_hit.push(format!(
            "reference cap {:.1} × triangles ({budget}) stopped a split",
            params.max_references_factor
        ));
    }
    let report = kd.report(params, builder.max_depth, build_time, caps_hit);
    Ok((kd, report))
}

/// Dropping the temporary tree frees many small vectors; it need not delay the caller.
fn drop_in_background(tree: Tmp) {
    rayon::spawn(move || drop(tree));
}

/// The tree as the recursion produces it, before it is laid out in compact nodes.
enum Tmp {
    Leaf(Vec<u32>),
    Interior {
        axis: usize,
        pos: f32,
        children: Box<[Tmp; 2]>,
    },
}

struct Builder<'a> {
    triangles: &'a [Triangle],
    params: &'a KdParams,
    progress: &'a BuildProgress<'a>,
    max_depth: u32,
    depth_cap_hit: AtomicBool,
    refs_cap_hit: AtomicBool,
}

impl Builder<'_> {
    /// The subtree over `refs` in `cell`, and the references its leaves hold. `budget` is
    /// the most they may hold: a share of the global cap proportional to the subtree's
    /// references, plus what its below sibling left unused when the two are built one after
    /// the other. The tree does not depend on the order parallel subtrees finish in.
    fn subtree(
        &self,
        refs: Vec<KdRef>,
        events: Option<Events>,
        cell: Aabb,
        depth: u32,
        bad_refines: u32,
        budget: usize,
    ) -> (Tmp, usize) {
        let n = refs.len();
        let p = self.params;
        if n <= p.max_leaf_size as usize || self.progress.is_abandoned() {
            return leaf(refs);
        }
        let events = events.filter(|_| n >= events::KEPT_FROM);
        let split = match &events {
            Some(events) => events.best_split(n, &cell, p),
            None => best_split(&refs, &cell, p),
        };
        let Some(split) = split else {
            return leaf(refs);
        };
        let leaf_cost = p.c_isect as f64 * n as f64;
        let mut bad_refines = bad_refines;
        if split.cost > leaf_cost {
            bad_refines += 1;
            if (split.cost > 4.0 * leaf_cost && n < 16) || bad_refines >= MAX_BAD_REFINES {
                return leaf(refs);
            }
        }
        if depth >= self.max_depth {
            self.depth_cap_hit.store(true, Ordering::Relaxed);
            return leaf(refs);
        }
        let (mut below_cell, mut above_cell) = (cell, cell);
        below_cell.max[split.axis] = split.pos;
        above_cell.min[split.axis] = split.pos;
        let cells = (&below_cell, &above_cell);
        let ((below, below_events), (above, above_events)) = match events {
            Some(events) => {
                let ((b, be), (a, ae)) = events.split(self.triangles, &refs, &split, cells);
                ((b, Some(be)), (a, Some(ae)))
            }
            None => {
                let (b, a) = classify(self.triangles, &refs, &split, &below_cell, &above_cell);
                ((b, None), (a, None))
            }
        };
        let total = below.len() + above.len();
        if total > budget {
            self.refs_cap_hit.store(true, Ordering::Relaxed);
            return leaf(refs);
        }
        drop(refs);
        // At most budget − |above|, so the above side always gets its own references.
        let below_budget = ((budget as u128 * below.len() as u128) / total as u128) as usize;
        let next = depth + 1;
        let ((b, used_below), (a, used_above)) = if n >= PARALLEL_SUBTREE {
            let above_budget = budget - below_budget;
            rayon::join(
                move || {
                    let b = (below, below_events);
                    self.subtree(b.0, b.1, below_cell, next, bad_refines, below_budget)
                },
                move || {
                    let a = (above, above_events);
                    self.subtree(a.0, a.1, above_cell, next, bad_refines, above_budget)
                },
            )
        } else {
            let b = self.subtree(
                below,
                below_events,
                below_cell,
                next,
                bad_refines,
                below_budget,
            );
            let above_budget = budget - b.1;
            let a = self.subtree(
                above,
                above_events,
                above_cell,
                next,
                bad_refines,
                above_budget,
            );
            (b, a)
        };
        let tree = Tmp::Interior {
            axis: split.axis,
            pos: split.pos,
            children: Box::new([b, a]),
        };
        (tree, used_below + used_above)
    }
}

/// Sends each reference to the side(s) of the plane its clipped bounds touch: one that
/// ends or starts on the plane goes to the side it lies on, one lying in the plane to
/// the side the SAH chose, and one straddling the plane to both, clipped to each cell.
pub(super) fn classify(
    triangles: &[Triangle],
    refs: &[KdRef],
    split: &Split,
    below_cell: &Aabb,
    above_cell: &Aabb,
) -> (Vec<KdRef>, Vec<KdRef>) {
    classify_into(
        triangles,
        refs,
        split,
        (below_cell, above_cell),
        &mut |_, _| {},
    )
}

/// `classify`, telling `note` where each reference `i` went: `Side::Below(k)` or
/// `Side::Above(k)` for its place in a child's list, and `Side::Cut` first for one the
/// plane cuts (clipped into one child or both).
pub(super) fn classify_into(
    triangles: &[Triangle],
    refs: &[KdRef],
    split: &Split,
    (below_cell, above_cell): (&Aabb, &Aabb),
    note: &mut impl FnMut(usize, Side),
) -> (Vec<KdRef>, Vec<KdRef>) {
    let (axis, pos) = (split.axis, split.pos);
    let mut below = Vec::with_capacity(refs.len());
    let mut above = Vec::with_capacity(refs.len());
    for (i, r) in refs.iter().enumerate() {
        let (lo, hi) = (r.bounds.min[axis], r.bounds.max[axis]);
        let (b, a) = if lo == pos && hi == pos {
            match split.planar_below {
                true => (Some(*r), None),
                false => (None, Some(*r)),
            }
        } else if hi <= pos {
            (Some(*r), None)
        } else if lo >= pos {
            (None, Some(*r))
        } else {
            note(i, Side::Cut);
            let tri = &triangles[r.tri as usize];
            match (
                clipped_bounds(tri, below_cell),
                clipped_bounds(tri, above_cell),
            ) {
                // The clip found the triangle in neither cell though its bounds straddle
                // the plane; keep it on both sides rather than lose it.
                (None, None) => (
                    Some(clamp_ref(r, below_cell)),
                    Some(clamp_ref(r, above_cell)),
                ),
                (b, a) => (
                    b.map(|bounds| KdRef { bounds, tri: r.tri }),
                    a.map(|bounds| KdRef { bounds, tri: r.tri }),
                ),
            }
        };
        if let Some(b) = b {
            note(i, Side::Below(below.len() as u32));
            below.push(b);
        }
        if let Some(a) = a {
            note(i, Side::Above(above.len() as u32));
            above.push(a);
        }
    }
    (below, above)
}

fn clamp_ref(r: &KdRef, cell: &Aabb) -> KdRef {
    KdRef {
        bounds: Aabb::new(r.bounds.min.max(cell.min), r.bounds.max.min(cell.max)),
        tri: r.tri,
    }
}

fn leaf(refs: Vec<KdRef>) -> (Tmp, usize) {
    (Tmp::Leaf(refs.iter().map(|r| r.tri).collect()), refs.len())
}

/// Lays the tree out depth first: a node's below child right after it, the above child
/// wherever its subtree starts; each leaf's references contiguous, one reference inline.
fn flatten(root: &Tmp) -> (Vec<KdNode>, Vec<u32>) {
    let mut nodes = Vec::new();
    let mut refs = Vec::new();
    let mut stack: Vec<(&Tmp, Option<usize>)> = vec![(root, None)];
    while let Some((t, parent)) = stack.pop() {
        let index = nodes.len();
        if let Some(p) = parent {
            let n: &mut KdNode = &mut nodes[p];
            *n = KdNode::interior(n.axis(), n.split(), index as u32);
        }
        match t {
            Tmp::Leaf(tris) => {
                let node = match tris.len() {
                    0 => KdNode::leaf(0, 0),
                    1 => KdNode::leaf(tris[0], 1),
                    k => {
                        let first = refs.len() as u32;
                        refs.extend_from_slice(tris);
                        KdNode::leaf(first, k as u32)
                    }
                };
                nodes.push(node);
            }
            Tmp::Interior {
                axis,
                pos,
                children,
            } => {
                nodes.push(KdNode::interior(*axis, *pos, 0));
                stack.push((&children[1], Some(index)));
                stack.push((&children[0], None));
            }
        }
    }
    (nodes, refs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin::by_name;

    /// Events carried from the root down give the tree that sorting them afresh at every
    /// node gives: the same planes and the same references in the same leaves. The scenes
    /// have planar triangles (the Cornell box, the walls), many cut by planes (the soup) and
    /// a small object in a large cell (the teapot in a stadium).
    #[test]
    fn events_kept_sorted_give_the_tree_of_events_sorted_at_every_node() {
        let progress = BuildProgress::default();
        for spec in [
            "cornell",
            "walls",
            "walls-rotated",
            "soup:3000",
            "teapot-in-stadium",
        ] {
            let scene = by_name(spec).unwrap().unwrap();
            let triangles = scene.flattened().unwrap();
            for max_leaf_size in [1, 4] {
                let params = KdParams {
                    max_leaf_size,
                    ..KdParams::default()
                };
                let kept = build_keeping_events(&triangles, &params, &progress, true).unwrap();
                let sorted = build_keeping_events(&triangles, &params, &progress, false).unwrap();
                assert!(kept.0.nodes.len() > 1, "{spec}: no split at all");
                assert_eq!(kept.0.nodes, sorted.0.nodes, "{spec}: the planes differ");
                assert_eq!(kept.0.refs, sorted.0.refs, "{spec}: the leaves differ");
            }
        }
    }
}
