//! Watertightness through the two levels: each closed mesh becomes one BLAS, placed as
//! instances that rotate it, scale it unevenly, mirror it and move it. The must-hit rays of
//! `leaks` are aimed in the mesh's own space exactly at its vertices and edge points, then
//! carried into the world by each instance's transform (in f64, rounded once), so in the
//! world they pass through the placed vertices and edges up to f32 rounding. A ray that
//! finds nothing through the two levels is a leak: the TLAS box missed the instance, the
//! ray's trip into object space went wrong, or the BLAS lost it. The flattened world
//! triangles, traced by brute force, confirm every ray is a hit and are the reference the
//! closest hits are compared with.

use super::leaks::{Leaks, RayMaker, count_leaks};
use super::meshes::{ClosedMesh, PlacedMesh, Placement};
use crate::accel::structure::{self, Structure};
use crate::accel::{Accel, BruteForce, Hit, NoStats, StructureError, StructureParams};
use crate::geometry::{Intersector, Ray, ReferenceF64, Triangle};
use crate::scene::{Instance, Instancing, instance};
use glam::{Affine3A, DVec3, Quat, Vec3};
use rayon::prelude::*;
use std::borrow::Cow;

/// One placement of the mesh: what it does, and the transform (object → world).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstancePlacement {
    pub label: &'static str,
    pub transform: Affine3A,
}

/// The placements of the issue: rotations about skew axes, non-uniform scales from 10^-2 to
/// 10^3, mirrors (a negative determinant turns the triangles' winding around), and moves
/// up to 10^5 away, at most 10^3 times the placed mesh's size, so the rounding of the
/// transform stays well inside the meshes' robust interior.
pub fn instance_placements() -> Vec<InstancePlacement> {
    let place = |label, scale: Vec3, axis: Vec3, degrees: f32, at: Vec3| InstancePlacement {
        label,
        transform: Affine3A::from_scale_rotation_translation(
            scale,
            Quat::from_axis_angle(axis.normalize(), degrees.to_radians()),
            at,
        ),
    };
    vec![
        place(
            "rotated 30° about (1,1,1), scaled (1, 2, 0.5)",
            Vec3::new(1.0, 2.0, 0.5),
            Vec3::ONE,
            30.0,
            Vec3::new(3.0, -2.0, 1.0),
        ),
        place(
            "mirrored in x, rotated 50° about y, scaled 10^-2·(1, 2, 1.5)",
            Vec3::new(-0.01, 0.02, 0.015),
            Vec3::Y,
            50.0,
            Vec3::new(0.1, 0.2, -0.05),
        ),
        place(
            "rotated 75° about (0.3,-1,0.2), scaled (1000, 300, 700), at 10^4",
            Vec3::new(1000.0, 300.0, 700.0),
            Vec3::new(0.3, -1.0, 0.2),
            75.0,
            Vec3::new(1.0e4, -2.0e4, 5.0e3),
        ),
        place(
            "mirrored in z, rotated 120° about x, scaled 200, at 10^5",
            Vec3::new(200.0, 200.0, -200.0),
            Vec3::X,
            120.0,
            Vec3::new(1.0e5, 1.0e5, -1.0e5),
        ),
        place(
            "mirrored in x and y, rotated 10° about (1,2,3), scaled (3, 1, 2), at 10^3",
            Vec3::new(-3.0, -1.0, 2.0),
            Vec3::new(1.0, 2.0, 3.0),
            10.0,
            Vec3::new(-1.0e3, 2.0e3, 1.5e3),
        ),
    ]
}

/// One closed mesh placed by every instance placement, with its two-level structure, the
/// flattened triangles' brute force and the rays (`rays_per_instance` at each instance).
pub struct InstancedCase {
    pub mesh: &'static str,
    pub placements: Vec<InstancePlacement>,
    pub two_level: Structure,
    pub flattened: Vec<Triangle>,
    pub brute: BruteForce,
    pub rays: Vec<Ray>,
}

