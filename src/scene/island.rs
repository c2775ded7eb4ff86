//! `island`: an instanced scene in the spirit of Disney's Moana island. A heightfield terrain
//! and a few detailed unique meshes (two kinds of tree, a rock, a plant clump) scattered as
//! instances at varied scales and turns: billions of placed triangles from about a million
//! unique ones, never flattened.

use super::builtin::{Rng, quad};
use super::{Camera, Instance, Mesh, Scene};
use crate::geometry::Triangle;
use glam::{Affine3A, Quat, Vec3, vec3};
use std::f32::consts::{PI, TAU};

/// Scattered instances without a size: enough for 1.5 × 10^10 placed triangles.
pub const DEFAULT_INSTANCES: usize = 200_000;

/// The most instances `island:N` places (each costs a few hundred bytes).
pub const MAX_INSTANCES: usize = 2_000_000;

/// How finely the unique meshes are made: the full island, or a small one for tests
/// that compare with the flattened scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Detail {
    /// Terrain cells along each side (2 triangles each).
    pub terrain_cells: usize,
    /// Leaf cards (2 triangles each) per tree.
    pub leaves: usize,
    /// Rings of the rock's sphere (twice as many segments around).
    pub rock_rings: usize,
    /// Blades (2 triangles each) per plant clump.
    pub blades: usize,
}

impl Detail {
    /// About a million unique triangles.
    pub const FULL: Detail = Detail {
        terrain_cells: 384,
        leaves: 60_000,
        rock_rings: 128,
        blades: 30_000,
    };
    /// A few thousand unique triangles.
    pub const SMALL: Detail = Detail {
        terrain_cells: 24,
        leaves: 200,
        rock_rings: 8,
        blades: 100,
    };
}

/// The island's radius (metres) and the highest point of its terrain.
const RADIUS: f32 = 1000.0;
const PEAK: f32 = 160.0;
/// The terrain's square side, a little beyond the radius so the shore slopes under the sea.
const SIDE: f32 = 2.4 * RADIUS;

const TERRAIN_COLOR: Vec3 = vec3(0.45, 0.4, 0.28);
const SEA_COLOR: Vec3 = vec3(0.1, 0.3, 0.45);

/// The kinds of scattered mesh: name, colour, share of the instances, scale range.
const KINDS: [(&str, Vec3, f32, (f32, f32)); 4] = [
    ("broadleaf tree", vec3(0.2, 0.45, 0.12), 0.25, (0.6, 1.6)),
    ("conifer", vec3(0.1, 0.32, 0.15), 0.2, (0.6, 1.8)),
    ("rock", vec3(0.5, 0.48, 0.45), 0.15, (0.4, 4.0)),
    ("plant", vec3(0.35, 0.6, 0.2), 0.4, (0.5, 2.0)),
];

