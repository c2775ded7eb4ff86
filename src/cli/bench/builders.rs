//! `bench builders`, `bench tradeoff` and `bench sah-scatter`: every BVH builder on the
//! same ray sets, then the build-versus-trace study or the SAH scatter.

use super::{BenchArgs, output_paths};
use anyhow::{Context, Result};
use bvhlab::accel::bvh::Strategy;
use bvhlab::bench::json::{BestJson, BuildersJson};
use bvhlab::bench::{self, BenchConfig, plot, sah_scatter, tradeoff};
use bvhlab::scene::Scene;
use std::path::PathBuf;

/// `bench builders`: every BVH builder on the same ray sets, as one table (or one JSON object
/// with a `builders` array); with `tradeoff` also the build-versus-trace study, with `sah-scatter` the scatter.
pub(super) fn run_builders(
    args: &BenchArgs,
    scene: &Scene,
    cfg: &BenchConfig,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let quiet = args.json;
    // The scatter's CSV is read first: a file it cannot extend stops the run before the
    // benchmark, not after.
    let scatter_rows = if args.sah_scatter {
        Some(read_sah_scatter(args)?)
    } else {
        None
    };
    let variants = bench::builder_variants(&cfg.params.bvh);
    let results = pool.install(|| {
        bench::run_builders(scene, cfg, &variants, &mut |r| {
            if !quiet {
                eprintln!("  done: {}", bench::builder_label(&r.params.bvh));
            }
        })
    })?;
    let threads = results.first().map_or(0, |r| r.threads);
    let lines: Vec<tradeoff::Line> = results
        .iter()
        .map(|r| tradeoff::Line {
            builder: bench::builder_label(&r.params.bvh),
            build_s: r.report.build_time.as_secs_f64(),
            rays_per_s: r.diffuse.mrays_per_s() * 1e6,
        })
        .collect();
    let mut written = None;
    if args.tradeoff {
        let (csv_path, plot_path) = output_paths(args, "tradeoff", &scene.name);
        let csv = bvhlab::output::stage(&csv_path, tradeoff::csv(&scene.name, &lines).as_bytes())?;
        let svg_path = plot::save(&tradeoff::figure(&scene.name, threads, &lines), &plot_path)?;
        csv.commit()?;
        written = Some((csv_path, plot_path, svg_path));
    }
    let scatter = match scatter_rows {
        Some(earlier) => Some(write_sah_scatter(args, earlier, &scene.name, &results)?),
        None => None,
    };
    if args.json {
        let best = tradeoff::best_ranges(&lines)
            .iter()
            .map(|b| BestJson {
                builder: lines[b.line].builder.clone(),
                from_rays: b.from_rays,
                to_rays: b.to_rays,
            })
            .collect();
        let json = BuildersJson {
            scene: scene.name.clone(),
            triangles: scene.placed_triangles(),
            threads,
            builders: results.iter().map(|r| r.json()).collect(),
            tradeoff_best: args.tradeoff.then_some(best),
        };
        out!("{}", serde_json::to_string(&json)?);
        return Ok(());
    }
    // Percentages of SBVH's, as the paper's Table 1 gives them (of the best builder's if
    // SBVH is not among them).
    let sets = |r: &bench::BenchResult| [r.primary, r.diffuse, r.shadow];
    let reference = results
        .iter()
        .find(|r| r.params.bvh.strategy == Strategy::Sbvh);
    let base: Vec<f64> = (0..3)
        .map(|k| match reference {
            Some(r) => sets(r)[k].mrays_per_s(),
            None => results
                .iter()
                .map(|r| sets(r)[k].mrays_per_s())
                .fold(0.0, f64::max),
        })
        .collect();
    out!(
        "{}: {} triangles, {} threads, {}×{} ray sets (Mrays/s, and % of {}'s)",
        scene.name,
        scene.placed_triangles(),
        threads,
        cfg.width,
        cfg.height,
        if reference.is_some() {
            "SBVH"
        } else {
            "the best builder"
        }
    );
    out!(
        "  {:<28} {:>9} {:>6} {:>9} {:>9} {:>15} {:>15} {:>15}",
        "builder",
        "build ms",
        "% SBVH",
        "SAH cost",
        "dup refs",
        "primary",
        "diffuse",
        "shadow"
    );
    let sbvh_build = reference.map(|r| r.report.build_ms());
    for r in &results {
        let cells: Vec<String> = sets(r)
            .iter()
            .zip(&base)
            .map(|(s, &b)| {
                let m = s.mrays_per_s();
                format!("{m:>7.2} ({:>3.0} %)", 100.0 * m / b.max(1e-12))
            })
            .collect();
        out!(
            "  {:<28} {:>9.2} {:>6} {:>9.2} {:>9} {:>15} {:>15} {:>15}",
            bench::builder_label(&r.params.bvh),
            r.report.build_ms(),
            sbvh_build.map_or("-".into(), |b| format!(
                "{:.0}",
                100.0 * r.report.build_ms() / b.max(1e-12)
            )),
            r.sah_cost().unwrap_or(f64::NAN),
            r.duplicated_references(),
            cells[0],
            cells[1],
            cells[2]
        );
    }
    // Every BVH keeps the same closest-hit rule: the hit counts must not differ.
    let counts = |r: &bench::BenchResult| [r.primary.hits, r.diffuse.hits, r.shadow.hits];
    if let Some(first) = results.first() {
        let differing: Vec<String> = results
            .iter()
            .filter(|r| counts(r) != counts(first))
            .map(|r| bench::builder_label(&r.params.bvh))
            .collect();
        if differing.is_empty() {
            let [p, d, s] = counts(first);
            out!(
                "  hits: {p} primary, {d} diffuse, {s} occluded shadow rays, the same for every builder"
            );
        } else {
            out!(
                "  hit counts differ from the first builder's: {}",
                differing.join(", ")
            );
        }
    }
    sah_check_table(&results)?;
    if let Some((csv_path, plot_path, svg_path)) = scatter {
        out!(
            "  wrote {}, {} and {} (every scene in the CSV)",
            csv_path.display(),
            plot_path.display(),
            svg_path.display()
        );
    }
    if let Some((csv_path, plot_path, svg_path)) = written {
        out!(
            "  build + trace time of N diffuse rays per frame: T(N) = build + N / (diffuse rays/s)"
        );
        for b in tradeoff::best_ranges(&lines) {
            out!(
                "  best from {} to {} rays per frame: {}",
                tradeoff::format_rays(b.from_rays),
                tradeoff::format_rays(b.to_rays),
                lines[b.line].builder
            );
        }
        out!(
            "  wrote {}, {} and {}",
            csv_path.display(),
            plot_path.display(),
            svg_path.display()
        );
    }
    Ok(())
}

