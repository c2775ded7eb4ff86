//! Origins for secondary rays (shadow and bounce rays) that cannot hit the surface they
//! leave. The hit point is computed from barycentrics, with a rounding error bounded per
//! component (pbrt-v4 §6.8.5); the origin is pushed along the normal just past that bound
//! and then one more ulp away, so it lies strictly on the correct side of the surface.

use super::{Ray, Triangle, gamma};
use glam::Vec3;

/// A surface point with a conservative bound on the error of each coordinate.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    pub error: Vec3,
}

impl SurfacePoint {
    /// The point with barycentrics (1 − u − v, u, v) on `tri`.
    pub fn on_triangle(tri: &Triangle, u: f32, v: f32) -> Self {
        let b0 = 1.0 - u - v;
        let p = b0 * tri.v[0] + u * tri.v[1] + v * tri.v[2];
        let abs_sum = (b0 * tri.v[0]).abs() + (u * tri.v[1]).abs() + (v * tri.v[2]).abs();
        // b0 itself is rounded, by up to γ(2)·(|1 − u| + |b0|): an absolute error that is
        // large next to a small b0, so it is bounded with |v0| rather than |b0·v0|.
        let b0_error = gamma(2) * (1.0 + u.abs() + b0.abs());
        SurfacePoint {
            p,
            error: gamma(7) * abs_sum + b0_error * tri.v[0].abs(),
        }
    }

    /// An origin for a ray leaving the surface in `direction`, on the side of the geometric
    /// normal `n` (any length) that the direction points to.
    pub fn spawn_origin(&self, n: Vec3, direction: Vec3) -> Vec3 {
        let n = n.normalize_or_zero();
        let d = n.abs().dot(self.error);
        let mut offset = d * n;
        if direction.dot(n) < 0.0 {
            offset = -offset;
        }
        let mut po = self.p + offset;
        for i in 0..3 {
            if offset[i] > 0.0 {
                po[i] = po[i].next_up();
            } else if offset[i] < 0.0 {
                po[i] = po[i].next_down();
            }
        }
        po
    }

    /// The shadow-ray segment from this point (on the side of `n` facing `target`) to
    /// `target`: unit direction, tmax = the distance. A point at the target gets an empty
    /// segment along `n`, which hits nothing.
    pub fn ray_towards(&self, n: Vec3, target: Vec3) -> Ray {
        let origin = self.spawn_origin(n, target - self.p);
        let to_target = target - origin;
        let distance = to_target.length();
        if distance > 0.0 {
            Ray::segment(origin, to_target / distance, 0.0, distance)
        } else {
            Ray::segment(origin, n.normalize_or(Vec3::Y), 0.0, 0.0)
        }
    }
}
