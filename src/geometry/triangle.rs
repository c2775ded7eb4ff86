//! A triangle as three vertices, with the quantities the builders and shading need.

use super::Aabb;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub v: [Vec3; 3],
}

impl Triangle {
    pub fn new(a: Vec3, b: Vec3, c: Vec3) -> Self {
        Triangle { v: [a, b, c] }
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_point(self.v[0])
            .grow_point(self.v[1])
            .grow_point(self.v[2])
    }

    pub fn centroid(&self) -> Vec3 {
        (self.v[0] + self.v[1] + self.v[2]) / 3.0
    }

    /// Unnormalised geometric normal (e1 × e2); its length is twice the area.
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }

    /// The unit geometric normal on the side a ray with direction `dir` arrives from (zero
    /// for a degenerate triangle).
    pub fn facing_normal(&self, dir: Vec3) -> Vec3 {
        let n = self.normal().normalize_or_zero();
        if n.dot(dir) > 0.0 { -n } else { n }
    }

    pub fn area(&self) -> f32 {
        0.5 * self.normal().length()
    }

    /// The point with barycentric coordinates (1 − u − v, u, v).
    pub fn point(&self, u: f32, v: f32) -> Vec3 {
        (1.0 - u - v) * self.v[0] + u * self.v[1] + v * self.v[2]
    }

    pub fn is_finite(&self) -> bool {
        self.v.iter().all(|p| p.is_finite())
    }
}
