//! The slab test against exact rational arithmetic (i128): ±0 direction components, origins on
//! slab planes, rays touching a box exactly at a corner, edge or face. It must be conservative
//! (Ize 2013), exact on axis-parallel rays, and miss boxes missed by a clear margin.

use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::simd::WideRay;
use crate::geometry::simd::slab::fused_entry;
use crate::geometry::{Aabb, Ray, gamma};
use crate::random::Rng;
use glam::Vec3;
use std::cmp::Ordering;

/// Exact values are integers at this scale: every f32 with 2^-16 ≤ |x| ≤ 2^20 is an integer
/// multiple of 2^-40, and products of two such integers fit in i128.
const SCALE_BITS: i32 = 40;
pub const MIN_MAGNITUDE: f32 = 1.0 / 65536.0;
pub const MAX_MAGNITUDE: f32 = 1_048_576.0;

/// Whether `x` lies in the domain the exact reference handles.
pub fn in_domain(x: f32) -> bool {
    x == 0.0 || (MIN_MAGNITUDE..=MAX_MAGNITUDE).contains(&x.abs())
}

fn to_int(x: f32) -> i128 {
    // Exact: x · 2^40 is an integer below 2^61 for x in the domain.
    (x as f64 * 2f64.powi(SCALE_BITS)) as i128
}

/// An extended rational num/den (den > 0), or ±∞.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ext {
    NegInf,
    Fin(i128, i128),
    PosInf,
}

impl Ext {
    fn of_f32(x: f32) -> Ext {
        if x == f32::INFINITY {
            Ext::PosInf
        } else if x == f32::NEG_INFINITY {
            Ext::NegInf
        } else {
            Ext::Fin(to_int(x), 1 << SCALE_BITS)
        }
    }

    fn cmp(self, o: Ext) -> Ordering {
        match (self, o) {
            (Ext::NegInf, Ext::NegInf) | (Ext::PosInf, Ext::PosInf) => Ordering::Equal,
            (Ext::NegInf, _) | (_, Ext::PosInf) => Ordering::Less,
            (_, Ext::NegInf) | (Ext::PosInf, _) => Ordering::Greater,
            (Ext::Fin(a, b), Ext::Fin(c, d)) => (a * d).cmp(&(c * b)),
        }
    }

    fn max(self, o: Ext) -> Ext {
        if self.cmp(o) == Ordering::Less {
            o
        } else {
            self
        }
    }

    fn min(self, o: Ext) -> Ext {
        if self.cmp(o) == Ordering::Greater {
            o
        } else {
            self
        }
    }

    fn to_f64(self) -> f64 {
        match self {
            Ext::NegInf => f64::NEG_INFINITY,
            Ext::PosInf => f64::INFINITY,
            Ext::Fin(n, d) => n as f64 / d as f64,
        }
    }
}

/// The exact answer of the closed slab test: the smallest t in [tmin, tmax] at which the
/// ray is inside the closed box, or `None`. All inputs must be `in_domain` (or ±∞ for tmin
/// and tmax).
pub fn exact_entry(b: &Aabb, ray: &Ray, tmin: f32, tmax: f32) -> Option<f64> {
    let mut lo = Ext::of_f32(tmin);
    let mut hi = Ext::of_f32(tmax);
    for a in 0..3 {
        let (o, d) = (to_int(ray.origin[a]), to_int(ray.direction[a]));
        let (bmin, bmax) = (to_int(b.min[a]), to_int(b.max[a]));
        if d == 0 {
            // Parallel to the slab: inside it for every t, or for none.
            if o < bmin || o > bmax {
                return None;
            }
            continue;
        }
        let (t0, t1) = if d > 0 {
            (Ext::Fin(bmin - o, d), Ext::Fin(bmax - o, d))
        } else {
            (Ext::Fin(o - bmax, -d), Ext::Fin(o - bmin, -d))
        };
        lo = lo.max(t0);
        hi = hi.min(t1);
    }
    (lo.cmp(hi) != Ordering::Greater).then(|| lo.to_f64())
}

