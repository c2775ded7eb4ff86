//! End points spread uniformly over the placed surfaces, for the EPO of two levels that
//! place too many triangles to clip one by one (`epo`). The EPO is the mean charge of an
//! end point drawn by area, so the mean over many drawn is an unbiased estimate of it, with
//! the standard error of a mean.
//!
//! Drawing by world area without listing the placed triangles: an instance's triangle of
//! object-space area vector n has world area |cof(M) n| / 2 (M its linear map), at most
//! ‖cof(M)‖ |n| / 2. So an instance is drawn by that bound times its mesh's area, a
//! triangle of its mesh by its own area, and the pair kept with probability
//! |cof(M) n| / (‖cof(M)‖ |n|): what is kept is uniform over the world's surfaces (at least
//! one draw in √3 is kept, ‖·‖ being the Frobenius norm).

use super::epo::{Above, Probe, Walk};
use crate::accel::epo::Epo;
use crate::accel::epo::end_points::{area_vector, estimate, pick, point_on, running_areas};
use crate::geometry::Aabb;
use crate::random::Rng;
use glam::DVec3;

/// Both levels' EPO estimated from `n` end points; 0 for a scene without area; `None` once
/// `abandon` says so.
pub(super) fn epo_estimate(
    walk: &Walk,
    n: u64,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<Epo> {
    let sampler = Sampler::of(walk);
    if sampler.total() <= 0.0 {
        return Some(Epo::exact(0.0));
    }
    let chunk = |above: &mut Above, rng: &mut Rng, count: u64| {
        let (mut sum, mut squares) = (0.0, 0.0);
        for _ in 0..count {
            let point = sampler.draw(walk, rng);
            walk.mark(above, point.own, point.triangle);
            let x = walk.charge(&point, above);
            sum += x;
            squares += x * x;
        }
        (sum, squares)
    };
    estimate(n, Above::default, chunk, abandon)
}

/// Draws placed triangles by world area (see the module).
struct Sampler {
    /// Running sums of each instance's bound times its mesh's area.
    instances: Vec<f64>,
    /// Per instance, ‖cof(M)‖.
    bound: Vec<f64>,
    /// Per mesh, running sums of its triangles' |n| (twice their areas).
    meshes: Vec<Vec<f64>>,
}

impl Sampler {
    fn of(walk: &Walk) -> Sampler {
        let meshes: Vec<Vec<f64>> = (0..walk.tl.blases.len())
            .map(|m| {
                let tris = walk.meshes.get(m).copied().unwrap_or_default();
                running_areas(tris.iter().map(|t| area_vector(t).length()))
            })
            .collect();
        let bound: Vec<f64> = (0..walk.tl.instances.len())
            .map(|i| {
                let c = walk.cofactor(i);
                (c.x_axis.length_squared() + c.y_axis.length_squared() + c.z_axis.length_squared())
                    .sqrt()
            })
            .collect();
        let mut run = 0.0;
        let instances = walk
            .tl
            .instances
            .iter()
            .zip(&bound)
            .map(|(inst, b)| {
                run += b * meshes.get(inst.mesh).and_then(|m| m.last()).unwrap_or(&0.0);
                run
            })
            .collect();
        Sampler {
            instances,
            bound,
            meshes,
        }
    }

    fn total(&self) -> f64 {
        self.instances.last().copied().unwrap_or(0.0)
    }

    /// A point uniform over the placed surfaces.
    fn draw(&self, walk: &Walk, rng: &mut Rng) -> EndPoint {
        loop {
            let i = pick(&self.instances, rng.unit());
            let mesh = walk.tl.instances[i].mesh;
            let t = pick(&self.meshes[mesh], rng.unit());
            let tri = &walk.meshes[mesh][t];
            let n = area_vector(tri);
            let kept = (walk.cofactor(i) * n).length() / (self.bound[i] * n.length());
            if rng.unit() >= kept {
                continue;
            }
            let q = point_on(tri, rng);
            return EndPoint {
                at: walk.to_world[i].transform_point3(q),
                world: walk.to_world[i].transform_point3(q),
                own: i,
                in_own: q,
                triangle: t,
            };
        }
    }
}

/// An end point on triangle `triangle` of instance `own`, where the walk carries it.
#[derive(Clone, Copy)]
struct EndPoint {
    /// In the space of the level being walked.
    at: DVec3,
    world: DVec3,
    own: usize,
    /// In its own instance's space, as drawn (not carried there and back).
    in_own: DVec3,
    triangle: usize,
}

impl Probe for EndPoint {
    fn within(&self, b: &Aabb) -> Option<EndPoint> {
        let inside = self.at.cmpge(b.min.as_dvec3()).all() && self.at.cmple(b.max.as_dvec3()).all();
        inside.then_some(*self)
    }

    fn weight(&self) -> f64 {
        1.0
    }

    fn carried_to(&self, walk: &Walk, j: usize) -> EndPoint {
        let at = match j == self.own {
            true => self.in_own,
            false => walk.to_object(j).transform_point3(self.world),
        };
        EndPoint { at, ..*self }
    }
}
