//! Leaks on any mesh, open or closed: rays that cross the surface exactly at an edge shared by
//! two consistently wound triangles, or at a vertex inside a closed fan, transversally. The
//! exact ray hits there; a closest hit missing or farther away is a leak.

use crate::accel::{Accel, NoStats};
use crate::geometry::intersect::reference::{Shear64, evaluate};
use crate::geometry::{Intersector, Ray, Triangle};
use crate::random::Rng;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// A ray that must cross the surface at t = `t_cross`.
#[derive(Clone, Copy, Debug)]
pub struct Crossing {
    pub ray: Ray,
    pub t_cross: f64,
}

/// |n̂ · d̂| below this is too close to grazing to call the crossing certain.
const MIN_COS: f64 = 0.1;

/// The shared edges and closed vertex fans of a triangle soup, with vertices identified by
/// their bits.
pub struct Topology {
    /// (corner a, corner b, the two triangles), a and b as points.
    edges: Vec<(Vec3, Vec3, [u32; 2])>,
    /// (vertex, the triangles of its closed fan).
    fans: Vec<(Vec3, Vec<u32>)>,
}

impl Topology {
    pub fn new(triangles: &[Triangle]) -> Self {
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        // Directed edges: (from, to) → triangles having it in their winding order.
        let mut directed: HashMap<([u32; 3], [u32; 3]), Vec<u32>> = HashMap::new();
        let mut around: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
        for (i, t) in triangles.iter().enumerate() {
            if t.normal() == Vec3::ZERO || !t.is_finite() {
                continue;
            }
            let k = t.v.map(key);
            if k[0] == k[1] || k[1] == k[2] || k[2] == k[0] {
                continue;
            }
            for e in 0..3 {
                directed
                    .entry((k[e], k[(e + 1) % 3]))
                    .or_default()
                    .push(i as u32);
                around.entry(k[e]).or_default().push(i as u32);
            }
        }
        let point = |k: [u32; 3]| Vec3::from_array(k.map(f32::from_bits));
        let manifold = |a: [u32; 3], b: [u32; 3]| -> Option<[u32; 2]> {
            // Exactly one triangle each way round: shared by two, consistently wound.
            match (directed.get(&(a, b)), directed.get(&(b, a))) {
                (Some(x), Some(y)) if x.len() == 1 && y.len() == 1 => Some([x[0], y[0]]),
                _ => None,
            }
        };
        let mut edges = Vec::new();
        for &(a, b) in directed.keys() {
            if a < b
                && let Some(pair) = manifold(a, b)
            {
                edges.push((point(a), point(b), pair));
            }
        }
        let mut fans = Vec::new();
        for (&v, tris) in &around {
            // A closed fan: every edge from v is a manifold edge within the fan.
            let closed = tris.len() >= 3
                && tris.iter().all(|&t| {
                    let k = triangles[t as usize].v.map(key);
                    (0..3).all(|e| {
                        let (a, b) = (k[e], k[(e + 1) % 3]);
                        (a != v && b != v) || manifold(a, b).is_some()
                    })
                });
            if closed {
                fans.push((point(v), tris.clone()));
            }
        }
        // HashMap order is random: sort for reproducible runs.
        let bits = |p: &Vec3| p.to_array().map(f32::to_bits);
        edges.sort_by_key(|(a, b, _)| (bits(a), bits(b)));
        fans.sort_by_key(|(v, _)| bits(v));
        Topology { edges, fans }
    }

    pub fn edges(&self) -> usize {
        self.edges.len()
    }

    pub fn fans(&self) -> usize {
        self.fans.len()
    }

    /// Crossing `i`: even ones through edge points, odd ones through fan vertices, from
    /// either side. `None` when the attempt is not exact or not clearly transversal.
    pub fn crossing(&self, triangles: &[Triangle], i: u64, seed: u64) -> Option<Crossing> {
        let mut rng = Rng::for_case(seed, i);
        let side = if rng.coin() { 1.0 } else { -1.0 };
        if i.is_multiple_of(2) && !self.edges.is_empty() || self.fans.is_empty() {
            let (a, b, pair) = self
                .edges
                .get(rng.below(self.edges.len() as u64) as usize)?;
            let w = EDGE_WEIGHTS[rng.below(EDGE_WEIGHTS.len() as u64) as usize];
            let (a, b) = (a.as_dvec3(), b.as_dvec3());
            let p = edge_point(a, b, w);
            let normals = pair.map(|t| unit_normal(&triangles[t as usize]));
            let along = (normals[0] + normals[1]).normalize_or_zero();
            let dist = (b - a).length() * (0.5 + 4.0 * rng.unit());
            let offset = (along + rng.in_ball() * 0.7) * (dist * side);
            edge_crossing(a, b, w, p + offset, dist, &normals)
        } else {
            let (v, fan) = &self.fans[rng.below(self.fans.len() as u64) as usize];
            let normals = fan_normals(triangles, fan);
            let along = normals.iter().sum::<DVec3>().normalize_or_zero();
            let v = v.as_dvec3();
            let dist = fan_size(triangles, v, fan) * (0.5 + 4.0 * rng.unit());
            let offset = (along + rng.in_ball() * 0.7) * (dist * side);
            vertex_crossing(v, v + offset, dist, &normals)
        }
    }

