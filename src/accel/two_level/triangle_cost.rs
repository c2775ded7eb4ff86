//! Where both levels' SAH cost lives, on the placed triangles: the cost (`sah`) split among
//! them as one tree's is (`accel::triangle_cost`), so that the shares of every placed
//! triangle add up to both levels' SAH cost. A top-level node's C_trav · SA(n)/SA(root) is
//! shared evenly among the placed triangles under it; a reference's subtree root, weighed
//! with its top-level lane, among the reference's triangles (a reference that is one leaf
//! charges each of its triangles one test instead); a BLAS node below it, weighed with its
//! placed area, among the triangles under it; a leaf charges each of its triangles
//! C_isect times its placed area.
//!
//! The island places 10^10 triangles, so the shares are worked out only for the triangles
//! asked for (those a frame shows): one walk up each triangle's levels, over sums made once
//! per level (the top level's shares from the root down, each BLAS's placed-area products
//! from its root down, weighed by the instance as the SAH cost's are).

use super::TwoLevel;
use super::blas_index::BlasIndex;
use super::sah::{area_weights, products};
use crate::accel::bvh::wide::LaneKind;
use crate::accel::bvh::{Bvh8, Subtree};
use glam::DVec3;
use std::collections::HashMap;

/// The sums the shares are read from.
pub struct PlacedCosts<'a> {
    tl: &'a TwoLevel,
    blas: Vec<BlasIndex>,
    /// Per top-level node: its share and its ancestors', from the root down.
    top: Vec<f64>,
    /// Per BLAS, per node: Σ products(box)/N over the nodes from below the root down to
    /// it (the root's 0: a reference's subtree root is weighed with its top-level lane).
    below: Vec<Vec<DVec3>>,
    weights: Vec<DVec3>,
    reference_of: HashMap<(u32, u32), u32>,
    /// SA(root), 0 for a scene without area.
    root: f64,
    c_trav: f64,
    c_isect: f64,
}

impl TwoLevel {
    /// The sums for the shares of both levels' SAH cost weighed with `c_trav` and `c_isect`.
    pub fn placed_costs(&self, c_trav: f32, c_isect: f32) -> PlacedCosts<'_> {
        let root = match self.tlas.nodes.first() {
            Some(n) => f64::from(n.bounds().surface_area()).max(0.0),
            None => 0.0,
        };
        let c_trav = f64::from(c_trav);
        PlacedCosts {
            tl: self,
            blas: self
                .blases
                .iter()
                .map(|b| BlasIndex::of(b, b.triangle_count))
                .collect(),
            top: top_shares(self, c_trav, root),
            below: self.blases.iter().map(products_below).collect(),
            weights: area_weights(&self.instances),
            reference_of: self
                .references
                .iter()
                .enumerate()
                .map(|(r, reference)| ((reference.instance, reference.subtree.word()), r as u32))
                .collect(),
            root,
            c_trav,
            c_isect: f64::from(c_isect),
        }
    }
}

impl PlacedCosts<'_> {
    /// The share of flattened triangle `flat` (instance after instance, each mesh's
    /// triangles in order); 0 for a triangle no leaf holds or past the last.
    pub fn of(&self, flat: u64) -> f64 {
        let tl = self.tl;
        let i = tl.first_triangle.partition_point(|&f| f <= flat);
        let Some(i) = i.checked_sub(1) else {
            return 0.0;
        };
        let mesh = tl.instances[i].mesh;
        let (Some(blas), Some(index)) = (tl.blases.get(mesh), self.blas.get(mesh)) else {
            return 0.0;
        };
        let t = flat - tl.first_triangle[i];
        if t >= blas.triangle_count as u64 {
            return 0.0;
        }
        index
            .lanes_of(t as usize)
            .iter()
            .map(|&(node, first)| self.of_leaf(i, blas, index, node, first))
            .sum()
    }

    /// The shares of the triangles `flat` names, each once.
    pub fn of_all(&self, flat: impl IntoIterator<Item = u64>) -> HashMap<u64, f64> {
        let mut out = HashMap::new();
        for t in flat {
            out.entry(t).or_insert_with(|| self.of(t));
        }
        out
    }

    /// One reference of a triangle: the leaf lane of `node` from slot `first`, of instance
    /// `i`, and everything above it up to the top level's root.
    fn of_leaf(&self, i: usize, blas: &Bvh8, index: &BlasIndex, node: u32, first: u32) -> f64 {
        let n = &blas.nodes[node as usize];
        let Some(lane) = (0..n.child_count()).find(|&l| n.leaf(l).is_some_and(|f| f.0 == first))
        else {
            return 0.0;
        };
        if self.root <= 0.0 {
            // A scene without area: one test per triangle, as a flat BVH weighs it.
            return self.c_isect;
        }
        let leaf = products(n.child_bounds(lane));
        let count = n.leaf_count(lane);
        let key = |s: Subtree| (i as u32, s.word());
        // The reference holding the leaf: the leaf itself, or the nearest node above it.
        if let Some(&r) = self.reference_of.get(&key(Subtree::leaf(first, count))) {
            return self.top_of(r) + self.c_isect * self.lane_area(r) / self.root;
        }
        let mut s = node;
        while s != u32::MAX {
            if let Some(&r) = self.reference_of.get(&key(Subtree::node(s))) {
                let reference = &self.tl.references[r as usize];
                let mesh = &self.below[self.tl.instances[i].mesh];
                let w = self.weights[i];
                let subtree_root = self.c_trav * self.lane_area(r)
                    / self.root
                    / f64::from(reference.triangles.max(1));
                let nodes = self.c_trav * w.dot(mesh[node as usize] - mesh[s as usize]);
                let test = self.c_isect * w.dot(leaf);
                return self.top_of(r) + subtree_root + (nodes + test) / self.root;
            }
            s = index.parent[s as usize];
        }
        0.0
    }

    /// The top-level shares above reference `r`: its node's and its ancestors'.
    fn top_of(&self, r: u32) -> f64 {
        self.tl
            .top_index
            .slot_of(r as usize)
            .map_or(0.0, |(node, _)| self.top[node as usize])
    }

    /// The surface area of reference `r`'s top-level lane.
    fn lane_area(&self, r: u32) -> f64 {
        self.tl
            .top_index
            .slot_of(r as usize)
            .map_or(0.0, |(node, lane)| {
                let b = self.tl.tlas.nodes[node as usize].child_bounds(lane as usize);
                f64::from(b.surface_area())
            })
    }
}

