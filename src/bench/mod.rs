//! The benchmark behind `bvhlab bench`: best-of-several build times, memory and (for a
//! BVH) SAH cost, then Mrays/s and the mean work per ray on the standard primary, shadow
//! and diffuse ray sets of a view, for one structure or every structure on the same rays.

pub mod accuracy;
pub mod compare;
pub mod cpu_time;
pub mod json;
pub mod peers;
pub use peers::{
    EMBREE_AVAILABLE, EMBREE_MISSING, EmbreeQuality, TINYBVH_AVAILABLE, TINYBVH_MISSING,
};
pub mod plot;
pub mod rank_correlation;
pub mod rays;
pub mod rotation;
pub mod sah_check;
pub mod sah_scatter;
pub mod scaling;
pub mod stress;
pub mod tradeoff;

use crate::accel::bvh::packet::PACKET_SIZE;
use crate::accel::bvh::wide::{Lanes, MortonScratch, NodeWidth, WideBvh};
use crate::accel::bvh::{BuildParams, BuildReport, Strategy};
pub use crate::accel::sah_check::MeanWork;
use crate::accel::sah_check::mean_work_of;
use crate::accel::structure::{self, AccelKind, Built, Structure, StructureError};
use crate::accel::{Accel, NoStats, StructureParams, StructureReport};
use crate::geometry::{Intersector, IntersectorKind, Ray, Triangle};
use crate::scene::{Camera, Scene};
use glam::Vec3;
use rayon::prelude::*;
use rays::RaySets;
use sah_check::SahCheck;
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub struct BenchConfig {
    pub camera: Camera,
    pub light: Vec3,
    pub width: u32,
    pub height: u32,
    /// The structure (`params.kind`) and the parameters of every structure.
    pub params: StructureParams,
    /// Builds to time (the best counts).
    pub builds: u32,
    /// Runs over each ray set (the best counts).
    pub runs: u32,
    /// The ray–triangle test of the timed runs (the ray sets are always generated with the
    /// watertight default, so every intersector traces the same rays).
    pub intersector: IntersectorKind,
    /// Also build and trace with Embree, on the same rays and threads.
    pub embree: bool,
    /// Also Embree with its robust flag (`RTC_SCENE_FLAG_ROBUST`), the peer with the
    /// guarantee bvhlab's watertight test gives.
    pub embree_robust: bool,
    /// Which of Embree's builders builds those peers.
    pub embree_quality: EmbreeQuality,
    /// Also tinybvh's BVH8_CPU, from its default build and from its SBVH.
    pub tinybvh: bool,
    /// How the SAH check finds the EPO.
    pub epo: crate::accel::epo::EpoWay,
}

#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Build(#[from] StructureError),
    #[error("{0}")]
    Peer(String),
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RaySetResult {
    pub rays: usize,
    /// Hits for closest-hit sets, occluded rays for the shadow set.
    pub hits: usize,
    pub best: Duration,
    /// Mean counters per ray (from one counting pass, not timed); `None` where not counted.
    pub mean: Option<MeanWork>,
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

    /// The faster of two timings of the same rays (the counted work of the first).
    pub fn best_of(self, other: RaySetResult) -> RaySetResult {
        RaySetResult {
            best: self.best.min(other.best),
            ..self
        }
    }

    /// Time per traversal step, from the timed run and the counted mean steps per ray:
    /// what one node visit costs, the measure a wider node trades against fewer steps.
    pub fn ns_per_step(&self, mean_nodes: f64) -> Option<f64> {
        let mrays = self.mrays_per_s();
        (mrays > 0.0 && mean_nodes > 0.0).then(|| 1e3 / mrays / mean_nodes)
    }
}

#[derive(Clone, Debug)]
pub struct BenchResult {
    pub scene: String,
    pub triangles: usize,
    pub threads: usize,
    pub intersector: IntersectorKind,
    pub params: StructureParams,
    pub report: StructureReport,
    /// The BVH's own report (SAH cost), for a BVH.
    pub bvh_report: Option<BuildReport>,
    /// Brute force over a large scene traces every `sampled`-th ray of each set only.
    pub sampled: usize,
    pub primary: RaySetResult,
    /// The primary rays again, traced in packets of 8 × 8 pixels.
    pub primary_packets: RaySetResult,
    pub diffuse: RaySetResult,
    pub shadow: RaySetResult,
    /// The SAH cost against the cost per ray measured, for structures with an SAH cost.
    pub sah_check: Option<SahCheck>,
    /// The peers timed beside bvhlab: Embree with its defaults, then robust, as asked.
    pub peers: Vec<PeerResult>,
    /// Under the two levels, the best of the builds' count of top-level rebuilds over the
    /// references where they are (`TwoLevel::rebuild_top_level`): the rebuild per frame.
    pub top_level_rebuild: Option<Duration>,
    /// A BVH4 or BVH8 built straight from the Morton order (`--direct-wide`), rebuilt over
    /// the same triangles into its own memory (`WideBvh::rebuild_morton`), as a scene that
    /// moves is rebuilt every frame: the best of the builds' count.
    pub wide_rebuild: Option<Duration>,
}

