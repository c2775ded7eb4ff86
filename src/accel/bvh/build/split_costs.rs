//! The bucket-cost plot: every split a SAH builder weighs at one node and what it costs,
//! C = C_trav + S_A/S_N·N_A·C_isect + S_B/S_N·N_B·C_isect, beside the leaf's C_isect·N.
//! The costs come from the builders' own candidate loops, so the cheapest one shown is
//! the split the builder takes.

use super::prim::{NodeInfo, PrimRef};
use super::{BuildParams, Strategy, sah_binned, sah_sweep};
use crate::geometry::{Aabb, Triangle};

/// How the candidates were found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitMethod {
    /// The B − 1 bucket boundaries per axis of binned SAH.
    Binned { buckets: u32 },
    /// Every position between sorted centroids, N − 1 per axis.
    Sweep,
}

/// One candidate split plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitCandidate {
    pub axis: usize,
    /// The plane's position along `axis`, in world units.
    pub position: f32,
    /// C_trav + Σ S_child/S_N·N_child·C_isect.
    pub cost: f32,
    /// Triangles on each side.
    pub left: u32,
    pub right: u32,
}

/// The candidates of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitCosts {
    pub method: SplitMethod,
    pub triangles: usize,
    /// The node's box: the bounds of its triangles.
    pub bounds: Aabb,
    /// In the order the builder offers them.
    pub candidates: Vec<SplitCandidate>,
    /// C_isect·N: what the node costs as a leaf.
    pub leaf_cost: f32,
    /// The split the builder would take: the first of the cheapest candidates (a binned
    /// boundary after an empty bucket repeats the one before and is not taken).
    pub cheapest: Option<SplitCandidate>,
}

impl SplitCosts {
    /// Whether the builder splits here: the leaf is too big, or a split is cheaper.
    pub fn splits(&self, params: &BuildParams) -> bool {
        self.triangles > params.max_leaf_size as usize
            || self.cheapest.is_some_and(|c| c.cost < self.leaf_cost)
    }
}

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