/// The f32 slab test under test, in its plain form (the BVH2's, and the SIMD kernels'
/// without FMA).
pub fn f32_entry(b: &Aabb, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
    let e = slab_entry(&[b.min, b.max], &SlabRay::new(ray), tmin, tmax);
    (e != f32::INFINITY).then_some(e)
}

/// The f32 slab test as the AVX-512 walks take it: the fused form, or the plain
/// one for a ray whose fused constants are not usable (`FusedPlanes`).
pub fn fused_f32_entry(b: &Aabb, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
    let mut rows = [[0.0f32; 1]; 6];
    for a in 0..3 {
        rows[a][0] = b.min[a];
        rows[a + 3][0] = b.max[a];
    }
    let e = fused_entry(&rows, 0, &WideRay::new(ray), tmin, tmax);
    (e != f32::INFINITY).then_some(e)
}

/// Violations of the slab test's properties over a set of cases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlabReport {
    pub cases: u64,
    /// Exact touches, of which the f32 test missed `missed` (must be 0).
    pub touching: u64,
    pub missed: u64,
    /// f32 entry beyond the exact entry · (1 + 2γ(3)) (must be 0).
    pub late_entry: u64,
    /// Axis-parallel rays over [0, ∞) where f32 and exact disagree at all (must be 0).
    pub axis_parallel: u64,
    pub axis_parallel_wrong: u64,
    /// Misses by a clear margin (exit < entry · (1 − 1e-4)) reported as hits (must be 0).
    pub clear_misses: u64,
    pub clear_misses_hit: u64,
    /// Cases with a NaN in the result (must be 0).
    pub nan: u64,
}

impl SlabReport {
    pub fn failures(&self) -> u64 {
        self.missed + self.late_entry + self.axis_parallel_wrong + self.clear_misses_hit + self.nan
    }

    pub fn add(&mut self, o: &SlabReport) {
        self.cases += o.cases;
        self.touching += o.touching;
        self.missed += o.missed;
        self.late_entry += o.late_entry;
        self.axis_parallel += o.axis_parallel;
        self.axis_parallel_wrong += o.axis_parallel_wrong;
        self.clear_misses += o.clear_misses;
        self.clear_misses_hit += o.clear_misses_hit;
        self.nan += o.nan;
    }

    /// Checks one case in both forms and records it: a property broken by either counts.
    pub fn check(&mut self, b: &Aabb, ray: &Ray, tmin: f32, tmax: f32) {
        let mut plain = SlabReport::default();
        plain.check_form(f32_entry, b, ray, tmin, tmax);
        let mut fused = SlabReport::default();
        fused.check_form(fused_f32_entry, b, ray, tmin, tmax);
        let (p, f) = (&plain, &fused);
        self.add(&SlabReport {
            cases: 1,
            touching: p.touching,
            missed: p.missed.max(f.missed),
            late_entry: p.late_entry.max(f.late_entry),
            axis_parallel: p.axis_parallel,
            axis_parallel_wrong: p.axis_parallel_wrong.max(f.axis_parallel_wrong),
            clear_misses: p.clear_misses,
            clear_misses_hit: p.clear_misses_hit.max(f.clear_misses_hit),
            nan: p.nan.max(f.nan),
        });
    }

