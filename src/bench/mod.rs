//! The benchmark behind `bvhlab bench`: best-of-several build times and SAH cost, then
//! Mrays/s on the standard primary, shadow and diffuse ray sets of a view.

pub mod accuracy;
pub mod compare;
pub mod frames;
pub mod plot;
pub mod rays;
pub mod stress;

use crate::accel::bvh::packet::PACKET_SIZE;
use crate::accel::bvh::{BuildError, BuildReport, build};
use crate::accel::{Accel, BuildParams, Bvh, NoStats};
#[cfg(feature = "embree")]
use crate::geometry::Watertight;
use crate::geometry::{Intersector, IntersectorKind, Ray};
use crate::scene::{Camera, Scene};
use glam::Vec3;
use rayon::prelude::*;
use rays::RaySets;
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub struct BenchConfig {
    pub camera: Camera,
    pub light: Vec3,
    pub width: u32,
    pub height: u32,
    pub params: BuildParams,
    /// Builds to time (the best counts).
    pub builds: u32,
    /// Runs over each ray set (the best counts).
    pub runs: u32,
    /// The ray–triangle test of the timed runs (the ray sets are always generated with the
    /// watertight default, so every intersector traces the same rays).
    pub intersector: IntersectorKind,
    /// Also build and trace with Embree, on the same rays and threads.
    pub embree: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Build(#[from] BuildError),
    #[error("{0}")]
    Peer(String),
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RaySetResult {
    pub rays: usize,
    /// Hits for closest-hit sets, occluded rays for the shadow set.
    pub hits: usize,
    pub best: Duration,
}

impl RaySetResult {
    pub fn mrays_per_s(&self) -> f64 {
        let s = self.best.as_secs_f64();
        if s > 0.0 {
            self.rays as f64 / s / 1e6
        } else {
            0.0
        }
    }
}

#[derive(Clone, Debug)]
pub struct BenchResult {
    pub scene: String,
    pub triangles: usize,
    pub threads: usize,
    pub intersector: IntersectorKind,
    pub report: BuildReport,
    pub primary: RaySetResult,
    /// The primary rays again, traced in packets of 8 × 8 pixels.
    pub primary_packets: RaySetResult,
    pub diffuse: RaySetResult,
    pub shadow: RaySetResult,
    pub peer: Option<PeerResult>,
}

/// A peer structure timed on the same ray sets and threads.
#[derive(Clone, Debug)]
pub struct PeerResult {
    pub name: &'static str,
    /// The best of the builds.
    pub build: Duration,
    pub primary: RaySetResult,
    pub primary_packets: RaySetResult,
    pub diffuse: RaySetResult,
    pub shadow: RaySetResult,
    /// Primary rays that name another triangle than bvhlab at a depth within
    /// `TIE_ULPS` of bvhlab's: ties, mostly overlapping coplanar triangles.
    pub tied_primary_hits: usize,
    /// Primary rays whose hit really differs from bvhlab's: a hit against a miss, or a
    /// depth further than `TIE_ULPS` apart.
    pub differing_primary_hits: usize,
}

/// Runs the benchmark on the current rayon thread pool.
pub fn run(scene: &Scene, cfg: &BenchConfig) -> Result<BenchResult, BenchError> {
    let (bvh, report) = best_build(
        cfg.builds,
        || build(&scene.triangles, &cfg.params),
        |(_, report)| report.build_time,
    )?;
    let sets = RaySets::standard(&bvh, scene, &cfg.camera, cfg.light, cfg.width, cfg.height);
    let [primary, diffuse, shadow] =
        crate::with_intersector!(cfg.intersector, I => time_sets::<_, I>(&bvh, &sets, cfg.runs));
    let primary_packets = crate::with_intersector!(cfg.intersector, I => {
        time_packets::<_, I>(&bvh, &sets.primary_tiles, cfg.runs)
    });
    let peer = if cfg.embree {
        Some(run_embree(&bvh, scene, cfg, &sets)?)
    } else {
        None
    };
    Ok(BenchResult {
        scene: scene.name.clone(),
        triangles: scene.triangles.len(),
        threads: rayon::current_num_threads(),
        intersector: cfg.intersector,
        report,
        primary,
        primary_packets,
        diffuse,
        shadow,
        peer,
    })
}

/// The fastest of `builds` (at least one) builds, by the time `took` reads off each.
fn best_build<T, E>(
    builds: u32,
    mut build: impl FnMut() -> Result<T, E>,
    took: impl Fn(&T) -> Duration,
) -> Result<T, E> {
    let mut best = build()?;
    for _ in 1..builds {
        let next = build()?;
        if took(&next) < took(&best) {
            best = next;
        }
    }
    Ok(best)
}

/// Whether this build can run Embree beside bvhlab.
pub const EMBREE_AVAILABLE: bool = cfg!(feature = "embree");

pub const EMBREE_MISSING: &str = "this bvhlab was built without Embree: install libembree-dev \
     and build with `cargo build --release --features embree`";

#[cfg(not(feature = "embree"))]
fn run_embree(_: &Bvh, _: &Scene, _: &BenchConfig, _: &RaySets) -> Result<PeerResult, BenchError> {
    Err(BenchError::Peer(EMBREE_MISSING.into()))
}

/// Embree on the same ray sets, with as many build and trace threads as bvhlab had.
#[cfg(feature = "embree")]
fn run_embree(
    bvh: &Bvh,
    scene: &Scene,
    cfg: &BenchConfig,
    sets: &RaySets,
) -> Result<PeerResult, BenchError> {
    use crate::accel::embree::Embree;
    let threads = rayon::current_num_threads();
    let embree = best_build(
        cfg.builds,
        || Embree::build(&scene.triangles, threads).map_err(BenchError::Peer),
        |e| e.build_time,
    )?;
    let [primary, diffuse, shadow] = time_sets::<_, Watertight>(&embree, sets, cfg.runs);
    let primary_packets = time_packets::<_, Watertight>(&embree, &sets.primary_tiles, cfg.runs);
    let (tied_primary_hits, differing_primary_hits) = sets
        .primary
        .par_iter()
        .map(|r| {
            let ours = bvh.closest_hit::<Watertight, _>(r, &mut NoStats);
            let theirs = embree.closest_hit::<Watertight, _>(r, &mut NoStats);
            match (ours, theirs) {
                (Some(a), Some(b)) if a.triangle == b.triangle => (0, 0),
                (Some(a), Some(b)) if ulps_apart(a.t, b.t) <= TIE_ULPS => (1, 0),
                (None, None) => (0, 0),
                _ => (0, 1),
            }
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    Ok(PeerResult {
        name: "Embree 3",
        build: embree.build_time,
        primary,
        primary_packets,
        diffuse,
        shadow,
        tied_primary_hits,
        differing_primary_hits,
    })
}

/// Two hits this close in depth are a tie: f32 rounding of two nearly coplanar triangles'
/// distances, decided differently by the two ray–triangle tests.
#[cfg(feature = "embree")]
const TIE_ULPS: u32 = 16;

#[cfg(feature = "embree")]
fn ulps_apart(a: f32, b: f32) -> u32 {
    if a.is_sign_negative() != b.is_sign_negative() {
        return u32::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}

/// Primary, diffuse and shadow sets traced `runs` times each with the intersector `I`.
pub fn time_sets<A: Accel, I: Intersector>(
    accel: &A,
    sets: &RaySets,
    runs: u32,
) -> [RaySetResult; 3] {
    let runs = runs.max(1);
    let primary = time_set(&sets.primary, runs, |r| {
        accel.closest_hit::<I, _>(r, &mut NoStats).is_some()
    });
    let diffuse = time_set(&sets.diffuse, runs, |r| {
        accel.closest_hit::<I, _>(r, &mut NoStats).is_some()
    });
    let shadow = time_set(&sets.shadow, runs, |r| {
        accel.any_hit::<I, _>(r, &mut NoStats)
    });
    [primary, diffuse, shadow]
}

/// Closest hits of `rays` in packets of `PACKET_SIZE` consecutive rays, `runs` times.
pub fn time_packets<A: Accel, I: Intersector>(accel: &A, rays: &[Ray], runs: u32) -> RaySetResult {
    time_chunks(rays, runs, 4 * PACKET_SIZE, |chunk| {
        let mut hits = [None; 4 * PACKET_SIZE];
        let hits = &mut hits[..chunk.len()];
        accel.closest_hits::<I>(chunk, hits);
        hits.iter().filter(|h| h.is_some()).count()
    })
}

/// Traces `rays` `runs` times in parallel, one ray at a time; the best time and the hit count.
fn time_set(rays: &[Ray], runs: u32, trace: impl Fn(&Ray) -> bool + Sync) -> RaySetResult {
    time_chunks(rays, runs, 256, |chunk| {
        chunk.iter().filter(|r| trace(r)).count()
    })
}

/// Runs `trace` over `rays` in chunks of `chunk` rays on the thread pool, `runs` times; the
/// best time and the hits `trace` counted.
fn time_chunks(
    rays: &[Ray],
    runs: u32,
    chunk: usize,
    trace: impl Fn(&[Ray]) -> usize + Sync,
) -> RaySetResult {
    let mut result = RaySetResult {
        rays: rays.len(),
        hits: 0,
        best: Duration::MAX,
    };
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        result.hits = rays.par_chunks(chunk).map(&trace).sum();
        result.best = result.best.min(start.elapsed());
    }
    result
}

impl BenchResult {
    pub fn to_json(&self) -> serde_json::Value {
        let set = |r: &RaySetResult, hits: &str| {
            serde_json::json!({
                "rays": r.rays,
                hits: r.hits,
                "mrays_per_s": round3(r.mrays_per_s()),
            })
        };
        let t = &self.report.tree;
        serde_json::json!({
            "scene": self.scene,
            "triangles": self.triangles,
            "threads": self.threads,
            "intersector": self.intersector.label(),
            "builder": self.report.params.strategy.label(),
            "buckets": self.report.params.buckets,
            "max_leaf_size": self.report.params.max_leaf_size,
            "build_ms": round3(self.report.build_ms()),
            "sah_cost": round3(t.sah_cost),
            "nodes": t.nodes,
            "leaves": t.leaves,
            "max_leaf_depth": t.max_leaf_depth,
            "primary": set(&self.primary, "hits"),
            "primary_packets": set(&self.primary_packets, "hits"),
            "diffuse": set(&self.diffuse, "hits"),
            "shadow": set(&self.shadow, "occluded"),
            "peer": self.peer.as_ref().map(|p| serde_json::json!({
                "name": p.name,
                "build_ms": round3(p.build.as_secs_f64() * 1e3),
                "primary": set(&p.primary, "hits"),
                "primary_packets": set(&p.primary_packets, "hits"),
                "diffuse": set(&p.diffuse, "hits"),
                "shadow": set(&p.shadow, "occluded"),
                "tied_primary_hits": p.tied_primary_hits,
                "differing_primary_hits": p.differing_primary_hits,
            })),
        })
    }
}

fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}