/// The island with `instances` scattered meshes (plus the terrain and the sea) made at
/// `detail`. Deterministic: the same arguments give the same scene.
pub fn island(instances: usize, detail: &Detail) -> Scene {
    let terrain = Terrain::new(detail.terrain_cells);
    let mut scene = Scene::new("island");
    scene.meshes = vec![
        Mesh {
            name: "terrain".into(),
            triangles: terrain.triangles(),
        },
        Mesh {
            name: "sea".into(),
            triangles: quad(
                vec3(-SIDE, 0.0, -SIDE),
                vec3(-SIDE, 0.0, SIDE),
                vec3(SIDE, 0.0, SIDE),
                vec3(SIDE, 0.0, -SIDE),
            )
            .to_vec(),
        },
        Mesh {
            name: KINDS[0].0.into(),
            triangles: tree(detail.leaves, false),
        },
        Mesh {
            name: KINDS[1].0.into(),
            triangles: tree(detail.leaves, true),
        },
        Mesh {
            name: KINDS[2].0.into(),
            triangles: rock(detail.rock_rings),
        },
        Mesh {
            name: KINDS[3].0.into(),
            triangles: plant(detail.blades),
        },
    ];
    scene.place_instance("terrain", TERRAIN_COLOR, Instance::identity(0));
    scene.place_instance("sea", SEA_COLOR, Instance::identity(1));

    let mut rng = Rng::new(0x1514_a4d0);
    let mut placed = 0;
    while placed < instances {
        // A point of the island above the shore (rejection from the disc).
        let (r, a) = (RADIUS * 0.9 * rng.unit().sqrt(), rng.range(0.0, TAU));
        let (x, z) = (r * a.cos(), r * a.sin());
        let y = terrain.height_at(x, z);
        if y < 2.0 {
            continue;
        }
        let pick = rng.unit();
        let mut share = 0.0;
        let kind = KINDS
            .iter()
            .position(|k| {
                share += k.2;
                pick < share
            })
            .unwrap_or(KINDS.len() - 1);
        let (name, color, _, (low, high)) = KINDS[kind];
        let scale = rng.range(low, high);
        let stretch = vec3(
            rng.range(0.85, 1.15),
            rng.range(0.8, 1.25),
            rng.range(0.85, 1.15),
        );
        let turn = Quat::from_rotation_y(rng.range(0.0, TAU));
        // Rocks lie at any tilt, half sunk; plants and trees lean a little.
        let tilt = if kind == 2 { 0.6 } else { 0.08 };
        let axis = rng.range(0.0, TAU);
        let axis = vec3(axis.cos(), 0.0, axis.sin());
        let lean = Quat::from_axis_angle(axis, rng.range(0.0, tilt));
        let sink = if kind == 2 { 0.35 * scale } else { 0.05 };
        let transform = Affine3A::from_scale_rotation_translation(
            stretch * scale,
            lean * turn,
            vec3(x, y - sink, z),
        );
        // Scales and turns of finite numbers: always invertible.
        if let Ok(instance) = Instance::new(2 + kind, transform) {
            scene.place_instance(format!("{name} {placed}"), color, instance);
            placed += 1;
        }
    }
    // From above the sea off the south-west shore, over the forest to the peaks.
    let look_at = vec3(0.0, terrain.height_at(0.0, 150.0), 150.0);
    scene.view = Some(Camera::new(vec3(-380.0, 170.0, 1000.0), look_at));
    scene.light = Some(vec3(4000.0, 6000.0, 3000.0));
    scene
}

/// The terrain: heights on a square grid, an island of smooth value noise falling to the
/// sea towards its edge.
struct Terrain {
    cells: usize,
    heights: Vec<f32>,
}

impl Terrain {
    fn new(cells: usize) -> Self {
        let cells = cells.max(1);
        let n = cells + 1;
        let mut heights = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let (x, z) = Self::grid_xz(cells, i, j);
                heights.push(island_height(x, z));
            }
        }
        Terrain { cells, heights }
    }

    fn grid_xz(cells: usize, i: usize, j: usize) -> (f32, f32) {
        let step = 2.0 * SIDE / cells as f32;
        (-SIDE + i as f32 * step, -SIDE + j as f32 * step)
    }

    fn corner(&self, i: usize, j: usize) -> Vec3 {
        let (x, z) = Self::grid_xz(self.cells, i, j);
        vec3(x, self.heights[j * (self.cells + 1) + i], z)
    }

    /// Each cell as the quad's two triangles, (a, b, c) and (a, c, d), facing up.
    fn triangles(&self) -> Vec<Triangle> {
        let mut out = Vec::with_capacity(2 * self.cells * self.cells);
        for j in 0..self.cells {
            for i in 0..self.cells {
                out.extend(quad(
                    self.corner(i, j),
                    self.corner(i, j + 1),
                    self.corner(i + 1, j + 1),
                    self.corner(i + 1, j),
                ));
            }
        }
        out
    }

    /// The height of the triangulated surface at (x, z), on the triangle of its cell that
    /// holds it, so that instances stand on the ground rays see.
    fn height_at(&self, x: f32, z: f32) -> f32 {
        let step = 2.0 * SIDE / self.cells as f32;
        let fx = ((x + SIDE) / step).clamp(0.0, self.cells as f32 - 1e-3);
        let fz = ((z + SIDE) / step).clamp(0.0, self.cells as f32 - 1e-3);
        let (i, j) = (fx as usize, fz as usize);
        let (u, v) = (fx - i as f32, fz - j as f32);
        let h = |di, dj| self.corner(i + di, j + dj).y;
        // The diagonal a–c runs from (i, j) to (i + 1, j + 1).
        if v >= u {
            h(0, 0) + u * (h(1, 1) - h(0, 1)) + v * (h(0, 1) - h(0, 0))
        } else {
            h(0, 0) + u * (h(1, 0) - h(0, 0)) + v * (h(1, 1) - h(1, 0))
        }
    }
}

