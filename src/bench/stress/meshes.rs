//! Closed test meshes (icosphere, cube of many small triangles, torus) as indexed vertex
//! arrays, placed at any offset and scale and snapped to a per-axis power-of-two grid, so that
//! rays built in integer grid units pass exactly through vertices and edge points.

use crate::geometry::Triangle;
use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    Sphere,
    Cube,
    Torus,
}

/// Major and minor radius of the torus.
const TORUS_R: f64 = 1.0;
const TORUS_MINOR: f64 = 0.4;

/// A closed mesh in model space (about unit size, centred on the origin).
#[derive(Clone, Debug)]
pub struct ClosedMesh {
    pub name: &'static str,
    pub shape: Shape,
    pub vertices: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
}

impl ClosedMesh {
    /// The three meshes of the stress suite, about a thousand triangles each.
    pub fn all() -> Vec<ClosedMesh> {
        vec![
            ClosedMesh::icosphere(3),
            ClosedMesh::cube(8),
            ClosedMesh::torus(32, 16),
        ]
    }

    /// An icosahedron with every triangle split in four `levels` times, vertices pushed out
    /// to the unit sphere: 20·4^levels triangles.
    pub fn icosphere(levels: u32) -> Self {
        let p = (1.0 + 5f64.sqrt()) / 2.0;
        let mut vertices: Vec<DVec3> = [
            (-1.0, p, 0.0),
            (1.0, p, 0.0),
            (-1.0, -p, 0.0),
            (1.0, -p, 0.0),
            (0.0, -1.0, p),
            (0.0, 1.0, p),
            (0.0, -1.0, -p),
            (0.0, 1.0, -p),
            (p, 0.0, -1.0),
            (p, 0.0, 1.0),
            (-p, 0.0, -1.0),
            (-p, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            // One midpoint per edge, shared by the two faces on it.
            let mut midpoints = std::collections::HashMap::new();
            let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<DVec3>| {
                *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                    vertices.push(m);
                    vertices.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(faces.len() * 4);
            for [a, b, c] in faces {
                let ab = midpoint(a, b, &mut vertices);
                let bc = midpoint(b, c, &mut vertices);
                let ca = midpoint(c, a, &mut vertices);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            faces = next;
        }
        ClosedMesh {
            name: "icosphere",
            shape: Shape::Sphere,
            vertices,
            faces,
        }
    }

    /// The cube [-1, 1]³ with each face an n × n grid of squares, each split in two:
    /// 12·n² triangles. Vertices on the cube's edges and corners are shared between faces.
    pub fn cube(n: u32) -> Self {
        let n = n.max(1) as i64;
        let mut index = std::collections::HashMap::new();
        let mut vertices = Vec::new();
        let mut faces = Vec::new();
        let mut vertex = |g: [i64; 3], vertices: &mut Vec<DVec3>| -> u32 {
            *index.entry(g).or_insert_with(|| {
                let f = |c: i64| 2.0 * c as f64 / n as f64 - 1.0;
                vertices.push(DVec3::new(f(g[0]), f(g[1]), f(g[2])));
                vertices.len() as u32 - 1
            })
        };
        for axis in 0..3 {
            for side in [0, n] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                for i in 0..n {
                    for j in 0..n {
                        let corner = |di: i64, dj: i64| {
                            let mut g = [0i64; 3];
                            g[axis] = side;
                            g[u] = i + di;
                            g[v] = j + dj;
                            g
                        };
                        let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                        let q = q.map(|g| vertex(g, &mut vertices));
                        // Alternate the diagonal so both diagonal directions are tested.
                        if (i + j) % 2 == 0 {
                            faces.extend([[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
                        } else {
                            faces.extend([[q[0], q[1], q[3]], [q[1], q[2], q[3]]]);
                        }
                    }
                }
            }
        }
        ClosedMesh {
            name: "cube",
            shape: Shape::Cube,
            vertices,
            faces,
        }
    }

    /// A torus around the y axis (major radius 1, minor 0.4), `major` × `minor` quads.
    pub fn torus(major: u32, minor: u32) -> Self {
        let (nm, nn) = (major.max(3), minor.max(3));
        let tau = std::f64::consts::TAU;
        let mut vertices = Vec::with_capacity((nm * nn) as usize);
        for i in 0..nm {
            let phi = tau * i as f64 / nm as f64;
            for j in 0..nn {
                let theta = tau * j as f64 / nn as f64;
                let r = TORUS_R + TORUS_MINOR * theta.cos();
                vertices.push(DVec3::new(
                    r * phi.cos(),
                    TORUS_MINOR * theta.sin(),
                    r * phi.sin(),
                ));
            }
        }
        let at = |i: u32, j: u32| (i % nm) * nn + j % nn;
        let mut faces = Vec::with_capacity((2 * nm * nn) as usize);
        for i in 0..nm {
            for j in 0..nn {
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                faces.extend([[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
            }
        }
        ClosedMesh {
            name: "torus",
            shape: Shape::Torus,
            vertices,
            faces,
        }
    }

    /// Every face's three edges as (smaller index, larger index), sorted: shared edges sit
    /// next to each other.
    fn sorted_face_edges(&self) -> Vec<[u32; 2]> {
        let mut edges: Vec<[u32; 2]> = self
            .faces
            .iter()
            .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges
    }

    /// Every edge once, as (smaller index, larger index).
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let mut edges = self.sorted_face_edges();
        edges.dedup();
        edges
    }

    /// Whether every edge belongs to exactly two faces (a closed 2-manifold).
    pub fn is_closed(&self) -> bool {
        self.sorted_face_edges()
            .chunk_by(|a, b| a == b)
            .all(|run| run.len() == 2 && run[0][0] != run[0][1])
    }

    /// The centre of the solid region nearest to `p` (model space): the centre of the sphere
    /// or cube, the nearest point of the torus's core circle.
    pub fn core_near(&self, p: DVec3) -> DVec3 {
        match self.shape {
            Shape::Sphere | Shape::Cube => DVec3::ZERO,
            Shape::Torus => {
                let flat = DVec3::new(p.x, 0.0, p.z);
                let dir = flat.try_normalize().unwrap_or(DVec3::X);
                dir * TORUS_R
            }
        }
    }

    /// Radius of a ball around any `core_near` point that lies well inside the mesh (far
    /// more than any snapping to the grid can move the surface).
    pub fn core_radius(&self) -> f64 {
        match self.shape {
            Shape::Sphere | Shape::Cube => 0.3,
            Shape::Torus => 0.3 * TORUS_MINOR,
        }
    }

    /// Signed distance from model point `p` into the smooth solid the mesh approximates
    /// (negative outside).
    pub fn depth(&self, p: DVec3) -> f64 {
        match self.shape {
            Shape::Sphere => 1.0 - p.length(),
            Shape::Cube => 1.0 - p.abs().max_element(),
            Shape::Torus => {
                let ring = DVec3::new(p.x, 0.0, p.z).length() - TORUS_R;
                TORUS_MINOR - (ring * ring + p.y * p.y).sqrt()
            }
        }
    }

    /// How far the flat triangles stray from the smooth solid: the largest |depth| of a
    /// face centroid or edge midpoint (vertices lie on the smooth surface).
    pub fn sagitta(&self) -> f64 {
        let v = |i: u32| self.vertices[i as usize];
        self.faces
            .iter()
            .flat_map(|&[a, b, c]| {
                [
                    (v(a) + v(b) + v(c)) / 3.0,
                    (v(a) + v(b)) / 2.0,
                    (v(b) + v(c)) / 2.0,
                    (v(c) + v(a)) / 2.0,
                ]
            })
            .map(|p| self.depth(p).abs())
            .fold(0.0, f64::max)
    }

    /// The smallest feature of the shape: the radius of the sphere, the half side of the
    /// cube, the tube radius of the torus.
    pub fn feature_size(&self) -> f64 {
        match self.shape {
            Shape::Sphere | Shape::Cube => 1.0,
            Shape::Torus => TORUS_MINOR,
        }
    }

    /// Radius of a ball around the origin holding the mesh.
    pub fn bounding_radius(&self) -> f64 {
        self.vertices.iter().map(|v| v.length()).fold(0.0, f64::max)
    }
}

/// A similarity transform: model point p ↦ p · scale + offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub scale: f64,
    pub offset: DVec3,
}

impl Placement {
    pub fn apply(&self, p: DVec3) -> DVec3 {
        p * self.scale + self.offset
    }

    pub fn label(&self) -> String {
        format!(
            "scale {:e}, offset ({:e}, {:e}, {:e})",
            self.scale, self.offset.x, self.offset.y, self.offset.z
        )
    }
}

/// A mesh placed in the world and snapped to the grid: vertex i is `grid · ints[i]`.
#[derive(Clone, Debug)]
pub struct PlacedMesh {
    pub mesh: ClosedMesh,
    pub placement: Placement,
    /// Grid spacing per axis, a power of two.
    pub grid: DVec3,
    pub ints: Vec<[i64; 3]>,
    pub triangles: Vec<Triangle>,
    /// Depth (model units) beyond which a point is inside whatever snapping and the flat
    /// facets did: twice their combined effect.
    pub inside_margin: f64,
}

/// Integer grid coordinates whose magnitude is at most this are exact f32 multiples of G.
pub const F32_INTS: i64 = 1 << 24;

/// The exponent e with 2^e ≤ |x| < 2^(e+1).
fn exponent(x: f64) -> i32 {
    x.abs().log2().floor() as i32
}

impl PlacedMesh {
    /// Places and snaps `mesh`. Per axis, G is the spacing of f32 values at the largest
    /// coordinate (so no snapped vertex moves by more than that coordinate's own ulp), but no
    /// finer than 2^-21 of the mesh radius (which leaves integer room for the rays).
    pub fn new(mesh: &ClosedMesh, placement: Placement) -> Self {
        let world: Vec<DVec3> = mesh.vertices.iter().map(|&v| placement.apply(v)).collect();
        let radius = mesh.bounding_radius() * placement.scale;
        let mut grid = DVec3::ZERO;
        for axis in 0..3 {
            let max_abs = world.iter().map(|p| p[axis].abs()).fold(0.0, f64::max);
            let e = (exponent(max_abs) - 23).max(exponent(radius) - 21);
            grid[axis] = 2f64.powi(e);
        }
        let ints: Vec<[i64; 3]> = world
            .iter()
            .map(|p| std::array::from_fn(|a| (p[a] / grid[a]).round() as i64))
            .collect();
        let snap = 0.5 * grid.length() / placement.scale;
        let mut placed = PlacedMesh {
            mesh: mesh.clone(),
            placement,
            grid,
            ints,
            triangles: Vec::new(),
            inside_margin: 2.0 * (snap + mesh.sagitta()),
        };
        placed.triangles = mesh
            .faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| placed.point(placed.ints[i as usize]));
                Triangle::new(a, b, c)
            })
            .collect();
        placed
    }

    /// The f32 point at integer grid coordinates `g` (exact for |g| ≤ 2^24).
    pub fn point(&self, g: [i64; 3]) -> Vec3 {
        Vec3::new(
            (g[0] as f64 * self.grid.x) as f32,
            (g[1] as f64 * self.grid.y) as f32,
            (g[2] as f64 * self.grid.z) as f32,
        )
    }

    /// A world point snapped to the grid.
    pub fn snap(&self, p: DVec3) -> [i64; 3] {
        std::array::from_fn(|a| (p[a] / self.grid[a]).round() as i64)
    }

    /// A world point in grid units (not rounded).
    pub fn to_grid(&self, p: DVec3) -> DVec3 {
        p / self.grid
    }

    /// Model space of a world point.
    pub fn to_model(&self, p: DVec3) -> DVec3 {
        (p - self.placement.offset) / self.placement.scale
    }

    /// Grid points of a vertex, as world f64.
    pub fn world_of(&self, g: [i64; 3]) -> DVec3 {
        DVec3::new(
            g[0] as f64 * self.grid.x,
            g[1] as f64 * self.grid.y,
            g[2] as f64 * self.grid.z,
        )
    }

    /// Whether the snapped mesh still resolves its shape: its smallest feature spans at
    /// least 4 grid steps on every axis. Coarser meshes collapse into a few points and have
    /// no interior to aim at. (Rays are further checked against `robustly_inside`.)
    pub fn resolvable(&self) -> bool {
        let feature = self.mesh.feature_size() * self.placement.scale;
        (0..3).all(|a| feature / self.grid[a] >= 4.0)
    }

    /// Whether world point `p` lies inside the snapped mesh whatever the snapping and the
    /// flat facets did (see `inside_margin`).
    pub fn robustly_inside(&self, p: DVec3) -> bool {
        self.mesh.depth(self.to_model(p)) >= self.inside_margin
    }
}

/// Whether integer grid coordinates `g` are an exact f32 multiple of the spacing: the odd
/// part fits in f32's 24-bit significand.
pub fn exact_in_f32(g: i64) -> bool {
    g == 0 || (g.unsigned_abs() >> g.trailing_zeros()) < (1u64 << 24)
}
