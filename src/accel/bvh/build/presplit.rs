//! Triangle pre-splitting (Karras and Aila 2013, §5): before a fast builder that can only
//! sort whole references runs, the references of the triangles that waste most box area are
//! cut along the planes of the Morton grid, so that the builder sees several small boxes
//! instead of one large one. Only references are cut; each piece is the bounds of the
//! triangle clipped to its part of the box, and the triangle itself stays whole.
//!
//! Which triangles: the priority of a triangle is p = (2^(−level) · (A_box − A_ideal))^(1/3),
//! where A_box − A_ideal is the box area the triangle wastes (A_ideal = twice its area, the
//! area of the boxes of infinitely small pieces of a flat triangle) and `level` is the level
//! of the most important grid plane its box crosses (0 for the scene's mid-plane): a split
//! high in the grid separates what the builder would otherwise have to put in one subtree.
//! A budget of extra references is shared out in proportion to p.

use super::prim::PrimRef;
use crate::geometry::clip::clipped_bounds;
use crate::geometry::{Aabb, Triangle};
use rayon::iter::Either;
use rayon::prelude::*;

/// Levels of the grid, as the LBVH's Morton codes have per axis.
const GRID_BITS: u32 = 21;

/// The Morton grid over the scene's box, in f64 so huge coordinates keep their planes.
#[derive(Clone, Copy)]
struct Grid {
    origin: [f64; 3],
    extent: [f64; 3],
}

/// A plane of the grid: its axis, position, and level (0 = the mid-plane, the most
/// important).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Plane {
    axis: usize,
    position: f32,
    level: u32,
}

impl Grid {
    fn new(bounds: &Aabb) -> Self {
        Grid {
            origin: std::array::from_fn(|k| bounds.min[k] as f64),
            extent: std::array::from_fn(|k| (bounds.max[k] - bounds.min[k]) as f64),
        }
    }

    fn cell(&self, axis: usize, x: f32) -> u32 {
        let cells = (1u64 << GRID_BITS) as f64;
        let u = (x as f64 - self.origin[axis]) / self.extent[axis] * cells;
        u.clamp(0.0, cells - 1.0) as u32
    }

    /// The most important grid plane strictly inside `b` (ties: x before y before z, as in
    /// the Morton order), if any.
    fn most_important_plane(&self, b: &Aabb) -> Option<Plane> {
        let mut best: Option<Plane> = None;
        for axis in 0..3 {
            if self.extent[axis] <= 0.0 {
                continue;
            }
            let (lo, hi) = (self.cell(axis, b.min[axis]), self.cell(axis, b.max[axis]));
            if lo == hi {
                continue;
            }
            // The highest bit in which the cells differ: the plane between them on that
            // level is the multiple of 2^bit in (lo, hi].
            let bit = 31 - (lo ^ hi).leading_zeros();
            let level = GRID_BITS - 1 - bit;
            let q = (hi >> bit) << bit;
            let position = (self.origin[axis]
                + q as f64 / (1u64 << GRID_BITS) as f64 * self.extent[axis])
                as f32;
            if !(b.min[axis] < position && position < b.max[axis]) {
                continue;
            }
            if best.is_none_or(|p| level < p.level) {
                best = Some(Plane {
                    axis,
                    position,
                    level,
                });
            }
        }
        best
    }
}

/// The priority p of splitting `t` (see the module comment); 0 if no grid plane crosses
/// its box.
fn priority(t: &Triangle, grid: &Grid) -> f64 {
    let b = t.bounds();
    let Some(plane) = grid.most_important_plane(&b) else {
        return 0.0;
    };
    let waste = (b.surface_area() as f64 - 2.0 * t.area() as f64).max(0.0);
    (waste * 0.5f64.powi(plane.level as i32)).cbrt()
}

/// The references of `triangles` with at most `budget · N` extra ones from pre-splitting,
/// in triangle order (a triangle's pieces next to each other). Deterministic.
pub fn references(triangles: &[Triangle], budget: f32) -> Vec<PrimRef> {
    let whole = || {
        triangles
            .par_iter()
            .enumerate()
            .map(|(i, t)| PrimRef::new(t.bounds(), i as u32))
            .collect()
    };
    let extra = (budget as f64 * triangles.len() as f64) as u64;
    if extra == 0 || triangles.is_empty() {
        return whole();
    }
    let bounds = triangles
        .par_iter()
        .map(Triangle::bounds)
        .reduce(|| Aabb::EMPTY, Aabb::union);
    let grid = Grid::new(&bounds);
    let priorities: Vec<f64> = triangles.par_iter().map(|t| priority(t, &grid)).collect();
    // Summed in order: a parallel f64 sum could differ in the last bit between thread counts.
    let total: f64 = priorities.iter().sum();
    if total <= 0.0 {
        return whole();
    }
    let splits = apportion(&priorities, total, extra);
    triangles
        .par_iter()
        .zip(&splits)
        .enumerate()
        .flat_map_iter(|(i, (t, &s))| {
            if s == 0 {
                // Most triangles: their whole box, without a vector of pieces.
                return Either::Left(std::iter::once(PrimRef::new(t.bounds(), i as u32)));
            }
            let mut out = Vec::new();
            split(t, i as u32, t.bounds(), s, &grid, &mut out);
            Either::Right(out.into_iter())
        })
        .collect()
}

