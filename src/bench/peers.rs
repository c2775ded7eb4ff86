//! The peers of `bvhlab bench`: Embree 3 (`--embree`, `--embree-robust`) and tinybvh's
//! BVH8_CPU (`--tinybvh`), each built over the same scene and traced over the same ray sets
//! on the same threads as bvhlab's structure, their primary hits compared with bvhlab's.
//! Each is compiled in only with its feature; without it the command says how to get it.

use super::{BenchConfig, BenchError, PeerResult};
#[cfg(any(feature = "embree", feature = "tinybvh"))]
use super::{InTurns, RaySetResult, RaySets, time_packets, time_set};
use crate::accel::structure::Structure;
#[cfg(any(feature = "embree", feature = "tinybvh"))]
use crate::accel::{Accel, NoStats};
#[cfg(any(feature = "embree", feature = "tinybvh"))]
use crate::geometry::Watertight;
use crate::scene::Scene;
#[cfg(any(feature = "embree", feature = "tinybvh"))]
use rayon::prelude::*;
#[cfg(any(feature = "embree", feature = "tinybvh"))]
use std::time::Duration;

/// Which of Embree's builders builds the peer (`--embree-quality`), as `RTCBuildQuality`
/// names them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum EmbreeQuality {
    /// Its Morton builder (a BVH per mesh under a top level): the peer of bvhlab's LBVH.
    Low,
    /// Its default binned SAH build.
    #[default]
    Medium,
    /// Binned SAH with spatial splits: the peer of bvhlab's SBVH.
    High,
}

impl EmbreeQuality {
    /// The value of `RTCBuildQuality`.
    pub fn rtc(self) -> u32 {
        match self {
            EmbreeQuality::Low => 0,
            EmbreeQuality::Medium => 1,
            EmbreeQuality::High => 2,
        }
    }

    /// What the peer's name adds: nothing for the default.
    pub fn suffix(self) -> &'static str {
        match self {
            EmbreeQuality::Low => ", low quality",
            EmbreeQuality::Medium => "",
            EmbreeQuality::High => ", high quality",
        }
    }
}

/// Whether this build can run Embree beside bvhlab.
pub const EMBREE_AVAILABLE: bool = cfg!(feature = "embree");

pub const EMBREE_MISSING: &str = "this bvhlab was built without Embree: install libembree-dev \
     and build with `cargo build --release --features embree`";

/// Whether this build can run tinybvh beside bvhlab.
pub const TINYBVH_AVAILABLE: bool = cfg!(feature = "tinybvh");

pub const TINYBVH_MISSING: &str = "this bvhlab was built without tinybvh: build with \
     `cargo build --release --features tinybvh` (it compiles peers/tinybvh with the system's C++ compiler)";

#[cfg(not(feature = "embree"))]
pub(super) fn run_embree(
    _: &Structure,
    _: &Scene,
    _: &BenchConfig,
    _: &super::RaySets,
    _: bool,
    _: bool,
) -> Result<PeerResult, BenchError> {
    Err(BenchError::Peer(EMBREE_MISSING.into()))
}