    /// The shared edges: (corner a, corner b, the two triangles).
    pub(crate) fn shared_edges(&self) -> &[(Vec3, Vec3, [u32; 2])] {
        &self.edges
    }

    /// The closed fans: (vertex, its triangles).
    pub(crate) fn closed_fans(&self) -> &[(Vec3, Vec<u32>)] {
        &self.fans
    }

    /// `n` crossings (failed attempts are skipped; there are at most 32n attempts, done in
    /// batches until n succeed).
    pub fn crossings(&self, triangles: &[Triangle], n: usize, seed: u64) -> Vec<Crossing> {
        if self.edges.is_empty() && self.fans.is_empty() {
            return Vec::new();
        }
        let mut out: Vec<Crossing> = Vec::with_capacity(n);
        let batch = 2 * n as u64 + 64;
        for round in 0..16 {
            let start = round * batch;
            out.extend(
                (start..start + batch)
                    .into_par_iter()
                    .filter_map(|i| self.crossing(triangles, i, seed))
                    .collect::<Vec<_>>(),
            );
            if out.len() >= n {
                break;
            }
        }
        out.truncate(n);
        out
    }
}

/// The edge points crossings aim at, (wa·a + wb·b)/(wa + wb) for these weights (wa, wb).
pub(crate) const EDGE_WEIGHTS: [(f64, f64); 5] =
    [(1.0, 1.0), (1.0, 2.0), (2.0, 1.0), (1.0, 3.0), (3.0, 1.0)];

pub(crate) fn edge_point(a: DVec3, b: DVec3, (wa, wb): (f64, f64)) -> DVec3 {
    (a * wa + b * wb) / (wa + wb)
}

/// The exact ray from the grid point nearest `near` (`dist` from the edge) through the
/// edge point of weights (wa, wb), if it crosses the two faces of `normals` transversally.
pub(crate) fn edge_crossing(
    a: DVec3,
    b: DVec3,
    (wa, wb): (f64, f64),
    near: DVec3,
    dist: f64,
    normals: &[DVec3],
) -> Option<Crossing> {
    let o = snap(near, grain(&[a, b], dist))?;
    // o + d / (wa + wb) is the edge point, exactly: d's terms are exact differences.
    let d = (a - o) * wa + (b - o) * wb;
    let ray = exact_ray(o, d)?;
    transversal(normals, ray.direction.as_dvec3()).then_some(Crossing {
        ray,
        t_cross: 1.0 / (wa + wb),
    })
}

/// The exact ray from the grid point nearest `near` through vertex `v` (at t = 1), if it
/// crosses every face of its fan (`normals`) transversally.
pub(crate) fn vertex_crossing(
    v: DVec3,
    near: DVec3,
    dist: f64,
    normals: &[DVec3],
) -> Option<Crossing> {
    let o = snap(near, grain(&[v], dist))?;
    let ray = exact_ray(o, v - o)?;
    transversal(normals, ray.direction.as_dvec3()).then_some(Crossing { ray, t_cross: 1.0 })
}

pub(crate) fn fan_normals(triangles: &[Triangle], fan: &[u32]) -> Vec<DVec3> {
    fan.iter()
        .map(|&t| unit_normal(&triangles[t as usize]))
        .collect()
}

/// The farthest corner of the fan from its vertex `v`.
pub(crate) fn fan_size(triangles: &[Triangle], v: DVec3, fan: &[u32]) -> f64 {
    fan.iter()
        .flat_map(|&t| triangles[t as usize].v)
        .map(|p| (p.as_dvec3() - v).length())
        .fold(0.0, f64::max)
}

pub(crate) fn unit_normal(t: &Triangle) -> DVec3 {
    let [a, b, c] = t.v.map(|p| p.as_dvec3());
    (b - a).cross(c - a).normalize_or_zero()
}

/// Every normal faces the direction the same way, none nearly edge-on.
fn transversal(normals: &[DVec3], d: DVec3) -> bool {
    let d = d.normalize_or_zero();
    let cos: Vec<f64> = normals.iter().map(|n| n.dot(d)).collect();
    cos.iter().all(|&c| c > MIN_COS) || cos.iter().all(|&c| c < -MIN_COS)
}

