//! `bvhlab stress`: the numerical stress suite (watertightness at every offset and scale,
//! the slab test against exact arithmetic, degenerate and grazing triangles, agreement with
//! the f64 reference, shadow-ray self-intersection). Exits non-zero on any failure.

use super::{BuildArgs, load_scene, thread_pool};
use anyhow::{Result, bail};
use bvhlab::accel::bvh::{BuildParams, build};
use bvhlab::accel::{Accel, Counters, NoStats};
use bvhlab::bench::stress::slab;
use bvhlab::bench::stress::suite::{self, StressConfig, StressReport};
use bvhlab::geometry::{IntersectorKind, Ray, Watertight};
use bvhlab::scene::Scene;
use clap::Args;
use glam::Vec3;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Built-in scenes the suite always runs on.
const BUILTIN: [&str; 5] = [
    "cornell",
    "sphere:20000",
    "teapot-in-stadium",
    "walls-rotated",
    "soup:20000",
];
/// Shared scenes run when their folder is known.
const SHARED: [&str; 3] = ["sponza.obj", "sibenik.obj", "conference.obj"];

#[derive(Args)]
pub struct StressArgs {
    /// Print one JSON object with every count instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// The test suite's sizes (10^5 rays per case) instead of the full run.
    #[arg(long)]
    pub quick: bool,
    /// Scenes for the agreement, crossing and shadow parts (repeatable; default: cornell,
    /// sphere:20000, teapot-in-stadium, walls-rotated, soup:20000 and, with --scenes-dir,
    /// sponza, sibenik and conference).
    #[arg(long = "scene")]
    pub scenes: Vec<String>,
    /// Folder of the shared scenes (default: $BVHLAB_SCENES if set); for the default scene
    /// list, so not with --scene.
    #[arg(long, conflicts_with = "scenes")]
    pub scenes_dir: Option<PathBuf>,
    /// Must-hit rays per closed mesh and placement (at least 1).
    #[arg(long, value_parser = crate::cli::at_least_one::<usize>)]
    pub leak_rays: Option<usize>,
    /// Rays per scene for each scene part (at least 1).
    #[arg(long, value_parser = crate::cli::at_least_one::<usize>)]
    pub scene_rays: Option<usize>,
    #[arg(long, value_parser = crate::cli::whole_number::<u64>)]
    pub seed: Option<u64>,
    /// Worker threads, at most 4 × the cores (default: all cores).
    #[arg(long, value_parser = crate::cli::parse_threads)]
    pub threads: Option<usize>,
    /// Only the watertightness part, through Embree 3 with its defaults and with its robust
    /// flag beside the structure under test: the leaks of each, per mesh and per placement
    /// (needs a build with `--features embree`; reports, does not fail).
    #[arg(long, conflicts_with = "scenes")]
    pub embree: bool,
    /// The structure under test (and its parameters); the f64 reference runs through a BVH.
    #[command(flatten)]
    pub build: BuildArgs,
}