/// Embree on the same ray sets, with as many build and trace threads as bvhlab had, and
/// bvhlab's structure timed in turns with it if `in_turns`; with `robust`, built with its
/// robust flag.
#[cfg(feature = "embree")]
pub(super) fn run_embree(
    ours: &Structure,
    scene: &Scene,
    cfg: &BenchConfig,
    sets: &RaySets,
    robust: bool,
    in_turns: bool,
) -> Result<PeerResult, BenchError> {
    use crate::accel::embree::{Embree, EmbreeMode};
    let threads = rayon::current_num_threads();
    let mode = if robust {
        EmbreeMode::Robust
    } else {
        EmbreeMode::Default
    };
    // Two levels against Embree's two levels over the same meshes and instances; any other
    // structure against Embree's BVH over the flattened triangles.
    let two_level = ours.places_instances();
    let quality = cfg.embree_quality.rtc();
    let (mut embree, ours_build) = build_in_turns(
        scene,
        cfg,
        in_turns,
        || {
            if two_level {
                Embree::build_instanced_at(&scene.instancing(), threads, mode, quality)
            } else {
                Embree::build_at(&scene.triangles, threads, mode, quality)
            }
            .map_err(BenchError::Peer)
        },
        |e| e.build_time,
    )?;
    // Where bvhlab timed its tree rebuilt into its own memory, Embree's scene rebuilt
    // into its own: the best of as many, after one.
    let mut rebuild = None;
    if cfg.params.bvh.builds_morton_wide() && !two_level {
        for k in 0..=cfg.builds.max(1) {
            let took = embree.rebuild().map_err(BenchError::Peer)?;
            if k > 0 {
                rebuild = took.map(|t| rebuild.map_or(t, |b: std::time::Duration| b.min(t)));
            }
        }
    }
    let name = format!("{}{}", mode.name(two_level), cfg.embree_quality.suffix());
    let what = (name, embree.build_time, true);
    Ok(PeerResult {
        top_level_build: embree.top_level_time,
        rebuild,
        ..measure(what, &embree, ours, sets, cfg, ours_build)
    })
}

#[cfg(not(feature = "tinybvh"))]
pub(super) fn run_tinybvh(
    _: &Structure,
    _: &Scene,
    _: &BenchConfig,
    _: &super::RaySets,
    _: bool,
) -> Result<Vec<PeerResult>, BenchError> {
    Err(BenchError::Peer(TINYBVH_MISSING.into()))
}

/// tinybvh's BVH8_CPU on the same ray sets and trace threads, from its default build and
/// from its SBVH (its builds use their own threads), bvhlab's structure timed in turns with
/// each if `in_turns`.
#[cfg(feature = "tinybvh")]
pub(super) fn run_tinybvh(
    ours: &Structure,
    scene: &Scene,
    cfg: &BenchConfig,
    sets: &RaySets,
    in_turns: bool,
) -> Result<Vec<PeerResult>, BenchError> {
    use crate::accel::tinybvh::{TinyBuild, TinyBvh};
    [TinyBuild::Default, TinyBuild::Hq]
        .into_iter()
        .map(|build| {
            let (tiny, ours_build) = build_in_turns(
                scene,
                cfg,
                in_turns,
                || TinyBvh::build(&scene.triangles, build).map_err(BenchError::Peer),
                |t| t.build_time,
            )?;
            // One ray at a time: its CPU layout has no packet query.
            let what = (build.name().to_string(), tiny.build_time, false);
            Ok(measure(what, &tiny, ours, sets, cfg, ours_build))
        })
        .collect()
}

/// The peer built `cfg.builds` times (the fastest kept), each right after bvhlab's
/// structure is built again if `in_turns`; with bvhlab's best build time from those turns.
#[cfg(any(feature = "embree", feature = "tinybvh"))]
fn build_in_turns<P>(
    scene: &Scene,
    cfg: &BenchConfig,
    in_turns: bool,
    mut build: impl FnMut() -> Result<P, BenchError>,
    took: impl Fn(&P) -> Duration,
) -> Result<(P, Option<Duration>), BenchError> {
    let mut ours: Option<Duration> = None;
    let best = super::best_build(
        cfg.builds,
        || {
            if in_turns {
                let built =
                    crate::accel::structure::build_scene(scene, &cfg.params, &Default::default())?;
                let t = built.report.build_time;
                ours = Some(ours.map_or(t, |o| o.min(t)));
            }
            build()
        },
        took,
    )?;
    Ok((best, ours))
}