    fn check_form(
        &mut self,
        entry: fn(&Aabb, &Ray, f32, f32) -> Option<f32>,
        b: &Aabb,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
    ) {
        self.cases += 1;
        let exact = exact_entry(b, ray, tmin, tmax);
        let got = entry(b, ray, tmin, tmax);
        if got.is_some_and(f32::is_nan) {
            self.nan += 1;
        }
        if let Some(t) = exact {
            self.touching += 1;
            match got {
                None => self.missed += 1,
                Some(e) => {
                    let allowed = if t >= 0.0 {
                        t * (1.0 + 2.0 * gamma(3) as f64)
                    } else {
                        t * (1.0 - 2.0 * gamma(3) as f64)
                    };
                    if e as f64 > allowed.max(tmin as f64) {
                        self.late_entry += 1;
                    }
                }
            }
        } else if got.is_some() && clearly_missed(b, ray, tmin, tmax) {
            self.clear_misses_hit += 1;
        }
        if exact.is_none() && clearly_missed(b, ray, tmin, tmax) {
            self.clear_misses += 1;
        }
        let zeros = (0..3).filter(|&a| ray.direction[a] == 0.0).count();
        if zeros == 2 && tmin == 0.0 && tmax == f32::INFINITY {
            self.axis_parallel += 1;
            if exact.is_some() != got.is_some() {
                self.axis_parallel_wrong += 1;
            }
        }
    }
}

/// Whether the exact ray misses the box by a clear relative margin: shrinking the box by
/// 1e-4 of its size and of the distances involved still leaves no overlap... decided by
/// growing the box by that margin and asking the exact test again.
fn clearly_missed(b: &Aabb, ray: &Ray, tmin: f32, tmax: f32) -> bool {
    let size = b.extent().max_element().max(1.0);
    let reach = (b.center() - ray.origin).length() + size;
    let margin = 1e-4 * (size + reach);
    let grown = Aabb::new(b.min - Vec3::splat(margin), b.max + Vec3::splat(margin));
    let in_dom = |v: Vec3| v.to_array().iter().all(|&x| in_domain(x));
    if !in_dom(grown.min) || !in_dom(grown.max) {
        return false;
    }
    let widen = |t: f32, up: bool| {
        if t.is_infinite() || t == 0.0 {
            t
        } else {
            let w = t.abs() * 1e-4 + 1e-3;
            if up { t + w } else { t - w }
        }
    };
    let (lo, hi) = (widen(tmin, false), widen(tmax, true));
    if !(in_domain(lo) || lo.is_infinite()) || !(in_domain(hi) || hi.is_infinite()) {
        return false;
    }
    exact_entry(&grown, ray, lo, hi).is_none()
}

/// A value of the domain: sign, exponent in [-16, 19] and a random significand; with
/// probability 1/4 a coarse value (few significant bits) so that coincidences happen.
fn value(rng: &mut Rng) -> f32 {
    let sign = if rng.coin() { 1.0 } else { -1.0 };
    let e = rng.below(36) as i32 - 16;
    let m = if rng.below(4) == 0 {
        1.0 + rng.below(8) as f32 / 8.0
    } else {
        1.0 + (rng.next_u64() >> 41) as f32 / (1u64 << 23) as f32
    };
    sign * m * 2f32.powi(e)
}

