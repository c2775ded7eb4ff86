//! A lattice scene whose cell boundaries lie on integer planes, and rays aimed exactly at
//! those planes, edges and corners: the hard cases of the spatial structures.

use super::Rng;
use bvhlab::geometry::{Ray, Triangle};
use glam::{Vec3, vec3};

/// 512 triangles with integer vertices in [0, 8]³ (the two pinning the corners first): with
/// λ = 1 a grid is 8 × 8 × 8 cells of side 1, and an octree's faces down to depth 3 lie on
/// integer planes too.
pub fn lattice_scene(seed: u64) -> Vec<Triangle> {
    let mut rng = Rng::new(seed);
    let mut tris = vec![
        Triangle::new(vec3(0., 0., 0.), vec3(1., 0., 0.), vec3(0., 1., 0.)),
        Triangle::new(vec3(8., 8., 8.), vec3(7., 8., 8.), vec3(8., 7., 8.)),
    ];
    let mut int = |lo: i32, hi: i32| lo + rng.below((hi - lo + 1) as usize) as i32;
    while tris.len() < 512 {
        let a = vec3(int(0, 8) as f32, int(0, 8) as f32, int(0, 8) as f32);
        let mut near = || {
            let p = a + vec3(int(-2, 2) as f32, int(-2, 2) as f32, int(-2, 2) as f32);
            p.clamp(Vec3::ZERO, Vec3::splat(8.))
        };
        let (b, c) = (near(), near());
        tris.push(Triangle::new(a, b, c));
    }
    tris
}

/// Rays through lattice points, cell edges and faces: integer and half-integer origins,
/// small integer directions with signed zeros (rays in face planes and along edges), and
/// rays aimed at the triangles' vertices and edge midpoints from outside.
pub fn lattice_rays(tris: &[Triangle], seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    let dirs = [-2.0f32, -1.0, -0.0, 0.0, 1.0, 2.0];
    for i in 0..3000 {
        let coord = |rng: &mut Rng| {
            let c = rng.below(11) as f32 - 1.0;
            if i % 3 == 0 && rng.f32() < 0.5 {
                c + 0.5
            } else {
                c
            }
        };
        let o = vec3(coord(&mut rng), coord(&mut rng), coord(&mut rng));
        let d = vec3(dirs[rng.below(6)], dirs[rng.below(6)], dirs[rng.below(6)]);
        if d != Vec3::ZERO {
            out.push(Ray::new(o, d));
        }
    }
    for (i, t) in tris.iter().enumerate() {
        let targets = [t.v[0], (t.v[0] + t.v[1]) * 0.5, t.v[2]];
        let target = targets[i % 3];
        for d in [
            vec3(1., 0., 0.),
            vec3(0., -1., 0.),
            vec3(-0., 0., 1.),
            vec3(1., 1., 0.),
            vec3(1., -1., 1.),
            vec3(2., 1., -1.),
        ] {
            out.push(Ray::new(target - d * 12.0, d));
            out.push(Ray::new(target + d * 12.0, -d));
        }
    }
    out
}