/// `extra` splits shared out in proportion to `priorities` (summing to `total`):
/// s_t = ⌊D · p_t⌋ with the largest D whose splits fit the budget (bisection; D = budget / Σp
/// always fits). Triangles of equal priority cross each step together, so what the steps
/// leave of the budget goes one split each to the largest remainders D · p_t − s_t, ties to
/// the lower index. The same on any number of threads.
fn apportion(priorities: &[f64], total: f64, extra: u64) -> Vec<u64> {
    let splits_for = |d: f64| -> u64 { priorities.par_iter().map(|&p| (d * p) as u64).sum() };
    let (mut lo, mut hi) = (extra as f64 / total, 2.0 * extra as f64 / total);
    while splits_for(hi) <= extra {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..32 {
        let mid = 0.5 * (lo + hi);
        if splits_for(mid) <= extra {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d = lo;
    let mut splits: Vec<u64> = priorities.par_iter().map(|&p| (d * p) as u64).collect();
    let left = extra.saturating_sub(splits.par_iter().sum()) as usize;
    if left > 0 {
        let mut by_remainder: Vec<(f64, u32)> = priorities
            .par_iter()
            .enumerate()
            .filter(|(_, p)| **p > 0.0)
            .map(|(i, &p)| (d * p - (d * p).floor(), i as u32))
            .collect();
        // Only the `left` largest are needed, in no particular order: a selection, not a sort.
        let largest_first =
            |a: &(f64, u32), b: &(f64, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
        let left = left.min(by_remainder.len());
        if left < by_remainder.len() {
            by_remainder.select_nth_unstable_by(left, largest_first);
        }
        for &(_, i) in &by_remainder[..left] {
            splits[i as usize] += 1;
        }
    }
    splits
}

/// Cuts the reference (`t`, `bounds`) with `splits` more cuts, each at the most important
/// grid plane crossing the piece; the cuts left are shared between the two pieces in
/// proportion to their longest extents.
fn split(t: &Triangle, index: u32, bounds: Aabb, splits: u64, grid: &Grid, out: &mut Vec<PrimRef>) {
    let plane = if splits == 0 {
        None
    } else {
        grid.most_important_plane(&bounds)
    };
    let Some(plane) = plane else {
        out.push(PrimRef::new(bounds, index));
        return;
    };
    let (mut below, mut above) = (bounds, bounds);
    below.max[plane.axis] = plane.position;
    above.min[plane.axis] = plane.position;
    match (clipped_bounds(t, &below), clipped_bounds(t, &above)) {
        (Some(b), Some(a)) => {
            let (lb, la) = (b.extent().max_element(), a.extent().max_element());
            let rest = splits - 1;
            let share = if lb + la > 0.0 {
                ((rest as f64 * lb as f64 / (lb + la) as f64).round() as u64).min(rest)
            } else {
                rest / 2
            };
            split(t, index, b, share, grid, out);
            split(t, index, a, rest - share, grid, out);
        }
        // The plane misses the triangle within the box: the piece shrinks, no cut spent.
        (Some(piece), None) | (None, Some(piece)) => split(t, index, piece, splits, grid, out),
        (None, None) => out.push(PrimRef::new(bounds, index)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_mid_plane_is_the_most_important() {
        let grid = Grid::new(&Aabb::new(Vec3::ZERO, Vec3::splat(8.0)));
        let p = grid
            .most_important_plane(&Aabb::new(Vec3::splat(1.0), Vec3::splat(7.0)))
            .expect("crosses the mid-planes");
        assert_eq!((p.axis, p.position, p.level), (0, 4.0, 0));
        // Only y crosses a plane of level 1 (at 2); x and z stay in one half-cell.
        let b = Aabb::new(Vec3::new(0.5, 1.5, 4.5), Vec3::new(1.5, 2.5, 5.5));
        let p = grid.most_important_plane(&b).expect("crosses y = 2");
        assert_eq!((p.axis, p.position, p.level), (1, 2.0, 1));
    }

    #[test]
    fn pieces_cover_the_triangle_and_respect_the_budget() {
        let tris = [
            Triangle::new(
                Vec3::ZERO,
                Vec3::new(8.0, 8.0, 0.0),
                Vec3::new(8.0, 8.0, 8.0),
            ),
            Triangle::new(Vec3::splat(1.0), Vec3::splat(1.1), Vec3::new(1.0, 1.1, 1.0)),
        ];
        let refs = references(&tris, 1.0);
        assert!(refs.len() <= 4, "{} references", refs.len());
        assert!(refs.len() > 2, "the diagonal triangle is split");
        for (i, t) in tris.iter().enumerate() {
            let boxes: Vec<Aabb> = refs
                .iter()
                .filter(|r| r.index == i as u32)
                .map(|r| Aabb::new(r.min, r.max))
                .collect();
            for u in 0..=10 {
                for v in 0..=(10 - u) {
                    let p = t.point(u as f32 / 10.0, v as f32 / 10.0);
                    assert!(
                        boxes
                            .iter()
                            .any(|b| { Aabb::new(b.min - 1e-5, b.max + 1e-5).contains_point(p) }),
                        "{p:?} of triangle {i} in none of {boxes:?}"
                    );
                }
            }
        }
    }
}
