//! Triangle–box overlap by separating axes (Akenine-Möller 2001): how a spatial structure
//! (grid, octree) decides which cells really hold a triangle, rather than every cell its
//! bounding box touches. Closed boxes: a triangle touching a face, edge or corner overlaps.
//!
//! Two convex sets are disjoint exactly when some axis separates their projections; for a
//! triangle and a box it suffices to try 13: the box's three face normals, the triangle's
//! normal, and the nine cross products of a triangle edge with a box axis. A degenerate
//! triangle (a segment or a point) is covered by the same axes: its normal is zero, which
//! separates nothing, and the other twelve are those of a segment or a point against a box.
//! Everything is computed in f64 from the f32 inputs.

use super::{Aabb, Triangle};
use glam::DVec3;

/// A triangle prepared for many box tests: vertices, edges and normal in f64.
#[derive(Clone, Copy, Debug)]
pub struct TriangleSat {
    v: [DVec3; 3],
    e: [DVec3; 3],
    n: DVec3,
}

impl TriangleSat {
    #[inline]
    pub fn new(tri: &Triangle) -> Self {
        let v = tri.v.map(|p| p.as_dvec3());
        let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
        TriangleSat {
            v,
            e,
            n: e[0].cross(e[1]),
        }
    }

    /// Whether the triangle overlaps the closed box [min, max].
    #[inline]
    pub fn overlaps(&self, min: DVec3, max: DVec3) -> bool {
        let c = (min + max) * 0.5;
        let h = (max - min) * 0.5;
        let v = [self.v[0] - c, self.v[1] - c, self.v[2] - c];
        // Box face normals: the bounding boxes must overlap.
        for k in 0..3 {
            let lo = v[0][k].min(v[1][k]).min(v[2][k]);
            let hi = v[0][k].max(v[1][k]).max(v[2][k]);
            if lo > h[k] || hi < -h[k] {
                return false;
            }
        }
        // The triangle's plane against the box: the box's projection on n is ±h·|n|.
        let r = h.dot(self.n.abs());
        if self.n.dot(v[0]).abs() > r {
            return false;
        }
        // Edge × axis: a = e × u_k; the projections of the two vertices on the edge agree,
        // but computing all three keeps the code uniform and a segment's third vertex in.
        for e in &self.e {
            for k in 0..3 {
                let a = match k {
                    0 => DVec3::new(0.0, -e.z, e.y),
                    1 => DVec3::new(e.z, 0.0, -e.x),
                    _ => DVec3::new(-e.y, e.x, 0.0),
                };
                let p = [a.dot(v[0]), a.dot(v[1]), a.dot(v[2])];
                let r = h.dot(a.abs());
                let lo = p[0].min(p[1]).min(p[2]);
                let hi = p[0].max(p[1]).max(p[2]);
                if lo > r || hi < -r {
                    return false;
                }
            }
        }
        true
    }
}

/// A triangle prepared for many boxes of one size, such as a grid's cells or an octree
/// cell's octants: the box's extent along each of the 13 axes is then the same for every
/// box, so each axis reduces to an interval the box centre's projection must fall in.
///
/// Stored as structures of arrays over the axes, padded to `AXIS_LANES` with zero axes
/// (whose interval [0, 0] every centre's projection, ±0, falls in): the loops over the axes
/// then run in vectors, with the scalar test's operations in its order, so the same bits.
#[derive(Clone, Copy, Debug)]
pub struct TriangleSlabs {
    /// The axes' x, y and z components.
    axes: [[f64; AXIS_LANES]; 3],
    lo: [f64; AXIS_LANES],
    hi: [f64; AXIS_LANES],
}

/// The 13 separating axes, padded to a multiple of the widest vector (8 × f64).
const AXIS_LANES: usize = 16;

