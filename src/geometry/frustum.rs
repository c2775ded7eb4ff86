//! The interval-arithmetic box test for a packet of rays with one origin (Wald, Boulos and
//! Shirley 2007): instead of one slab test per ray, one test with the range of the packet's
//! reciprocal directions tells that no ray of the packet can enter a box.
//!
//! It is exact for culling, never an approximation: for a fixed plane offset x = b − o, the
//! rounded product x · (1/d) is monotonic in 1/d, so the smallest and largest reciprocal of
//! the packet bound every ray's own near and far distances as the slab test computes them.
//! A box the packet test rejects is therefore missed by every ray's own slab test.

use super::Ray;
use super::aabb::FAR_SCALE;
use glam::Vec3;

/// The packet as one "interval ray": its origin, the range of reciprocal directions per
/// axis and the range of the rays' t intervals.
#[derive(Clone, Copy, Debug)]
pub struct RayInterval {
    origin: Vec3,
    inv_lo: Vec3,
    inv_hi: Vec3,
    /// Per axis, the corner (0 = min, 1 = max) of the near plane, shared by all rays.
    near: [usize; 3],
    tmin: f32,
}

impl RayInterval {
    /// The interval ray of `rays`, or `None` when the test does not apply: the rays do not
    /// share one origin, a direction component changes sign (or is ±0) within the packet,
    /// or a reciprocal is not finite.
    pub fn new(rays: &[Ray]) -> Option<Self> {
        let first = rays.first()?;
        let inv = |r: &Ray| r.direction.recip();
        let (mut lo, mut hi) = (inv(first), inv(first));
        let mut tmin = first.tmin;
        for r in rays {
            let i = inv(r);
            let same_sign = i.is_negative_bitmask() == lo.is_negative_bitmask();
            if r.origin != first.origin || !i.is_finite() || !same_sign || i.cmpeq(Vec3::ZERO).any()
            {
                return None;
            }
            lo = lo.min(i);
            hi = hi.max(i);
            tmin = tmin.min(r.tmin);
        }
        let near = |c: f32| usize::from(c < 0.0);
        Some(RayInterval {
            origin: first.origin,
            inv_lo: lo,
            inv_hi: hi,
            near: [near(lo.x), near(lo.y), near(lo.z)],
            tmin,
        })
    }

    /// Whether no ray of the packet can enter the box `[min, max]` before `tmax` (the
    /// largest t any ray still looks for).
    #[inline(always)]
    pub fn misses(&self, corners: &[Vec3; 2], tmax: f32) -> bool {
        let mut enter = self.tmin;
        let mut exit = tmax;
        for (axis, &near) in self.near.iter().enumerate() {
            let n = near & 1;
            let near_offset = corners[n][axis] - self.origin[axis];
            let far_offset = corners[n ^ 1][axis] - self.origin[axis];
            let (lo, hi) = (self.inv_lo[axis], self.inv_hi[axis]);
            // The lowest near distance and the highest far distance over the packet.
            let near = (near_offset * lo).min(near_offset * hi);
            let far = (far_offset * lo).max(far_offset * hi) * FAR_SCALE;
            enter = enter.max(near);
            exit = exit.min(far);
        }
        enter > exit
    }
}
