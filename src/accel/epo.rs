//! EPO, the end-point overlap of a tree (Aila, Karras & Laine 2013): a second predictor of
//! trace cost beside the SAH. A ray that ends on a surface point p pays for every node whose
//! box holds p. The nodes above p's own triangle are unavoidable; every other node holding p
//! is overlap the SAH does not see (it weighs a box by its area, not by what else lies in
//! it). EPO is that extra cost for an end point spread uniformly over the scene's surfaces:
//!
//! EPO = Σ_n C(n) · A((S \ Q(n)) ∩ n) / A(S)
//!
//! with S the scene's triangles, Q(n) those referenced under node n, A the surface area of
//! geometry (clipped to n's box for ∩ n), and C(n) the node's cost in the SAH's units:
//! C_trav for an interior node, C_isect times its triangles for a leaf.
//!
//! It is computed triangle by triangle: each walks the tree from the root into the nodes its
//! part overlaps, skipping the cost of the nodes it is referenced under. A triangle split
//! into several references (SBVH, pre-splitting) is "under" every node above any of them.

use super::Outline;
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use rayon::prelude::*;

/// The EPO of a tree given as its `outline` (BVH2, BVH4/8, k-d tree, octree), whose leaves
/// reference `scene`'s triangles. 0 for a scene without area.
pub fn epo(outline: &Outline, scene: &[Triangle], c_trav: f32, c_isect: f32) -> f64 {
    epo_unless(outline, scene, c_trav, c_isect, &|| false).unwrap_or_default()
}

/// `epo`, given up (`None`) as soon as `abandon` says so: the app computes it at quiet
/// moments and any command comes first.
pub fn epo_unless(
    outline: &Outline,
    scene: &[Triangle],
    c_trav: f32,
    c_isect: f32,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<f64> {
    if outline.nodes.is_empty() {
        return Some(0.0);
    }
    let tree = Tree::of(outline, c_trav, c_isect);
    let refs = References::of(outline, scene.len());
    let total_area: f64 = scene.iter().map(area).sum();
    if total_area <= 0.0 {
        return Some(0.0);
    }
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
                        overlap_of(&tree, refs.leaves_of(t), &scene[t], above, scratch)
                    })
                    .sum::<f64>()
            },
        )
        .collect();
    (!abandon()).then(|| parts.iter().sum::<f64>() / total_area)
}

/// The outline as the walks read it: 32 bytes a node, and each node's cost.
struct Tree {
    nodes: Vec<TreeNode>,
    parent: Vec<u32>,
    /// C_trav for an interior node, C_isect times its triangles for a leaf.
    cost: Vec<f64>,
}

#[derive(Clone, Copy)]
struct TreeNode {
    min: [f32; 3],
    max: [f32; 3],
    first_child: u32,
    child_count: u32,
}

impl Tree {
    fn of(outline: &Outline, c_trav: f32, c_isect: f32) -> Tree {
        let n = &outline.nodes;
        Tree {
            nodes: n
                .iter()
                .map(|o| TreeNode {
                    min: o.bounds.min.into(),
                    max: o.bounds.max.into(),
                    first_child: o.first_child,
                    child_count: o.child_count,
                })
                .collect(),
            parent: n.iter().map(|o| o.parent).collect(),
            cost: n
                .iter()
                .map(|o| {
                    if o.is_leaf() {
                        f64::from(c_isect) * f64::from(o.refs.1)
                    } else {
                        f64::from(c_trav)
                    }
                })
                .collect(),
        }
    }
}

/// Where each triangle is referenced: its leaves, as a compressed list per triangle.
struct References {
    /// `leaves[start[t]..start[t + 1]]` are the leaves referencing triangle t.
    start: Vec<u32>,
    leaves: Vec<u32>,
    /// Every triangle once, in leaf order (the walks of one triangle after another then
    /// share the part of the tree they read; in scene order each would miss the cache),
    /// triangles no leaf references last.
    order: Vec<u32>,
}

