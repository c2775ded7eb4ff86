//! The part of a triangle inside a box: the triangle is clipped to the box (Sutherland–Hodgman,
//! one half-space after another) and the clipped polygon's bounds are the triangle's bounds
//! within that box. The k-d tree's perfect splits and the SBVH's reference splitting use it.
//!
//! The clipping runs in f64 and the bounds are rounded outward to f32, so a triangle keeps
//! every cell it touches: coordinates that are exact (input vertices, and a new vertex's
//! coordinate on the clipping plane) are kept as they are, so a triangle lying in or ending
//! on a plane is recognised as such; interpolated coordinates get a margin far above the f64
//! rounding error before they are rounded outward.

use crate::geometry::{Aabb, Triangle};
use glam::{DVec3, Vec3};

/// Three vertices, and at most one more per clipping plane.
const MAX_VERTS: usize = 9;

/// Relative margin given to interpolated coordinates (f64 rounds at ~1e-16).
const INTERPOLATED_MARGIN: f64 = 1e-12;
/// Relative enlargement of the cell for the second look at a triangle the clip found to miss
/// the cell: if it comes that close, it is kept.
const TOUCH_MARGIN: f64 = 1e-9;

#[derive(Clone, Copy)]
struct Vertex {
    p: DVec3,
    /// Bit k set: coordinate k is exact (an input coordinate or a clipping plane's).
    exact: u8,
}

struct Polygon {
    v: [Vertex; MAX_VERTS],
    n: usize,
}

impl Polygon {
    fn of(tri: &Triangle) -> Self {
        let mut v = [Vertex {
            p: DVec3::ZERO,
            exact: 7,
        }; MAX_VERTS];
        for (dst, src) in v.iter_mut().zip(tri.v) {
            dst.p = src.as_dvec3();
        }
        Polygon { v, n: 3 }
    }

    /// Keeps the part on the side `keep_above` of the plane x_axis = c (closed half-space).
    fn clip(&mut self, axis: usize, c: f64, keep_above: bool) {
        let inside = |p: &DVec3| {
            if keep_above {
                p[axis] >= c
            } else {
                p[axis] <= c
            }
        };
        if self.v[..self.n].iter().all(|v| inside(&v.p)) {
            return;
        }
        let mut out = [self.v[0]; MAX_VERTS];
        let mut m = 0;
        for i in 0..self.n {
            let a = self.v[i];
            let b = self.v[(i + 1) % self.n];
            let (ia, ib) = (inside(&a.p), inside(&b.p));
            if ia {
                out[m] = a;
                m += 1;
            }
            if ia != ib && m < MAX_VERTS {
                out[m] = crossing(&a, &b, axis, c);
                m += 1;
            }
        }
        self.v = out;
        self.n = m;
    }
}

/// Where the edge a–b crosses the plane x_axis = c: on the plane exactly along `axis`,
/// interpolated (and kept within the edge's bounds) along the others.
fn crossing(a: &Vertex, b: &Vertex, axis: usize, c: f64) -> Vertex {
    let s = ((c - a.p[axis]) / (b.p[axis] - a.p[axis])).clamp(0.0, 1.0);
    let mut p = a.p + (b.p - a.p) * s;
    p = p.clamp(a.p.min(b.p), a.p.max(b.p));
    p[axis] = c;
    Vertex {
        p,
        exact: 1 << axis,
    }
}

/// `x` rounded to an f32 at or below it.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// `x` rounded to an f32 at or above it.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

fn clip_to(tri: &Triangle, lo: DVec3, hi: DVec3) -> Polygon {
    let mut poly = Polygon::of(tri);
    for axis in 0..3 {
        poly.clip(axis, lo[axis], true);
        if poly.n == 0 {
            break;
        }
        poly.clip(axis, hi[axis], false);
        if poly.n == 0 {
            break;
        }
    }
    poly
}