impl TriangleSat {
    /// The 13 separating axes as intervals for boxes of half extents `h`.
    #[inline(always)]
    pub fn slabs(&self, h: DVec3) -> TriangleSlabs {
        let mut axes = [[0.0; AXIS_LANES]; 3];
        let mut set = |j: usize, a: DVec3| {
            (axes[0][j], axes[1][j], axes[2][j]) = (a.x, a.y, a.z);
        };
        set(0, DVec3::X);
        set(1, DVec3::Y);
        set(2, DVec3::Z);
        set(3, self.n);
        for (i, e) in self.e.iter().enumerate() {
            set(4 + 3 * i, DVec3::new(0.0, -e.z, e.y));
            set(5 + 3 * i, DVec3::new(e.z, 0.0, -e.x));
            set(6 + 3 * i, DVec3::new(-e.y, e.x, 0.0));
        }
        let [ax, ay, az] = &axes;
        let mut lo = [0.0; AXIS_LANES];
        let mut hi = [0.0; AXIS_LANES];
        // `DVec3::dot`'s operations, lane by lane: (x·x + y·y) + z·z.
        let dot = |j: usize, p: DVec3| (ax[j] * p.x + ay[j] * p.y) + az[j] * p.z;
        for j in 0..AXIS_LANES {
            let p = [dot(j, self.v[0]), dot(j, self.v[1]), dot(j, self.v[2])];
            let r = (h.x * ax[j].abs() + h.y * ay[j].abs()) + h.z * az[j].abs();
            lo[j] = p[0].min(p[1]).min(p[2]) - r;
            hi[j] = p[0].max(p[1]).max(p[2]) + r;
        }
        TriangleSlabs { axes, lo, hi }
    }
}

impl TriangleSlabs {
    /// Whether the triangle overlaps the closed box with centre `c` (and the half extents
    /// these slabs were made for): on every axis, the centre's projection lies within the
    /// triangle's projection widened by the box's radius.
    #[inline(always)]
    pub fn overlaps_centered(&self, c: DVec3) -> bool {
        let [ax, ay, az] = &self.axes;
        let mut inside = true;
        for j in 0..AXIS_LANES {
            let p = (ax[j] * c.x + ay[j] * c.y) + az[j] * c.z;
            // `&`, not `&&`: both compares in every lane, no branch to vectorise around.
            inside &= (p >= self.lo[j]) & (p <= self.hi[j]);
        }
        inside
    }
}

/// The separating axes seen along lines parallel to one axis `u`, for boxes of one size
/// whose bounding boxes overlap the triangle's (a grid's cells within the triangle's range):
/// along such a line (a row of cells), the box centres that pass every axis form one
/// interval, since each axis admits an interval of the line (a slab crossed by a line) and
/// intervals intersect in one. A row then costs one interval instead of a test per box.
///
/// The three box normals are left out (the caller walks only boxes overlapping the
/// triangle's bounding box), which leaves the triangle's normal and the nine edge
/// cross products. With (u, v, w) a cyclic order of the axes, so that cross products keep
/// their form, edge e gives e × u = (0, e_w, −e_v), perpendicular to the line; and
/// e × v = (−e_w, 0, e_u) and e × w = (e_v, −e_u, 0), along it.
#[derive(Clone, Copy, Debug)]
pub struct TriangleRuns {
    u: usize,
    /// Axes with a nonzero `u` component: the centre's `u` coordinate must lie in
    /// [lo − sv·c_v − sw·c_w, hi − sv·c_v − sw·c_w], stored as (lo, hi, sv, sw).
    along: [[f64; 4]; 10],
    n_along: usize,
    /// Axes perpendicular to the line: a row passes or fails as a whole, by
    /// lo ≤ a_v·c_v + a_w·c_w ≤ hi, stored as (a_v, a_w, lo, hi).
    across: [[f64; 4]; 10],
    n_across: usize,
}

