//! Degenerate triangles (one point, a repeated corner, three collinear corners) on exact
//! dyadic grids: they have no area, so no ray may hit them, and none may give a NaN.

use crate::geometry::{Intersector, Ray, Triangle};
use crate::random::Rng;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Degeneracy {
    /// All three corners are one point.
    Point,
    /// Two corners are equal (in each of the three positions).
    Repeated,
    /// Three distinct corners on one line.
    Collinear,
}

impl Degeneracy {
    pub const ALL: [Degeneracy; 3] = [
        Degeneracy::Point,
        Degeneracy::Repeated,
        Degeneracy::Collinear,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Degeneracy::Point => "point",
            Degeneracy::Repeated => "repeated vertex",
            Degeneracy::Collinear => "collinear",
        }
    }
}

/// The dyadic grid of one triangle: spacing 2^-s (s in 6..=20) around an offset 2^o (or 0)
/// with o + s ≤ 20, so every corner, sum and small multiple below fits f32's 24 bits.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub step: f32,
    pub offset: f32,
}

impl Grid {
    pub fn random(rng: &mut Rng) -> Self {
        let s = 6 + rng.below(15) as i32;
        let offset = if rng.coin() {
            0.0
        } else {
            2f32.powi(rng.below((21 - s) as u64) as i32)
        };
        Grid {
            step: 2f32.powi(-s),
            offset,
        }
    }

    fn point(&self, rng: &mut Rng) -> Vec3 {
        let mut c = || self.offset + (rng.below(8193) as f32 - 4096.0) * self.step;
        Vec3::new(c(), c(), c())
    }

    /// A vector of up to `n` steps per component.
    fn vector(&self, rng: &mut Rng, n: u64) -> Vec3 {
        let mut c = || (rng.below(2 * n + 1) as f32 - n as f32) * self.step;
        Vec3::new(c(), c(), c())
    }
}

/// Whether three points are exactly collinear (or coincide): the f32 differences are exact
/// in f64 and so are their products, for points of one grid.
pub fn exactly_degenerate(t: &Triangle) -> bool {
    let a = t.v[0].as_dvec3();
    (t.v[1].as_dvec3() - a).cross(t.v[2].as_dvec3() - a) == glam::DVec3::ZERO
}

/// A degenerate triangle of the given kind on `grid`.
pub fn triangle(kind: Degeneracy, rng: &mut Rng, grid: &Grid) -> Triangle {
    let a = grid.point(rng);
    match kind {
        Degeneracy::Point => Triangle::new(a, a, a),
        Degeneracy::Repeated => {
            let b = loop {
                let b = grid.point(rng);
                if b != a {
                    break b;
                }
            };
            match rng.below(3) {
                0 => Triangle::new(a, a, b),
                1 => Triangle::new(a, b, a),
                _ => Triangle::new(b, a, a),
            }
        }
        Degeneracy::Collinear => {
            let u = loop {
                let u = grid.vector(rng, 16);
                if u != Vec3::ZERO {
                    break u;
                }
            };
            // Distinct multiples of u: exact on the grid, so exactly collinear.
            let (p, q) = [(1.0, 2.0), (-1.0, 1.0), (0.5, 3.0), (2.0, -3.0)][rng.below(4) as usize];
            let corners = [a, a + u * p, a + u * q];
            let r = rng.below(3) as usize;
            Triangle::new(corners[r], corners[(r + 1) % 3], corners[(r + 2) % 3])
        }
    }
}

/// Ray `i` at triangle `tri`: aimed exactly at a corner or at a point of the segment (from
/// random directions and axis-parallel with ±0 components), running along the segment's
/// line, aimed near it, or random.
pub fn ray(tri: &Triangle, grid: &Grid, rng: &mut Rng, i: u64) -> Ray {
    let corner = tri.v[rng.below(3) as usize];
    let other = tri.v[rng.below(3) as usize];
    let delta = grid.vector(rng, 128);
    match i % 6 {
        // Exactly through a corner: origin = corner + delta, direction = −delta.
        0 => Ray::new(corner + delta, -delta),
        // Exactly through a point of the segment: d = (a − o) + (b − o) passes (a + b)/2.
        1 => {
            let o = corner + delta;
            Ray::new(o, (corner - o) + (other - o))
        }
        // Axis-parallel through a corner, the other components ±0.
        2 => {
            let axis = rng.below(3) as usize;
            let mut d = Vec3::new(rng.signed_zero(), rng.signed_zero(), rng.signed_zero());
            let len = (rng.below(64) as f32 + 1.0) * grid.step;
            d[axis] = if rng.coin() { len } else { -len };
            Ray::new(corner - d * 4.0, d)
        }
        // Along the segment's own line.
        3 => {
            let d = other - corner;
            let d = if d == Vec3::ZERO { delta } else { d };
            Ray::new(corner - d * 2.0, d)
        }
        // Near a point of the segment (rounded aim).
        4 => {
            let w = rng.unit() as f32;
            let target = corner * w + other * (1.0 - w);
            let o = target + delta * 3.0;
            Ray::new(o, target - o)
        }
        _ => {
            let o = corner + delta * 4.0;
            Ray::new(o, rng.in_ball().as_vec3())
        }
    }
}

/// Hits on degenerate triangles of each kind for one intersector.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DegenerateReport {
    pub rays: u64,
    /// Hits per `Degeneracy::ALL` entry (must be 0 for the watertight and f64 tests).
    pub hits: [u64; 3],
    /// Hits with a NaN or infinite t, u or v (must be 0 for every test).
    pub non_finite: u64,
}

impl DegenerateReport {
    pub fn total_hits(&self) -> u64 {
        self.hits.iter().sum()
    }

    pub fn add(&mut self, o: &DegenerateReport) {
        self.rays += o.rays;
        for k in 0..3 {
            self.hits[k] += o.hits[k];
        }
        self.non_finite += o.non_finite;
    }
}

/// `n` rays, each at its own degenerate triangle on its own grid (kinds taking turns).
pub fn run<I: Intersector>(n: u64, seed: u64) -> DegenerateReport {
    use rayon::prelude::*;
    (0..n)
        .into_par_iter()
        .fold(DegenerateReport::default, |mut r, i| {
            let mut rng = Rng::for_case(seed, i);
            let k = (i % 3) as usize;
            let grid = Grid::random(&mut rng);
            let tri = triangle(Degeneracy::ALL[k], &mut rng, &grid);
            debug_assert!(exactly_degenerate(&tri));
            let ray = ray(&tri, &grid, &mut rng, i / 3);
            if !ray.is_valid() {
                return r;
            }
            r.rays += 1;
            let data = I::prepare(&ray);
            if let Some(h) = I::intersect(&data, &ray, &tri, ray.tmin, ray.tmax) {
                r.hits[k] += 1;
                if !(h.t.is_finite() && h.u.is_finite() && h.v.is_finite()) {
                    r.non_finite += 1;
                }
            }
            r
        })
        .reduce(DegenerateReport::default, |mut a, b| {
            a.add(&b);
            a
        })
}
