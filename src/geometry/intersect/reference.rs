//! The f64 reference: the watertight test (Woop, Benthin and Wald 2013) in double precision,
//! the accurate end of the time/error trade-off. `evaluate` also bounds how far the f32 test's
//! edge functions and t can be from it (pbrt-v4 §6.8.4): within them, an f32 answer is rounding.

use super::{Intersector, TriangleHit};
use crate::geometry::{Ray, Triangle, gamma};
use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, Default)]
pub struct ReferenceF64;

/// The ray's shear in f64: axis permutation (kx, ky, kz), kz the largest direction component.
#[derive(Clone, Copy, Debug)]
pub struct Shear64 {
    k: [usize; 3],
    s: DVec3,
    origin: DVec3,
}

impl Shear64 {
    pub fn new(ray: &Ray) -> Self {
        // The same axis choice as the f32 test, from the same f32 values.
        let [kx, ky, kz] = super::watertight::shear_axes(ray.direction);
        let d = ray.direction.as_dvec3();
        Shear64 {
            k: [kx, ky, kz],
            s: DVec3::new(-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]),
            origin: ray.origin.as_dvec3(),
        }
    }

    /// A vertex in ray space: relative to the origin, permuted, sheared; z scaled to t units.
    #[inline(always)]
    fn project(&self, p: Vec3) -> DVec3 {
        let q = p.as_dvec3() - self.origin;
        let [kx, ky, kz] = self.k;
        let z = q[kz];
        DVec3::new(q[kx] + self.s.x * z, q[ky] + self.s.y * z, self.s.z * z)
    }
}

/// γ(n) of f64 arithmetic.
pub const fn gamma64(n: i32) -> f64 {
    let ne = n as f64 * (f64::EPSILON * 0.5);
    ne / (1.0 - ne)
}

/// Everything the f64 test computes for one ray and triangle, hit or not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// The three edge functions (twice the signed areas seen from the ray), in f64.
    pub e: [f64; 3],
    /// e0 + e1 + e2: twice the signed area of the projected triangle.
    pub det: f64,
    /// Distance to the triangle's plane in units of the direction (NaN when det = 0).
    pub t: f64,
    /// All edge functions of one sign and det ≠ 0: the line meets the triangle.
    pub inside: bool,
    /// Bound on the error of this evaluation's edge functions and of t.
    pub edge_error: f64,
    pub t_error: f64,
    /// Bound on the error of the f32 watertight test's edge functions and t for the same
    /// ray and triangle.
    pub f32_edge_error: f64,
    pub f32_t_error: f64,
}

impl Evaluation {
    /// Whether rounding within the f32 test's bounds could decide either way whether the
    /// ray meets the triangle: the ray passes within the edge error of the boundary, or
    /// the projected triangle is degenerate within it.
    pub fn edge_ambiguous(&self) -> bool {
        let bound = self.f32_edge_error + self.edge_error;
        let nearest_edge = self.e.iter().fold(f64::INFINITY, |m, &e| m.min(e.abs()));
        nearest_edge <= bound || self.det.abs() <= 3.0 * bound
    }

    /// Whether `t` lies within the f32 t error of the open interval's ends (tmin, tmax).
    pub fn t_ambiguous(&self, tmin: f32, tmax: f32) -> bool {
        let bound = self.f32_t_error + self.t_error;
        (self.t - tmin as f64).abs() <= bound
            || (tmax.is_finite() && (self.t - tmax as f64).abs() <= bound)
            || self.t <= bound
    }
}

/// The f64 test with its error bounds for one ray and triangle.
pub fn evaluate(shear: &Shear64, tri: &Triangle) -> Evaluation {
    let [kx, ky, kz] = shear.k;
    let rel = tri.v.map(|p| p.as_dvec3() - shear.origin);
    let [a, b, c] = tri.v.map(|p| shear.project(p));
    let e = [
        b.x * c.y - b.y * c.x,
        c.x * a.y - c.y * a.x,
        a.x * b.y - a.y * b.x,
    ];
    let det = e[0] + e[1] + e[2];
    let mixed = e.iter().any(|&x| x < 0.0) && e.iter().any(|&x| x > 0.0);
    let t = (e[0] * a.z + e[1] * b.z + e[2] * c.z) / det;
    let max3 = |f: &dyn Fn(DVec3) -> f64| f(rel[0]).max(f(rel[1])).max(f(rel[2]));
    // Bounds on the sheared coordinates' magnitudes before cancellation: each is computed
    // as q_x + s_x·q_z from these terms. (pbrt-v4 §6.8.4 uses max |z'| in place of
    // |s_x·q_z|, which is too small when the direction is not normalised.)
    let sum_x = max3(&|q| q[kx].abs() + (shear.s.x * q[kz]).abs());
    let sum_y = max3(&|q| q[ky].abs() + (shear.s.y * q[kz]).abs());
    let max_x = a.x.abs().max(b.x.abs()).max(c.x.abs());
    let max_y = a.y.abs().max(b.y.abs()).max(c.y.abs());
    let max_z = a.z.abs().max(b.z.abs()).max(c.z.abs());
    let max_e = e[0].abs().max(e[1].abs()).max(e[2].abs());
    // Error bounds once with f64's γ and once with f32's: the coordinates carry up to five
    // roundings (difference, shear factor, product, sum), an edge function two more.
    let bounds = |g: &dyn Fn(i32) -> f64| {
        let delta_x = g(5) * sum_x;
        let delta_y = g(5) * sum_y;
        let delta_z = g(3) * max_z;
        let delta_e = 2.0
            * (g(2) * (max_x + delta_x) * (max_y + delta_y)
                + delta_y * max_x
                + delta_x * max_y
                + delta_x * delta_y);
        let delta_t = 3.0 * (g(3) * max_e * max_z + delta_e * max_z + delta_z * max_e)
            / det.abs().max(f64::MIN_POSITIVE);
        (delta_e, delta_t)
    };
    let (edge_error, t_error) = bounds(&gamma64);
    let (f32_edge_error, f32_t_error) = bounds(&|n| gamma(n) as f64);
    Evaluation {
        e,
        det,
        t,
        inside: !mixed && det != 0.0,
        edge_error,
        t_error,
        f32_edge_error,
        f32_t_error,
    }
}

impl Intersector for ReferenceF64 {
    type RayData = Shear64;
    const NAME: &'static str = "f64";

    #[inline(always)]
    fn prepare(ray: &Ray) -> Shear64 {
        Shear64::new(ray)
    }

    #[inline(always)]
    fn intersect(
        shear: &Shear64,
        _ray: &Ray,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<TriangleHit> {
        let a = shear.project(tri.v[0]);
        let b = shear.project(tri.v[1]);
        let c = shear.project(tri.v[2]);
        let e0 = b.x * c.y - b.y * c.x;
        let e1 = c.x * a.y - c.y * a.x;
        let e2 = a.x * b.y - a.y * b.x;
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        let t = (e0 * a.z + e1 * b.z + e2 * c.z) / det;
        if !(t > tmin as f64 && t < tmax as f64) {
            return None;
        }
        // As in the f32 test: a hit within t's own rounding error of the origin cannot be
        // told apart from the surface the ray starts on.
        let ev = evaluate(shear, tri);
        if t <= ev.t_error {
            return None;
        }
        Some(TriangleHit {
            t: t as f32,
            u: (e1 / det) as f32,
            v: (e2 / det) as f32,
        })
    }
}