impl TriangleRuns {
    /// The axes of `tri` for boxes of half extents `h`, along lines parallel to axis `u`.
    #[inline]
    pub fn new(tri: &TriangleSat, h: DVec3, u: usize) -> Self {
        let (v, w) = ((u + 1) % 3, (u + 2) % 3);
        // Everything in (u, v, w) order.
        let p = tri.v.map(|x| [x[u], x[v], x[w]]);
        let h = [h[u], h[v], h[w]];
        let mut runs = TriangleRuns {
            u,
            along: [[0.0; 4]; 10],
            n_along: 0,
            across: [[0.0; 4]; 10],
            n_across: 0,
        };
        let mut axes = [[0.0; 3]; 10];
        axes[0] = [tri.n[u], tri.n[v], tri.n[w]];
        for (i, e) in tri.e.iter().enumerate() {
            let (eu, ev, ew) = (e[u], e[v], e[w]);
            axes[1 + 3 * i] = [0.0, ew, -ev];
            axes[2 + 3 * i] = [-ew, 0.0, eu];
            axes[3 + 3 * i] = [ev, -eu, 0.0];
        }
        for a in axes {
            let d = |x: &[f64; 3]| a[0] * x[0] + a[1] * x[1] + a[2] * x[2];
            let (d0, d1, d2) = (d(&p[0]), d(&p[1]), d(&p[2]));
            let r = h[0] * a[0].abs() + h[1] * a[1].abs() + h[2] * a[2].abs();
            let lo = d0.min(d1).min(d2) - r;
            let hi = d0.max(d1).max(d2) + r;
            if a[0] == 0.0 {
                runs.across[runs.n_across] = [a[1], a[2], lo, hi];
                runs.n_across += 1;
            } else {
                let (lo, hi) = if a[0] > 0.0 { (lo, hi) } else { (hi, lo) };
                // One division, then products: the extra rounding is far below the margin.
                let inv = 1.0 / a[0];
                runs.along[runs.n_along] = [lo * inv, hi * inv, a[1] * inv, a[2] * inv];
                runs.n_along += 1;
            }
        }
        runs
    }

    /// The closed interval of `u` coordinates of the box centres on the line through `c`
    /// (its `u` coordinate ignored) whose boxes overlap the triangle; empty when lo > hi.
    /// It agrees with `overlaps_centered` up to rounding for boxes overlapping the
    /// triangle's bounding box, so callers keep a margin (the grid pads its cells). An axis
    /// whose `u` component is so small that its bounds overflow yields NaN, which the
    /// comparisons ignore: the axis is then dropped, which only widens the interval.
    #[inline]
    pub fn run(&self, c: DVec3) -> (f64, f64) {
        let (cv, cw) = (c[(self.u + 1) % 3], c[(self.u + 2) % 3]);
        for &[av, aw, lo, hi] in &self.across[..self.n_across] {
            let p = av * cv + aw * cw;
            if !(p >= lo && p <= hi) {
                return (f64::INFINITY, f64::NEG_INFINITY);
            }
        }
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for &[lo, hi, sv, sw] in &self.along[..self.n_along] {
            let shift = sv * cv + sw * cw;
            let (a, b) = (lo - shift, hi - shift);
            if a > t0 {
                t0 = a;
            }
            if b < t1 {
                t1 = b;
            }
        }
        (t0, t1)
    }
}

