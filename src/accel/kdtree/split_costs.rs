//! The bucket-cost plot of a k-d tree node: the build is replayed from the root along the
//! path to the node (the same references, clipped the same way, and the same split chosen
//! at every ancestor), then every plane the SAH weighs at the node is listed with its
//! cost, the empty-space bonus included.

use super::build::classify;
use super::split::{KdRef, all_splits, best_split};
use super::{KdParams, KdSplit, KdTree};
use crate::accel::split_costs::{SplitCandidate, SplitCosts, SplitMethod};

impl KdTree {
    /// The split costs at the node reached from the root by `path` (`false`: the below
    /// child, `true`: the above child), with the parameters the tree was built with.
    /// `None` if the path leaves the tree or the replay does not reach the tree's own
    /// splits (other parameters than the build's).
    pub fn split_costs(&self, params: &KdParams, path: &[bool]) -> Option<SplitCosts> {
        let mut refs: Vec<KdRef> = (self.triangles.iter().enumerate())
            .map(|(i, t)| KdRef {
                bounds: t.bounds(),
                tri: i as u32,
            })
            .collect();
        let mut cell = self.bounds;
        let mut node = 0;
        for &above in path {
            let n = self.nodes.get(node)?;
            if n.is_leaf() {
                return None;
            }
            let split = best_split(&refs, &cell, params)?;
            if (split.axis, split.pos) != (n.axis(), n.split()) {
                return None;
            }
            let (mut below_cell, mut above_cell) = (cell, cell);
            below_cell.max[split.axis] = split.pos;
            above_cell.min[split.axis] = split.pos;
            let (below_refs, above_refs) =
                classify(&self.triangles, &refs, &split, &below_cell, &above_cell);
            (refs, cell, node) = if above {
                (above_refs, above_cell, n.above_child())
            } else {
                (below_refs, below_cell, node + 1)
            };
        }
        let candidate = |s: &super::split::Split| SplitCandidate {
            axis: s.axis,
            position: s.pos,
            cost: s.cost as f32,
            left: s.below as u32,
            right: s.above as u32,
        };
        let method = match params.split {
            KdSplit::Sweep => SplitMethod::KdPerfect,
            KdSplit::Binned(bins) => SplitMethod::KdBinned { bins },
        };
        Some(SplitCosts {
            method,
            triangles: refs.len(),
            bounds: cell,
            candidates: all_splits(&refs, &cell, params)
                .iter()
                .map(candidate)
                .collect(),
            leaf_cost: params.c_isect * refs.len() as f32,
            cheapest: best_split(&refs, &cell, params).as_ref().map(candidate),
        })
    }
}