/// Per axis, a power of two that divides every coordinate of `points` (their finest ulp), so
/// that origins on its multiples keep differences to them exact.
fn grain(points: &[DVec3], dist: f64) -> DVec3 {
    let ulp = |x: f64| 2f64.powi(x.abs().log2().floor() as i32 - 23);
    DVec3::from_array(std::array::from_fn(|axis| {
        let finest = points
            .iter()
            .map(|p| p[axis])
            .filter(|&x| x != 0.0)
            .map(ulp)
            .fold(f64::INFINITY, f64::min);
        // All zero on this axis: any grain works; one fine enough for the offset.
        if finest.is_finite() {
            finest
        } else {
            ulp(dist) * 0.25
        }
    }))
}

/// `p` rounded to a multiple of `grain` per axis, if that is an f32.
fn snap(p: DVec3, grain: DVec3) -> Option<DVec3> {
    let o = (p / grain).round() * grain;
    o.to_array()
        .iter()
        .all(|&x| (x as f32) as f64 == x)
        .then_some(o)
}

/// The ray from `o` along `d` if both are exact f32 values and d ≠ 0.
fn exact_ray(o: DVec3, d: DVec3) -> Option<Ray> {
    let exact = |v: DVec3| v.to_array().iter().all(|&x| (x as f32) as f64 == x);
    (exact(o) && exact(d) && d != DVec3::ZERO).then(|| Ray::new(o.as_vec3(), d.as_vec3()))
}

/// Leaks among crossings for one intersector.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CrossingReport {
    pub rays: u64,
    /// No closest hit at all.
    pub missed: u64,
    /// The closest hit lies beyond the crossing point: the ray slipped through.
    pub passed_through: u64,
    /// Any-hit queries that found nothing.
    pub any_missed: u64,
}

impl CrossingReport {
    pub fn leaks(&self) -> u64 {
        self.missed + self.passed_through + self.any_missed
    }

    pub fn leak_rate(&self) -> f64 {
        (self.missed + self.passed_through) as f64 / self.rays.max(1) as f64
    }

    pub fn add(&mut self, o: &CrossingReport) {
        self.rays += o.rays;
        self.missed += o.missed;
        self.passed_through += o.passed_through;
        self.any_missed += o.any_missed;
    }
}

/// What one crossing's rays found; all false when the surface held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// No closest hit at all.
    pub missed: bool,
    /// The closest hit lies beyond the crossing point.
    pub passed_through: bool,
    /// The any-hit query found nothing.
    pub any_missed: bool,
}

impl Outcome {
    /// The closest hit missed or lay beyond the surface: the ray slipped through.
    pub fn slipped_through(&self) -> bool {
        self.missed || self.passed_through
    }

    /// Any of the three: what `CrossingReport::leaks` counts.
    pub fn leaked(&self) -> bool {
        self.slipped_through() || self.any_missed
    }
}

impl CrossingReport {
    /// Adds one crossing's outcome.
    pub fn record(&mut self, o: Outcome) {
        self.rays += 1;
        self.missed += u64::from(o.missed);
        self.passed_through += u64::from(o.passed_through);
        self.any_missed += u64::from(o.any_missed);
    }
}

/// Traces crossing `c` through `accel` with `I`, closest and any hit. Whether a hit lies
/// beyond the crossing is decided by the f64 distance to the hit triangle; one within the
/// f32 test's t error of the crossing is a tie in f32 (a neighbour at the same depth), not
/// a leak.
pub fn classify<A: Accel, I: Intersector>(
    accel: &A,
    triangles: &[Triangle],
    c: &Crossing,
) -> Outcome {
    let mut o = Outcome::default();
    match accel.closest_hit::<I, _>(&c.ray, &mut NoStats) {
        None => o.missed = true,
        Some(h) => {
            let ev = evaluate(&Shear64::new(&c.ray), &triangles[h.triangle as usize]);
            o.passed_through = ev.t > c.t_cross * (1.0 + 1e-9) + ev.f32_t_error + ev.t_error;
        }
    }
    o.any_missed = !accel.any_hit::<I, _>(&c.ray, &mut NoStats);
    o
}

/// Counts the crossings `I` lost through `accel` (`classify`, summed).
pub fn count<A: Accel, I: Intersector>(
    accel: &A,
    triangles: &[Triangle],
    crossings: &[Crossing],
) -> CrossingReport {
    crossings
        .par_iter()
        .with_min_len(256)
        .fold(CrossingReport::default, |mut r, c| {
            r.record(classify::<A, I>(accel, triangles, c));
            r
        })
        .reduce(CrossingReport::default, |mut a, b| {
            a.add(&b);
            a
        })
}