pub fn run(args: StressArgs) -> Result<()> {
    for (i, scene) in args.scenes.iter().enumerate() {
        if args.scenes[..i].contains(scene) {
            anyhow::bail!("--scene {scene} is given twice");
        }
    }
    let mut cfg = if args.quick {
        StressConfig::tests()
    } else {
        StressConfig::full()
    };
    if let Some(n) = args.leak_rays {
        cfg.leak_rays = super::rays_within_budget("--leak-rays", n, 1)?;
        cfg.brute_rays = cfg.brute_rays.min(n);
    }
    if let Some(n) = args.scene_rays {
        cfg.scene_rays = super::rays_within_budget("--scene-rays", n, 3)?;
    }
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    cfg.structure = args.build.structure_params_for(
        args.build
            .accel
            .unwrap_or(super::AccelArg::One(bvhlab::accel::AccelKind::Bvh))
            .kind()?,
    );
    cfg.structure.validate()?;
    super::check_given_apply(&cfg.structure)?;
    if args.embree {
        return run_embree(&args, &cfg);
    }
    let mut specs: Vec<String> = args.scenes.clone();
    if specs.is_empty() {
        specs.extend(BUILTIN.iter().map(|s| s.to_string()));
        let dir = args
            .scenes_dir
            .clone()
            .or_else(|| std::env::var_os("BVHLAB_SCENES").map(PathBuf::from));
        if let Some(dir) = dir {
            // Said before any scene is made: a wrong folder is found at once.
            if let Some(missing) = SHARED.iter().find(|f| !dir.join(f).is_file()) {
                anyhow::bail!(
                    "the scenes folder {} has no {missing} (it should hold {})",
                    dir.display(),
                    SHARED.join(", ")
                );
            }
            specs.extend(SHARED.iter().map(|f| dir.join(f).display().to_string()));
        }
    }
    let scenes = specs
        .iter()
        .map(|s| {
            let scene = load_scene(s)?;
            let _scene_held = scene.hold_budget();
            if !scene.is_flattened() {
                anyhow::bail!(
                    "the stress suite works on a scene's stored triangles: {s} places its \
                     instances without storing them"
                );
            }
            Ok(scene)
        })
        .collect::<Result<Vec<Scene>>>()?;
    let pool = thread_pool(args.threads)?;
    let quiet = args.json;
    let (report, timing) = pool.install(|| {
        let report = suite::run(&scenes, &cfg, &mut |line| {
            if !quiet {
                eprintln!("  done: {line}");
            }
        })?;
        // Time traversal on the largest scene.
        let largest = scenes.iter().max_by_key(|s| s.triangles.len());
        let timing = largest.map(axis_parallel_timing).unwrap_or_default();
        anyhow::Ok((report, timing))
    })?;
    if args.json {
        let mut json = report.to_json();
        json["timing"] = serde_json::json!({
            "slab_ns_general": round2(timing.slab_general),
            "slab_ns_axis_parallel": round2(timing.slab_axis),
            "bvh_scene": timing.scene,
            "bvh_mrays_general": round2(timing.bvh_mrays_general),
            "bvh_mrays_axis_parallel": round2(timing.bvh_mrays_axis),
            "bvh_ns_per_box_test_general": round2(timing.bvh_ns_per_box_general),
            "bvh_ns_per_box_test_axis_parallel": round2(timing.bvh_ns_per_box_axis),
        });
        out!("{json}");
    } else {
        print_summary(&report, &timing)?;
    }
    let failures = report.failures();
    if !failures.is_empty() {
        bail!(
            "{} stress failure(s): {}",
            failures.len(),
            failures.join("; ")
        );
    }
    Ok(())
}

/// `stress --embree`: the must-hit rays through bvhlab and both Embree modes.
#[cfg(feature = "embree")]
fn run_embree(args: &StressArgs, cfg: &StressConfig) -> Result<()> {
    use bvhlab::bench::stress::peer::{self, PeerLeakRow};
    let pool = thread_pool(args.threads)?;
    let quiet = args.json;
    let report = pool
        .install(|| {
            peer::run(cfg, &mut |line| {
                if !quiet {
                    eprintln!("  done: {line}");
                }
            })
        })
        .map_err(anyhow::Error::msg)?;
    let row_json = |r: &PeerLeakRow| {
        serde_json::json!({
            "label": r.label,
            "rays": r.rays,
            "bvhlab": { "closest": r.bvhlab.closest, "any": r.bvhlab.any },
            "embree": { "closest": r.embree.closest, "any": r.embree.any },
            "embree_robust": { "closest": r.embree_robust.closest, "any": r.embree_robust.any },
        })
    };
    if args.json {
        out!(
            "{}",
            serde_json::json!({
                "structure": cfg.structure.kind.label(),
                "meshes": report.meshes.iter().map(row_json).collect::<Vec<_>>(),
                "placements": report.placements.iter().map(row_json).collect::<Vec<_>>(),
                "families": report.families.iter().map(row_json).collect::<Vec<_>>(),
                "total": row_json(&report.total),
            })
        );
        return Ok(());
    }
    out!(
        "Must-hit rays through shared edges and vertices that found nothing (closest hit / any hit): bvhlab's {} with the watertight test, Embree 3, and Embree 3 with its robust flag:",
        cfg.structure.kind.title()
    );
    let header = |first: &str| -> Result<()> {
        out!(
            "  {first:<44} {:>9} {:>17} {:>17} {:>17}",
            "rays",
            "bvhlab",
            "Embree 3",
            "Embree 3 robust"
        );
        Ok(())
    };
    let row = |r: &PeerLeakRow| -> Result<()> {
        let pair =
            |l: bvhlab::bench::stress::peer::TracerLeaks| format!("{} / {}", l.closest, l.any);
        out!(
            "  {:<44} {:>9} {:>17} {:>17} {:>17}",
            r.label,
            r.rays,
            pair(r.bvhlab),
            pair(r.embree),
            pair(r.embree_robust)
        );
        Ok(())
    };
    header("mesh")?;
    for r in &report.meshes {
        row(r)?;
    }
    row(&report.total)?;
    header("placement (all meshes)")?;
    for r in &report.placements {
        row(r)?;
    }
    header("aimed (all meshes and placements)")?;
    for r in &report.families {
        row(r)?;
    }
    Ok(())
}