/// Bounds of `tri`'s part inside the closed box `cell`, rounded outward to f32 and within
/// both the cell and the triangle's own bounds; `None` if the triangle misses the cell.
pub fn clipped_bounds(tri: &Triangle, cell: &Aabb) -> Option<Aabb> {
    let tb = tri.bounds();
    let within = Aabb::new(tb.min.max(cell.min), tb.max.min(cell.max));
    if within.is_empty() {
        return None;
    }
    if cell.contains(&tb) {
        return Some(tb);
    }
    let scale = tb
        .min
        .abs()
        .max(tb.max.abs())
        .max(cell.min.abs())
        .max(cell.max.abs())
        .max_element() as f64;
    let (lo, hi) = (cell.min.as_dvec3(), cell.max.as_dvec3());
    let poly = clip_to(tri, lo, hi);
    let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    if poly.n > 0 {
        let margin = INTERPOLATED_MARGIN * scale;
        for v in &poly.v[..poly.n] {
            for k in 0..3 {
                let pad = if v.exact & (1 << k) != 0 { 0.0 } else { margin };
                min[k] = min[k].min(round_down(v.p[k] - pad));
                max[k] = max[k].max(round_up(v.p[k] + pad));
            }
        }
    } else {
        // The clip says the triangle misses the cell; if it comes within a hair's breadth,
        // f64 rounding may have decided it, so it is kept.
        let pad = DVec3::splat(TOUCH_MARGIN * scale);
        let poly = clip_to(tri, lo - pad, hi + pad);
        if poly.n == 0 {
            return None;
        }
        for v in &poly.v[..poly.n] {
            for k in 0..3 {
                min[k] = min[k].min(round_down(v.p[k]));
                max[k] = max[k].max(round_up(v.p[k]));
            }
        }
    }
    let b = Aabb::new(min.max(within.min), max.min(within.max));
    (!b.is_empty()).then_some(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle::new(Vec3::from(a), Vec3::from(b), Vec3::from(c))
    }

    fn cell(min: [f32; 3], max: [f32; 3]) -> Aabb {
        Aabb::new(Vec3::from(min), Vec3::from(max))
    }

    #[test]
    fn a_triangle_inside_the_cell_keeps_its_bounds() {
        let t = tri([0.1, 0.2, 0.3], [0.5, 0.2, 0.1], [0.3, 0.9, 0.4]);
        assert_eq!(
            clipped_bounds(&t, &cell([0.0; 3], [1.0; 3])),
            Some(t.bounds())
        );
    }

    #[test]
    fn a_diagonal_triangle_clipped_to_a_corner_cell_shrinks_to_the_part_inside() {
        // The triangle x + y = 1 (z in [0, 1]); the cell [0, 0.25]² × [0, 1] misses it, the
        // cell [0, 0.5]² × [0, 1] touches it only at (0.5, 0.5).
        let t = tri([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 1.0]);
        assert_eq!(
            clipped_bounds(&t, &cell([0.0, 0.0, 0.0], [0.25, 0.25, 1.0])),
            None
        );
        let b = clipped_bounds(&t, &cell([0.0, 0.0, 0.0], [0.5, 0.5, 1.0])).expect("touches");
        assert!(b.min.x >= 0.5 - 1e-6 && b.min.y >= 0.5 - 1e-6, "{b:?}");
        assert!(b.contains_point(Vec3::new(0.5, 0.5, 0.0)));
        // A cell over the middle of the hypotenuse: x in [0.4, 0.6] gives y in [0.4, 0.6].
        let b = clipped_bounds(&t, &cell([0.4, 0.0, 0.0], [0.6, 1.0, 1.0])).expect("crosses");
        assert_eq!((b.min.x, b.max.x), (0.4, 0.6));
        assert!((b.min.y - 0.4).abs() < 1e-6 && (b.max.y - 0.6).abs() < 1e-6);
        assert!(b.min.y <= 0.4 && b.max.y >= 0.6, "rounded outward: {b:?}");
        assert_eq!((b.min.z, b.max.z), (0.0, 0.6));
    }

    #[test]
    fn a_triangle_in_a_cell_face_or_ending_on_it_stays_exact() {
        // In the plane z = 1, the cell's top face: flat bounds, exactly on the face.
        let t = tri([-1.0, 0.5, 1.0], [2.0, 0.5, 1.0], [0.5, 3.0, 1.0]);
        let b = clipped_bounds(&t, &cell([0.0; 3], [1.0; 3])).expect("in the face");
        assert_eq!((b.min.z, b.max.z), (1.0, 1.0));
        assert_eq!((b.min.x, b.max.x), (0.0, 1.0));
        // Touching the cell at one vertex only.
        let t = tri([1.0, 1.0, 1.0], [2.0, 1.0, 1.0], [2.0, 2.0, 3.0]);
        let b = clipped_bounds(&t, &cell([0.0; 3], [1.0; 3])).expect("touches");
        assert_eq!(b, Aabb::from_point(Vec3::ONE));
    }

    #[test]
    fn clipped_bounds_contain_points_of_the_triangle_in_the_cell() {
        // Random triangles and cells: every sampled point of the triangle inside the cell
        // lies in the clipped bounds.
        let mut s = 1u64;
        let mut r = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        for _ in 0..2000 {
            let mut p = || Vec3::new(r() * 4.0 - 2.0, r() * 4.0 - 2.0, r() * 4.0 - 2.0);
            let t = Triangle::new(p(), p(), p());
            let (a, b) = (p(), p());
            let c = Aabb::new(a.min(b), a.max(b));
            let bounds = clipped_bounds(&t, &c);
            for i in 0..=20 {
                for j in 0..=(20 - i) {
                    let q = t.point(i as f32 / 20.0, j as f32 / 20.0);
                    if c.contains_point(q) {
                        let bb = bounds.expect("a point of the triangle is in the cell");
                        let grown = Aabb::new(bb.min - 1e-5, bb.max + 1e-5);
                        assert!(grown.contains_point(q), "{q:?} outside {bb:?}");
                    }
                }
            }
        }
    }
}
