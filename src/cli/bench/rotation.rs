//! `bench rotation-sweep`: the walls turned from 0° to 45°, each builder from each angle.

use super::super::thread_pool;
use super::{BenchArgs, output_paths};
use anyhow::{Context, Result};
use bvhlab::accel::AccelKind;
use bvhlab::bench::{BenchConfig, plot, rotation};
use bvhlab::scene::Scene;

/// `bench rotation-sweep`: the walls turned from 0° to 45°, each builder traced from each angle's
/// view; a table, a CSV and a plot.
pub(super) fn run_rotation_sweep(args: &BenchArgs, width: u32, height: u32) -> Result<()> {
    let walls = match args.scene.split_once(':') {
        None if args.scene == "walls" => None,
        Some(("walls", n)) => Some(
            n.replace('_', "")
                .parse::<usize>()
                .ok()
                .filter(|&n| n > 0)
                .with_context(|| format!("'{n}' is not a number of walls"))?,
        ),
        _ => anyhow::bail!(
            "bench rotation-sweep turns the walls: use --scene walls (or walls:N), not {}",
            args.scene
        ),
    };
    if args.view.eye.is_some() || args.view.look.is_some() || args.view.light.is_some() {
        anyhow::bail!(
            "bench rotation-sweep traces each angle's own view: leave out --eye, --look and --light"
        );
    }
    if args
        .build
        .accel
        .is_some_and(|a| a != crate::cli::AccelArg::One(AccelKind::Bvh))
    {
        anyhow::bail!("bench rotation-sweep compares BVH builders: leave out --accel");
    }
    let first = Scene::load(&bvhlab::scene::builtin::walls_rotated_spec(0.0))?;
    let cfg = BenchConfig {
        camera: first.camera(),
        light: first.light(),
        width,
        height,
        params: args.build.structure_params_for(AccelKind::Bvh),
        builds: args.builds,
        runs: args.runs,
        intersector: args.intersector,
        embree: false,
        embree_robust: false,
        embree_quality: Default::default(),
        tinybvh: false,
        epo: args.epo,
    };
    cfg.params.validate()?;
    let pool = thread_pool(args.threads)?;
    let quiet = args.json;
    let rows = pool.install(|| {
        rotation::run(walls, &rotation::DEFAULT_ANGLES, &cfg, &mut |r| {
            if !quiet {
                eprintln!("  done: {}°, {}", r.degrees, r.builder);
            }
        })
    })?;
    let threads = pool.current_num_threads();
    let (csv_path, plot_path) = output_paths(args, "rotation", &args.scene);
    // Written once the plot is: a plot that cannot be written leaves no CSV either.
    let csv = bvhlab::output::stage(&csv_path, rotation::csv(&rows).as_bytes())?;
    let svg_path = plot::save(&rotation::figure(&rows, threads), &plot_path)?;
    csv.commit()?;
    if args.json {
        #[derive(serde::Serialize)]
        struct RotationJson<'a> {
            threads: usize,
            rows: &'a [rotation::RotationRow],
        }
        let json = RotationJson {
            threads,
            rows: &rows,
        };
        out!("{}", serde_json::to_string(&json)?);
        return Ok(());
    }
    out!(
        "{}: walls turned about +Y, {width}×{height} rays of each angle's view, {threads} threads",
        args.scene
    );
    out!(
        "  {:>5} {:<28} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "angle",
        "builder",
        "build ms",
        "dup refs",
        "nodes",
        "tri tests",
        "primary",
        "diffuse"
    );
    for r in &rows {
        out!(
            "  {:>4}° {:<28} {:>9.2} {:>9} {:>9.1} {:>9.1} {:>9.2} {:>9.2}",
            r.degrees,
            r.builder,
            r.build_ms,
            r.duplicated_references,
            r.nodes,
            r.triangle_tests,
            r.primary_mrays,
            r.diffuse_mrays
        );
    }
    out!("  (nodes and triangle tests: mean per primary ray; primary and diffuse: Mrays/s)");
    out!(
        "  wrote {}, {} and {}",
        csv_path.display(),
        plot_path.display(),
        svg_path.display()
    );
    Ok(())
}