#[cfg(not(feature = "embree"))]
fn run_embree(_: &StressArgs, _: &StressConfig) -> Result<()> {
    bail!(bvhlab::bench::EMBREE_MISSING)
}

fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// Slab-test ns per test on general and axis-parallel rays, then BVH closest-hit traversal of
/// `scene` for rays from the same random origins in random and in axis-parallel directions:
/// Mrays/s and ns per box test (directions change how many boxes a ray tests).
fn axis_parallel_timing(scene: &Scene) -> Timing {
    let (slab_general, slab_axis) = slab::timing(20_000_000, 3);
    let mut t = Timing {
        slab_general,
        slab_axis,
        ..Timing::default()
    };
    let Ok((bvh, _)) = build(&scene.triangles, &BuildParams::default()) else {
        return t;
    };
    let b = scene.bounds();
    let mut rng = bvhlab::random::Rng(5);
    let n = 400_000;
    let origins: Vec<Vec3> = (0..n)
        .map(|_| {
            let u = Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32);
            b.min + (b.max - b.min) * u
        })
        .collect();
    let general: Vec<Ray> = origins
        .iter()
        .map(|&o| Ray::new(o, rng.in_ball().normalize_or_zero().as_vec3()))
        .filter(|r| r.direction != Vec3::ZERO)
        .collect();
    let axes = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let axis: Vec<Ray> = origins
        .iter()
        .enumerate()
        .map(|(i, &o)| {
            let mut d = axes[i % 6];
            for k in 0..3 {
                if d[k] == 0.0 && rng.coin() {
                    d[k] = -0.0;
                }
            }
            Ray::new(o, d)
        })
        .collect();
    let measure = |rays: &[Ray]| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let start = Instant::now();
            let hits = rays
                .par_iter()
                .filter(|r| bvh.closest_hit::<Watertight, _>(r, &mut NoStats).is_some())
                .count();
            std::hint::black_box(hits);
            best = best.min(start.elapsed().as_secs_f64());
        }
        let boxes: u64 = rays
            .par_iter()
            .map(|r| {
                let mut c = Counters::default();
                bvh.closest_hit::<Watertight, _>(r, &mut c);
                c.box_tests as u64
            })
            .sum();
        let threads = rayon::current_num_threads() as f64;
        (
            rays.len() as f64 / best / 1e6,
            best * threads * 1e9 / boxes.max(1) as f64,
        )
    };
    (t.bvh_mrays_general, t.bvh_ns_per_box_general) = measure(&general);
    (t.bvh_mrays_axis, t.bvh_ns_per_box_axis) = measure(&axis);
    t.scene = scene.name.clone();
    t
}

#[derive(Clone, Debug, Default)]
struct Timing {
    slab_general: f64,
    slab_axis: f64,
    scene: String,
    bvh_mrays_general: f64,
    bvh_mrays_axis: f64,
    bvh_ns_per_box_general: f64,
    bvh_ns_per_box_axis: f64,
}

