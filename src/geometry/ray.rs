//! A ray with its valid interval (tmin, tmax) and the per-ray values every box test reuses.

use glam::Vec3;

/// A ray `origin + t · direction` for t in the open interval (`tmin`, `tmax`).
/// The direction need not be normalised; t is measured in units of it.
/// `repr(C)`: a packet loads rays as eight floats each (`simd::ray_packet`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Ray {
            origin,
            direction,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    pub fn segment(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Self {
        Ray {
            origin,
            direction,
            tmin,
            tmax,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }

    /// A ray that can be traced: finite origin and direction, a non-zero direction and an
    /// interval that is not NaN. Tools that take rays from users check this first.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.direction.is_finite()
            && self.direction != Vec3::ZERO
            && !self.tmin.is_nan()
            && !self.tmax.is_nan()
    }
}
