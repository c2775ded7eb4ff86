//! Rays grazing triangles edge-on. A ray exactly in an axis-aligned triangle's plane (d = ±0
//! across it) sees zero area and must not hit; rays along edges or nearly in the plane of any
//! triangle may hit or miss, but never with a NaN.

use crate::geometry::{Intersector, Ray, Triangle};
use crate::random::Rng;
use glam::Vec3;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GrazingReport {
    /// Rays exactly in the plane of an axis-aligned triangle, and their hits (must be 0).
    pub in_plane: u64,
    pub in_plane_hits: u64,
    /// Rays along an edge or nearly in the plane of a general triangle, and their hits
    /// (allowed: the f32 ray is not exactly in the plane).
    pub near_plane: u64,
    pub near_plane_hits: u64,
    /// Hits with a NaN or infinite t, u or v, or t outside (tmin, tmax) (must be 0).
    pub bad_hits: u64,
}

impl GrazingReport {
    pub fn failures(&self) -> u64 {
        self.in_plane_hits + self.bad_hits
    }

    pub fn add(&mut self, o: &GrazingReport) {
        self.in_plane += o.in_plane;
        self.in_plane_hits += o.in_plane_hits;
        self.near_plane += o.near_plane;
        self.near_plane_hits += o.near_plane_hits;
        self.bad_hits += o.bad_hits;
    }
}

fn random_point(rng: &mut Rng, scale: f32) -> Vec3 {
    (rng.in_ball() * scale as f64).as_vec3()
}

/// Case `i`: an axis-plane triangle with a ray in its plane (even cases), or a general
/// triangle with a ray along one of its edges or through its plane at a tiny angle (odd).
pub fn case(i: u64, seed: u64) -> (Triangle, Ray, bool) {
    let mut rng = Rng::for_case(seed, i);
    let scale = 10f32.powi(rng.below(7) as i32 - 3);
    let far = 10f32.powi(rng.below(4) as i32);
    let offset = random_point(&mut rng, scale * far);
    if i.is_multiple_of(2) {
        let axis = rng.below(3) as usize;
        let plane = offset[axis];
        let mut corner = || {
            let mut p = offset + random_point(&mut rng, scale);
            p[axis] = plane;
            p
        };
        let tri = Triangle::new(corner(), corner(), corner());
        // Aim through a point of the triangle (or near it), staying in the plane.
        let target = tri.point(rng.unit() as f32, 0.5 * rng.unit() as f32);
        let mut o = target + random_point(&mut rng, 2.0 * scale);
        o[axis] = plane;
        let mut d = target - o;
        d[axis] = rng.signed_zero();
        if d == Vec3::ZERO {
            d[(axis + 1) % 3] = 1.0;
        }
        (tri, Ray::new(o, d), true)
    } else {
        let mut corner = || offset + random_point(&mut rng, scale);
        let tri = Triangle::new(corner(), corner(), corner());
        let k = rng.below(3) as usize;
        let (a, b) = (tri.v[k], tri.v[(k + 1) % 3]);
        let ray = if rng.coin() {
            // Along the edge a–b, from before a.
            Ray::new(a - (b - a) * 0.5, b - a)
        } else {
            // Through the centroid, almost in the plane.
            let n = tri.normal().normalize_or_zero();
            let along = (b - a).normalize_or_zero();
            let tilt = 10f32.powi(-(rng.below(8) as i32) - 1);
            let d = along + n * tilt * if rng.coin() { 1.0 } else { -1.0 };
            Ray::new(tri.centroid() - d * scale * 2.0, d)
        };
        (tri, ray, false)
    }
}

/// `n` grazing cases for the intersector `I`.
pub fn run<I: Intersector>(n: u64, seed: u64) -> GrazingReport {
    use rayon::prelude::*;
    (0..n)
        .into_par_iter()
        .fold(GrazingReport::default, |mut r, i| {
            let (tri, ray, in_plane) = case(i, seed);
            if !ray.is_valid() {
                return r;
            }
            let hit = I::intersect(&I::prepare(&ray), &ray, &tri, ray.tmin, ray.tmax);
            if in_plane {
                r.in_plane += 1;
                r.in_plane_hits += u64::from(hit.is_some());
            } else {
                r.near_plane += 1;
                r.near_plane_hits += u64::from(hit.is_some());
            }
            if let Some(h) = hit
                && !(h.u.is_finite() && h.v.is_finite() && h.t > ray.tmin && h.t < ray.tmax)
            {
                r.bad_hits += 1;
            }
            r
        })
        .reduce(GrazingReport::default, |mut a, b| {
            a.add(&b);
            a
        })
}
