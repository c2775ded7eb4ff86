//! EPO estimated from end points instead of clipped: EPO is the mean, over end points p
//! spread uniformly over the scene's surfaces, of the cost of the nodes whose box holds p
//! but not p's own triangle. So the mean over n points drawn by area is an unbiased
//! estimate of it, with the standard error of a mean. Each point walks the tree once, root
//! to the leaves whose boxes hold it, where the exact form clips its whole triangle into
//! every box the triangle crosses: a few thousand points give the EPO to a percent or two
//! in a fraction of a fast build's time (`docs/measurements.md`).

use super::by_triangle::{mark, references};
use super::{Epo, Estimate, Outline, Tree};
use crate::geometry::Triangle;
use crate::random::Rng;
use glam::DVec3;
use rayon::prelude::*;

/// End points drawn by one generator: the estimate is the same on any number of threads.
const CHUNK: u64 = 8192;
const SEED: u64 = 0xE90;

/// The end points `stats --epo estimate` draws unless told.
pub const DEFAULT_END_POINTS: u64 = 1 << 14;

/// The EPO of `outline` over `scene` estimated from `n` end points (the same ones every
/// time); `None` once `abandon` says so.
pub fn epo_estimate(
    outline: &Outline,
    scene: &[Triangle],
    c_trav: f32,
    c_isect: f32,
    n: u64,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<Epo> {
    let runs = running_areas(scene.iter().map(|t| area_vector(t).length()));
    if outline.nodes.is_empty() || runs.last().is_none_or(|&a| a <= 0.0) {
        return Some(Epo::exact(0.0));
    }
    let tree = Tree::of(outline, c_trav, c_isect);
    let refs = references(outline, scene.len());
    // Each triangle's place in leaf order: a chunk's points walked in that order share the
    // part of the tree they read, where points in drawing order would each miss the cache.
    let mut rank = vec![0u32; scene.len()];
    for (k, &t) in refs.order.iter().enumerate() {
        rank[t as usize] = k as u32;
    }
    let init = || (vec![false; tree.nodes.len()], Vec::new(), Vec::new());
    type State = (Vec<bool>, Vec<u32>, Vec<(u32, DVec3)>);
    let chunk = |(above, stack, points): &mut State, rng: &mut Rng, count: u64| {
        points.clear();
        points.extend((0..count).map(|_| {
            let t = pick(&runs, rng.unit());
            (t as u32, point_on(&scene[t], rng))
        }));
        points.sort_unstable_by_key(|&(t, _)| rank[t as usize]);
        let (mut sum, mut squares) = (0.0, 0.0);
        for &(t, p) in points.iter() {
            let leaves = refs.of_triangle(t as usize);
            mark(&tree, leaves, above, true);
            let mut x = 0.0;
            stack.clear();
            stack.push(0);
            while let Some(n) = stack.pop() {
                let node = &tree.nodes[n as usize];
                let min = DVec3::from(node.min.map(f64::from));
                let max = DVec3::from(node.max.map(f64::from));
                if p.cmplt(min).any() || p.cmpgt(max).any() {
                    continue;
                }
                if !above[n as usize] {
                    x += tree.cost[n as usize];
                }
                stack.extend(node.first_child..node.first_child + node.child_count);
            }
            mark(&tree, leaves, above, false);
            sum += x;
            squares += x * x;
        }
        (sum, squares)
    };
    estimate(n, init, chunk, abandon)
}

/// The mean of `n` charges, as an estimated EPO: `chunk(state, generator, count)` draws
/// and charges `count` end points and returns the sum of their charges and of their
/// squares (each chunk with its own generator and a state `init` makes). `None` once
/// `abandon` says so.
pub(crate) fn estimate<S>(
    n: u64,
    init: impl Fn() -> S + Sync + Send,
    chunk: impl Fn(&mut S, &mut Rng, u64) -> (f64, f64) + Sync + Send,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<Epo> {
    let sums: Vec<(f64, f64)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map_init(&init, |state, k| {
            if abandon() {
                return (0.0, 0.0);
            }
            let mut rng = Rng::for_case(SEED, k);
            chunk(state, &mut rng, CHUNK.min(n - k * CHUNK))
        })
        .collect();
    if abandon() {
        return None;
    }
    let (sum, squares) = sums
        .iter()
        .fold((0.0, 0.0), |(s, q), &(ds, dq)| (s + ds, q + dq));
    let count = n.max(1) as f64;
    let mean = sum / count;
    let variance = ((squares - count * mean * mean) / (count - 1.0).max(1.0)).max(0.0);
    Some(Epo {
        value: mean,
        estimate: Some(Estimate {
            std_error: (variance / count).sqrt(),
            end_points: n,
        }),
    })
}

/// Running sums of `weights`.
pub(crate) fn running_areas(weights: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut run = 0.0;
    weights
        .map(|w| {
            run += w;
            run
        })
        .collect()
}

/// The entry a uniform `u` in [0, 1) falls in, by the running sums `runs` (an entry of no
/// weight is never picked).
pub(crate) fn pick(runs: &[f64], u: f64) -> usize {
    let total = runs.last().copied().unwrap_or(0.0);
    runs.partition_point(|&r| r <= u * total)
        .min(runs.len().saturating_sub(1))
}

/// Twice a triangle's vector area, in f64.
pub(crate) fn area_vector(t: &Triangle) -> DVec3 {
    let [a, b, c] = t.v.map(|v| v.as_dvec3());
    (b - a).cross(c - a)
}

/// A point uniform on `tri`: the square root spreads the first coordinate by area. From a
/// vertex along the edges, so a coordinate all three vertices share is kept to the bit: a
/// triangle in a box's face plane stays in the box, as its clipped part does.
pub(crate) fn point_on(tri: &Triangle, rng: &mut Rng) -> DVec3 {
    let (r, s) = (rng.unit().sqrt(), rng.unit());
    let [a, b, c] = tri.v.map(|v| v.as_dvec3());
    a + (b - a) * (r * (1.0 - s)) + (c - a) * (r * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::accel::structure::build_scene;
    use crate::accel::{StructureParams, bvh::Strategy};
    use crate::scene::builtin;

    /// On every kind of tree and builder, over a soup that overlaps and the stadium whose
    /// walls lie in the boxes' face planes, the estimate lies within 4.5 standard errors of
    /// the clipped EPO, to a few percent.
    #[test]
    fn the_estimate_finds_the_clipped_epo() {
        for name in ["soup:3000", "teapot-in-stadium"] {
            let scene = builtin::by_name(name).unwrap().unwrap();
            let tris = &scene.triangles;
            for (kind, strategy) in [
                (AccelKind::Bvh, Strategy::SahBinned),
                (AccelKind::Bvh, Strategy::ObjectMedian),
                (AccelKind::Bvh, Strategy::Sbvh),
                (AccelKind::Bvh8, Strategy::Lbvh),
                (AccelKind::KdTree, Strategy::SahBinned),
                (AccelKind::Octree, Strategy::SahBinned),
            ] {
                let mut params = StructureParams::of_kind(kind);
                params.bvh.strategy = strategy;
                let s = build_scene(&scene, &params, &Default::default())
                    .unwrap()
                    .structure;
                let (c_trav, c_isect) = params.sah_constants();
                let outline = s.outline();
                let exact = super::super::epo(&outline, tris, c_trav, c_isect);
                let est =
                    epo_estimate(&outline, tris, c_trav, c_isect, 1 << 15, &|| false).unwrap();
                let e = est.estimate.unwrap();
                let what = format!("{name} {} {}", kind.label(), strategy.label());
                assert!(
                    (est.value - exact).abs() <= 4.5 * e.std_error + 1e-12,
                    "{what}: {} ± {} against {exact}",
                    est.value,
                    e.std_error
                );
                assert!(
                    e.std_error <= 0.05 * exact + 1e-9,
                    "{what}: {}",
                    e.std_error
                );
            }
        }
    }
}
