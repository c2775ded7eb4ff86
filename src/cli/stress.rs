//! `bvhlab stress`: the numerical stress suite (watertightness at every offset and scale,
//! the slab test against exact arithmetic, degenerate and grazing triangles, agreement with
//! the f64 reference, shadow-ray self-intersection). Exits non-zero on any failure.

use super::{load_scene, thread_pool};
use anyhow::{Result, bail};
use bvhlab::accel::bvh::{BuildParams, build};
use bvhlab::accel::{Accel, NoStats};
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
    /// Folder of the shared scenes (default: $BVHLAB_SCENES if set).
    #[arg(long)]
    pub scenes_dir: Option<PathBuf>,
    /// Must-hit rays per closed mesh and placement.
    #[arg(long)]
    pub leak_rays: Option<usize>,
    /// Rays per scene for each scene part.
    #[arg(long)]
    pub scene_rays: Option<usize>,
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

pub fn run(args: StressArgs) -> Result<()> {
    let mut cfg = if args.quick {
        StressConfig::tests()
    } else {
        StressConfig::full()
    };
    if let Some(n) = args.leak_rays {
        cfg.leak_rays = n;
        cfg.brute_rays = cfg.brute_rays.min(n);
    }
    if let Some(n) = args.scene_rays {
        cfg.scene_rays = n;
    }
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    let mut specs: Vec<String> = args.scenes.clone();
    if specs.is_empty() {
        specs.extend(BUILTIN.iter().map(|s| s.to_string()));
        let dir = args
            .scenes_dir
            .clone()
            .or_else(|| std::env::var_os("BVHLAB_SCENES").map(PathBuf::from));
        if let Some(dir) = dir {
            specs.extend(SHARED.iter().map(|f| dir.join(f).display().to_string()));
        }
    }
    let scenes = specs
        .iter()
        .map(|s| load_scene(s))
        .collect::<Result<Vec<Scene>>>()?;
    let pool = thread_pool(args.threads)?;
    let quiet = args.json;
    let (report, timing) = pool.install(|| {
        let report = suite::run(&scenes, &cfg, &mut |line| {
            if !quiet {
                eprintln!("  done: {line}");
            }
        });
        (report, axis_parallel_timing(&scenes[0]))
    });
    if args.json {
        let mut json = report.to_json();
        json["timing"] = serde_json::json!({
            "slab_ns_general": round2(timing.0),
            "slab_ns_axis_parallel": round2(timing.1),
            "bvh_mrays_general": round2(timing.2),
            "bvh_mrays_axis_parallel": round2(timing.3),
            "bvh_scene": scenes[0].name,
        });
        out!("{json}");
    } else {
        print_summary(&report, timing)?;
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

fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// Slab-test ns per test on general and axis-parallel rays, and BVH closest-hit Mrays/s on
/// `scene` for rays from its camera in general and in axis-parallel directions.
fn axis_parallel_timing(scene: &Scene) -> (f64, f64, f64, f64) {
    let (g, a) = slab::timing(20_000_000, 3);
    let Ok((bvh, _)) = build(&scene.triangles, &BuildParams::default()) else {
        return (g, a, 0.0, 0.0);
    };
    let cam = scene.camera().rays(512, 384);
    let general: Vec<Ray> = (0..384)
        .flat_map(|y| (0..512).map(move |x| (x, y)))
        .map(|(x, y)| cam.pixel_center(x, y))
        .collect();
    let axes = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let axis: Vec<Ray> = general
        .iter()
        .enumerate()
        .map(|(i, r)| {
            // Origins spread like the general rays', directions along the axes with ±0.
            let mut d = axes[i % 6];
            for k in 0..3 {
                if d[k] == 0.0 && (i / 6 + k) % 2 == 1 {
                    d[k] = -0.0;
                }
            }
            Ray::new(r.at(0.5 * (i % 7) as f32), d)
        })
        .collect();
    let mrays = |rays: &[Ray]| {
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
        rays.len() as f64 / best / 1e6
    };
    (g, a, mrays(&general), mrays(&axis))
}

fn print_summary(r: &StressReport, timing: (f64, f64, f64, f64)) -> Result<()> {
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
            "  {:<16} {:>10} rays  leaks: {} closest, {} any-hit (BVH); {} of {} (brute force)",
            kind.label(),
            t.rays,
            t.bvh_closest,
            t.bvh_any,
            t.brute_closest,
            t.brute_rays
        );
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
        "  timing: {:.2} ns per slab test on general rays, {:.2} on axis-parallel; BVH {:.2} vs {:.2} Mrays/s",
        timing.0,
        timing.1,
        timing.2,
        timing.3
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