/// Height of the island at (x, z): noise hills under a dome that meets the sea at RADIUS.
fn island_height(x: f32, z: f32) -> f32 {
    let r = (x * x + z * z).sqrt() / RADIUS;
    let dome = 1.0 - r * r;
    let mut hills = 0.0;
    let (mut amplitude, mut frequency) = (0.5, 1.0 / 400.0);
    for octave in 0..5 {
        hills += amplitude * value_noise(x * frequency, z * frequency, octave);
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    PEAK * (dome + 0.6 * (hills - 0.45)) - 6.0
}

/// Smooth value noise in [0, 1): random values on the integer lattice, blended by
/// smoothstep.
fn value_noise(x: f32, z: f32, seed: u32) -> f32 {
    let (x0, z0) = (x.floor(), z.floor());
    let (u, v) = (x - x0, z - z0);
    let (u, v) = (u * u * (3.0 - 2.0 * u), v * v * (3.0 - 2.0 * v));
    let at = |dx: i32, dz: i32| lattice(x0 as i32 + dx, z0 as i32 + dz, seed);
    let top = at(0, 0) + u * (at(1, 0) - at(0, 0));
    let bottom = at(0, 1) + u * (at(1, 1) - at(0, 1));
    top + v * (bottom - top)
}

/// A random value in [0, 1) for a lattice point (a hash, so no table to store).
fn lattice(i: i32, j: i32, seed: u32) -> f32 {
    let mut h = (i as u32).wrapping_mul(0x8da6_b343)
        ^ (j as u32).wrapping_mul(0xd816_3841)
        ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// Half the side of a leaf card (metres): a card is a cluster of leaves, 16 cm across on a
/// broadleaf tree, 12 cm on a conifer. 60 000 of them leave a crown as opaque as a real
/// one (a ray meets a card within about 20 cm of entering it). Cards of 70 and 50 cm, as
/// the island first had, made a crown of 30 000 m² of leaves (a hundred times a real
/// tree's), each point of which lay inside the boxes of some 70 cards: a ray entering the
/// crown tested about 60 cards before its hit, and no builder can sort them apart, as the
/// cards themselves overlap, not only their boxes (measured in the README).
const BROADLEAF_CARD: f32 = 0.08;
const CONIFER_CARD: f32 = 0.06;

/// A tree about 10 m tall: a tapered trunk and `leaves` leaf cards (small quads at random
/// turns) filling its crown, a sphere for a broadleaf tree, a cone for a conifer.
fn tree(leaves: usize, conifer: bool) -> Vec<Triangle> {
    let mut rng = Rng::new(if conifer { 0xc0_41fe } else { 0xb40a_d1ea });
    let (trunk_height, trunk_radius) = if conifer { (9.0, 0.3) } else { (5.0, 0.35) };
    let mut out = trunk(trunk_height, trunk_radius, 24, 8);
    for _ in 0..leaves {
        let centre = if conifer {
            // Uniform in a cone from 2 m (radius 3 m) up to 11 m.
            let h = 1.0 - rng.unit().cbrt();
            let (r, a) = (3.0 * (1.0 - h) * rng.unit().sqrt(), rng.range(0.0, TAU));
            vec3(r * a.cos(), 2.0 + 9.0 * h, r * a.sin())
        } else {
            // Uniform in a squashed ball of radius 3.5 m around 6.5 m.
            let r = 3.5 * rng.unit().cbrt();
            rng.direction() * r * vec3(1.0, 0.8, 1.0) + vec3(0.0, 6.5, 0.0)
        };
        let size = if conifer {
            CONIFER_CARD
        } else {
            BROADLEAF_CARD
        };
        let normal = rng.direction();
        let u = normal.any_orthonormal_vector() * size;
        let v = normal.cross(u);
        out.extend(quad(
            centre - u - v,
            centre + u - v,
            centre + u + v,
            centre - u + v,
        ));
    }
    out
}

/// A closed tapered cylinder along +Y from the origin: `segments` around, `rings` up.
fn trunk(height: f32, radius: f32, segments: usize, rings: usize) -> Vec<Triangle> {
    let point = |ring: usize, s: usize| {
        let h = ring as f32 / rings as f32;
        let r = radius * (1.0 - 0.6 * h);
        let a = TAU * (s % segments) as f32 / segments as f32;
        vec3(r * a.cos(), height * h, r * a.sin())
    };
    let mut out = Vec::with_capacity(2 * segments * (rings + 1));
    for ring in 0..rings {
        for s in 0..segments {
            out.extend(quad(
                point(ring, s),
                point(ring + 1, s),
                point(ring + 1, s + 1),
                point(ring, s + 1),
            ));
        }
    }
    let top = vec3(0.0, height, 0.0);
    for s in 0..segments {
        out.push(Triangle::new(top, point(rings, s + 1), point(rings, s)));
    }
    out
}

/// A rock: a closed sphere of radius 1 with `rings` rings, its vertices pushed in and out
/// by noise. Vertices are shared, so neighbouring triangles meet exactly.
fn rock(rings: usize) -> Vec<Triangle> {
    let rings = rings.max(2);
    let segments = 2 * rings;
    let displaced = |d: Vec3| {
        let bumps = value_noise(3.0 * d.x + 7.0, 3.0 * d.z - 5.0 * d.y, 7)
            + 0.5 * value_noise(9.0 * d.y + 2.0, 9.0 * d.x + 11.0 * d.z, 8);
        d * (0.75 + 0.35 * bumps)
    };
    let mut grid = Vec::with_capacity((rings - 1) * segments);
    for i in 1..rings {
        let polar = PI * i as f32 / rings as f32;
        for j in 0..segments {
            let azimuth = TAU * j as f32 / segments as f32;
            let (s, c) = polar.sin_cos();
            grid.push(displaced(vec3(s * azimuth.cos(), c, s * azimuth.sin())));
        }
    }
    let at = |i: usize, j: usize| grid[(i - 1) * segments + j % segments];
    let (north, south) = (displaced(Vec3::Y), displaced(Vec3::NEG_Y));
    let mut out = Vec::with_capacity(2 * segments * (rings - 1));
    for j in 0..segments {
        out.push(Triangle::new(north, at(1, j + 1), at(1, j)));
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            out.extend(quad(at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)));
        }
    }
    for j in 0..segments {
        out.push(Triangle::new(south, at(rings - 1, j), at(rings - 1, j + 1)));
    }
    out
}

