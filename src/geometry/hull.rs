//! The convex hull's vertices of a point set: the fewest points whose box, under any affine
//! map, is the box of the whole set mapped. A rotated instance's tightest world box is its
//! mesh's hull vertices placed one by one, where the box of its BLAS's boxes placed takes in
//! the corners those boxes swing out (`two_level::rebraid`).
//!
//! Built in f64 by quickhull (Barber, Dobkin and Huhdanpaa 1996): a tetrahedron of extreme
//! points, each point outside it kept in the outside set of one face that sees it; then,
//! face by face, the farthest point of an outside set joined to the surface (the faces it
//! sees replaced by faces from their border to it) and the replaced faces' points shared
//! out among the new faces. A hull that rounding might have made wrong (a face of no area,
//! a surface that does not close, a point left outside it) is refused (`None`), and the
//! caller keeps its coarser box.

use glam::{DVec3, Vec3};
use std::collections::HashSet;

/// A face: its corners counter-clockwise seen from outside, and its outward unit normal
/// with the plane's offset.
#[derive(Clone)]
struct Face {
    v: [u32; 3],
    normal: DVec3,
    offset: f64,
    alive: bool,
    /// Points this face sees, not yet joined.
    outside: Vec<u32>,
}

struct Builder {
    points: Vec<DVec3>,
    faces: Vec<Face>,
    /// The faces still on the surface.
    live: Vec<usize>,
    /// A point is outside a face when its distance beyond the plane exceeds this.
    tolerance: f64,
}

/// The vertices of the convex hull of `points`, or `None` where the points do not span a
/// solid (fewer than four, or all on one plane) or rounding made the hull doubtful. Every
/// point lies inside the returned points' hull, up to `tolerance(points)` beyond a face.
pub fn hull_vertices(points: &[Vec3]) -> Option<Vec<Vec3>> {
    let mut b = Builder::new(points)?;
    b.tetrahedron()?;
    let all: Vec<u32> = (0..b.points.len() as u32).collect();
    let first = b.faces.len();
    b.share_out(&all, 0..first);
    let mut pending: Vec<usize> = (0..first).collect();
    while let Some(f) = pending.pop() {
        let face = &b.faces[f];
        if !face.alive || face.outside.is_empty() {
            continue;
        }
        let far = |&p: &u32| b.beyond(face, p);
        let p = *face
            .outside
            .iter()
            .max_by(|x, y| far(x).total_cmp(&far(y)))?;
        let new = b.insert(p)?;
        pending.extend(new);
    }
    b.faces.retain(|f| f.alive);
    b.is_closed().then_some(())?;
    b.all_inside().then_some(())?;
    let used: HashSet<u32> = b.faces.iter().flat_map(|f| f.v).collect();
    let mut vertices: Vec<u32> = used.into_iter().collect();
    vertices.sort_unstable();
    Some(
        vertices
            .iter()
            .map(|&v| b.points[v as usize].as_vec3())
            .collect(),
    )
}

/// How far beyond its hull's faces `hull_vertices` may leave a point of `points`: a
/// ten-billionth of the points' extent, far below f32's rounding of them.
pub fn tolerance(points: &[Vec3]) -> f32 {
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    (1e-10
        * f64::from(
            (hi - lo)
                .max_element()
                .max(lo.abs().max(hi.abs()).max_element()),
        )) as f32
}

impl Builder {
    fn new(points: &[Vec3]) -> Option<Builder> {
        if points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        // Over the points as given: dropping repeats changes no extent.
        let tolerance = f64::from(tolerance(points));
        let mut seen = HashSet::new();
        let points: Vec<DVec3> = points
            .iter()
            .filter(|p| seen.insert(p.to_array().map(f32::to_bits)))
            .map(|p| p.as_dvec3())
            .collect();
        (points.len() >= 4).then(|| Builder {
            tolerance,
            points,
            faces: Vec::new(),
            live: Vec::new(),
        })
    }

    fn beyond(&self, f: &Face, p: u32) -> f64 {
        f.normal.dot(self.points[p as usize]) - f.offset
    }

    /// The point of greatest `key`.
    fn farthest(&self, key: impl Fn(DVec3) -> f64) -> u32 {
        (0..self.points.len())
            .max_by(|&a, &b| key(self.points[a]).total_cmp(&key(self.points[b])))
            .unwrap_or(0) as u32
    }

