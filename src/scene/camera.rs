//! The pinhole camera: one ray per pixel from the eye through the image plane.

use crate::geometry::{Aabb, Ray};
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
}

impl Camera {
    pub fn new(eye: Vec3, look_at: Vec3) -> Self {
        Camera {
            eye,
            look_at,
            up: Vec3::Y,
            fov_y_deg: 60.0,
        }
    }

    /// The standard automatic view of a box: look at its centre from the direction
    /// (0.3, 0.4, 1.0), at 0.9 × its diagonal.
    pub fn framing(bounds: &Aabb) -> Self {
        let center = bounds.center();
        let distance = (0.9 * bounds.diagonal()).max(1e-3);
        let dir = Vec3::new(0.3, 0.4, 1.0).normalize();
        Camera::new(center + dir * distance, center)
    }

    /// An orthonormal basis (right, up, back) of the view; robust to `up` parallel to the
    /// view direction.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let back = (self.eye - self.look_at).normalize_or(Vec3::Z);
        let mut right = self.up.cross(back);
        if right.length_squared() < 1e-12 {
            right = back.any_orthonormal_vector();
        }
        let right = right.normalize();
        (right, back.cross(right), back)
    }

    /// The primary-ray generator for a `width` × `height` image.
    pub fn rays(&self, width: u32, height: u32) -> CameraRays {
        let (right, up, back) = self.basis();
        let half_h = (self.fov_y_deg.to_radians() * 0.5).tan();
        let aspect = width as f32 / height.max(1) as f32;
        CameraRays {
            eye: self.eye,
            right: right * (half_h * aspect),
            up: up * half_h,
            forward: -back,
            width: width as f32,
            height: height as f32,
        }
    }
}

impl Camera {
    /// Where a world point lands in a `width` × `height` image: (x, y) in pixels (y down)
    /// and its distance from the eye (the t of a primary ray, whose direction is unit
    /// length). `None` behind the eye.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<(f32, f32, f32)> {
        self.rays(width, height).project(p)
    }
}

/// Precomputed image-plane vectors for generating primary rays.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    width: f32,
    height: f32,
}

impl CameraRays {
    /// `Camera::project` with the image plane made once: what a loop over many points
    /// calls, as the camera's basis and field of view cost a normalisation and a tangent.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let v = p - self.eye;
        let z = v.dot(self.forward);
        if z <= 1e-6 * v.length().max(1e-30) {
            return None;
        }
        let sx = v.dot(self.right) / (z * self.right.length_squared());
        let sy = v.dot(self.up) / (z * self.up.length_squared());
        Some((
            (sx + 1.0) * 0.5 * self.width,
            (1.0 - sy) * 0.5 * self.height,
            v.length(),
        ))
    }

    /// The ray through image position (x, y) in pixels, y down; (px + 0.5, py + 0.5) is the
    /// centre of pixel (px, py).
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let sx = 2.0 * x / self.width - 1.0;
        let sy = 1.0 - 2.0 * y / self.height;
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        Ray::new(self.eye, dir)
    }

    pub fn pixel_center(&self, px: u32, py: u32) -> Ray {
        self.ray(px as f32 + 0.5, py as f32 + 0.5)
    }
}