/// A clump of `blades` tapered grass blades (2 triangles each), leaning out from the
/// centre of a disc of radius 0.5 m.
fn plant(blades: usize) -> Vec<Triangle> {
    let mut rng = Rng::new(0x0009_1a47);
    let mut out = Vec::with_capacity(2 * blades);
    for _ in 0..blades {
        let (r, a) = (0.5 * rng.unit().sqrt(), rng.range(0.0, TAU));
        let root = vec3(r * a.cos(), 0.0, r * a.sin());
        let turn = rng.range(0.0, TAU);
        let across = vec3(turn.cos(), 0.0, turn.sin()) * rng.range(0.005, 0.012);
        let height = rng.range(0.3, 0.8);
        let lean = root * rng.range(0.3, 1.2);
        let tip = root + lean + vec3(0.0, height, 0.0);
        out.extend(quad(
            root - across,
            root + across,
            tip + across * 0.2,
            tip - across * 0.2,
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Intersector, Ray, Watertight};

    #[test]
    fn instances_stand_on_the_triangulated_ground() {
        let terrain = Terrain::new(16);
        let triangles = terrain.triangles();
        // A vertical ray down at (x, z) meets the terrain at height_at(x, z).
        for (x, z) in [(10.0, 20.0), (-333.3, 512.5), (700.0, -80.0)] {
            let y = terrain.height_at(x, z);
            let ray = Ray::new(vec3(x, 1e4, z), Vec3::NEG_Y);
            let data = Watertight::prepare(&ray);
            let hit = triangles
                .iter()
                .find_map(|t| Watertight::intersect(&data, &ray, t, 0.0, f32::INFINITY));
            let t = hit.expect("the ray meets the terrain").t;
            assert!((1e4 - t - y).abs() < 1e-2, "{x} {z}: {} vs {y}", 1e4 - t);
        }
    }

    #[test]
    fn rocks_face_out() {
        let triangles = rock(8);
        assert!(triangles.iter().all(|t| t.normal().dot(t.centroid()) > 0.0));
    }
}