impl References {
    fn of(outline: &Outline, triangles: usize) -> Self {
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

    fn leaves_of(&self, t: usize) -> &[u32] {
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
    let mark = |above: &mut [bool], on: bool| {
        for &leaf in leaves {
            let mut n = leaf;
            while n != u32::MAX && above[n as usize] != on {
                above[n as usize] = on;
                n = tree.parent[n as usize];
            }
        }
    };
    mark(above, true);
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
    mark(above, false);
    sum
}

/// What one thread reuses from triangle to triangle.
#[derive(Default)]
struct Scratch {
    parts: Vec<Part>,
    /// (node, its parent's part of the triangle).
    stack: Vec<(u32, u32)>,
}

/// Three vertices, and at most one more per clipping plane.
const MAX_VERTS: usize = 9;

/// A convex part of a triangle: its vertices, bounds and area, in f64.
#[derive(Clone, Copy)]
struct Part {
    v: [DVec3; MAX_VERTS],
    n: usize,
    lo: DVec3,
    hi: DVec3,
    area: f64,
}

/// Where a part lies against a box, from its bounds.
enum Against {
    Outside,
    Inside,
    /// Its bounds cross a face plane: it must be clipped to tell.
    Crossing,
}

impl Part {
    fn of(tri: &Triangle) -> Part {
        let mut v = [DVec3::ZERO; MAX_VERTS];
        for (p, q) in v.iter_mut().zip(tri.v) {
            *p = q.as_dvec3();
        }
        Part::new(v, 3)
    }

    fn new(v: [DVec3; MAX_VERTS], n: usize) -> Part {
        let (mut lo, mut hi) = (v[0], v[0]);
        for p in &v[1..n] {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        // Half the length of Σ (v_i − v_0) × (v_(i+1) − v_0).
        let mut normal = DVec3::ZERO;
        for i in 1..n - 1 {
            normal += (v[i] - v[0]).cross(v[i + 1] - v[0]);
        }
        Part {
            v,
            n,
            lo,
            hi,
            area: 0.5 * normal.length(),
        }
    }

    #[inline(always)]
    fn against(&self, min: &[f64; 3], max: &[f64; 3]) -> Against {
        let (min, max) = (DVec3::from(*min), DVec3::from(*max));
        if self.lo.cmpgt(max).any() || self.hi.cmplt(min).any() {
            Against::Outside
        } else if self.lo.cmpge(min).all() && self.hi.cmple(max).all() {
            Against::Inside
        } else {
            Against::Crossing
        }
    }

    /// The part inside the closed box [min, max] (Sutherland–Hodgman, one face plane after
    /// another, only the planes the part crosses); `None` if nothing of it with an area is.
    #[inline(never)]
    fn clipped(&self, min: &[f64; 3], max: &[f64; 3]) -> Option<Part> {
        let mut buffers = [self.v, [DVec3::ZERO; MAX_VERTS]];
        let (mut from, mut n) = (0, self.n);
        for axis in 0..3 {
            for (c, above) in [(min[axis], true), (max[axis], false)] {
                if (above && self.lo[axis] >= c) || (!above && self.hi[axis] <= c) {
                    continue;
                }
                // Signed distance into the kept side: ≥ 0 is inside.
                let into = |p: &DVec3| if above { p[axis] - c } else { c - p[axis] };
                let [a_buf, b_buf] = &mut buffers;
                let (src, dst) = if from == 0 {
                    (a_buf, b_buf)
                } else {
                    (b_buf, a_buf)
                };
                let mut m = 0;
                let (mut a, mut a_in) = (src[n - 1], into(&src[n - 1]) >= 0.0);
                for &b in &src[..n] {
                    let b_in = into(&b) >= 0.0;
                    if a_in != b_in && m < MAX_VERTS {
                        let s = (c - a[axis]) / (b[axis] - a[axis]);
                        dst[m] = a + (b - a) * s;
                        dst[m][axis] = c;
                        m += 1;
                    }
                    if b_in && m < MAX_VERTS {
                        dst[m] = b;
                        m += 1;
                    }
                    (a, a_in) = (b, b_in);
                }
                from = 1 - from;
                n = m;
                if n < 3 {
                    return None;
                }
            }
        }
        let part = Part::new(buffers[from], n);
        (part.area > 0.0).then_some(part)
    }
}

/// A triangle's area, in f64 as its clipped parts' are.
pub fn area(tri: &Triangle) -> f64 {
    Part::of(tri).area
}

/// The area of `tri` clipped to the closed box `cell`.
pub fn clipped_area(tri: &Triangle, cell: &Aabb) -> f64 {
    let whole = Part::of(tri);
    let (min, max) = (cell.min.as_dvec3().into(), cell.max.as_dvec3().into());
    match whole.against(&min, &max) {
        Against::Outside => 0.0,
        Against::Inside => whole.area,
        Against::Crossing => whole.clipped(&min, &max).map_or(0.0, |p| p.area),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_triangle_clipped_by_half_a_box_keeps_half_its_area() {
        // The right triangle (0,0)-(2,0)-(0,2) in z = 0, area 2; the box x ≤ 1 keeps the
        // trapezoid of area 2 − 0.5 = 1.5, the box x ≤ 1, y ≤ 1 the unit square.
        let tri = Triangle::new(
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        );
        let cell = |max: Vec3| Aabb::new(Vec3::splat(-1.0), max);
        assert!((clipped_area(&tri, &cell(Vec3::new(1.0, 5.0, 1.0))) - 1.5).abs() < 1e-12);
        assert!((clipped_area(&tri, &cell(Vec3::new(1.0, 1.0, 1.0))) - 1.0).abs() < 1e-12);
        // A box the triangle only touches, and one in its plane's face.
        assert_eq!(clipped_area(&tri, &cell(Vec3::new(0.0, 5.0, 1.0))), 0.0);
        assert!((clipped_area(&tri, &cell(Vec3::new(5.0, 5.0, 0.0))) - 2.0).abs() < 1e-12);
    }
}
