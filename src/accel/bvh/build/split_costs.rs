//! The bucket-cost plot of a BVH node: every split a SAH builder weighs there and what it
//! costs, C = C_trav + S_A/S_N·N_A·C_isect + S_B/S_N·N_B·C_isect, beside the leaf's
//! C_isect·N. The costs come from the builders' own candidate loops, so the cheapest one
//! shown is the split the builder takes.

use super::prim::{NodeInfo, PrimRef};
use super::{BuildParams, Strategy, sah_binned, sah_sweep};
use crate::accel::split_costs::{SplitCandidate, SplitCosts, SplitMethod};
use crate::geometry::Triangle;

/// The split candidates of a node over the triangles `under` (indices into `triangles`),
/// as the full sweep weighs them for a full-sweep tree and as binned SAH with B =
/// `params.buckets` weighs them for any other (for median and LBVH trees: what the SAH
/// would have chosen instead).
pub fn split_costs(triangles: &[Triangle], under: &[u32], params: &BuildParams) -> SplitCosts {
    let refs: Vec<PrimRef> = under
        .iter()
        .map(|&i| PrimRef::new(triangles[i as usize].bounds(), i))
        .collect();
    let info = NodeInfo::of(&refs);
    let area = info.bounds.surface_area();
    // Costs relative to the node's area; a flat node (area 0) has no meaningful ratio.
    let normalise = |raw: f32| if area > 0.0 { raw / area } else { f32::NAN };
    let (method, candidates, cheapest) = if params.strategy == Strategy::SahSweep {
        let all = sah_sweep::all_candidates(&refs, &info, params);
        let candidate = |&(axis, left, cost, position): &(usize, usize, f32, f32)| SplitCandidate {
            axis,
            position,
            cost: normalise(cost),
            left: left as u32,
            right: (refs.len() - left) as u32,
        };
        let cheapest = first_minimum(all.iter().map(|c| (c.2, c))).map(candidate);
        (
            SplitMethod::Sweep,
            all.iter().map(candidate).collect(),
            cheapest,
        )
    } else {
        let all = sah_binned::all_candidates(&refs, &info, params);
        let candidate = |&(c, position): &(sah_binned::Candidate, f32)| SplitCandidate {
            axis: c.axis,
            position,
            cost: normalise(c.cost),
            left: c.left,
            right: c.right,
        };
        let offered = all.iter().filter(|(c, _)| !c.repeats_previous);
        let cheapest = first_minimum(offered.map(|c| (c.0.cost, c))).map(candidate);
        let method = SplitMethod::Binned {
            buckets: params.buckets,
        };
        (method, all.iter().map(candidate).collect(), cheapest)
    };
    SplitCosts {
        method,
        triangles: refs.len(),
        bounds: info.bounds.to_aabb(),
        candidates,
        leaf_cost: params.c_isect * refs.len() as f32,
        cheapest,
    }
}

/// The first candidate of lowest (unnormalised) cost: the builders' tie rule, on the
/// costs they compare.
fn first_minimum<T>(candidates: impl Iterator<Item = (f32, T)>) -> Option<T> {
    let mut best: Option<(f32, T)> = None;
    for (cost, c) in candidates {
        if best.as_ref().is_none_or(|(b, _)| cost < *b) {
            best = Some((cost, c));
        }
    }
    best.map(|(_, c)| c)
}
