//! The watertight ray–triangle test of Woop, Benthin and Wald (2013).
//!
//! The ray is made the +z axis of a sheared coordinate system, so the test reduces to the
//! signs of three 2D edge functions of the projected vertices. Two triangles sharing an edge
//! compute that edge's function from the same two vertices, in the same order up to sign, so
//! they disagree on no ray: nothing slips through. An edge function that rounds to exactly
//! zero is recomputed in f64, where the f32 inputs multiply exactly; so is the distance of a
//! hit too close to the origin for f32 to tell which side it is on.

use super::reference::gamma64;
use super::{Intersector, TriangleHit};
use crate::geometry::simd::triangle::{BlockHits, TriangleBlock, TriangleKernel};
use crate::geometry::{Ray, Triangle, gamma};
use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, Default)]
pub struct Watertight;

/// The ray's shear: axis permutation (kx, ky, kz), kz the largest direction component.
#[derive(Clone, Copy, Debug)]
pub struct Shear {
    /// Each below 3, as `Watertight::prepare` (which alone makes a shear) makes them: the
    /// block test indexes a block's rows by them without bounds checks.
    k: [usize; 3],
    /// (−d_kx / d_kz, −d_ky / d_kz, 1 / d_kz).
    pub s: Vec3,
    /// The origin in the permuted axes (o_kx, o_ky, o_kz): a block test broadcasts each
    /// straight from here, once per ray picked.
    pub o: [f32; 3],
}

impl Shear {
    /// The axes (kx, ky, kz), each below 3.
    #[inline(always)]
    pub fn k(&self) -> [usize; 3] {
        self.k
    }
}

/// The axes of the ray's coordinate system: kz is the direction's largest component, kx and
/// ky follow it cyclically (so the permutation keeps the triangles' winding).
#[inline(always)]
pub fn shear_axes(direction: Vec3) -> [usize; 3] {
    let a = direction.abs();
    let kz = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    shear_axes_of(kz)
}

/// The permutation (kx, ky, kz) for the largest axis kz.
#[inline(always)]
pub fn shear_axes_of(kz: usize) -> [usize; 3] {
    let kx = (kz + 1) % 3;
    [kx, (kx + 1) % 3, kz]
}

impl Intersector for Watertight {
    type RayData = Shear;
    const NAME: &'static str = "watertight";
    const PACKET_TEST: bool = true;
    const BLOCK_TEST: bool = true;

