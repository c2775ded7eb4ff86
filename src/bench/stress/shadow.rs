//! Shadow-ray self-intersection: from every hit, a shadow ray to the light and a bounce ray
//! start at `SurfacePoint::spawn_origin` (pbrt-v4's error-bound offset); one whose closest hit
//! is the triangle it leaves has hit itself.

use crate::accel::{Accel, NoStats};
use crate::geometry::spawn::SurfacePoint;
use crate::geometry::{Intersector, Ray, Triangle};
use crate::random::cosine_direction;
use glam::Vec3;
use rayon::prelude::*;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadowReport {
    /// Shadow rays traced (one per hit), how many were occluded, and how many of those hit
    /// the triangle they start on (must be 0).
    pub shadow_rays: u64,
    pub occluded: u64,
    pub shadow_self_hits: u64,
    /// The same for diffuse bounce rays.
    pub bounce_rays: u64,
    pub bounce_self_hits: u64,
}

impl ShadowReport {
    pub fn self_hits(&self) -> u64 {
        self.shadow_self_hits + self.bounce_self_hits
    }

    pub fn add(&mut self, o: &ShadowReport) {
        self.shadow_rays += o.shadow_rays;
        self.occluded += o.occluded;
        self.shadow_self_hits += o.shadow_self_hits;
        self.bounce_rays += o.bounce_rays;
        self.bounce_self_hits += o.bounce_self_hits;
    }
}

/// Traces `rays` with `I`, then from every hit a shadow ray to `light` and a bounce ray.
pub fn run<A: Accel, I: Intersector>(
    accel: &A,
    triangles: &[Triangle],
    rays: &[Ray],
    light: Vec3,
) -> ShadowReport {
    rays.par_iter()
        .enumerate()
        .with_min_len(256)
        .fold(ShadowReport::default, |mut r, (i, ray)| {
            let Some(hit) = accel.closest_hit::<I, _>(ray, &mut NoStats) else {
                return r;
            };
            let tri = &triangles[hit.triangle as usize];
            let n = tri.facing_normal(ray.direction);
            let point = SurfacePoint::on_triangle(tri, hit.u, hit.v);
            let shadow = point.ray_towards(n, light);
            if shadow.tmax > 0.0 {
                r.shadow_rays += 1;
                if let Some(h) = accel.closest_hit::<I, _>(&shadow, &mut NoStats) {
                    r.occluded += 1;
                    r.shadow_self_hits += u64::from(h.triangle == hit.triangle);
                }
            }
            if n == Vec3::ZERO {
                return r;
            }
            let dir = cosine_direction(n, i as u64);
            let bounce = Ray::new(point.spawn_origin(n, dir), dir);
            r.bounce_rays += 1;
            if let Some(h) = accel.closest_hit::<I, _>(&bounce, &mut NoStats) {
                r.bounce_self_hits += u64::from(h.triangle == hit.triangle);
            }
            r
        })
        .reduce(ShadowReport::default, |mut a, b| {
            a.add(&b);
            a
        })
}
