//! Closest hits measured against the f64 reference. A disagreement is forgiven only as a tie
//! (both triangles at the same t within the error bounds) or as rounding (the ray passes within
//! the f32 test's error of the edges involved); anything else is a mismatch.

use crate::accel::{Accel, Hit, NoStats};
use crate::geometry::intersect::reference::{Evaluation, Shear64, evaluate};
use crate::geometry::{Aabb, Intersector, Ray, ReferenceF64, Triangle};
use crate::random::Rng;
use glam::Vec3;
use rayon::prelude::*;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The same triangle, or both miss.
    Agree,
    /// Different triangles at the same t within the error bounds.
    Tie,
    /// Different answers, each within the f32 test's rounding of a triangle edge.
    Rounding,
    Mismatch,
}

/// How far past a triangle the reference is asked again for the next one, at most.
const MAX_SKIPS: usize = 16;

/// Classifies `got` (a tested intersector's closest hit) against `reference` (the f64 closest
/// hit of the same ray through `accel`). `triangles` are in scene order.
pub fn classify<A: Accel>(
    accel: &A,
    triangles: &[Triangle],
    ray: &Ray,
    got: Option<Hit>,
    reference: Option<Hit>,
) -> Verdict {
    match (got, reference) {
        (None, None) => return Verdict::Agree,
        (Some(g), Some(r)) if g.triangle == r.triangle => return Verdict::Agree,
        _ => {}
    }
    let shear = Shear64::new(ray);
    let eval = |i: u64| evaluate(&shear, &triangles[i as usize]);
    let explained = |ev: &Evaluation| ev.edge_ambiguous() || ev.t_ambiguous(ray.tmin, ray.tmax);
    // The tested hit must be one the reference hits, or one rounding could produce.
    let (limit, got_eval) = match got {
        Some(g) => {
            let ev = eval(g.triangle);
            let hit = ev.inside && ev.t > ray.tmin as f64 && ev.t < ray.tmax as f64;
            if !hit && !explained(&ev) {
                return Verdict::Mismatch;
            }
            (ev.t - (ev.f32_t_error + ev.t_error), Some(ev))
        }
        None => (f64::INFINITY, None),
    };
    // Every reference hit the tested answer skipped (closer than its hit) must be one that
    // rounding could lose.
    let mut next = reference;
    for _ in 0..MAX_SKIPS {
        let Some(h) = next else {
            return verdict_for(got_eval, reference.map(|r| eval(r.triangle)));
        };
        let ev = eval(h.triangle);
        if ev.t >= limit {
            return verdict_for(got_eval, reference.map(|r| eval(r.triangle)));
        }
        if !explained(&ev) {
            return Verdict::Mismatch;
        }
        let past = Ray::segment(ray.origin, ray.direction, h.t.next_up(), ray.tmax);
        next = accel.closest_hit::<ReferenceF64, _>(&past, &mut NoStats);
    }
    Verdict::Mismatch
}

fn verdict_for(got: Option<Evaluation>, reference: Option<Evaluation>) -> Verdict {
    match (got, reference) {
        (Some(g), Some(r))
            if g.inside
                && r.inside
                && (g.t - r.t).abs() <= g.f32_t_error + g.t_error + r.f32_t_error + r.t_error =>
        {
            Verdict::Tie
        }
        _ => Verdict::Rounding,
    }
}

/// Agreement of one intersector with the reference over a set of rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Agreement {
    pub rays: u64,
    /// Rays the reference finds a hit for.
    pub reference_hits: u64,
    pub agree: u64,
    pub ties: u64,
    pub rounding: u64,
    pub mismatches: u64,
    /// Largest |t − t_ref| / t_ref over agreeing hits.
    pub max_rel_t_error: f64,
}