/// A peer (its name, build time and whether it has a packet query) timed on the ray sets,
/// with bvhlab's structure timed in turns with it where bvhlab's builds were (`ours_build`,
/// their best), and its primary hits against bvhlab's.
#[cfg(any(feature = "embree", feature = "tinybvh"))]
fn measure<A: Accel>(
    (name, build, packets): (String, Duration, bool),
    peer: &A,
    ours: &Structure,
    sets: &RaySets,
    cfg: &BenchConfig,
    ours_build: Option<Duration>,
) -> PeerResult {
    let in_turns = ours_build.is_some();
    // Each set traced by bvhlab and by the peer in turns.
    // Where bvhlab traced a sample of the rays (brute force), the peer alone.
    let turns = |ours: &dyn Fn() -> RaySetResult, theirs: &dyn Fn() -> RaySetResult| {
        let mut a = in_turns.then(ours);
        let mut b = theirs();
        for _ in 1..cfg.runs.max(1) {
            a = a.map(|a| a.best_of(ours()));
            b = b.best_of(theirs());
        }
        (a, b)
    };
    let closest = |rays: &[crate::geometry::Ray]| {
        crate::with_intersector!(cfg.intersector, I => time_set(rays, 1, |r| {
            ours.closest_hit::<I, _>(r, &mut NoStats).is_some()
        }))
    };
    let watertight = |rays: &[crate::geometry::Ray]| {
        time_set(rays, 1, |r| {
            peer.closest_hit::<Watertight, _>(r, &mut NoStats).is_some()
        })
    };
    let (ours_primary, primary) = turns(&|| closest(&sets.primary), &|| watertight(&sets.primary));
    let (ours_diffuse, diffuse) = turns(&|| closest(&sets.diffuse), &|| watertight(&sets.diffuse));
    let (ours_shadow, shadow) = turns(
        &|| {
            crate::with_intersector!(cfg.intersector, I => time_set(&sets.shadow, 1, |r| {
                ours.any_hit::<I, _>(r, &mut NoStats)
            }))
        },
        &|| {
            time_set(&sets.shadow, 1, |r| {
                peer.any_hit::<Watertight, _>(r, &mut NoStats)
            })
        },
    );
    let ours_packets =
        || crate::with_intersector!(cfg.intersector, I => time_packets::<_, I>(ours, sets, 1));
    let theirs_packets = || time_packets::<_, Watertight>(peer, sets, 1);
    let (ours_in_packets, primary_packets) = match packets {
        true => {
            let (a, b) = turns(&ours_packets, &theirs_packets);
            (a, Some(b))
        }
        false => (in_turns.then(ours_packets), None),
    };
    let bvhlab = (|| {
        Some(InTurns {
            build: ours_build?,
            primary: ours_primary?,
            primary_packets: ours_in_packets?,
            diffuse: ours_diffuse?,
            shadow: ours_shadow?,
        })
    })();
    let (tied_primary_hits, differing_primary_hits) = sets
        .primary
        .par_iter()
        .map(|r| {
            let mine = ours.closest_hit::<Watertight, _>(r, &mut NoStats);
            let theirs = peer.closest_hit::<Watertight, _>(r, &mut NoStats);
            match (mine, theirs) {
                (Some(a), Some(b)) if a.triangle == b.triangle => (0, 0),
                (Some(a), Some(b)) if ulps_apart(a.t, b.t) <= TIE_ULPS => (1, 0),
                (None, None) => (0, 0),
                _ => (0, 1),
            }
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    PeerResult {
        name,
        build,
        primary,
        primary_packets,
        diffuse,
        shadow,
        tied_primary_hits,
        differing_primary_hits,
        top_level_build: None,
        rebuild: None,
        bvhlab,
    }
}

/// Two hits this close in depth are a tie: f32 rounding of two nearly coplanar triangles'
/// distances, decided differently by the two ray–triangle tests.
#[cfg(any(feature = "embree", feature = "tinybvh"))]
const TIE_ULPS: u32 = 16;

#[cfg(any(feature = "embree", feature = "tinybvh"))]
fn ulps_apart(a: f32, b: f32) -> u32 {
    if a.is_sign_negative() != b.is_sign_negative() {
        return u32::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}
