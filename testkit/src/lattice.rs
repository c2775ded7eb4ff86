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

/// Two small triangles pinning the corners of [0, 8]³, far off the contact rays' paths.
pub const PINS: [Triangle; 2] = [
    Triangle {
        v: [vec3(0., 0., 0.), vec3(0.5, 0., 0.), vec3(0., 0.5, 0.)],
    },
    Triangle {
        v: [vec3(8., 8., 8.), vec3(7.5, 8., 8.), vec3(8., 7.5, 8.)],
    },
];

/// Triangles whose only contact with the rays of `contact_rays` is a point on a cell face
/// (x = 4), an edge (x = y = 4) or a corner (4, 4, 4) of a [0, 8]³ lattice of unit cells.
pub fn contact_targets() -> [Triangle; 4] {
    [
        // In the face plane x = 4.
        Triangle::new(vec3(4., 2., 2.), vec3(4., 6., 2.), vec3(4., 2., 6.)),
        // A vertex at the corner (4, 4, 4), reaching into one cell only.
        Triangle::new(vec3(4., 4., 4.), vec3(5., 4.5, 4.5), vec3(4.5, 5., 4.5)),
        // An edge along the cell edge x = y = 4.
        Triangle::new(vec3(4., 4., 1.), vec3(4., 4., 7.), vec3(6., 5., 4.)),
        // A vertex on the face x = 4 at (4, 4.5, 4.5), reaching into x < 4.
        Triangle::new(vec3(4., 4.5, 4.5), vec3(3., 4., 4.), vec3(3., 5., 4.5)),
    ]
}

/// Rays aimed at the contact points of `contact_targets` from far away, from the aim
/// point's own cell and from the far side, along axes, diagonals and signed-zero directions.
pub fn contact_rays() -> Vec<Ray> {
    let aims = [
        vec3(4., 3., 3.),
        vec3(4., 4., 4.),
        vec3(4., 4., 2.5),
        vec3(4., 4.5, 4.5),
    ];
    let dirs = [
        vec3(1., 0., 0.),
        vec3(-1., 0., 0.),
        vec3(0., 1., 0.),
        vec3(0., 0., -1.),
        vec3(1., 1., 1.),
        vec3(-1., 1., -1.),
        vec3(1., 2., 3.),
        vec3(0., 1., 1.),
        vec3(-0., 1., -1.),
    ];
    let mut rays = Vec::new();
    for aim in aims {
        for d in dirs {
            rays.push(Ray::new(aim - d * 10.0, d));
            rays.push(Ray::new(aim - d * 0.25, d));
            rays.push(Ray::new(aim + d * 10.0, -d));
        }
    }
    rays
}