impl BenchResult {
    /// The tree's SAH cost: the BVH2's own, or the wide tree's.
    pub fn sah_cost(&self) -> Option<f64> {
        match &self.bvh_report {
            Some(b) => Some(b.tree.sah_cost),
            None => self.sah_check.as_ref().map(|c| c.predicted),
        }
    }

    /// References beyond one per triangle (spatial splits and pre-splits).
    pub fn duplicated_references(&self) -> usize {
        self.report.references.saturating_sub(self.report.triangles)
    }
}

/// A peer structure timed on the same ray sets and threads.
#[derive(Clone, Debug)]
pub struct PeerResult {
    pub name: String,
    /// The best of the builds.
    pub build: Duration,
    pub primary: RaySetResult,
    /// `None` for a peer without a packet query.
    pub primary_packets: Option<RaySetResult>,
    pub diffuse: RaySetResult,
    pub shadow: RaySetResult,
    /// Primary rays that name another triangle than bvhlab at a depth within
    /// `TIE_ULPS` of bvhlab's: ties, mostly overlapping coplanar triangles.
    pub tied_primary_hits: usize,
    /// Primary rays whose hit really differs from bvhlab's: a hit against a miss, or a
    /// depth further than `TIE_ULPS` apart.
    pub differing_primary_hits: usize,
    /// Of a peer's two levels, its top level's build alone (its meshes' already built).
    pub top_level_build: Option<Duration>,
    /// The peer's scene rebuilt after its vertices were marked changed, into the memory
    /// it kept (timed where bvhlab's `wide_rebuild` is): the best of the builds' count.
    pub rebuild: Option<Duration>,
    /// bvhlab's ray sets timed in turns with the peer's (`None` where bvhlab traced a
    /// sample of the rays: brute force over a large scene).
    pub bvhlab: Option<InTurns>,
}

/// bvhlab's timings taken in turns with a peer's: bvhlab's build, the peer's, bvhlab's
/// again, the builds' count of each, and likewise each ray set the runs' count of times, so
/// that both see the machine in the same state; the best of each. The ratios are taken
/// from these.
#[derive(Clone, Copy, Debug)]
pub struct InTurns {
    /// bvhlab's best build, each built just before one of the peer's.
    pub build: Duration,
    pub primary: RaySetResult,
    pub primary_packets: RaySetResult,
    pub diffuse: RaySetResult,
    pub shadow: RaySetResult,
}

/// Runs the benchmark of `cfg.params.kind` on the current rayon thread pool.
pub fn run(scene: &Scene, cfg: &BenchConfig) -> Result<BenchResult, BenchError> {
    let mut built = timed_build(scene, cfg, &cfg.params)?;
    let top_level_rebuild = time_top_level_rebuild(&mut built.structure, cfg.builds)?;
    let wide_rebuild = time_wide_rebuild(&mut built.structure, scene, &cfg.params, cfg.builds)?;
    let sets = RaySets::standard(
        &built.structure,
        scene,
        &cfg.camera,
        cfg.light,
        cfg.width,
        cfg.height,
    );
    let mut result = measure(scene, cfg, &cfg.params, &built, &sets);
    result.top_level_rebuild = top_level_rebuild;
    result.wide_rebuild = wide_rebuild;
    // bvhlab is timed again in turns with each peer, unless it traced a sample of the rays.
    let turns = result.sampled == 1;
    for (asked, robust) in [(cfg.embree, false), (cfg.embree_robust, true)] {
        if asked {
            let peer = peers::run_embree(&built.structure, scene, cfg, &sets, robust, turns)?;
            result.peers.push(peer);
        }
    }
    if cfg.tinybvh {
        result.peers.extend(peers::run_tinybvh(
            &built.structure,
            scene,
            cfg,
            &sets,
            turns,
        )?);
    }
    Ok(result)
}

/// Runs the benchmark of every structure in `kinds` on the same ray sets (made with a BVH
/// built with `cfg.params.bvh`), calling `done` after each.
pub fn run_all(
    scene: &Scene,
    cfg: &BenchConfig,
    kinds: &[AccelKind],
    done: &mut dyn FnMut(&BenchResult),
) -> Result<Vec<BenchResult>, BenchError> {
    let each = kinds
        .iter()
        .map(|&kind| StructureParams { kind, ..cfg.params })
        .collect();
    run_each(scene, cfg, each, done)
}

