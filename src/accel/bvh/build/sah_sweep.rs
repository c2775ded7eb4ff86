//! Full-sweep SAH: sort the primitives by centroid along each axis and evaluate the cost
//! C = C_trav + S_A/S_N·N_A·C_isect + S_B/S_N·N_B·C_isect at every one of the N − 1 positions.
//! The exact minimum of the greedy SAH, at O(N log N) per node: the reference the binned
//! builder approximates.

use super::prim::{Box3A, NodeInfo, PrimRef, Split, split_at};
use super::{BuildParams, sah_split_cost, sah_worth_splitting};

/// Offers every position on every axis to `visit` as (axis, left count, unnormalised cost,
/// plane between the two centroids), leaving `sorted` ordered along the last axis.
fn candidates(
    sorted: &mut [PrimRef],
    parent_area: f32,
    p: &BuildParams,
    mut visit: impl FnMut(usize, usize, f32, f32),
) {
    let n = sorted.len();
    // right_area[i] = surface area of the boxes of sorted[i..].
    let mut right_area = vec![0.0f32; n];
    for axis in 0..3 {
        sort_along(sorted, axis);
        let mut right = Box3A::EMPTY;
        for i in (1..n).rev() {
            right.grow(sorted[i].lo(), sorted[i].hi());
            right_area[i] = right.surface_area();
        }
        let mut left = Box3A::EMPTY;
        for i in 1..n {
            left.grow(sorted[i - 1].lo(), sorted[i - 1].hi());
            let cost = sah_split_cost(parent_area, left.surface_area(), i, right_area[i], n - i, p);
            let plane = 0.25 * (sorted[i - 1].centroid2()[axis] + sorted[i].centroid2()[axis]);
            visit(axis, i, cost, plane);
        }
    }
}

pub fn split(refs: &mut [PrimRef], info: &NodeInfo, p: &BuildParams) -> Option<Split> {
    let n = refs.len();
    let parent_area = info.bounds.surface_area();
    let mut sorted = refs.to_vec();
    let mut best: Option<(f32, usize, usize)> = None;
    candidates(&mut sorted, parent_area, p, |axis, i, cost, _| {
        if best.is_none_or(|(c, _, _)| cost < c) {
            best = Some((cost, axis, i));
        }
    });
    let (cost, axis, m) = best?;
    if !sah_worth_splitting(n, cost, parent_area, p) {
        return None;
    }
    sort_along(refs, axis);
    Some(split_at(refs, m))
}

/// Every position of the node over `refs` as (axis, left count, unnormalised cost, plane):
/// what the bucket-cost plot draws for a full-sweep tree.
pub(super) fn all_candidates(
    refs: &[PrimRef],
    info: &NodeInfo,
    p: &BuildParams,
) -> Vec<(usize, usize, f32, f32)> {
    let mut sorted = refs.to_vec();
    let mut out = Vec::with_capacity(3 * refs.len());
    candidates(
        &mut sorted,
        info.bounds.surface_area(),
        p,
        |axis, i, cost, plane| out.push((axis, i, cost, plane)),
    );
    out
}

/// Sorts by centroid along `axis`, ties by index, so the same input always gives the same
/// tree.
fn sort_along(refs: &mut [PrimRef], axis: usize) {
    refs.sort_unstable_by(|a, b| {
        a.centroid2()[axis]
            .total_cmp(&b.centroid2()[axis])
            .then(a.index.cmp(&b.index))
    });
}