/// Whether `tri` overlaps the closed box `b`.
pub fn triangle_box_overlap(tri: &Triangle, b: &Aabb) -> bool {
    if b.is_empty() {
        return false;
    }
    TriangleSat::new(tri).overlaps(b.min.as_dvec3(), b.max.as_dvec3())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, vec3};

    /// The independent check: clip the triangle (as a polygon) against the six closed
    /// half-spaces of the box; it overlaps if anything is left.
    fn clip_overlaps(tri: &Triangle, min: DVec3, max: DVec3) -> bool {
        let mut poly: Vec<DVec3> = tri.v.iter().map(|p| p.as_dvec3()).collect();
        for k in 0..3 {
            for (sign, bound) in [(1.0, max[k]), (-1.0, min[k])] {
                // Keep sign·(p_k − bound) ≤ 0.
                let d = |p: DVec3| sign * (p[k] - bound);
                let mut out = Vec::new();
                for i in 0..poly.len() {
                    let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                    let (da, db) = (d(a), d(b));
                    if da <= 0.0 {
                        out.push(a);
                    }
                    if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                        let mut p = a + (b - a) * (da / (da - db));
                        p[k] = bound;
                        out.push(p);
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return false;
                }
            }
        }
        true
    }

    fn unit() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    fn both(tri: Triangle, b: Aabb, expected: bool, what: &str) {
        assert_eq!(triangle_box_overlap(&tri, &b), expected, "SAT: {what}");
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        let slabs = TriangleSat::new(&tri).slabs((max - min) * 0.5);
        assert_eq!(
            slabs.overlaps_centered((min + max) * 0.5),
            expected,
            "slabs: {what}"
        );
        assert_eq!(
            clip_overlaps(&tri, b.min.as_dvec3(), b.max.as_dvec3()),
            expected,
            "clipping: {what}"
        );
    }

    #[test]
    fn touching_counts_at_a_face_an_edge_and_a_corner() {
        let b = unit();
        // A triangle lying in the face plane x = 1, overlapping the face.
        both(
            Triangle::new(vec3(1., 0.5, 0.5), vec3(1., 2., 0.5), vec3(1., 0.5, 2.)),
            b,
            true,
            "in a face plane",
        );
        // A triangle outside whose vertex touches the face x = 1.
        both(
            Triangle::new(vec3(1., 0.5, 0.5), vec3(2., 0.5, 0.5), vec3(2., 0.6, 0.7)),
            b,
            true,
            "vertex on a face",
        );
        // A vertex exactly on the corner (1, 1, 1), the triangle pointing away.
        both(
            Triangle::new(vec3(1., 1., 1.), vec3(2., 1., 2.), vec3(2., 2., 1.)),
            b,
            true,
            "vertex on a corner",
        );
        // An edge crossing the box edge x = 1, y = 1 from outside (the triangle lies in
        // the plane x + y = 2, touching the box only along that edge).
        both(
            Triangle::new(vec3(2., 0., -1.), vec3(0., 2., -1.), vec3(1., 1., 3.)),
            b,
            true,
            "plane touching an edge",
        );
        // The plane x + y + z = 3 touches the box only at the corner (1, 1, 1).
        both(
            Triangle::new(vec3(3., 0., 0.), vec3(0., 3., 0.), vec3(0., 0., 3.)),
            b,
            true,
            "plane touching a corner",
        );
        // Just beyond: x + y + z = 3 + 1/64.
        let s = 3.0 + 1.0 / 64.0;
        both(
            Triangle::new(vec3(s, 0., 0.), vec3(0., s, 0.), vec3(0., 0., s)),
            b,
            false,
            "plane past a corner",
        );
        // A vertex a little outside the face.
        both(
            Triangle::new(
                vec3(1. + 1. / 1024., 0.5, 0.5),
                vec3(2., 0.5, 0.5),
                vec3(2., 0.6, 0.7),
            ),
            b,
            false,
            "vertex off a face",
        );
    }

    #[test]
    fn separated_by_an_edge_axis_though_the_boxes_overlap() {
        // The triangle's bounding box contains the box's corner region, its plane cuts the
        // box's bounding planes, yet an edge cross product separates them: the triangle's
        // long edge passes by the corner (1, 1, ·) at x + y = 2.25.
        let tri = Triangle::new(vec3(2.25, 0., 0.5), vec3(0., 2.25, 0.5), vec3(3., 3., 0.5));
        both(tri, unit(), false, "edge axis separates");
        let tri = Triangle::new(vec3(2., 0., 0.5), vec3(0., 2., 0.5), vec3(3., 3., 0.5));
        both(tri, unit(), true, "edge touches the box edge");
    }

    #[test]
    fn degenerate_triangles_a_point_a_segment_zero_area() {
        let b = unit();
        let p = |x: f32, y: f32, z: f32| Triangle::new(vec3(x, y, z), vec3(x, y, z), vec3(x, y, z));
        both(p(0.5, 0.5, 0.5), b, true, "point inside");
        both(p(1.0, 1.0, 0.0), b, true, "point on an edge");
        both(p(1.0, 1.0, 1.0), b, true, "point on a corner");
        both(p(1.0, 1.5, 0.5), b, false, "point outside");
        let seg = |a: Vec3, c: Vec3| Triangle::new(a, (a + c) * 0.5, c);
        both(
            seg(vec3(-1., 0.5, 0.5), vec3(2., 0.5, 0.5)),
            b,
            true,
            "segment through",
        );
        both(
            seg(vec3(0., 2., 0.5), vec3(2., 0., 0.5)),
            b,
            true,
            "segment touching at an edge",
        );
        both(
            seg(vec3(0., 2.5, 0.5), vec3(2.5, 0., 0.5)),
            b,
            false,
            "segment passing a corner",
        );
        // A segment given by a repeated vertex.
        both(
            Triangle::new(vec3(0., 2.5, 0.5), vec3(2.5, 0., 0.5), vec3(2.5, 0., 0.5)),
            b,
            false,
            "segment with a repeated vertex",
        );
        both(
            Triangle::new(vec3(1., 1., 2.), vec3(1., 1., -1.), vec3(1., 1., -1.)),
            b,
            true,
            "segment along an edge",
        );
    }

    #[test]
    fn agrees_with_clipping_on_random_triangles_and_boxes() {
        let mut s = 0x1234_5678_9abc_def0u64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f32 / (1u64 << 53) as f32
        };
        let mut counts = [0usize; 2];
        for i in 0..200_000 {
            let mut v = || vec3(rnd() * 3. - 1., rnd() * 3. - 1., rnd() * 3. - 1.);
            let mut tri = Triangle::new(v(), v(), v());
            if i % 10 == 0 {
                tri.v[2] = tri.v[0] + (tri.v[1] - tri.v[0]) * 0.25; // collinear
            }
            let lo = vec3(rnd(), rnd(), rnd()) * 0.8;
            let b = Aabb::new(lo, lo + vec3(rnd(), rnd(), rnd()) * 0.6);
            // Only where a tiny change of the box does not change the answer.
            let e = DVec3::splat(1e-7);
            let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
            let inner = clip_overlaps(&tri, min + e, max - e);
            let outer = clip_overlaps(&tri, min - e, max + e);
            if inner == outer {
                assert_eq!(triangle_box_overlap(&tri, &b), inner, "{tri:?} {b:?}");
                let h = (max - min) * 0.5;
                let slabs = TriangleSat::new(&tri).slabs(h);
                assert_eq!(
                    slabs.overlaps_centered(min + h),
                    inner,
                    "slabs {tri:?} {b:?}"
                );
                counts[usize::from(inner)] += 1;
            }
        }
        assert!(counts[0] > 10_000 && counts[1] > 10_000, "{counts:?}");
    }

    /// The slabs in lanes are the per-axis form's bit for bit: the axes as `DVec3`s, each
    /// projected by `DVec3::dot` (the octree's and grid's cells must not move with the
    /// layout), and every centre gets the same answer.
    #[test]
    fn slabs_in_lanes_equal_the_axis_by_axis_slabs() {
        let mut rng = crate::random::Rng(0x5eed_0fa1_1a7e_5123);
        let mut rnd = move || rng.unit() * 4.0 - 2.0;
        let (mut inside, mut outside) = (0, 0);
        for i in 0..20_000 {
            let mut v = || vec3(rnd() as f32, rnd() as f32, rnd() as f32);
            let mut tri = Triangle::new(v(), v(), v());
            if i % 9 == 0 {
                tri.v[2] = tri.v[1]; // a segment
            }
            let sat = TriangleSat::new(&tri);
            let h = DVec3::new(rnd().abs(), rnd().abs(), rnd().abs()) * 0.5;
            let slabs = sat.slabs(h);
            let mut axes = vec![DVec3::X, DVec3::Y, DVec3::Z, sat.n];
            for e in &sat.e {
                axes.push(DVec3::new(0.0, -e.z, e.y));
                axes.push(DVec3::new(e.z, 0.0, -e.x));
                axes.push(DVec3::new(-e.y, e.x, 0.0));
            }
            let interval = |a: DVec3| {
                let p = sat.v.map(|v| a.dot(v));
                let r = h.dot(a.abs());
                (p[0].min(p[1]).min(p[2]) - r, p[0].max(p[1]).max(p[2]) + r)
            };
            for (j, &a) in axes.iter().enumerate() {
                let (lo, hi) = interval(a);
                assert_eq!(slabs.lo[j].to_bits(), lo.to_bits(), "{tri:?} axis {j}");
                assert_eq!(slabs.hi[j].to_bits(), hi.to_bits(), "{tri:?} axis {j}");
            }
            for _ in 0..4 {
                let c = DVec3::new(rnd(), rnd(), rnd());
                let expected = axes.iter().all(|&a| {
                    let (lo, hi) = interval(a);
                    lo <= a.dot(c) && a.dot(c) <= hi
                });
                assert_eq!(slabs.overlaps_centered(c), expected, "{tri:?} {c}");
                match expected {
                    true => inside += 1,
                    false => outside += 1,
                }
            }
        }
        assert!(inside > 5_000 && outside > 5_000, "{inside} {outside}");
    }

    #[test]
    fn runs_agree_with_the_box_test_along_every_axis() {
        let mut s = 0x0bad_cafe_1234_5678u64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let h = DVec3::new(0.11, 0.07, 0.13);
        let (mut inside, mut outside) = (0, 0);
        for i in 0..20_000 {
            let mut v = || vec3(rnd() as f32, rnd() as f32, rnd() as f32);
            let mut tri = Triangle::new(v(), v(), v());
            if i % 7 == 0 {
                tri.v[2] = tri.v[0] + (tri.v[1] - tri.v[0]) * 0.5; // a segment
            }
            if i % 11 == 0 {
                tri.v[1].y = tri.v[0].y; // flat in y
                tri.v[2].y = tri.v[0].y;
            }
            if i % 13 == 0 {
                tri.v[1].x = tri.v[0].x; // an edge perpendicular to x
            }
            let sat = TriangleSat::new(&tri);
            let slabs = sat.slabs(h);
            let b = tri.bounds();
            let (bmin, bmax) = (b.min.as_dvec3() - h, b.max.as_dvec3() + h);
            for u in 0..3 {
                let runs = TriangleRuns::new(&sat, h, u);
                let mut c = DVec3::new(rnd(), rnd(), rnd()) * 1.4 - 0.2;
                let (t0, t1) = runs.run(c);
                for k in 0..40 {
                    c[u] = -0.3 + 1.6 * f64::from(k) / 39.0;
                    // Only boxes overlapping the triangle's bounding box, away from the
                    // interval's ends.
                    let near = (c[u] - t0).abs() < 1e-9 || (c[u] - t1).abs() < 1e-9;
                    let in_box = c.cmpge(bmin).all() && c.cmple(bmax).all();
                    if in_box && !near {
                        let in_run = c[u] >= t0 && c[u] <= t1;
                        assert_eq!(in_run, slabs.overlaps_centered(c), "{tri:?} u {u} {c}");
                        inside += usize::from(in_run);
                        outside += usize::from(!in_run);
                    }
                }
            }
        }
        assert!(inside > 10_000 && outside > 10_000, "{inside} {outside}");
    }

    #[test]
    fn empty_box_overlaps_nothing() {
        let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        assert!(!triangle_box_overlap(&t, &Aabb::EMPTY));
    }
}