fn print_summary(r: &StressReport, timing: &Timing) -> Result<()> {
    let kinds = IntersectorKind::ALL;
    out!(
        "bvhlab stress: {} edge and vertex rays, {:.1} s",
        r.edge_and_vertex_rays(),
        r.elapsed.as_secs_f64()
    );
    let totals = r.leak_totals();
    out!(
        "watertightness: {} closed-mesh cases (icosphere, cube, torus × offsets 10^0..10^6, scales 10^-3..10^3)",
        r.leak_cases.len()
    );
    for (k, kind) in kinds.iter().enumerate() {
        let t = &totals[k];
        out!(
            "  {:<16} {:>10} rays  leaks: {} closest, {} any-hit ({}); {} of {} (brute force)",
            kind.label(),
            t.rays,
            t.bvh_closest,
            t.bvh_any,
            r.config.structure.kind.label(),
            t.brute_closest,
            t.brute_rays
        );
    }
    if !r.instanced.is_empty() {
        out!(
            "through the two levels: each closed mesh as {} instances ({})",
            r.instanced[0].placements.len(),
            r.instanced[0].placements.join("; ")
        );
        for c in &r.instanced {
            for (k, kind) in kinds.iter().enumerate() {
                let (l, a) = (&c.leaks[k], &c.agreement[k]);
                out!(
                    "  {:<9} {:<16} {:>8} rays  leaks: {} closest, {} any-hit; {} of {} (flattened brute force); against the f64 reference: {} mismatches of {} ({} on the same triangle, {} at a shared edge or vertex)",
                    c.label.split(' ').next().unwrap_or(""),
                    kind.label(),
                    l.rays,
                    l.bvh_closest,
                    l.bvh_any,
                    l.brute_closest,
                    l.brute_rays,
                    a.mismatches,
                    a.rays,
                    a.same_triangle,
                    a.shared_point
                );
            }
        }
    }
    let s = &r.slab;
    out!(
        "slab test vs exact rationals: {} cases, {} touching: {} missed, {} late entries; {} axis-parallel: {} wrong; {} clear misses: {} hit; {} NaN",
        s.cases,
        s.touching,
        s.missed,
        s.late_entry,
        s.axis_parallel,
        s.axis_parallel_wrong,
        s.clear_misses,
        s.clear_misses_hit,
        s.nan
    );
    out!(
        "  timing: {:.2} ns per slab test on general rays, {:.2} on axis-parallel; BVH on {}: {:.2} vs {:.2} Mrays/s, {:.2} vs {:.2} ns per box test (thread time)",
        timing.slab_general,
        timing.slab_axis,
        timing.scene,
        timing.bvh_mrays_general,
        timing.bvh_mrays_axis,
        timing.bvh_ns_per_box_general,
        timing.bvh_ns_per_box_axis
    );
    for (k, kind) in kinds.iter().enumerate() {
        let d = &r.degenerate[k];
        let g = &r.grazing[k];
        out!(
            "  {:<16} degenerate: {} rays, hits point/repeated/collinear {}/{}/{}, {} NaN; in-plane: {} rays, {} hits; near-plane {} hits of {}",
            kind.label(),
            d.rays,
            d.hits[0],
            d.hits[1],
            d.hits[2],
            d.non_finite,
            g.in_plane,
            g.in_plane_hits,
            g.near_plane_hits,
            g.near_plane
        );
    }
    out!("scenes (per intersector: watertight / moller-trumbore / f64):");
    for sc in &r.scenes {
        let c = |k: usize| sc.crossings[k].leaks();
        let m = |k: usize| sc.agreement[k].mismatches;
        let h = |k: usize| sc.shadow[k].self_hits();
        let a = &sc.agreement[0];
        out!(
            "  {:<18} {:>7} tris  crossings {:>8}: lost {}/{}/{}  agreement {:>8}: mismatches {}/{}/{} (watertight: {} ties, {} rounding, max rel t err {:.1e})  self-hits of {} shadow+bounce: {}/{}/{}",
            sc.name,
            sc.triangles,
            sc.crossings[0].rays,
            c(0),
            c(1),
            c(2),
            a.rays,
            m(0),
            m(1),
            m(2),
            a.ties,
            a.rounding,
            a.max_rel_t_error,
            sc.shadow[0].shadow_rays + sc.shadow[0].bounce_rays,
            h(0),
            h(1),
            h(2)
        );
    }
    let failures = r.failures();
    if failures.is_empty() {
        out!("PASSED: every count that must be zero is zero");
    } else {
        out!("FAILED: {}", failures.join("; "));
    }
    Ok(())
}