/// The builders `bench builders` compares, as Karras and Aila's Table 1 does: every
/// strategy, and the fast ones (LBVH, LBVH + treelets, binned SAH) again with pre-splits
/// (`base.presplit`, or `accuracy::PRESPLIT_BUDGET` if it is 0). The other parameters come
/// from `base`.
pub fn builder_variants(base: &BuildParams) -> Vec<BuildParams> {
    let budget = if base.presplit > 0.0 {
        base.presplit
    } else {
        accuracy::PRESPLIT_BUDGET
    };
    let mut out = Vec::new();
    for strategy in Strategy::ALL {
        let plain = BuildParams {
            strategy,
            presplit: 0.0,
            ..*base
        };
        out.push(plain);
        if strategy.takes_presplit() {
            out.push(BuildParams {
                presplit: budget,
                ..plain
            });
        }
    }
    out
}

/// A builder's name in tables and plots: the strategy, and whether it pre-splits.
pub fn builder_label(p: &BuildParams) -> String {
    if p.presplit > 0.0 && p.strategy.takes_presplit() {
        format!("{} (pre-split)", p.strategy.label())
    } else if p.strategy == Strategy::Sbvh && p.overlap_penalty > 0.0 {
        // (No comma: the label is a CSV field.)
        format!(
            "{} (κ = {}; budget {} N)",
            p.strategy.label(),
            p.overlap_penalty,
            p.split_budget
        )
    } else {
        p.strategy.label().to_string()
    }
}

/// Runs the benchmark of a BVH built with each of `builders` on the same ray sets, calling
/// `done` after each.
pub fn run_builders(
    scene: &Scene,
    cfg: &BenchConfig,
    builders: &[BuildParams],
    done: &mut dyn FnMut(&BenchResult),
) -> Result<Vec<BenchResult>, BenchError> {
    // Each builder's BVH2 is traced as it is, or collapsed to the wide layout asked for.
    let kind = if cfg.params.kind.is_wide() {
        cfg.params.kind
    } else {
        AccelKind::Bvh
    };
    let each = builders
        .iter()
        .map(|&bvh| StructureParams {
            kind,
            bvh,
            ..cfg.params
        })
        .collect();
    run_each(scene, cfg, each, done)
}

/// Runs the benchmark of each structure in `each` on the same ray sets (made with a BVH
/// built with `cfg.params.bvh`).
fn run_each(
    scene: &Scene,
    cfg: &BenchConfig,
    each: Vec<StructureParams>,
    done: &mut dyn FnMut(&BenchResult),
) -> Result<Vec<BenchResult>, BenchError> {
    // The ray sets are made with a BVH2 over the flattened scene, or the two levels where
    // the scene is not flattened.
    let bvh_params = StructureParams {
        kind: if scene.is_flattened() {
            AccelKind::Bvh
        } else {
            AccelKind::TwoLevel
        },
        ..cfg.params
    };
    let bvh = structure::build_scene(scene, &bvh_params, &Default::default())?;
    let sets = RaySets::standard(
        &bvh.structure,
        scene,
        &cfg.camera,
        cfg.light,
        cfg.width,
        cfg.height,
    );
    drop(bvh);
    let mut out = Vec::new();
    for params in each {
        let built = timed_build(scene, cfg, &params)?;
        let result = measure(scene, cfg, &params, &built, &sets);
        done(&result);
        out.push(result);
    }
    Ok(out)
}

/// The best of `cfg.builds` builds of the structure `params` names.
fn timed_build(
    scene: &Scene,
    cfg: &BenchConfig,
    params: &StructureParams,
) -> Result<Built, BenchError> {
    let builds = if params.kind.is_brute_force() {
        1
    } else {
        cfg.builds
    };
    Ok(best_build(
        builds,
        || structure::build_scene(scene, params, &Default::default()),
        |b| b.report.build_time,
    )?)
}

/// Brute force tests every triangle for every ray: over a large scene it traces every k-th
/// ray only, so that no set takes more than about this many triangle tests.
const BRUTE_FORCE_TESTS: usize = 1 << 28;

/// Times the ray sets through `built` and counts the mean work per ray.
fn measure(
    scene: &Scene,
    cfg: &BenchConfig,
    params: &StructureParams,
    built: &Built,
    full: &RaySets,
) -> BenchResult {
    let accel = &built.structure;
    let sampled = if params.kind.is_brute_force() {
        (scene.placed_triangles() * full.primary.len()).div_ceil(BRUTE_FORCE_TESTS)
    } else {
        1
    }
    .max(1);
    let subset;
    let sets = if sampled > 1 {
        subset = full.every(sampled);
        &subset
    } else {
        full
    };
    let [mut primary, mut diffuse, mut shadow] =
        crate::with_intersector!(cfg.intersector, I => time_sets::<_, I>(accel, sets, cfg.runs));
    let primary_packets = crate::with_intersector!(cfg.intersector, I => {
        time_packets::<_, I>(accel, sets, cfg.runs)
    });
    let [p, d, s] = mean_work(accel, sets);
    let sah_check = SahCheck::measure(
        accel,
        params,
        scene,
        [p, d, s],
        cfg.epo,
        sah_check::EPO_DEADLINE,
    );
    primary.mean = Some(p);
    diffuse.mean = Some(d);
    shadow.mean = Some(s);
    BenchResult {
        scene: scene.name.clone(),
        triangles: scene.placed_triangles(),
        threads: rayon::current_num_threads(),
        intersector: cfg.intersector,
        params: *params,
        report: built.report.clone(),
        bvh_report: built.bvh_report.clone(),
        sampled,
        primary,
        primary_packets,
        diffuse,
        shadow,
        sah_check,
        peers: Vec::new(),
        top_level_rebuild: None,
        wide_rebuild: None,
    }
}