/// The CSV and plot paths of a study: `--csv` and `--plot`, or `<study>-<scene>.csv|png`.
/// The SAH check of every builder: its prediction, and each ray set's measured cost per
/// ray with its share of the prediction; then the tree's EPO, and how well each predictor
/// orders the builders by measured cost.
pub(super) fn sah_check_table(results: &[bench::BenchResult]) -> Result<()> {
    out!("  SAH predicted against measured (cost per ray, and % of the SAH cost):");
    out!(
        "  {:<28} {:>9} {:>15} {:>15} {:>15} {:>15} {:>8}",
        "builder",
        "SAH cost",
        "random lines",
        "primary",
        "diffuse",
        "shadow",
        "EPO"
    );
    let mut checks = Vec::new();
    for r in results {
        let Some(c) = &r.sah_check else { continue };
        checks.push(*c);
        let cell = |m: f64| format!("{m:>7.1} ({:>3.0} %)", 100.0 * m / c.predicted);
        out!(
            "  {:<28} {:>9.2} {:>15} {:>15} {:>15} {:>15} {:>8}",
            bench::builder_label(&r.params.bvh),
            c.predicted,
            cell(c.random),
            cell(c.primary),
            cell(c.diffuse),
            cell(c.shadow),
            c.epo.map_or("–".into(), |e| format!("{e:.2}"))
        );
    }
    if checks.len() >= 3 {
        let rho = sah_scatter::Correlations::of(&checks);
        out!(
            "  how each predictor orders these builders by measured cost (Spearman's ρ, 1 = the same order):"
        );
        out!("    {rho}");
    }
    Ok(())
}

/// The `sah-scatter` files: the CSV and the plot.
pub(super) fn sah_scatter_paths(args: &BenchArgs) -> (PathBuf, PathBuf) {
    let csv = args
        .csv
        .clone()
        .unwrap_or_else(|| PathBuf::from("sah-scatter.csv"));
    let plot = args
        .plot
        .clone()
        .unwrap_or_else(|| PathBuf::from("sah-scatter.png"));
    (csv, plot)
}

/// The rows already in the `sah-scatter` CSV (none if it does not exist yet).
pub(super) fn read_sah_scatter(args: &BenchArgs) -> Result<Vec<sah_scatter::Row>> {
    let (csv_path, _) = sah_scatter_paths(args);
    match bvhlab::input::read_text(&csv_path, 1) {
        Ok(text) => sah_scatter::parse_csv(&text)
            .map_err(|e| anyhow::anyhow!("{} is not a SAH scatter CSV: {e}", csv_path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Vec::new()),
        Err(e) => Err(e).with_context(|| format!("cannot read {}", csv_path.display())),
    }
}

/// `sah-scatter`: this scene's rows merged into the CSV's, and the plot of them all.
pub(super) fn write_sah_scatter(
    args: &BenchArgs,
    earlier: Vec<sah_scatter::Row>,
    scene: &str,
    results: &[bench::BenchResult],
) -> Result<(PathBuf, PathBuf, PathBuf)> {
    let (csv_path, plot_path) = sah_scatter_paths(args);
    let new = results
        .iter()
        .filter_map(|r| {
            Some(sah_scatter::Row {
                scene: scene.to_string(),
                builder: bench::builder_label(&r.params.bvh),
                check: r.sah_check?,
            })
        })
        .collect();
    let rows = sah_scatter::merge(earlier, new);
    // The shared CSV changes only once the plot is written.
    let csv = bvhlab::output::stage(&csv_path, sah_scatter::csv(&rows).as_bytes())?;
    let svg_path = plot::save(&sah_scatter::figure(&rows), &plot_path)?;
    csv.commit()?;
    Ok((csv_path, plot_path, svg_path))
}
