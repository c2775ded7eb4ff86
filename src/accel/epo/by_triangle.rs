//! EPO triangle by triangle: each triangle walks the tree from the root into the nodes its
//! part overlaps, clipped down the tree, and adds their cost but for the nodes it is
//! referenced under. It serves every tree, also those referencing a triangle more than once.

use super::part::{Against, Part};
use super::{Outline, Tree};
use crate::geometry::Triangle;
use rayon::prelude::*;

/// Σ_n C(n) · A((S \ Q(n)) ∩ n), or `None` once `abandon` says so.
pub(super) fn overlap(
    tree: &Tree,
    outline: &Outline,
    scene: &[Triangle],
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<f64> {
    let refs = references(outline, scene.len());
    // Chunks summed in a fixed order: the same tree always gives the same EPO.
    let parts: Vec<f64> = refs
        .order
        .par_chunks(256)
        .map_init(
            || (vec![false; tree.nodes.len()], Scratch::default()),
            |(above, scratch), chunk| {
                if abandon() {
                    return 0.0;
                }
                chunk
                    .iter()
                    .map(|&t| {
                        let t = t as usize;
                        overlap_of(tree, refs.of_triangle(t), &scene[t], above, scratch)
                    })
                    .sum::<f64>()
            },
        )
        .collect();
    (!abandon()).then(|| parts.iter().sum::<f64>())
}

/// Per triangle, the places holding it (leaves, leaf lanes), as one compressed list.
pub(crate) struct ByTriangle<T> {
    /// `places[start[t]..start[t + 1]]` hold triangle t.
    start: Vec<u32>,
    places: Vec<T>,
    /// Every triangle once, in the order the places were listed (leaf order: the walks of
    /// one triangle after another then share the part of the tree they read; in scene
    /// order each would miss the cache), triangles held nowhere last.
    pub(crate) order: Vec<u32>,
}

impl<T: Copy + Default> ByTriangle<T> {
    /// From the (triangle, place) pairs `pairs` lists (called twice: to count, to fill);
    /// triangles from `triangles` on are left out.
    pub(crate) fn of<I: Iterator<Item = (u32, T)>>(
        triangles: usize,
        pairs: impl Fn() -> I,
    ) -> Self {
        let held = || pairs().filter(|&(t, _)| (t as usize) < triangles);
        let mut start = vec![0u32; triangles + 1];
        for (t, _) in held() {
            start[t as usize + 1] += 1;
        }
        for t in 0..triangles {
            start[t + 1] += start[t];
        }
        let mut next = start.clone();
        let mut places = vec![T::default(); start[triangles] as usize];
        let mut order = Vec::with_capacity(triangles);
        for (t, place) in held() {
            let t = t as usize;
            if next[t] == start[t] {
                order.push(t as u32);
            }
            places[next[t] as usize] = place;
            next[t] += 1;
        }
        order.extend((0..triangles as u32).filter(|&t| start[t as usize] == start[t as usize + 1]));
        ByTriangle {
            start,
            places,
            order,
        }
    }

    /// The places holding triangle `t`.
    pub(crate) fn of_triangle(&self, t: usize) -> &[T] {
        &self.places[self.start[t] as usize..self.start[t + 1] as usize]
    }
}

/// Where each triangle is referenced: the outline's leaves holding it.
pub(super) fn references(outline: &Outline, triangles: usize) -> ByTriangle<u32> {
    // (A wide BVH pads its references between leaves: only the leaves' count.)
    ByTriangle::of(triangles, || {
        (0..outline.nodes.len())
            .filter(|&n| outline.nodes[n].is_leaf())
            .flat_map(|n| outline.leaf_refs(n).iter().map(move |&t| (t, n as u32)))
    })
}

/// Σ C(n) · A(t ∩ n) over the nodes n not above triangle `t`. `above` is all false on entry
/// and on return; `scratch` is reused.
///
/// The triangle is clipped down the tree: a node's part of it is its parent's part clipped
/// to the node's box, against only the planes that part crosses, so deep in the tree, where
/// parts are small, most boxes hold all of a part or none of it and nothing is clipped.
fn overlap_of(
    tree: &Tree,
    leaves: &[u32],
    tri: &Triangle,
    above: &mut [bool],
    scratch: &mut Scratch,
) -> f64 {
    let whole = Part::of(tri);
    if whole.area <= 0.0 {
        return 0.0;
    }
    mark(tree, leaves, above, true);
    let Scratch { parts, stack } = scratch;
    parts.clear();
    parts.push(whole);
    stack.clear();
    stack.push((0, 0));
    let mut sum = 0.0;
    while let Some((n, part)) = stack.pop() {
        let node = &tree.nodes[n as usize];
        let (min, max) = (node.min.map(f64::from), node.max.map(f64::from));
        let of_parent = &parts[part as usize];
        let part = match of_parent.against(&min, &max) {
            Against::Outside => continue,
            Against::Inside => part,
            Against::Crossing => match of_parent.clipped(&min, &max) {
                Some(p) => {
                    parts.push(p);
                    (parts.len() - 1) as u32
                }
                None => continue,
            },
        };
        if !above[n as usize] {
            sum += tree.cost[n as usize] * parts[part as usize].area;
        }
        let first = node.first_child;
        stack.extend((first..first + node.child_count).map(|c| (c, part)));
    }
    mark(tree, leaves, above, false);
    sum
}

/// Sets (`on`) or clears in `above` the nodes above `leaves`, the leaves included.
pub(super) fn mark(tree: &Tree, leaves: &[u32], above: &mut [bool], on: bool) {
    for &leaf in leaves {
        let mut n = leaf;
        while n != u32::MAX && above[n as usize] != on {
            above[n as usize] = on;
            n = tree.parent[n as usize];
        }
    }
}

/// What one thread reuses from triangle to triangle.
#[derive(Default)]
struct Scratch {
    parts: Vec<Part>,
    /// (node, its parent's part of the triangle).
    stack: Vec<(u32, u32)>,
}
