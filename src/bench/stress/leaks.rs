//! Watertightness: rays aimed exactly at a closed mesh's vertices and shared-edge points, from
//! inside and outside, each passing through a robustly interior point, so it must hit. A ray
//! with no hit is a leak, whether the triangle test or the BVH's box test lost it.

use super::meshes::{ClosedMesh, F32_INTS, PlacedMesh, Placement, exact_in_f32};
use crate::accel::structure::{self, Structure};
use crate::accel::{Accel, BruteForce, NoStats, StructureParams};
use crate::geometry::{Intersector, Ray};
use crate::random::Rng;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// How a must-hit ray was aimed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// From an interior point exactly through a vertex.
    VertexFromInside,
    /// From outside exactly through a vertex, towards the interior.
    VertexFromOutside,
    /// From an interior point exactly through a point of an edge.
    EdgeFromInside,
    /// From outside exactly through a point of an edge, towards the interior.
    EdgeFromOutside,
    /// Axis-parallel (two ±0 direction components) through a vertex, from inside.
    AxisFromInside,
    /// Axis-parallel through a vertex from outside, into the mesh.
    AxisFromOutside,
    /// From an interior point in a random direction.
    RandomFromInside,
}

impl Family {
    pub const ALL: [Family; 7] = [
        Family::VertexFromInside,
        Family::VertexFromOutside,
        Family::EdgeFromInside,
        Family::EdgeFromOutside,
        Family::AxisFromInside,
        Family::AxisFromOutside,
        Family::RandomFromInside,
    ];
}

/// Points of an edge a–b aimed at: (w_a·a + w_b·b) / (w_a + w_b).
const EDGE_WEIGHTS: [(i64, i64); 5] = [(1, 1), (1, 2), (2, 1), (1, 3), (3, 1)];

/// The must-hit rays of one placed mesh.
pub struct RayMaker<'a> {
    mesh: &'a PlacedMesh,
    edges: Vec<[u32; 2]>,
}

impl<'a> RayMaker<'a> {
    pub fn new(mesh: &'a PlacedMesh) -> Self {
        RayMaker {
            edges: mesh.mesh.edges(),
            mesh,
        }
    }

    /// A grid point well inside the mesh near world point `p`, with some random jitter.
    fn interior_near(&self, p: DVec3, rng: &mut Rng) -> [i64; 3] {
        let m = self.mesh;
        let core = m.mesh.core_near(m.to_model(p));
        let jitter = rng.in_ball() * m.mesh.core_radius() * 0.9;
        m.snap(m.placement.apply(core + jitter))
    }

    /// The core point (model centre of the solid part) near `p`, in grid units.
    fn core_grid(&self, p: DVec3) -> DVec3 {
        let m = self.mesh;
        m.to_grid(m.placement.apply(m.mesh.core_near(m.to_model(p))))
    }

    /// A ray from grid point `o` along integer direction `d`, or `None` if it is not exact in
    /// f32 (it then would not pass exactly through its target). Zero components get a random
    /// sign: +0.0 and −0.0 pick opposite slab planes and must both work.
    fn exact_ray(&self, o: [i64; 3], d: [i64; 3], rng: &mut Rng) -> Option<Ray> {
        if d == [0; 3] || !o.iter().chain(&d).all(|&g| exact_in_f32(g)) {
            return None;
        }
        let origin = self.mesh.point(o);
        let g = self.mesh.grid;
        let mut direction = Vec3::ZERO;
        for a in 0..3 {
            direction[a] = if d[a] == 0 {
                rng.signed_zero()
            } else {
                (d[a] as f64 * g[a]) as f32
            };
        }
        Some(Ray::new(origin, direction))
    }