    /// The first four faces, from the lowest point in x, the point farthest from it, the
    /// farthest from their line and the farthest from their plane.
    fn tetrahedron(&mut self) -> Option<()> {
        let a = self.farthest(|p| -p.x);
        let pa = self.points[a as usize];
        let b = self.farthest(|p| (p - pa).length_squared());
        let pb = self.points[b as usize];
        let line = (pb - pa).normalize_or_zero();
        let c = self.farthest(|p| (p - pa).cross(line).length_squared());
        let pc = self.points[c as usize];
        let normal = (pb - pa).cross(pc - pa).normalize_or_zero();
        let d = self.farthest(|p| (p - pa).dot(normal).abs());
        if (self.points[d as usize] - pa).dot(normal).abs() <= 16.0 * self.tolerance {
            return None;
        }
        // Oriented so that d lies below the face (a, b, c).
        let (b, c) = match (self.points[d as usize] - pa).dot(normal) > 0.0 {
            true => (c, b),
            false => (b, c),
        };
        for v in [[a, b, c], [a, d, b], [b, d, c], [c, d, a]] {
            self.add_face(v)?;
        }
        Some(())
    }

    fn add_face(&mut self, v: [u32; 3]) -> Option<()> {
        let [a, b, c] = v.map(|i| self.points[i as usize]);
        let n = (b - a).cross(c - a);
        let length = n.length();
        // A face of no area has no direction to be outside of.
        if length <= self.tolerance * (b - a).length().max((c - a).length()) {
            return None;
        }
        let normal = n / length;
        self.live.push(self.faces.len());
        self.faces.push(Face {
            v,
            normal,
            offset: normal.dot(a),
            alive: true,
            outside: Vec::new(),
        });
        Some(())
    }

    /// Each of `points` into the outside set of the first of `faces` that sees it; a point
    /// none sees is inside them for good.
    fn share_out(&mut self, points: &[u32], faces: std::ops::Range<usize>) {
        for &p in points {
            if let Some(f) = faces
                .clone()
                .find(|&f| self.beyond(&self.faces[f], p) > self.tolerance)
            {
                self.faces[f].outside.push(p);
            }
        }
    }

    /// Joins point `p`, which some face sees, to the surface: the faces it sees go, the
    /// edges around them (each seen face's edge whose other face is not seen) are joined
    /// to `p`, and the seen faces' points are shared out among the new faces. Returns the
    /// new faces.
    fn insert(&mut self, p: u32) -> Option<std::ops::Range<usize>> {
        let seen: Vec<usize> = (self.live.iter().copied())
            .filter(|&f| self.beyond(&self.faces[f], p) > self.tolerance)
            .collect();
        let edges: HashSet<(u32, u32)> = seen
            .iter()
            .flat_map(|&f| {
                let [a, b, c] = self.faces[f].v;
                [(a, b), (b, c), (c, a)]
            })
            .collect();
        let mut orphans = Vec::new();
        for &f in &seen {
            self.faces[f].alive = false;
            orphans.extend(std::mem::take(&mut self.faces[f].outside));
        }
        orphans.retain(|&q| q != p);
        self.live.retain(|&f| self.faces[f].alive);
        let mut horizon: Vec<(u32, u32)> = edges
            .iter()
            .copied()
            .filter(|&(a, b)| !edges.contains(&(b, a)))
            .collect();
        horizon.sort_unstable();
        let first = self.faces.len();
        for (a, b) in horizon {
            self.add_face([a, b, p])?;
        }
        let new = first..self.faces.len();
        self.share_out(&orphans, new.clone());
        Some(new)
    }

    /// Whether every point lies within the tolerance inside every face: the check that
    /// rounding did not leave one out. The planes as arrays, so that the loop over them is
    /// vectorised.
    fn all_inside(&self) -> bool {
        let column = |k: usize| -> Vec<f64> {
            self.faces
                .iter()
                .map(|f| match k {
                    0 => f.normal.x,
                    1 => f.normal.y,
                    2 => f.normal.z,
                    _ => f.offset + self.tolerance,
                })
                .collect()
        };
        let (nx, ny, nz, off) = (column(0), column(1), column(2), column(3));
        const LANES: usize = 8;
        let n = off.len().div_ceil(LANES) * LANES;
        // Padded with a plane no point is beyond.
        let pad = |mut v: Vec<f64>, with: f64| {
            v.resize(n, with);
            v
        };
        let (nx, ny, nz, off) = (pad(nx, 0.0), pad(ny, 0.0), pad(nz, 0.0), pad(off, 1.0));
        let planes: Vec<[[f64; LANES]; 4]> = (0..n / LANES)
            .map(|c| {
                let lanes = |v: &[f64]| std::array::from_fn(|k| v[c * LANES + k]);
                [lanes(&nx), lanes(&ny), lanes(&nz), lanes(&off)]
            })
            .collect();
        // A point nearer the hull's centre than its nearest face is inside them all.
        let used: HashSet<u32> = self.faces.iter().flat_map(|f| f.v).collect();
        let centre =
            used.iter().map(|&v| self.points[v as usize]).sum::<DVec3>() / used.len() as f64;
        let inner = (self.faces.iter())
            .map(|f| f.offset - f.normal.dot(centre))
            .fold(f64::INFINITY, f64::min)
            - self.tolerance;
        let inner = inner.max(0.0).powi(2);
        self.points
            .iter()
            .filter(|p| p.distance_squared(centre) >= inner)
            .all(|p| {
                let mut worst = [f64::NEG_INFINITY; LANES];
                for [x, y, z, o] in &planes {
                    for k in 0..LANES {
                        let d = x[k] * p.x + y[k] * p.y + z[k] * p.z - o[k];
                        worst[k] = if d > worst[k] { d } else { worst[k] };
                    }
                }
                worst.iter().all(|&w| w <= 0.0)
            })
    }

