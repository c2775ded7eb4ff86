//! The O(N) baseline: test the ray against every triangle. With the bounding-box early out
//! (the lecture's `if (!p.bbox.intersect(r)) continue;`), a ray first tests the scene's box
//! and then each triangle's own box, and tests only the triangles whose boxes it pierces:
//! N box tests, but far fewer triangle tests.

use super::bvh::traverse::T_SCALE;
use super::outline::{Outline, OutlineNode};
use super::{Accel, BestHit, Hit, Stats};
use crate::accel::replay::{Level, Step, Visited, entered};
use crate::accel::stats::{count_locally, record};
use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::{Aabb, Intersector, Ray, Triangle};

pub struct BruteForce {
    pub triangles: Vec<Triangle>,
    pub bounds: Aabb,
    /// Each triangle's box as its two corners, when the early out is on.
    boxes: Vec<[glam::Vec3; 2]>,
    early_out: bool,
}

impl BruteForce {
    pub fn new(triangles: &[Triangle], early_out: bool) -> Self {
        let boxes = if early_out {
            triangles
                .iter()
                .map(|t| {
                    let b = t.bounds();
                    [b.min, b.max]
                })
                .collect()
        } else {
            Vec::new()
        };
        BruteForce {
            triangles: triangles.to_vec(),
            bounds: triangles
                .iter()
                .fold(Aabb::EMPTY, |b, t| b.union(t.bounds())),
            boxes,
            early_out,
        }
    }

    /// Whether each triangle's box is tested before the triangle.
    pub fn early_out(&self) -> bool {
        self.early_out
    }

    pub fn bytes(&self) -> usize {
        self.triangles.len() * std::mem::size_of::<Triangle>()
            + self.boxes.len() * std::mem::size_of::<[glam::Vec3; 2]>()
    }

    /// The scene's box at depth 0 and, with the early out, every triangle's box below it.
    pub fn outline(&self) -> Outline {
        let n = self.triangles.len() as u32;
        let mut nodes = vec![OutlineNode {
            bounds: self.bounds,
            depth: 0,
            parent: u32::MAX,
            first_child: 1,
            child_count: if self.early_out() { n } else { 0 },
            refs: (0, n),
            plane: None,
        }];
        nodes.extend(self.boxes.iter().enumerate().map(|(i, b)| OutlineNode {
            bounds: Aabb::new(b[0], b[1]),
            depth: 1,
            parent: 0,
            first_child: 0,
            child_count: 0,
            refs: (i as u32, 1),
            plane: None,
        }));
        Outline {
            nodes,
            refs: (0..n).collect(),
        }
    }

    /// The one traversal step: the whole scene.
    fn visit_step(&self) -> Step {
        Step::visit(0, Visited::Scene, Level::Single, self.bounds)
    }

    /// With the early out, the scene's box first: a ray that misses it costs one box test.
    #[inline(always)]
    fn misses_scene<S: Stats>(&self, slab: &SlabRay, ray: &Ray, stats: &mut S) -> bool {
        if !self.early_out() {
            return false;
        }
        stats.box_tests(1);
        let entry = self.bounds.slab_test(slab, ray.tmin, ray.tmax);
        record(stats, || Step::Bounds {
            entry: entered(entry),
        });
        entry == f32::INFINITY
    }

    /// With the early out, whether the ray pierces triangle `i`'s box within (tmin, tmax).
    #[inline(always)]
    fn pierces<S: Stats>(&self, i: usize, slab: &SlabRay, ray: &Ray, stats: &mut S) -> bool {
        if !self.early_out() {
            return true;
        }
        stats.box_tests(1);
        let pierced =
            slab_entry(&self.boxes[i], slab, ray.tmin, ray.tmax * T_SCALE) != f32::INFINITY;
        record(stats, || Step::TriangleBox {
            triangle: i as u64,
            pierced,
        });
        pierced
    }

    fn closest_counted<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        stats.node_visit();
        record(stats, || self.visit_step());
        let slab = SlabRay::new(ray);
        if self.misses_scene(&slab, ray, stats) {
            return None;
        }
        let data = I::prepare(ray);
        let mut best = BestHit::new(ray);
        for (i, tri) in self.triangles.iter().enumerate() {
            if !self.pierces(i, &slab, ray, stats) {
                continue;
            }
            stats.triangle_test();
            let hit = I::intersect(&data, ray, tri, ray.tmin, best.limit);
            record(stats, || Step::Triangle {
                triangle: i as u64,
                t: hit.map(|h| h.t),
            });
            if let Some(h) = hit {
                best.offer(h, i as u64);
            }
        }
        best.hit()
    }

    fn occluded_counted<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        stats.node_visit();
        record(stats, || self.visit_step());
        let slab = SlabRay::new(ray);
        if self.misses_scene(&slab, ray, stats) {
            return false;
        }
        let data = I::prepare(ray);
        (0..self.triangles.len()).any(|i| {
            if !self.pierces(i, &slab, ray, stats) {
                return false;
            }
            stats.triangle_test();
            let hit = I::intersect(&data, ray, &self.triangles[i], ray.tmin, ray.tmax);
            record(stats, || Step::Triangle {
                triangle: i as u64,
                t: hit.map(|h| h.t),
            });
            hit.is_some()
        })
    }
}

impl Accel for BruteForce {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        count_locally(stats, |local| self.closest_counted::<I, S>(ray, local))
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        count_locally(stats, |local| self.occluded_counted::<I, S>(ray, local))
    }
}