impl InstancedCase {
    /// The mesh at scale 1 about the origin (snapped to its grid, so the object-space rays
    /// are exact) is the BLAS; `params` build the structure (its kind is ignored: the case
    /// is about the two levels).
    pub fn new(
        mesh: &ClosedMesh,
        rays_per_instance: usize,
        seed: u64,
        params: &StructureParams,
    ) -> Result<Self, StructureError> {
        let object = PlacedMesh::new(
            mesh,
            Placement {
                scale: 1.0,
                offset: DVec3::ZERO,
            },
        );
        // Every placement is invertible; one that were not would be left out.
        let (placements, instances): (Vec<InstancePlacement>, Vec<Instance>) =
            instance_placements()
                .into_iter()
                .filter_map(|p| Some((p, Instance::new(0, p.transform).ok()?)))
                .unzip();
        let scene = Instancing {
            meshes: vec![object.triangles.as_slice()],
            instances: Cow::Borrowed(&instances),
        };
        let two_level = structure::build_two_level(&scene, params, &Default::default())?;
        let meshes = [instance::Mesh {
            name: mesh.name.into(),
            triangles: object.triangles.clone(),
        }];
        let flattened = instance::flatten(&meshes, &instances);
        let brute = BruteForce::new(&flattened, true);
        let maker = RayMaker::new(&object);
        let per_instance: Vec<Vec<Ray>> = instances
            .iter()
            .enumerate()
            .map(|(i, inst)| {
                let rays = maker.rays(rays_per_instance, seed ^ (i as u64) << 40);
                rays.iter().map(|r| to_world(inst, r)).collect()
            })
            .collect();
        // Interleaved, so that any first part of the rays visits every instance.
        let longest = per_instance.iter().map(Vec::len).max().unwrap_or(0);
        let rays = (0..longest)
            .flat_map(|k| per_instance.iter().filter_map(move |r| r.get(k).copied()))
            .collect();
        Ok(InstancedCase {
            mesh: mesh.name,
            placements,
            two_level: two_level.structure,
            flattened,
            brute,
            rays,
        })
    }

    /// Leaks through the two levels (closest and any hit) and, for the first `brute_rays`,
    /// by brute force over the flattened triangles.
    pub fn leaks<I: Intersector>(&self, brute_rays: usize) -> Leaks {
        count_leaks::<I>(&self.two_level, &self.brute, &self.rays, brute_rays)
    }

    /// The two levels' closest hits against the flattened triangles' by brute force with
    /// the f64 reference, for the first `rays` rays (see `PlacementAgreement`).
    pub fn placement_agreement<I: Intersector>(&self, rays: usize) -> PlacementAgreement {
        let rays = &self.rays[..rays.min(self.rays.len())];
        rays.par_iter()
            .with_min_len(64)
            .map(|ray| {
                let got = self.two_level.closest_hit::<I, _>(ray, &mut NoStats);
                let reference = self.brute.closest_hit::<ReferenceF64, _>(ray, &mut NoStats);
                PlacementAgreement::of(ray, &self.flattened, got, reference)
            })
            .reduce(PlacementAgreement::default, |mut a, b| {
                a.add(&b);
                a
            })
    }

    pub fn label(&self) -> String {
        format!("{} as {} instances", self.mesh, self.placements.len())
    }
}

/// The rounding a placement may bring, relative to the magnitude of the coordinates
/// involved (about 64 units in the last place of f32): placing a vertex, and carrying a ray
/// into object space and its hit back, each round a few times.
pub const PLACEMENT_ROUNDING: f64 = 64.0 * f32::EPSILON as f64;