    /// Whether every edge of the surface has the face across it: each directed edge once,
    /// and its reverse once.
    fn is_closed(&self) -> bool {
        let mut edges = HashSet::new();
        for f in &self.faces {
            let [a, b, c] = f.v;
            for e in [(a, b), (b, c), (c, a)] {
                if !edges.insert(e) {
                    return false;
                }
            }
        }
        edges.iter().all(|&(a, b)| edges.contains(&(b, a)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Rng;
    use glam::{Mat3, Quat};

    fn cloud(rng: &mut Rng, n: usize) -> Vec<Vec3> {
        (0..n).map(|_| random_vec(rng) * 2.0 - 1.0).collect()
    }

    fn random_vec(rng: &mut Rng) -> Vec3 {
        Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32)
    }

    /// The largest of each coordinate over `points` mapped by `m`, in f64.
    fn top(points: &[Vec3], m: Mat3) -> [f64; 3] {
        let m = m.as_dmat3();
        [0, 1, 2].map(|i| {
            points
                .iter()
                .map(|p| (m * p.as_dvec3())[i])
                .fold(f64::NEG_INFINITY, f64::max)
        })
    }

    #[test]
    fn a_cube_with_points_inside_has_its_eight_corners() {
        let mut rng = Rng(7);
        let mut points: Vec<Vec3> = cloud(&mut rng, 500).iter().map(|p| *p * 0.9).collect();
        for c in 0..8 {
            let corner = |bit: usize| if c >> bit & 1 == 1 { 1.0 } else { -1.0 };
            points.push(Vec3::new(corner(0), corner(1), corner(2)));
        }
        let hull = hull_vertices(&points).unwrap();
        assert_eq!(hull.len(), 8);
        assert!(hull.iter().all(|p| p.abs() == Vec3::ONE));
    }

    /// Under any rotation, the hull's vertices reach exactly as far as all the points, in
    /// every axis both ways: the property the world boxes rest on.
    #[test]
    fn the_hull_reaches_as_far_as_the_points_under_any_rotation() {
        let mut rng = Rng(11);
        for case in 0..20 {
            let mut points = cloud(&mut rng, 2000);
            if case % 2 == 1 {
                // A stretched cloud with points on a sphere's surface: many hull vertices.
                points.extend(cloud(&mut rng, 300).iter().map(|p| p.normalize() * 3.0));
                points.iter_mut().for_each(|p| p.y *= 5.0);
            }
            let hull = hull_vertices(&points).unwrap();
            assert!(hull.len() < points.len());
            for _ in 0..20 {
                let axis = (random_vec(&mut rng) - 0.5).normalize();
                let m = Mat3::from_quat(Quat::from_axis_angle(axis, rng.unit() as f32 * 6.3));
                for m in [m, -m] {
                    assert_eq!(top(&hull, m), top(&points, m), "case {case}");
                }
            }
        }
    }

    #[test]
    fn flat_or_too_few_points_have_no_hull() {
        let mut rng = Rng(3);
        let flat: Vec<Vec3> = cloud(&mut rng, 100)
            .iter()
            .map(|p| Vec3::new(p.x, p.y, 0.5))
            .collect();
        assert!(hull_vertices(&flat).is_none());
        assert!(hull_vertices(&flat[..3]).is_none());
        let line: Vec<Vec3> = (0..10).map(|i| Vec3::splat(i as f32)).collect();
        assert!(hull_vertices(&line).is_none());
        let mut bad = cloud(&mut rng, 10);
        bad[4].x = f32::NAN;
        assert!(hull_vertices(&bad).is_none());
    }
}