impl Agreement {
    pub fn add(&mut self, o: &Agreement) {
        self.rays += o.rays;
        self.reference_hits += o.reference_hits;
        self.agree += o.agree;
        self.ties += o.ties;
        self.rounding += o.rounding;
        self.mismatches += o.mismatches;
        self.max_rel_t_error = self.max_rel_t_error.max(o.max_rel_t_error);
    }

    pub fn mismatch_rate(&self) -> f64 {
        self.mismatches as f64 / self.rays.max(1) as f64
    }
}

/// Closest hits of the f64 reference through `accel`.
pub fn reference_hits<A: Accel>(accel: &A, rays: &[Ray]) -> Vec<Option<Hit>> {
    rays.par_iter()
        .map(|r| accel.closest_hit::<ReferenceF64, _>(r, &mut NoStats))
        .collect()
}

/// Traces `rays` with `I` through `accel` and classifies every answer against `reference`
/// (from `reference_hits` over the same rays, through `reference_accel`, which may be another
/// structure over the same triangles).
pub fn agreement<A: Accel, R: Accel, I: Intersector>(
    accel: &A,
    reference_accel: &R,
    triangles: &[Triangle],
    rays: &[Ray],
    reference: &[Option<Hit>],
) -> Agreement {
    rays.par_iter()
        .zip(reference)
        .with_min_len(256)
        .fold(Agreement::default, |mut acc, (ray, &r)| {
            let got = accel.closest_hit::<I, _>(ray, &mut NoStats);
            acc.rays += 1;
            acc.reference_hits += u64::from(r.is_some());
            match classify(reference_accel, triangles, ray, got, r) {
                Verdict::Agree => {
                    acc.agree += 1;
                    if let (Some(g), Some(r)) = (got, r) {
                        let t = evaluate(&Shear64::new(ray), &triangles[r.triangle as usize]).t;
                        acc.max_rel_t_error = acc.max_rel_t_error.max((g.t as f64 - t).abs() / t);
                    }
                }
                Verdict::Tie => acc.ties += 1,
                Verdict::Rounding => acc.rounding += 1,
                Verdict::Mismatch => acc.mismatches += 1,
            }
            acc
        })
        .reduce(Agreement::default, |mut a, b| {
            a.add(&b);
            a
        })
}

/// Random rays for a scene: from inside its box in random directions, from outside aimed at
/// random points of random triangles, aimed (to f32 precision) at vertices and at edge
/// midpoints, and segments of random length.
pub fn random_rays(triangles: &[Triangle], bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    if triangles.is_empty() {
        return Vec::new();
    }
    let size = bounds.diagonal().max(1e-3);
    let center = bounds.center();
    (0..n as u64)
        .into_par_iter()
        .map(|i| {
            let mut rng = Rng::for_case(seed, i);
            let mut in_box = || {
                let u = Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32);
                bounds.min + (bounds.max - bounds.min) * u
            };
            let o = in_box();
            let tri = &triangles[(rng.below(triangles.len() as u64)) as usize];
            let dir = rng.in_ball().as_vec3();
            let ray = match i % 5 {
                0 => Ray::new(o, dir),
                1 => {
                    let (u, v) = (rng.unit() as f32, rng.unit() as f32);
                    let (u, v) = if u + v > 1.0 {
                        (1.0 - u, 1.0 - v)
                    } else {
                        (u, v)
                    };
                    let target = tri.point(u, v);
                    let from = center + rng.in_ball().as_vec3().normalize_or_zero() * size;
                    Ray::new(from, target - from)
                }
                2 => Ray::new(o, tri.v[rng.below(3) as usize] - o),
                3 => {
                    let k = rng.below(3) as usize;
                    let mid = (tri.v[k] + tri.v[(k + 1) % 3]) * 0.5;
                    Ray::new(o, mid - o)
                }
                _ => Ray::segment(o, dir, 0.0, size * rng.unit() as f32 * 0.5),
            };
            if ray.is_valid() {
                ray
            } else {
                Ray::new(o, Vec3::X)
            }
        })
        .collect()
}
