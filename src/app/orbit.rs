//! The orbit camera of the viewport: turn around a target (left drag), move the target in
//! the view plane (right or middle drag), and move closer or further (wheel).

use crate::geometry::Aabb;
use crate::scene::Camera;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub target: Vec3,
    /// Angle around +Y, radians.
    pub yaw: f32,
    /// Angle above the horizontal, radians, kept inside (−89°, 89°).
    pub pitch: f32,
    pub distance: f32,
    pub fov_y_deg: f32,
}

const PITCH_LIMIT: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl Orbit {
    pub fn from_camera(c: &Camera) -> Self {
        let offset = c.eye - c.look_at;
        let distance = offset.length().max(1e-6);
        let d = offset / distance;
        Orbit {
            target: c.look_at,
            yaw: d.x.atan2(d.z),
            pitch: d.y.clamp(-1.0, 1.0).asin().clamp(-PITCH_LIMIT, PITCH_LIMIT),
            distance,
            fov_y_deg: c.fov_y_deg,
        }
    }

    pub fn camera(&self) -> Camera {
        let dir = Vec3::new(
            self.pitch.cos() * self.yaw.sin(),
            self.pitch.sin(),
            self.pitch.cos() * self.yaw.cos(),
        );
        Camera {
            eye: self.target + dir * self.distance,
            look_at: self.target,
            up: Vec3::Y,
            fov_y_deg: self.fov_y_deg,
        }
    }

    /// Turns by a drag of (dx, dy) pixels in a viewport `height` pixels tall.
    pub fn rotate(&mut self, dx: f32, dy: f32, height: f32) {
        let speed = std::f32::consts::PI / height.max(1.0);
        self.yaw -= dx * speed;
        self.pitch = (self.pitch + dy * speed).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// The world-space length of one pixel at the target's distance.
    pub fn pixel_size(&self, height: f32) -> f32 {
        2.0 * self.distance * (self.fov_y_deg.to_radians() * 0.5).tan() / height.max(1.0)
    }

    /// Moves the target so the scene follows a drag of (dx, dy) pixels.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let (right, up, _) = self.camera().basis();
        let s = self.pixel_size(height);
        self.target += (-dx * right + dy * up) * s;
    }

    /// Wheel zoom: each step of `amount` (positive = closer) scales the distance.
    pub fn zoom(&mut self, amount: f32) {
        self.distance = (self.distance * (-amount * 0.0015).exp()).clamp(1e-4, 1e9);
    }

    /// Looks at the whole box from the current direction.
    pub fn frame_all(&mut self, bounds: &Aabb) {
        if bounds.is_empty() {
            return;
        }
        self.target = bounds.center();
        let radius = 0.5 * bounds.diagonal().max(1e-6);
        self.distance = radius / (self.fov_y_deg.to_radians() * 0.5).sin() * 1.05;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_a_camera() {
        let c = Camera::new(Vec3::new(1.0, 2.0, 5.0), Vec3::new(0.0, 1.0, 0.0));
        let back = Orbit::from_camera(&c).camera();
        assert!((back.eye - c.eye).length() < 1e-4, "{back:?}");
        assert_eq!(back.look_at, c.look_at);
    }
}