    /// Ray `index` of the sequence seeded by `seed`: the families take turns, vertices and
    /// edges are visited in turn. `None` when the attempt is not a certain hit: not exact in
    /// f32, or (on coarse grids) not passing robustly through the interior.
    pub fn ray(&self, index: u64, seed: u64) -> Option<(Family, Ray)> {
        let mut rng = Rng::for_case(seed, index);
        let family = Family::ALL[(index % Family::ALL.len() as u64) as usize];
        let m = self.mesh;
        let turn = (index / Family::ALL.len() as u64) as usize;
        let vertex = m.ints[turn % m.ints.len()];
        let v_world = m.world_of(vertex);
        let v_grid = to_f64(vertex);
        // How far out an outside origin starts, as a multiple of its distance to the core.
        let alpha = 0.1 + 0.9 * rng.unit();
        let (ray, core) = match family {
            Family::VertexFromInside | Family::RandomFromInside => {
                let o = self.interior_near(v_world, &mut rng);
                let ray = if family == Family::VertexFromInside {
                    self.exact_ray(o, sub(vertex, o), &mut rng)?
                } else {
                    Ray::new(m.point(o), rng.in_ball().as_vec3())
                };
                (ray, None)
            }
            Family::VertexFromOutside => {
                let core = self.core_grid(v_world);
                let o = round(v_grid + (v_grid - core) * alpha);
                (self.exact_ray(o, sub(vertex, o), &mut rng)?, Some(core))
            }
            Family::EdgeFromInside | Family::EdgeFromOutside => {
                let [a, b] = self.edges[turn % self.edges.len()];
                let (ka, kb) = (m.ints[a as usize], m.ints[b as usize]);
                let (wa, wb) = EDGE_WEIGHTS[rng.below(EDGE_WEIGHTS.len() as u64) as usize];
                let w = (wa + wb) as f64;
                let p_grid = (to_f64(ka) * wa as f64 + to_f64(kb) * wb as f64) / w;
                let p_world = p_grid * m.grid;
                let (o, core) = if family == Family::EdgeFromInside {
                    (self.interior_near(p_world, &mut rng), None)
                } else {
                    let core = self.core_grid(p_world);
                    (round(p_grid + (p_grid - core) * alpha), Some(core))
                };
                // The line o + t·d passes through the edge point exactly at t = 1/(wa + wb).
                let d = std::array::from_fn(|i| wa * (ka[i] - o[i]) + wb * (kb[i] - o[i]));
                (self.exact_ray(o, d, &mut rng)?, core)
            }
            Family::AxisFromInside | Family::AxisFromOutside => {
                let core = self.core_grid(v_world);
                // The axis along which the vertex lies farthest from the core, in world
                // units: moving along it from the vertex heads into the solid.
                let to_core = (core - v_grid) * m.grid;
                let axis = (0..3)
                    .max_by(|&i, &j| to_core[i].abs().total_cmp(&to_core[j].abs()))
                    .unwrap_or(0);
                let step =
                    ((0.5 * (core[axis] - v_grid[axis])).round() as i64).clamp(-F32_INTS, F32_INTS);
                let mut o = vertex;
                if family == Family::AxisFromInside {
                    o[axis] += step;
                } else {
                    o[axis] -= step;
                }
                let ray = self.exact_ray(o, sub(vertex, o), &mut rng)?;
                (ray, (family == Family::AxisFromOutside).then_some(core))
            }
        };
        // The certainty check: the ray starts robustly inside, or after the aimed-at surface
        // point it comes closest to the core at a point robustly inside.
        let witness = match core {
            None => ray.origin.as_dvec3(),
            Some(core_grid) => {
                let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
                let c = core_grid * m.grid;
                let t = (c - o).dot(d) / d.length_squared();
                if t <= 0.0 {
                    return None;
                }
                o + d * t
            }
        };
        m.robustly_inside(witness).then_some((family, ray))
    }

    /// `n` must-hit rays (attempts that are not exact in f32 are skipped, which is rare).
    pub fn rays(&self, n: usize, seed: u64) -> Vec<Ray> {
        self.rays_by_family(n, seed).map(|(_, r)| r).collect()
    }

    /// The rays of `rays`, in the same order, each with how it was aimed.
    pub fn rays_by_family(&self, n: usize, seed: u64) -> impl Iterator<Item = (Family, Ray)> {
        (0..16 * n as u64 + 64)
            .filter_map(move |i| self.ray(i, seed))
            .take(n)
    }
}