/// Case `i` of the random slab stress: a random box, a ray with 0–2 zero direction
/// components of random sign, an origin on a slab plane half of the time, and a ray built to
/// touch a corner, an edge or a face exactly a third of the time.
pub fn case(i: u64, seed: u64) -> (Aabb, Ray, f32, f32) {
    let mut rng = Rng::for_case(seed, i);
    let (p, q) = (
        Vec3::new(value(&mut rng), value(&mut rng), value(&mut rng)),
        Vec3::new(value(&mut rng), value(&mut rng), value(&mut rng)),
    );
    let b = Aabb::new(p.min(q), p.max(q));
    let zeros = rng.below(3) as usize;
    let mut d = Vec3::new(value(&mut rng), value(&mut rng), value(&mut rng));
    let mut axes = [0usize, 1, 2];
    // Shuffle so any axes can be the zero ones.
    for k in (1..3).rev() {
        axes.swap(k, rng.below(k as u64 + 1) as usize);
    }
    for &a in &axes[..zeros] {
        d[a] = rng.signed_zero();
    }
    let mut o = Vec3::new(value(&mut rng), value(&mut rng), value(&mut rng));
    let kind = rng.below(3);
    if kind == 1 {
        // Origin exactly on a slab plane (of a zero axis when there is one).
        let a = if zeros > 0 {
            axes[0]
        } else {
            rng.below(3) as usize
        };
        o[a] = if rng.coin() { b.min[a] } else { b.max[a] };
    } else if kind == 2 {
        // Through a corner, an edge point or a face point of the box, exactly at t = 2^j.
        let mut target = Vec3::ZERO;
        let on_boundary = 1 + rng.below(3) as usize;
        for (k, &a) in axes.iter().enumerate() {
            target[a] = if k < on_boundary {
                if rng.coin() { b.min[a] } else { b.max[a] }
            } else {
                b.min[a] + (b.max[a] - b.min[a]) * 0.5
            };
        }
        let t0 = 2f32.powi(rng.below(9) as i32 - 4);
        let origin = target - d * t0;
        // Keep it only if it is exact: then the ray passes through `target` at t0.
        let exact = (0..3).all(|a| {
            (origin[a] as f64 + d[a] as f64 * t0 as f64) == target[a] as f64 && in_domain(origin[a])
        });
        if exact {
            o = origin;
        }
    }
    let ray = Ray::new(o, d);
    let (tmin, tmax) = match rng.below(4) {
        0 | 1 => (0.0, f32::INFINITY),
        2 => (0.0, value(&mut rng).abs()),
        _ => {
            let (x, y) = (value(&mut rng).abs(), value(&mut rng).abs());
            (x.min(y), x.max(y))
        }
    };
    (b, ray, tmin, tmax)
}

/// Runs `n` random cases.
pub fn run(n: u64, seed: u64) -> SlabReport {
    use rayon::prelude::*;
    (0..n)
        .into_par_iter()
        .fold(SlabReport::default, |mut r, i| {
            let (b, ray, tmin, tmax) = case(i, seed);
            r.check(&b, &ray, tmin, tmax);
            r
        })
        .reduce(SlabReport::default, |mut a, b| {
            a.add(&b);
            a
        })
}

/// Mean time of one slab test (ns) on general rays and on axis-parallel rays (two ±0
/// components), over the same random boxes. Measured for `bvhlab stress`, never asserted.
pub fn timing(tests: u64, seed: u64) -> (f64, f64) {
    const N: usize = 1024;
    let mut rng = Rng::for_case(seed, 0);
    let boxes: Vec<[Vec3; 2]> = (0..N)
        .map(|_| {
            let c = rng.in_ball().as_vec3() * 10.0;
            let e = (rng.in_ball().as_vec3().abs() + Vec3::splat(0.1)) * 2.0;
            [c - e, c + e]
        })
        .collect();
    let general: Vec<SlabRay> = (0..N)
        .map(|_| {
            let d = rng.in_ball().as_vec3();
            SlabRay::new(&Ray::new(rng.in_ball().as_vec3() * 10.0, d))
        })
        .collect();
    let axis: Vec<SlabRay> = (0..N)
        .map(|_| {
            let mut d = Vec3::new(rng.signed_zero(), rng.signed_zero(), rng.signed_zero());
            d[rng.below(3) as usize] = if rng.coin() { 1.0 } else { -1.0 };
            SlabRay::new(&Ray::new(rng.in_ball().as_vec3() * 10.0, d))
        })
        .collect();
    let time = |rays: &[SlabRay]| {
        let start = std::time::Instant::now();
        let mut hits = 0u64;
        for i in 0..tests as usize {
            let e = slab_entry(
                std::hint::black_box(&boxes[i % N]),
                std::hint::black_box(&rays[(i / N + i) % N]),
                0.0,
                f32::INFINITY,
            );
            hits += u64::from(e != f32::INFINITY);
        }
        std::hint::black_box(hits);
        start.elapsed().as_secs_f64() * 1e9 / tests.max(1) as f64
    };
    // Warm up, then measure each twice and keep the faster.
    time(&general);
    let g = time(&general).min(time(&general));
    let a = time(&axis).min(time(&axis));
    (g, a)
}
