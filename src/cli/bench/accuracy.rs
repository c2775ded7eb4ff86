//! `bench accuracy`: run time against error, every intersector with every builder.

use super::{BenchArgs, output_paths};
use anyhow::Result;
use bvhlab::bench::accuracy::{self, AccuracyConfig};
use bvhlab::bench::{BenchConfig, plot};
use bvhlab::scene::Scene;

pub(super) fn run_accuracy(
    args: &BenchArgs,
    scene: &Scene,
    cfg: &BenchConfig,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let acc = AccuracyConfig {
        camera: cfg.camera,
        light: cfg.light,
        width: cfg.width,
        height: cfg.height,
        builds: cfg.builds,
        runs: cfg.runs,
        random_rays: crate::cli::rays_within_budget("--random-rays", args.random_rays, 1)?,
        crossing_rays: crate::cli::rays_within_budget("--crossing-rays", args.crossing_rays, 1)?,
        seed: 1,
    };
    let quiet = args.json;
    let rows = pool.install(|| {
        accuracy::run(scene, &acc, &mut |line| {
            if !quiet {
                eprintln!("  done: {line}");
            }
        })
    })?;
    let (csv_path, plot_path) = output_paths(args, "accuracy", &scene.name);
    // Written once the plot is: a plot that cannot be written leaves no CSV either.
    let csv = bvhlab::output::stage(&csv_path, accuracy::csv(&rows).as_bytes())?;
    let svg_path = plot::save(&accuracy::pareto_plot(&rows), &plot_path)?;
    csv.commit()?;
    if args.json {
        let json: Vec<_> = rows.iter().map(|r| r.json()).collect();
        out!("{}", serde_json::to_string(&json)?);
        return Ok(());
    }
    out!(
        "{}: {} triangles, {} threads, {}x{} ray sets; {} crossing rays, {} rays compared with f64",
        scene.name,
        scene.placed_triangles(),
        rows.first().map_or(0, |r| r.threads),
        cfg.width,
        cfg.height,
        rows.first().map_or(0, |r| r.crossings.rays),
        rows.first().map_or(0, |r| r.agreement.rays)
    );
    out!(
        "  {:<17} {:<16} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>10}",
        "builder",
        "intersector",
        "build ms",
        "SAH rel",
        "primary",
        "diffuse",
        "shadow",
        "ns/ray",
        "leaks",
        "mismatches"
    );
    for r in &rows {
        out!(
            "  {:<17} {:<16} {:>9.2} {:>8.3} {:>8.2} {:>8.2} {:>8.2} {:>8.1} {:>8} {:>10}",
            r.builder.label,
            r.intersector.label(),
            r.build_ms,
            r.sah_vs_sweep,
            r.sets[0].mrays_per_s(),
            r.sets[1].mrays_per_s(),
            r.sets[2].mrays_per_s(),
            r.ns_per_ray(),
            r.crossings.missed + r.crossings.passed_through,
            r.agreement.mismatches
        );
    }
    out!(
        "wrote {}, {} and {}",
        csv_path.display(),
        plot_path.display(),
        svg_path.display()
    );
    Ok(())
}
