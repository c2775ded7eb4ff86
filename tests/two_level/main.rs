//! The two-level structure against the same scene flattened into world-space triangles:
//! instances rotated, scaled unevenly, mirrored and sheared give the flattened scene's
//! closest hit (same triangle, t within the transform's rounding) and any hit, in either
//! child order, with counting on or off; scenes without instances of their own (each
//! object one instance) answer bit for bit like brute force; degenerate inputs build.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::build::{DEFAULT_REBRAID, MAX_REBRAID};
use bvhlab::accel::bvh::{Strategy, Subtree};
use bvhlab::accel::structure::{self, AccelKind, Structure, StructureParams};
use bvhlab::accel::two_level::{LeafReference, Reference, TwoLevel};
use bvhlab::accel::{Accel, BruteForce, Counters, NoStats, TraversalOrder};
use bvhlab::geometry::{Ray, Triangle, Watertight};
use bvhlab::scene::{Instance, Instancing, Mesh, Scene, instance};
use common::Rng;
use common::instanced::compare;

/// The extent of the test scenes, the distance scale of their rounding.
const EXTENT: f32 = 20.0;
use glam::{Affine3A, Quat, Vec3};

fn two_level_params(order: TraversalOrder) -> StructureParams {
    StructureParams {
        order,
        ..StructureParams::of_kind(AccelKind::TwoLevel)
    }
}

/// Re-braiding off, at its default budget and at its largest.
const BUDGETS: [f32; 3] = [0.0, DEFAULT_REBRAID, MAX_REBRAID];

fn rebraided(order: TraversalOrder, rebraid: f32) -> StructureParams {
    let mut p = two_level_params(order);
    p.bvh.rebraid = rebraid;
    p
}

/// Both levels built as the LBVH's wide trees straight from the Morton order.
fn direct_wide(mut p: StructureParams) -> StructureParams {
    p.bvh.strategy = Strategy::Lbvh;
    p.bvh.direct_wide = true;
    p
}

/// A closed mesh: the built-in sphere, centred at the origin with radius 1.
fn sphere() -> Vec<Triangle> {
    let s = Scene::load("sphere:400").unwrap();
    let c = s.bounds().center();
    let r = s.bounds().extent().x / 2.0;
    s.triangles
        .iter()
        .map(|t| Triangle::new((t.v[0] - c) / r, (t.v[1] - c) / r, (t.v[2] - c) / r))
        .collect()
}

/// A random rotation, a scale of up to 4:1 between axes, and a translation in a 20-unit
/// cube; every fifth transform is a mirror, every seventh has a shear.
fn random_transform(rng: &mut Rng, k: usize) -> Affine3A {
    let axis = rng.unit_vector();
    let rotation = Quat::from_axis_angle(axis, rng.range(0.0, std::f32::consts::TAU));
    let mut scale = Vec3::new(
        rng.range(0.5, 2.0),
        rng.range(0.5, 2.0),
        rng.range(0.5, 2.0),
    );
    if k.is_multiple_of(5) {
        scale.x = -scale.x;
    }
    let translation = Vec3::new(
        rng.range(-10.0, 10.0),
        rng.range(-10.0, 10.0),
        rng.range(-10.0, 10.0),
    );
    let mut m = Affine3A::from_scale_rotation_translation(scale, rotation, translation);
    if k.is_multiple_of(7) {
        m.matrix3.y_axis += m.matrix3.x_axis * 0.5;
    }
    m
}

/// Three unique meshes (a random soup, a sphere, an empty mesh) placed by `count`
/// instances, one in ten of the empty mesh.
fn instanced_scene(count: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene::new("instanced");
    let soup: Vec<Triangle> = common::soup(200, seed)
        .iter()
        .map(|t| Triangle::new(t.v[0] * 2.0, t.v[1] * 2.0, t.v[2] * 2.0))
        .collect();
    scene.meshes = vec![
        Mesh {
            name: "soup".into(),
            triangles: soup,
        },
        Mesh {
            name: "sphere".into(),
            triangles: sphere(),
        },
        Mesh {
            name: "nothing".into(),
            triangles: Vec::new(),
        },
    ];
    for k in 0..count {
        let mesh = if k % 10 == 9 { 2 } else { k % 2 };
        let instance = Instance::new(mesh, random_transform(&mut rng, k)).unwrap();
        scene.push_instance(format!("instance {k}"), Vec3::ONE, instance);
    }
    scene
}

/// Rays from around the scene at random points of random triangles, so most rays hit.
fn rays_at_triangles(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed ^ 0x7a11);
    let b = scene.bounds();
    (0..n)
        .map(|_| {
            let t = &scene.triangles[rng.below(scene.triangles.len())];
            let (u, v) = (rng.f32(), rng.f32());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let target = t.point(u, v);
            let origin = b.center() + rng.unit_vector() * b.diagonal();
            Ray::new(origin, (target - origin) * rng.range(0.1, 3.0))
        })
        .collect()
}

mod hits;
mod inputs;
mod moves;
mod outline;
mod packets;
mod rebraid;
