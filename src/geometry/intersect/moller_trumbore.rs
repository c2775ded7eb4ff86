//! Möller–Trumbore (1997): barycentrics from Cramer's rule on the edge vectors, in f32.
//! Fast and compact, but not watertight: a ray through a shared edge can slip between
//! the two triangles when rounding puts it just outside both.

use super::{Intersector, TriangleHit};
use crate::geometry::{Ray, Triangle};

#[derive(Clone, Copy, Debug, Default)]
pub struct MollerTrumbore;

impl Intersector for MollerTrumbore {
    type RayData = ();
    const NAME: &'static str = "moller-trumbore";

    #[inline(always)]
    fn prepare(_ray: &Ray) -> Self::RayData {}

    #[inline(always)]
    fn intersect(
        _data: &(),
        ray: &Ray,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<TriangleHit> {
        let e1 = tri.v[1] - tri.v[0];
        let e2 = tri.v[2] - tri.v[0];
        let p = ray.direction.cross(e2);
        let det = e1.dot(p);
        // Exactly zero only: a relative epsilon would make the test depend on the scene scale.
        if det == 0.0 {
            return None;
        }
        let inv_det = 1.0 / det;
        let s = ray.origin - tri.v[0];
        let u = s.dot(p) * inv_det;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = ray.direction.dot(q) * inv_det;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv_det;
        (t > tmin && t < tmax).then_some(TriangleHit { t, u, v })
    }
}