/// How the two levels' closest hit of a world ray compares with the flattened triangles'
/// by brute force (the f64 reference). The two levels meet the mesh in its own space, the
/// brute force the triangles placed in the world, rounded: the same surface, moved by the
/// placement's rounding. So a hit agrees when it names the same triangle, or another one
/// through the same point (the ray crosses a shared edge or vertex, and rounding chose the
/// side); it is a mismatch when its point lies off the triangle it names, or away from the
/// reference's point, by more than `PLACEMENT_ROUNDING` of the coordinates' magnitude.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlacementAgreement {
    pub rays: u64,
    pub same_triangle: u64,
    pub shared_point: u64,
    /// One of the two found a hit and the other did not (leaks are counted apart).
    pub missing: u64,
    pub mismatches: u64,
    /// The largest distance of a hit point from its triangle or from the reference's
    /// point, in units of the rounding allowed.
    pub max_error: f64,
}

impl PlacementAgreement {
    fn of(ray: &Ray, flattened: &[Triangle], got: Option<Hit>, reference: Option<Hit>) -> Self {
        let mut a = PlacementAgreement {
            rays: 1,
            ..Default::default()
        };
        let (g, r) = match (got, reference) {
            (None, None) => {
                a.same_triangle = 1;
                return a;
            }
            (Some(g), Some(r)) => (g, r),
            _ => {
                a.missing = 1;
                return a;
            }
        };
        let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
        let p_got = o + d * g.t as f64;
        let p_ref = o + d * r.t as f64;
        let magnitude = [o, p_ref, p_got]
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
        let allowed = PLACEMENT_ROUNDING * magnitude.max(f64::MIN_POSITIVE);
        let off_triangle = flattened
            .get(g.triangle as usize)
            .map_or(f64::INFINITY, |t| distance_to_triangle(p_got, t));
        let error = off_triangle.max(p_got.distance(p_ref)) / allowed;
        a.max_error = error;
        if error > 1.0 {
            a.mismatches = 1;
        } else if g.triangle == r.triangle {
            a.same_triangle = 1;
        } else {
            a.shared_point = 1;
        }
        a
    }

    pub fn add(&mut self, o: &PlacementAgreement) {
        self.rays += o.rays;
        self.same_triangle += o.same_triangle;
        self.shared_point += o.shared_point;
        self.missing += o.missing;
        self.mismatches += o.mismatches;
        self.max_error = self.max_error.max(o.max_error);
    }
}

/// The distance from `p` to triangle `t` (its closest point: inside, on an edge or at a
/// corner), in f64.
fn distance_to_triangle(p: DVec3, t: &Triangle) -> f64 {
    let [a, b, c] = t.v.map(|v| v.as_dvec3());
    let on_segment = |u: DVec3, v: DVec3| {
        let e = v - u;
        let s = ((p - u).dot(e) / e.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
        p.distance(u + e * s)
    };
    let edges = on_segment(a, b).min(on_segment(b, c)).min(on_segment(c, a));
    let n = (b - a).cross(c - a);
    if n.length_squared() == 0.0 {
        return edges;
    }
    // The foot of the perpendicular, if it falls inside.
    let foot = p - n * ((p - a).dot(n) / n.length_squared());
    let inside = [(a, b), (b, c), (c, a)]
        .iter()
        .map(|&(u, v)| (v - u).cross(foot - u).dot(n))
        .all(|s| s >= 0.0);
    if inside { p.distance(foot) } else { edges }
}

/// An object-space ray carried into the world by `instance`: its origin and direction
/// transformed in f64 and rounded once to f32.
fn to_world(instance: &Instance, ray: &Ray) -> Ray {
    let t = &instance.transform;
    let m = [t.matrix3.x_axis, t.matrix3.y_axis, t.matrix3.z_axis].map(|c| c.as_dvec3());
    let linear = |v: Vec3| m[0] * v.x as f64 + m[1] * v.y as f64 + m[2] * v.z as f64;
    let origin = linear(ray.origin) + t.translation.as_dvec3();
    Ray::new(origin.as_vec3(), linear(ray.direction).as_vec3())
}