/// The best of `builds` rebuilds of a two-level structure's top level over its references
/// where they are (`TwoLevel::rebuild_top_level`); `None` for the other structures.
fn time_top_level_rebuild(
    structure: &mut Structure,
    builds: u32,
) -> Result<Option<Duration>, BenchError> {
    let Structure::TwoLevel(levels) = structure else {
        return Ok(None);
    };
    let mut best = Duration::MAX;
    for _ in 0..builds.max(1) {
        let start = Instant::now();
        levels.rebuild_top_level().map_err(StructureError::from)?;
        best = best.min(start.elapsed());
    }
    Ok(Some(best))
}

/// The best of `builds` rebuilds of a BVH4 or BVH8 built straight from the Morton order,
/// into its own memory, after one that fills the kept scratch; `None` for other builds.
/// The tree rebuilt is the tree built, so the rays after it trace the same tree.
fn time_wide_rebuild(
    structure: &mut Structure,
    scene: &Scene,
    params: &StructureParams,
    builds: u32,
) -> Result<Option<Duration>, BenchError> {
    if !params.bvh.builds_morton_wide() {
        return Ok(None);
    }
    let leaf_size = params.bvh.direct_wide_leaf_size();
    fn best<const W: usize>(
        tree: &mut WideBvh<W>,
        triangles: &[Triangle],
        leaf_size: u32,
        builds: u32,
    ) -> Result<Duration, BenchError>
    where
        Lanes<W>: NodeWidth,
    {
        let mut scratch = MortonScratch::default();
        let mut best = Duration::MAX;
        for k in 0..=builds.max(1) {
            let start = Instant::now();
            tree.rebuild_morton(triangles, leaf_size, &mut scratch)
                .map_err(StructureError::from)?;
            if k > 0 {
                best = best.min(start.elapsed());
            }
        }
        Ok(best)
    }
    Ok(match structure {
        Structure::Bvh4(t) => Some(best(t, &scene.triangles, leaf_size, builds)?),
        Structure::Bvh8(t) => Some(best(t, &scene.triangles, leaf_size, builds)?),
        _ => None,
    })
}

/// The mean counters per ray of the primary, diffuse and shadow sets (one counting pass).
pub fn mean_work(accel: &Structure, sets: &RaySets) -> [MeanWork; 3] {
    [
        mean_work_of(accel, &sets.primary, false),
        mean_work_of(accel, &sets.diffuse, false),
        mean_work_of(accel, &sets.shadow, true),
    ]
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

/// Closest hits of the packet set, tile by tile (a tile in packets of `PACKET_SIZE`
/// consecutive rays), `runs` times.
pub fn time_packets<A: Accel, I: Intersector>(
    accel: &A,
    sets: &RaySets,
    runs: u32,
) -> RaySetResult {
    let mut result = RaySetResult {
        rays: sets.primary_tiles.len(),
        hits: 0,
        best: Duration::MAX,
        mean: None,
    };
    let tiles: Vec<&[Ray]> = sets.tiles().collect();
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        result.hits = tiles
            .par_iter()
            .map(|tile| {
                let mut hits = [None; 4 * PACKET_SIZE];
                let hits = &mut hits[..tile.len()];
                accel.closest_hits::<I>(tile, hits);
                hits.iter().filter(|h| h.is_some()).count()
            })
            .sum();
        result.best = result.best.min(start.elapsed());
    }
    result
}

/// Traces `rays` `runs` times in parallel, one ray at a time; the best time and the hit count.
pub(crate) fn time_set(
    rays: &[Ray],
    runs: u32,
    trace: impl Fn(&Ray) -> bool + Sync,
) -> RaySetResult {
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
        mean: None,
    };
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        result.hits = rays.par_chunks(chunk).map(&trace).sum();
        result.best = result.best.min(start.elapsed());
    }
    result
}

pub(crate) fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// A parameter as the user typed it: the f64 nearest the f32's shortest decimal (0.1, not
/// 0.10000000149011612).
pub(crate) fn as_typed(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}
