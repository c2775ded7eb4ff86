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
    /// Where each tile of `primary_tiles` ends: a tile at the image's right or bottom edge
    /// holds fewer than 64 rays, and a packet must not take the next tile's.
    pub tile_ends: Vec<usize>,
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
        let mut primary_tiles = Vec::with_capacity(primary.len());
        let mut tile_ends = Vec::new();
        for y0 in (0..h).step_by(8) {
            for x0 in (0..w).step_by(8) {
                let tile = tile_pixels(x0 as u32, y0 as u32, w as u32, h as u32);
                primary_tiles.extend(tile.map(|(x, y)| primary[y as usize * w + x as usize]));
                tile_ends.push(primary_tiles.len());
            }
        }
        RaySets {
            primary_tiles,
            tile_ends,
            primary,
            shadow,
            diffuse,
        }
    }
}

impl RaySets {
    /// Every `k`-th ray of each set (every `k`-th whole tile for the packet set).
    pub fn every(&self, k: usize) -> RaySets {
        let k = k.max(1);
        let pick = |rays: &[Ray]| rays.iter().step_by(k).copied().collect();
        let mut primary_tiles = Vec::new();
        let mut tile_ends = Vec::new();
        for tile in self.tiles().step_by(k) {
            primary_tiles.extend_from_slice(tile);
            tile_ends.push(primary_tiles.len());
        }
        RaySets {
            primary: pick(&self.primary),
            primary_tiles,
            tile_ends,
            shadow: pick(&self.shadow),
            diffuse: pick(&self.diffuse),
        }
    }

    /// The packet set's tiles, each a slice of `primary_tiles`.
    pub fn tiles(&self) -> impl Iterator<Item = &[Ray]> {
        let starts = std::iter::once(0).chain(self.tile_ends.iter().copied());
        starts
            .zip(&self.tile_ends)
            .map(|(start, &end)| &self.primary_tiles[start..end])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::structure::{self, AccelKind, StructureParams};

    /// On an image whose sides are not multiples of 8, the edge tiles are partial: each
    /// tile holds exactly its own pixels' rays, and every k-th tile is picked whole.
    #[test]
    fn tiles_hold_their_own_pixels_and_are_picked_whole() {
        let scene = Scene::load("cornell").unwrap();
        let params = StructureParams {
            kind: AccelKind::Bvh,
            ..StructureParams::default()
        };
        let built = structure::build_scene(&scene, &params, &Default::default()).unwrap();
        let camera = Camera::new(Vec3::new(0.0, 1.0, 3.5), Vec3::new(0.0, 1.0, 0.0));
        let (w, h) = (21, 13);
        let sets = RaySets::standard(&built.structure, &scene, &camera, Vec3::Y, w, h);
        let sizes: Vec<usize> = sets.tiles().map(<[Ray]>::len).collect();
        // Tiles of 8, 8 and 5 columns by 8 and 5 rows.
        assert_eq!(sizes, [64, 64, 40, 40, 40, 25]);
        assert_eq!(sets.primary_tiles.len(), (w * h) as usize);
        // Tile 2 (columns 16..21, rows 0..8) holds exactly its pixels' rays.
        let want: Vec<_> = tile_pixels(16, 0, w, h)
            .map(|(x, y)| sets.primary[(y * w + x) as usize].direction)
            .collect();
        let got: Vec<_> = sets
            .tiles()
            .nth(2)
            .unwrap()
            .iter()
            .map(|r| r.direction)
            .collect();
        assert_eq!(got, want);
        let every = sets.every(2);
        let picked: Vec<usize> = every.tiles().map(<[Ray]>::len).collect();
        assert_eq!(picked, [64, 40, 40]);
        assert_eq!(every.primary_tiles.len(), 144);
    }
}