    #[inline(always)]
    fn prepare(ray: &Ray) -> Shear {
        let [kx, ky, kz] = shear_axes(ray.direction);
        // An array is indexed by address; a vector's index is a branch per axis.
        let d = ray.direction.to_array();
        let o = ray.origin.to_array();
        Shear {
            k: [kx, ky, kz],
            s: Vec3::new(-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]),
            o: [o[kx], o[ky], o[kz]],
        }
    }

    /// Four triangles per SIMD kernel call, each lane bit for bit this test (`simd::triangle`).
    #[inline(always)]
    unsafe fn intersect_block<K: TriangleKernel>(
        shear: &Shear,
        ray: &Ray,
        block: &TriangleBlock,
        tmin: f32,
        tmax: f32,
    ) -> BlockHits {
        // SAFETY: the caller guarantees the CPU supports K's instruction set.
        unsafe { K::watertight(block, shear, ray, tmin, tmax) }
    }

    #[inline(always)]
    fn intersect(
        shear: &Shear,
        ray: &Ray,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<TriangleHit> {
        let [kx, ky, kz] = shear.k;
        let s = shear.s;
        // Vertices relative to the origin, permuted so the ray runs along +z, then sheared.
        let rel = |p: Vec3| {
            let q = (p - ray.origin).to_array();
            Vec3::new(q[kx], q[ky], q[kz])
        };
        let (a, b, c) = (rel(tri.v[0]), rel(tri.v[1]), rel(tri.v[2]));
        let (ax, ay) = (a.x + s.x * a.z, a.y + s.y * a.z);
        let (bx, by) = (b.x + s.x * b.z, b.y + s.y * b.z);
        let (cx, cy) = (c.x + s.x * c.z, c.y + s.y * c.z);

        let mut e0 = bx * cy - by * cx;
        let mut e1 = cx * ay - cy * ax;
        let mut e2 = ax * by - ay * bx;
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            let f = |px: f32, py: f32, qx: f32, qy: f32| {
                (px as f64 * qy as f64 - py as f64 * qx as f64) as f32
            };
            e0 = f(bx, by, cx, cy);
            e1 = f(cx, cy, ax, ay);
            e2 = f(ax, ay, bx, by);
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        let (az, bz, cz) = (s.z * a.z, s.z * b.z, s.z * c.z);
        let inv_det = 1.0 / det;
        let mut t = (e0 * az + e1 * bz + e2 * cz) * inv_det;
        if !(t > tmin && t < tmax) {
            return None;
        }
        // The rounding error of t (pbrt-v4 §6.8.4). The sheared x and y are q_x + s_x·q_z
        // with |s_x| ≤ 1, so their error is bounded with |q_z| (pbrt uses the scaled z,
        // too small when the direction is longer than 1).
        let max_z = az.abs().max(bz.abs()).max(cz.abs());
        let max_qz = a.z.abs().max(b.z.abs()).max(c.z.abs());
        let max_x = ax.abs().max(bx.abs()).max(cx.abs());
        let max_y = ay.abs().max(by.abs()).max(cy.abs());
        let delta_z = gamma(3) * max_z;
        let delta_x = gamma(5) * (max_x + max_qz);
        let delta_y = gamma(5) * (max_y + max_qz);
        let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let max_e = e0.abs().max(e1.abs()).max(e2.abs());
        let delta_t =
            3.0 * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * inv_det.abs();
        if t <= delta_t {
            // f32 cannot tell this hit from the surface the ray starts on. pbrt rejects it,
            // which avoids self-intersection but also loses real hits close to long thin
            // triangles (whose f32 t error is large), letting rays through closed meshes.
            // f64 decides instead: its error is ~10^-16 of the same terms.
            let t64 = plane_distance_f64(ray, tri)?;
            if !(t64 > tmin as f64 && t64 < tmax as f64) {
                return None;
            }
            t = t64 as f32;
        }
        Some(TriangleHit {
            t,
            u: e1 * inv_det,
            v: e2 * inv_det,
        })
    }
}

/// The distance along the ray to the triangle's plane, n·(v0 − o) / n·d, in f64 with an error
/// bound: `None` unless it is positive beyond that bound. The f32 inputs' differences are
/// exact in f64; each later operation is counted in the γ terms.
#[cold]
#[inline(never)]
fn plane_distance_f64(ray: &Ray, tri: &Triangle) -> Option<f64> {
    let a = tri.v[0].as_dvec3();
    let e1 = tri.v[1].as_dvec3() - a;
    let e2 = tri.v[2].as_dvec3() - a;
    let n = e1.cross(e2);
    // |error of each component of n|: two products and a difference, on exact inputs.
    let n_err = DVec3::new(
        (e1.y * e2.z).abs() + (e1.z * e2.y).abs(),
        (e1.z * e2.x).abs() + (e1.x * e2.z).abs(),
        (e1.x * e2.y).abs() + (e1.y * e2.x).abs(),
    ) * gamma64(2);
    let w = a - ray.origin.as_dvec3();
    let d = ray.direction.as_dvec3();
    let (num, den) = (n.dot(w), n.dot(d));
    let num_err = gamma64(3) * (n.abs() + n_err).dot(w.abs()) + n_err.dot(w.abs());
    let den_err = gamma64(3) * (n.abs() + n_err).dot(d.abs()) + n_err.dot(d.abs());
    if den.abs() <= den_err {
        return None;
    }
    let t = num / den;
    let t_err = (num_err + t.abs() * den_err) / (den.abs() - den_err) + gamma64(1) * t.abs();
    (t > t_err).then_some(t)
}
