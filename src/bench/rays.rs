//! The standard ray sets of a benchmark view (shared/scenes/README.md): one primary ray
//! through each pixel centre; then, for every primary hit, one shadow ray to the light
//! (any hit, tmax = distance to the light) and one cosine-distributed diffuse ray around the
//! geometric normal facing the ray (closest hit).

use crate::accel::bvh::packet::tile_pixels;
use crate::accel::{Accel, NoStats};
use crate::geometry::spawn::SurfacePoint;
use crate::geometry::{Ray, Watertight};
use crate::random::cosine_direction;
use crate::scene::{Camera, Scene};
use glam::Vec3;
use rayon::prelude::*;

#[derive(Clone, Debug, Default)]
pub struct RaySets {
    /// Row by row, as in the image.
    pub primary: Vec<Ray>,
    /// The same rays by 8 × 8 tiles of pixels, each tile one packet of coherent rays.
    pub primary_tiles: Vec<Ray>,
    pub shadow: Vec<Ray>,
    pub diffuse: Vec<Ray>,
}

impl RaySets {
    /// Generates the sets; `accel` finds the primary hits the secondary rays start from.
    pub fn standard<A: Accel>(
        accel: &A,
        scene: &Scene,
        camera: &Camera,
        light: Vec3,
        width: u32,
        height: u32,
    ) -> Self {
        let cam = camera.rays(width, height);
        let primary: Vec<Ray> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| cam.pixel_center(x, y))
            .collect();
        let secondary: Vec<(Ray, Ray)> = primary
            .par_iter()
            .enumerate()
            .filter_map(|(i, ray)| {
                let hit = accel.closest_hit::<Watertight, _>(ray, &mut NoStats)?;
                let tri = &scene.triangle(hit.triangle)?;
                let n = tri.facing_normal(ray.direction);
                let point = SurfacePoint::on_triangle(tri, hit.u, hit.v);
                let shadow = point.ray_towards(n, light);
                let dir = cosine_direction(n, i as u64);
                let diffuse = Ray::new(point.spawn_origin(n, dir), dir);
                Some((shadow, diffuse))
            })
            .collect();
        let (shadow, diffuse) = secondary.into_iter().unzip();
        let (w, h) = (width as usize, height as usize);
        let primary_tiles = (0..h)
            .step_by(8)
            .flat_map(|y0| (0..w).step_by(8).map(move |x0| (x0, y0)))
            .flat_map(|(x0, y0)| tile_pixels(x0 as u32, y0 as u32, w as u32, h as u32))
            .map(|(x, y)| primary[y as usize * w + x as usize])
            .collect();
        RaySets {
            primary_tiles,
            primary,
            shadow,
            diffuse,
        }
    }
}

impl RaySets {
    /// Every `k`-th ray of each set (whole 8 × 8 tiles for the packet set).
    pub fn every(&self, k: usize) -> RaySets {
        let k = k.max(1);
        let pick = |rays: &[Ray]| rays.iter().step_by(k).copied().collect();
        RaySets {
            primary: pick(&self.primary),
            primary_tiles: self
                .primary_tiles
                .chunks(64)
                .step_by(k)
                .flatten()
                .copied()
                .collect(),
            shadow: pick(&self.shadow),
            diffuse: pick(&self.diffuse),
        }
    }
}
