//! The O(N) baseline: test the ray against every triangle. With the bounding-box early out,
//! a ray that misses the scene's box costs one box test instead of N triangle tests.

use super::{Accel, BestHit, Hit, Stats};
use crate::geometry::aabb::SlabRay;
use crate::geometry::{Aabb, Intersector, Ray, Triangle};

pub struct BruteForce {
    pub triangles: Vec<Triangle>,
    pub bounds: Aabb,
    /// Test the scene's bounding box first.
    pub early_out: bool,
}

impl BruteForce {
    pub fn new(triangles: &[Triangle], early_out: bool) -> Self {
        BruteForce {
            triangles: triangles.to_vec(),
            bounds: triangles
                .iter()
                .fold(Aabb::EMPTY, |b, t| b.union(t.bounds())),
            early_out,
        }
    }

    fn misses_box<S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        if !self.early_out {
            return false;
        }
        stats.box_tests(1);
        self.bounds
            .slab_test(&SlabRay::new(ray), ray.tmin, ray.tmax)
            == f32::INFINITY
    }
}

impl Accel for BruteForce {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        stats.node_visit();
        if self.misses_box(ray, stats) {
            return None;
        }
        let data = I::prepare(ray);
        let mut best = BestHit::new(ray);
        for (i, tri) in self.triangles.iter().enumerate() {
            stats.triangle_test();
            if let Some(h) = I::intersect(&data, ray, tri, ray.tmin, best.limit) {
                best.offer(h, i as u32);
            }
        }
        best.hit()
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        stats.node_visit();
        if self.misses_box(ray, stats) {
            return false;
        }
        let data = I::prepare(ray);
        self.triangles.iter().any(|tri| {
            stats.triangle_test();
            I::intersect(&data, ray, tri, ray.tmin, ray.tmax).is_some()
        })
    }
}
