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
use rayon::prelude::*;

/// Levels of the grid, as the LBVH's Morton codes have per axis.
const GRID_BITS: u32 = 21;

/// The Morton grid over the scene's box, in f64 so huge coordinates keep their planes.
#[derive(Clone, Copy)]
struct Grid {
    origin: [f64; 3],
    extent: [f64; 3],
    /// Cells per unit length on each axis (0 where the box is flat): a multiply per
    /// coordinate instead of a divide.
    cells_per_unit: [f64; 3],
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
        let extent: [f64; 3] = std::array::from_fn(|k| (bounds.max[k] - bounds.min[k]) as f64);
        let cells = (1u64 << GRID_BITS) as f64;
        Grid {
            origin: std::array::from_fn(|k| bounds.min[k] as f64),
            extent,
            cells_per_unit: extent.map(|e| if e > 0.0 { cells / e } else { 0.0 }),
        }
    }

    fn cell(&self, axis: usize, x: f32) -> u32 {
        let cells = (1u64 << GRID_BITS) as f64;
        let u = (x as f64 - self.origin[axis]) * self.cells_per_unit[axis];
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

/// The cube of the priority p of splitting `t` (see the module comment), 2^(−level) times
/// the wasted area; 0 if no grid plane crosses its box.
fn priority_cubed(t: &Triangle, grid: &Grid) -> f64 {
    let b = t.bounds();
    let Some(plane) = grid.most_important_plane(&b) else {
        return 0.0;
    };
    let waste = (b.surface_area() as f64 - 2.0 * t.area() as f64).max(0.0);
    // 2^(−level) from its exponent bits (level ≤ 20).
    waste * f64::from_bits((1023 - plane.level as u64) << 52)
}

/// Replaces every value with its cube root, four at a time: each root is a chain of
/// dependent multiplies, so four chains in step keep the multipliers busy.
fn cube_roots(values: &mut [f64]) {
    let mut quads = values.chunks_exact_mut(4);
    for q in &mut quads {
        let roots = cube_root4([q[0], q[1], q[2], q[3]]);
        q.copy_from_slice(&roots);
    }
    for x in quads.into_remainder() {
        *x = cube_root4([*x; 4])[0];
    }
}

/// ∛x of four x ≥ 0, each to within a few units in the last place, in multiplies only:
/// Newton's method on y = x^(−1/3) (y ← y·(4 − x·y³)/3 needs no division), then ∛x = x·y².
/// The library's `cbrt` took as long as the rest of the priority.
fn cube_root4(x: [f64; 4]) -> [f64; 4] {
    // Zero, subnormal (no exponent bits to guess from), infinite or NaN: rare enough for
    // the library.
    let usual = |x: f64| (f64::MIN_POSITIVE..f64::INFINITY).contains(&x);
    // A first guess within about 10 % from the exponent bits: x^(−1/3) divides the exponent
    // by −3, which on the bit pattern is a subtraction of a third of it.
    let mut y = x.map(|x| {
        let bits = if usual(x) {
            x.to_bits()
        } else {
            1f64.to_bits()
        };
        f64::from_bits(0x553E_F0FF_289D_D796 - bits / 3)
    });
    let z = x.map(|x| if usual(x) { x } else { 1.0 });
    for _ in 0..6 {
        for k in 0..4 {
            y[k] *= (4.0 - z[k] * y[k] * y[k] * y[k]) * (1.0 / 3.0);
        }
    }
    std::array::from_fn(|k| {
        if usual(x[k]) {
            z[k] * y[k] * y[k]
        } else {
            x[k].max(0.0).cbrt()
        }
    })
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
    let mut priorities: Vec<f64> = triangles
        .par_iter()
        .map(|t| priority_cubed(t, &grid))
        .collect();
    priorities.par_chunks_mut(4096).for_each(cube_roots);
    // Summed in order: a parallel f64 sum could differ in the last bit between thread counts.
    let total: f64 = priorities.iter().sum();
    if total <= 0.0 {
        return whole();
    }
    let splits = apportion(&priorities, total, extra);
    // The few triangles that are cut, in parallel; then every reference in triangle order.
    let cut: Vec<(usize, Vec<PrimRef>)> = splits
        .par_iter()
        .enumerate()
        .filter(|&(_, &s)| s > 0)
        .map(|(i, &s)| {
            let t = &triangles[i];
            let mut pieces = Vec::new();
            split(t, i as u32, t.bounds(), s, &grid, &mut pieces);
            (i, pieces)
        })
        .collect();
    let pieces: usize = cut.iter().map(|(_, p)| p.len()).sum();
    let mut refs = Vec::with_capacity(triangles.len() - cut.len() + pieces);
    let mut next = 0;
    for (i, t) in triangles.iter().enumerate() {
        match cut.get(next) {
            Some((j, p)) if *j == i => {
                refs.extend_from_slice(p);
                next += 1;
            }
            _ => refs.push(PrimRef::new(t.bounds(), i as u32)),
        }
    }
    refs
}

/// `extra` splits shared out in proportion to `priorities` (summing to `total`):
/// s_t = ⌊D · p_t⌋ with the largest D whose splits fit the budget (bisection; D = budget / Σp
/// always fits). Triangles of equal priority cross each step together, so what the steps
/// leave of the budget goes one split each to the largest remainders D · p_t − s_t, ties to
/// the lower index. The same on any number of threads.
fn apportion(priorities: &[f64], total: f64, extra: u64) -> Vec<u64> {
    let splits_for = |d: f64, ps: &[f64]| -> u64 { ps.iter().map(|&p| (d * p) as u64).sum() };
    // Σ⌊D·p⌋ > D·Σp − N₊ (N₊ the triangles with p > 0), so D = (extra + N₊) / Σp is past
    // the budget but for rounding, which the loop catches.
    let positive = priorities.par_iter().filter(|&&p| p > 0.0).count() as u64;
    let (mut lo, mut hi) = (extra as f64 / total, (extra + positive + 1) as f64 / total);
    while splits_for(hi, priorities) <= extra {
        lo = hi;
        hi *= 2.0;
    }
    // Only a triangle with hi · p ≥ 1 can get a split at a D below hi, so the bisection
    // looks at those alone, and fewer as hi comes down: at the end, at most the `extra`
    // triangles that get one.
    let mut candidates: Vec<f64> = priorities
        .par_iter()
        .copied()
        .filter(|&p| hi * p >= 1.0)
        .collect();
    for _ in 0..32 {
        let mid = 0.5 * (lo + hi);
        let splits = splits_for(mid, &candidates);
        if splits <= extra {
            lo = mid;
            // Every larger D with the same sum has the same splits: nothing left to find.
            if splits == extra {
                break;
            }
        } else {
            hi = mid;
            candidates.retain(|&p| hi * p >= 1.0);
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
            .map(|(i, &p)| (d * p - ((d * p) as u64) as f64, i as u32))
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
    fn cube_root_matches_the_library() {
        let mut rng = crate::random::Rng(7);
        for _ in 0..100_000 {
            // Mantissas and exponents across the whole normal range.
            let x = (1.0 + rng.unit()) * 2f64.powi(rng.below(2040) as i32 - 1020);
            let (got, want) = (cube_root4([x; 4])[3], x.cbrt());
            assert!(
                (got - want).abs() <= 4.0 * f64::EPSILON * want,
                "∛{x:e}: {got:e} against {want:e}"
            );
        }
        let mut special = [
            0.0,
            -1.0,
            1e-310,
            f64::MIN_POSITIVE,
            1.0,
            8.0,
            27.0,
            f64::MAX,
            3.0,
        ];
        let want = special.map(|x: f64| x.max(0.0).cbrt());
        cube_roots(&mut special);
        for (got, want) in special.into_iter().zip(want) {
            assert!(
                (got - want).abs() <= 4.0 * f64::EPSILON * want,
                "{got:e} against {want:e}"
            );
        }
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
