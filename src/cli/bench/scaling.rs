//! `bench scaling`: how the cost per primary ray grows with the scene.

use super::super::thread_pool;
use super::{BenchArgs, output_paths};
use anyhow::Result;
use bvhlab::accel::AccelKind;
use bvhlab::bench::plot;
use bvhlab::bench::scaling::{self, ScalingConfig};

/// `bench scaling`: every structure at every size, as a table, a CSV, plots and fitted slopes.
pub(super) fn run_scaling(args: &BenchArgs, width: u32, height: u32) -> Result<()> {
    if args.build.accel == Some(crate::cli::AccelArg::All) {
        anyhow::bail!("bench scaling always runs every structure: leave out --accel all");
    }
    if args.view.eye.is_some() || args.view.look.is_some() || args.view.light.is_some() {
        anyhow::bail!(
            "bench scaling traces each scene's own view: leave out --eye, --look and --light"
        );
    }
    let name = args.scene.as_str();
    let sizes = args
        .sizes
        .clone()
        .unwrap_or_else(|| scaling::DEFAULT_SIZES.to_vec());
    if sizes.len() < 2 {
        anyhow::bail!("--sizes needs at least two sizes: a slope is drawn through several");
    }
    let (planned, note) = scaling::plan_sizes(name, &sizes)?;
    let cfg = ScalingConfig {
        scene: name.to_string(),
        sizes,
        kinds: AccelKind::ALL.to_vec(),
        params: args.build.structure_params_for(AccelKind::Bvh),
        width,
        height,
        runs: args.runs,
        intersector: args.intersector,
    };
    cfg.params.validate()?;
    let pool = thread_pool(args.threads)?;
    let quiet = args.json;
    if !quiet {
        if let Some(note) = &note {
            eprintln!("  note: {note}");
        }
        eprintln!(
            "  sizes: {}",
            planned
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let rows = pool.install(|| {
        scaling::run(&cfg, &mut |r| {
            if !quiet {
                eprintln!("  done: {} triangles, {}", r.triangles, r.kind.label());
            }
        })
    })?;
    let slopes = scaling::slopes(&rows);
    let (csv_path, plot_path) = output_paths(args, "scaling", name);
    // Written once the plot is: a plot that cannot be written leaves no CSV either.
    let csv = bvhlab::output::stage(&csv_path, scaling::csv(&rows).as_bytes())?;
    let svg_path = plot::save(&scaling::figure(&rows), &plot_path)?;
    csv.commit()?;
    let threads = rows.first().map_or(0, |r| r.threads);
    if args.json {
        #[derive(serde::Serialize)]
        struct ScalingJson<'a> {
            scene: &'a str,
            threads: usize,
            width: u32,
            height: u32,
            note: Option<&'a str>,
            rows: &'a [scaling::ScalingRow],
            slopes: &'a [scaling::Slopes],
        }
        let json = ScalingJson {
            scene: name,
            threads,
            width,
            height,
            note: note.as_deref(),
            rows: &rows,
            slopes: &slopes,
        };
        out!("{}", serde_json::to_string(&json)?);
        return Ok(());
    }
    out!(
        "{name}: cost per primary ray against size, {width}×{height} rays of the scene's view, \
         {threads} threads"
    );
    if let Some(note) = &note {
        out!("  ({note})");
    }
    out!(
        "  {:>9}  {:<17} {:>9} {:>10} {:>12} {:>10}",
        "triangles",
        "structure",
        "build ms",
        "nodes/ray",
        "tests/ray",
        "ns/ray"
    );
    for r in &rows {
        let note = if r.sampled > 1 {
            format!("  ({} of {} rays: 1 in {})", r.traced, r.rays, r.sampled)
        } else {
            String::new()
        };
        out!(
            "  {:>9}  {:<17} {:>9.2} {:>10.1} {:>12.1} {:>10.1}{note}",
            r.triangles,
            r.kind.label(),
            r.build_ms,
            r.nodes,
            r.triangle_tests,
            r.ns_per_ray
        );
    }
    out!("  slope of log(cost) against log(N), all sizes [larger half]:");
    out!(
        "  {:<17} {:>15} {:>15} {:>15}",
        "structure",
        "tests/ray",
        "nodes/ray",
        "ns/ray"
    );
    let f = |s: Option<f64>| s.map_or("-".to_string(), |s| format!("{s:.2}"));
    for s in &slopes {
        let cell = |k: usize| format!("{} [{}]", f(s.all[k]), f(s.upper[k]));
        out!(
            "  {:<17} {:>15} {:>15} {:>15}",
            s.kind.label(),
            cell(0),
            cell(1),
            cell(2)
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
