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
    let refs = References::of(outline, scene.len());
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
                        overlap_of(tree, refs.leaves_of(t), &scene[t], above, scratch)
                    })
                    .sum::<f64>()
            },
        )
        .collect();
    (!abandon()).then(|| parts.iter().sum::<f64>())
}

/// Where each triangle is referenced: its leaves, as a compressed list per triangle.
pub(super) struct References {
    /// `leaves[start[t]..start[t + 1]]` are the leaves referencing triangle t.
    start: Vec<u32>,
    leaves: Vec<u32>,
    /// Every triangle once, in leaf order (the walks of one triangle after another then
    /// share the part of the tree they read; in scene order each would miss the cache),
    /// triangles no leaf references last.
    pub(super) order: Vec<u32>,
}

impl References {
    pub(super) fn of(outline: &Outline, triangles: usize) -> Self {
        let mut start = vec![0u32; triangles + 1];
        // (A wide BVH pads its references between leaves: only the leaves' count.)
        let leaf_refs = || {
            (0..outline.nodes.len())
                .filter(|&n| outline.nodes[n].is_leaf())
                .flat_map(|n| outline.leaf_refs(n).iter().map(move |&t| (n as u32, t)))
        };
        for (_, t) in leaf_refs() {
            start[t as usize + 1] += 1;
        }
        for t in 0..triangles {
            start[t + 1] += start[t];
        }
        let mut next = start.clone();
        let mut leaves = vec![0u32; start[triangles] as usize];
        let mut order = Vec::with_capacity(triangles);
        for (leaf, t) in leaf_refs() {
            let t = t as usize;
            if next[t] == start[t] {
                order.push(t as u32);
            }
            leaves[next[t] as usize] = leaf;
            next[t] += 1;
        }
        order.extend((0..triangles as u32).filter(|&t| start[t as usize] == start[t as usize + 1]));
        References {
            start,
            leaves,
            order,
        }
    }

    pub(super) fn leaves_of(&self, t: usize) -> &[u32] {
        &self.leaves[self.start[t] as usize..self.start[t + 1] as usize]
    }
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