fn sub(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn to_f64(a: [i64; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

fn round(p: DVec3) -> [i64; 3] {
    [p.x.round() as i64, p.y.round() as i64, p.z.round() as i64]
}

/// Leaks of one intersector on one set of must-hit rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Leaks {
    pub rays: u64,
    /// Closest-hit queries through the structure under test that returned no hit.
    pub bvh_closest: u64,
    /// Any-hit queries through the structure under test that returned "not occluded".
    pub bvh_any: u64,
    /// Rays also traced by brute force (with the bounding-box early out), and its misses.
    pub brute_rays: u64,
    pub brute_closest: u64,
}

impl Leaks {
    pub fn total(&self) -> u64 {
        self.bvh_closest + self.bvh_any + self.brute_closest
    }

    pub fn add(&mut self, o: &Leaks) {
        self.rays += o.rays;
        self.bvh_closest += o.bvh_closest;
        self.bvh_any += o.bvh_any;
        self.brute_rays += o.brute_rays;
        self.brute_closest += o.brute_closest;
    }
}

/// Traces `rays` through `bvh`, the structure under test (closest and any hit), and the
/// first `brute_rays` of them by brute force, counting the rays that found nothing.
pub fn count_leaks<I: Intersector>(
    bvh: &Structure,
    brute: &BruteForce,
    rays: &[Ray],
    brute_rays: usize,
) -> Leaks {
    let brute_rays = brute_rays.min(rays.len());
    let sum = |a: (u64, u64, u64), b: (u64, u64, u64)| (a.0 + b.0, a.1 + b.1, a.2 + b.2);
    let (closest, any, brute_miss) = rays
        .par_iter()
        .enumerate()
        .with_min_len(256)
        .map(|(i, r)| {
            let closest = bvh.closest_hit::<I, _>(r, &mut NoStats).is_none();
            let any = !bvh.any_hit::<I, _>(r, &mut NoStats);
            let brute = i < brute_rays && brute.closest_hit::<I, _>(r, &mut NoStats).is_none();
            (u64::from(closest), u64::from(any), u64::from(brute))
        })
        .reduce(|| (0, 0, 0), sum);
    Leaks {
        rays: rays.len() as u64,
        bvh_closest: closest,
        bvh_any: any,
        brute_rays: brute_rays as u64,
        brute_closest: brute_miss,
    }
}

/// One mesh in one placement, with its structures and rays.
pub struct LeakCase {
    pub placed: PlacedMesh,
    /// The structure under test (a BVH unless the suite is told otherwise).
    pub bvh: Structure,
    pub brute: BruteForce,
    pub rays: Vec<Ray>,
    /// How each ray of `rays` was aimed.
    pub families: Vec<Family>,
}

impl LeakCase {
    /// `None` when the placement is too coarse for the mesh to keep an interior.
    pub fn new(
        mesh: &ClosedMesh,
        placement: Placement,
        rays: usize,
        seed: u64,
        params: &StructureParams,
    ) -> Option<Self> {
        let placed = PlacedMesh::new(mesh, placement);
        if !placed.resolvable() {
            return None;
        }
        let bvh = structure::build(&placed.triangles, params, &Default::default())
            .ok()?
            .structure;
        let brute = BruteForce::new(&placed.triangles, true);
        let (families, rays) = RayMaker::new(&placed).rays_by_family(rays, seed).unzip();
        Some(LeakCase {
            placed,
            bvh,
            brute,
            rays,
            families,
        })
    }

    pub fn label(&self) -> String {
        format!(
            "{} ({})",
            self.placed.mesh.name,
            self.placed.placement.label()
        )
    }
}

/// The placements of the issue: translated by 10^k (k = 0..=6) at scale 1, and scaled by
/// 10^s (s = -3..=3) at the origin; with `grid`, every combination of the two as well
/// (those too coarse to resolve the mesh are dropped by `LeakCase::new`).
pub fn placements(grid: bool) -> Vec<Placement> {
    // Different magnitudes and signs per axis, so each axis has its own grid spacing.
    let direction = DVec3::new(1.0, -1.0, 0.5);
    let mut out = Vec::new();
    for k in 0..=6 {
        out.push(Placement {
            scale: 1.0,
            offset: direction * 10f64.powi(k),
        });
    }
    for s in -3..=3 {
        out.push(Placement {
            scale: 10f64.powi(s),
            offset: DVec3::ZERO,
        });
    }
    if grid {
        for k in 0..=6 {
            for s in -3..=3 {
                if s != 0 {
                    out.push(Placement {
                        scale: 10f64.powi(s),
                        offset: direction * 10f64.powi(k),
                    });
                }
            }
        }
    }
    out
}