/// Per top-level node, C_trav · SA/SA(root) shared among the placed triangles under it,
/// summed from the root down (the root weighed with its own box, the others with their
/// lanes').
fn top_shares(tl: &TwoLevel, c_trav: f64, root: f64) -> Vec<f64> {
    let nodes = &tl.tlas.nodes;
    // The placed triangles under each node: its leaves' references' triangles.
    let under = counts_under(&tl.tlas, |first, count| {
        (first..first + count)
            .filter_map(|k| tl.references.get(tl.tlas.prim_indices[k as usize] as usize))
            .map(|r| u64::from(r.triangles))
            .sum()
    });
    let mut top = vec![0.0; nodes.len()];
    if nodes.is_empty() || root <= 0.0 {
        return top;
    }
    let share = |area: f64, n: usize| match under[n] {
        0 => 0.0,
        u => c_trav * area / root / u as f64,
    };
    top[0] = share(root, 0);
    for n in 0..nodes.len() {
        let node = &nodes[n];
        for lane in 0..node.child_count() {
            if let LaneKind::Interior(c) = node.lane_kind(lane) {
                let area = f64::from(node.child_bounds(lane).surface_area());
                top[c as usize] = top[n] + share(area, c as usize);
            }
        }
    }
    top
}

/// Per node of `tree`, the sum of `leaf(first slot, count)` over the leaves under it
/// (children come after their parents: one backward pass).
fn counts_under(tree: &Bvh8, leaf: impl Fn(u32, u32) -> u64) -> Vec<u64> {
    let nodes = &tree.nodes;
    let mut under = vec![0u64; nodes.len()];
    for n in (0..nodes.len()).rev() {
        let node = &nodes[n];
        under[n] = (0..node.child_count())
            .map(|lane| match node.lane_kind(lane) {
                LaneKind::Interior(c) => under[c as usize],
                LaneKind::Leaf { first, count } => leaf(first, count),
                LaneKind::Unused => 0,
            })
            .sum();
    }
    under
}

/// Per BLAS node, Σ products(box)/N over the nodes strictly below the root down to it, N
/// the triangle references under each.
fn products_below(blas: &Bvh8) -> Vec<DVec3> {
    let nodes = &blas.nodes;
    let under = counts_under(blas, |_, count| u64::from(count));
    let mut below = vec![DVec3::ZERO; nodes.len()];
    for n in 0..nodes.len() {
        let node = &nodes[n];
        for lane in 0..node.child_count() {
            if let LaneKind::Interior(c) = node.lane_kind(lane) {
                let c = c as usize;
                let share = match under[c] {
                    0 => DVec3::ZERO,
                    u => products(node.child_bounds(lane)) / u as f64,
                };
                below[c] = below[n] + share;
            }
        }
    }
    below
}

#[cfg(test)]
mod tests {
    use super::super::sah::tests::{two_levels, wild};
    use crate::scene::builtin;
    use glam::Affine3A;

    /// Every placed triangle's share, summed, is both levels' SAH cost: one instance left
    /// whole, and turned, unevenly scaled and mirrored instances at three re-braiding
    /// budgets, with two pairs of costs.
    #[test]
    fn the_shares_sum_to_both_levels_sah_cost() {
        let sphere = builtin::by_name("sphere:3000").unwrap().unwrap().triangles;
        let teapot = builtin::by_name("teapot-in-stadium")
            .unwrap()
            .unwrap()
            .triangles;
        let mut cases = vec![two_levels(&[&sphere], &[(0, Affine3A::IDENTITY)], 0.0)];
        for rebraid in [0.0, 0.5, 4.0] {
            cases.push(two_levels(&[&sphere, &teapot], &wild(), rebraid));
        }
        for (k, t) in cases.iter().enumerate() {
            for (c_trav, c_isect) in [(1.0, 1.0), (1.0, 3.0)] {
                let costs = t.placed_costs(c_trav, c_isect);
                let placed: u64 = t
                    .instances
                    .iter()
                    .map(|i| t.blases[i.mesh].triangle_count as u64)
                    .sum();
                let sum: f64 = (0..placed).map(|f| costs.of(f)).sum();
                let want = t.sah_cost(c_trav, c_isect);
                assert!(
                    (sum - want).abs() <= 1e-9 * want,
                    "case {k}: {sum} against {want}"
                );
                assert!((0..placed).all(|f| costs.of(f) > 0.0), "case {k}");
                assert_eq!(costs.of(placed), 0.0);
            }
        }
    }
}
