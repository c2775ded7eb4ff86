//! `bvhlab bench`: build times and Mrays/s on the standard ray sets of a view.

use super::{BuildArgs, IntersectorArg, ViewArgs, check_size, load_scene, thread_pool};
use anyhow::{Context, Result};
use bvhlab::accel::AccelKind;
use bvhlab::accel::bvh::Strategy;
use bvhlab::bench::accuracy::{self, AccuracyConfig};
use bvhlab::bench::scaling::{self, ScalingConfig};
use bvhlab::bench::{self, BenchConfig, plot, rotation, sah_scatter, tradeoff};
use bvhlab::scene::Scene;
use clap::{ArgGroup, Args};
use std::path::PathBuf;

#[derive(Args)]
#[command(group(ArgGroup::new("study").args(["accuracy", "scaling", "tradeoff", "rotation_sweep", "sah_scatter"])))]
pub struct BenchArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long)]
    pub scene: String,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Image width (default: 1024, or 256 with --scaling).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default: 768, or 192 with --scaling).
    #[arg(long)]
    pub height: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Builds to time; the best is reported.
    #[arg(long, default_value_t = 5)]
    pub builds: u32,
    /// Runs over each ray set; the best is reported.
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Print exactly one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Also build and trace with Embree 3 on the same rays and threads, and print the
    /// ratios (needs a build with `--features embree`).
    #[arg(long, conflicts_with = "study")]
    pub embree: bool,
    /// Also Embree 3 built with its robust flag (RTC_SCENE_FLAG_ROBUST: the structures and
    /// tests it offers against rays slipping through shared edges), as a second peer with
    /// --embree or on its own (needs a build with `--features embree`).
    #[arg(long, conflicts_with = "study")]
    pub embree_robust: bool,
    /// Ray–triangle test of the timed runs.
    #[arg(long, value_enum, default_value_t = IntersectorArg::Watertight)]
    pub intersector: IntersectorArg,
    /// Run time against error: every intersector with every builder (object median, spatial
    /// median, full-sweep SAH, binned SAH with B = 2..64, LBVH, LBVH + treelets); writes a CSV
    /// and a Pareto plot.
    #[arg(long)]
    pub accuracy: bool,
    /// Every BVH builder (object median, spatial median, full-sweep SAH, binned SAH, LBVH,
    /// LBVH + treelets, SBVH, and binned SAH, LBVH and LBVH + treelets again with pre-splits:
    /// --presplit, or 0.3) on the same ray sets, as one table: build ms, SAH cost, duplicated
    /// references, and Mrays/s with its percentage of SBVH's. Each BVH2 is traced as it is,
    /// or collapsed to the layout --accel bvh4 or bvh8 names (its build time then includes
    /// the collapse).
    #[arg(long, conflicts_with_all = ["accuracy", "scaling", "embree", "embree_robust", "rotation_sweep"])]
    pub builders: bool,
    /// The --builders table, then build + trace time against N diffuse rays per frame (10^5
    /// to 10^11) from each builder's build time and diffuse Mrays/s: a CSV, a log–log plot,
    /// and for which range of N each builder is best.
    #[arg(long, conflicts_with_all = ["embree", "embree_robust"])]
    pub tradeoff: bool,
    /// The --builders table, then each tree's SAH cost against its measured cost per ray
    /// (random lines and the view's rays) as a scatter plot: the scene's rows go into the
    /// CSV (default sah-scatter.csv) beside the rows of other scenes already there, and the
    /// plot shows them all.
    #[arg(long, conflicts_with_all = ["embree", "embree_robust"])]
    pub sah_scatter: bool,
    /// Turn the walls (--scene walls or walls:N) from 0° to 45° in steps of 5° and trace
    /// each angle's own view with binned SAH, SBVH, SBVH with the overlap penalty (κ = 1,
    /// --split-budget 16, unless --overlap-penalty is given) and pre-split LBVH + treelets:
    /// mean nodes visited, triangle tests and Mrays/s against the angle, as a table, a CSV
    /// and a plot.
    #[arg(long, conflicts_with_all = ["embree", "embree_robust"])]
    pub rotation_sweep: bool,
    /// How the cost per primary ray grows with the scene: every structure on the scene's own
    /// view at sizes from 10^3 to 10^6 triangles (soup, sphere, grass or teapot-in-stadium),
    /// one build per point; writes a CSV and log-log plots and prints the slopes.
    #[arg(long)]
    pub scaling: bool,
    /// With --scaling: the triangle counts, comma-separated (default:
    /// 1000,3000,10000,30000,100000,300000,1000000).
    #[arg(long, requires = "scaling", value_delimiter = ',')]
    pub sizes: Option<Vec<usize>>,
    /// With --accuracy, --scaling, --tradeoff, --rotation-sweep or --sah-scatter: the CSV
    /// file (default: <study>-<scene>.csv).
    #[arg(long, requires = "study")]
    pub csv: Option<PathBuf>,
    /// With --accuracy, --scaling, --tradeoff, --rotation-sweep or --sah-scatter: the plot
    /// PNG, with an SVG beside it (default: <study>-<scene>.png).
    #[arg(long, requires = "study")]
    pub plot: Option<PathBuf>,
    /// With --accuracy: random rays compared with the f64 reference besides the ray sets.
    #[arg(long, default_value_t = 100_000)]
    pub random_rays: usize,
    /// With --accuracy: rays crossing the surface exactly at shared edges and vertices.
    #[arg(long, default_value_t = 100_000)]
    pub crossing_rays: usize,
    #[command(flatten)]
    pub build: BuildArgs,
}

pub fn run(args: BenchArgs) -> Result<()> {
    let (width, height) = if args.scaling {
        (args.width.unwrap_or(256), args.height.unwrap_or(192))
    } else {
        (args.width.unwrap_or(1024), args.height.unwrap_or(768))
    };
    check_size(width, height)?;
    let peers = args.embree || args.embree_robust;
    if peers && !bench::EMBREE_AVAILABLE {
        anyhow::bail!(bench::EMBREE_MISSING);
    }
    if args.scaling {
        return run_scaling(&args, width, height);
    }
    if args.rotation_sweep {
        return run_rotation_sweep(&args, width, height);
    }
    let load_start = std::time::Instant::now();
    let scene = load_scene(&args.scene)?;
    let load_time = load_start.elapsed();
    // The builders and the accuracy study compare BVH2 builds (the builders, or their wide
    // collapses with --accel bvh4 or bvh8); the ray sets are traced with
    // the fastest layout unless --accel names one.
    let compares_builds = args.builders || args.accuracy || args.sah_scatter;
    let traced = if compares_builds {
        args.build.accel_for(&scene)
    } else {
        args.build.accel_to_trace(&scene)
    };
    let cfg = BenchConfig {
        camera: args.view.camera(&scene)?,
        light: args.view.light(&scene),
        width,
        height,
        params: args.build.structure_params_for(match traced {
            super::AccelArg::All => AccelKind::Bvh,
            a => a.kind()?,
        }),
        builds: args.builds,
        runs: args.runs,
        intersector: args.intersector.kind(),
        embree: args.embree,
        embree_robust: args.embree_robust,
    };
    let all = args.build.accel == Some(super::AccelArg::All);
    if all && (peers || args.accuracy) {
        anyhow::bail!(
            "--accel all times bvhlab's structures only: leave out --embree and --accuracy"
        );
    }
    // Embree's instanced build needs no flattened triangles when the two levels are traced.
    let peer_flattens = peers && cfg.params.kind != AccelKind::TwoLevel;
    if (peer_flattens || args.accuracy) && !scene.is_flattened() {
        anyhow::bail!(
            "--embree and --accuracy work on the scene's stored triangles: {} places its \
             instances without storing them (--embree with --accel two-level compares \
             Embree's instances instead)",
            scene.name
        );
    }
    if (args.builders || args.tradeoff || args.sah_scatter)
        && args.build.accel.is_some_and(|a| {
            !matches!(
                a,
                super::AccelArg::Bvh | super::AccelArg::Bvh4 | super::AccelArg::Bvh8
            )
        })
    {
        anyhow::bail!(
            "--builders, --tradeoff and --sah-scatter compare the BVH's builders: --accel bvh \
             (the default there), bvh4 or bvh8"
        );
    }
    cfg.params.validate()?;
    let pool = thread_pool(args.threads)?;
    if args.builders || args.tradeoff || args.sah_scatter {
        return run_builders(&args, &scene, &cfg, &pool);
    }
    if args.accuracy {
        return run_accuracy(&args, &scene, &cfg, &pool);
    }
    if all {
        return run_all(&args, &scene, &cfg, &pool);
    }
    let result = pool.install(|| bench::run(&scene, &cfg))?;
    if args.json {
        let mut json = result.to_json();
        add_instancing(&mut json, &scene);
        json["load_ms"] = (load_time.as_secs_f64() * 1e3).into();
        out!("{}", json);
        return Ok(());
    }
    let r = &result;
    let what = match &r.bvh_report {
        Some(b) => format!("BVH2, {}", b.params.strategy.label()),
        None if r.params.kind.is_wide() => format!(
            "{}, {}, {} kernel",
            r.params.kind.title(),
            r.params.bvh.strategy.label(),
            r.params.simd.label()
        ),
        None => r.params.kind.title().to_string(),
    };
    let fastest = if args.build.fastest_by_default(&scene) {
        " (the fastest layout on this machine; --accel picks another)"
    } else {
        ""
    };
    out!(
        "{}: {} triangles, {} threads, {what}, {} intersector{fastest}",
        r.scene,
        r.triangles,
        r.threads,
        r.intersector.label()
    );
    let sah = r.bvh_report.as_ref().map_or(String::new(), |b| {
        format!(", SAH cost {:.2}", b.tree.sah_cost)
    });
    out!(
        "  build {:.2} ms (best of {}){sah}, {} nodes, {:.2} MiB, {:.2} references per triangle",
        r.report.build_ms(),
        cfg.builds.max(1),
        r.report.nodes,
        r.report.mib(),
        r.report.references_per_triangle()
    );
    // The two levels' build, each level on its own (as `blas_build_ms` and `tlas_build_ms`
    // in --json).
    let detail = |name: &str| {
        r.report
            .details
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.clone())
    };
    if let (Some(blas), Some(tlas)) = (detail("BLAS builds"), detail("TLAS build")) {
        out!("  of which BLAS builds {blas}, TLAS build {tlas}");
    }
    out!(
        "  load {:.2} ms, ready (load + build) {:.2} ms",
        load_time.as_secs_f64() * 1e3,
        load_time.as_secs_f64() * 1e3 + r.report.build_ms()
    );
    for (k, v) in scene.instancing_rows() {
        out!("  {k}: {v}");
    }
    if r.sampled > 1 {
        out!("  (brute force: 1 in {} rays of each set)", r.sampled);
    }
    for (name, set, what) in [
        ("primary", &r.primary, "hits"),
        ("primary in 8×8 packets", &r.primary_packets, "hits"),
        ("diffuse", &r.diffuse, "hits"),
        ("shadow", &r.shadow, "occluded"),
    ] {
        let work = set.mean.map_or(String::new(), |m| {
            let step = set
                .ns_per_step(m.nodes)
                .map_or(String::new(), |ns| format!(" {ns:>6.1} ns per step"));
            let levels = if r.params.kind == AccelKind::TwoLevel {
                format!(
                    "  (top {:.1} nodes, {:.1} boxes; bottom {:.1} nodes, {:.1} boxes; {:.1} instances entered)",
                    m.top_nodes,
                    m.top_box_tests,
                    m.nodes - m.top_nodes,
                    m.box_tests - m.top_box_tests,
                    m.instances_entered
                )
            } else {
                String::new()
            };
            format!(
                "  {:>8.1} nodes {:>8.1} triangle tests per ray{step}{levels}",
                m.nodes, m.triangle_tests
            )
        });
        out!(
            "  {name:<22} {:>9} rays  {:>9} {what:<8}  {:>7.2} Mrays/s{work}",
            set.rays,
            set.hits,
            set.mrays_per_s()
        );
    }
    if let Some(c) = &r.sah_check {
        out!(
            "  SAH cost {:.2} predicted; measured C_trav·nodes + C_isect·tests per ray: random lines {:.2}, primary {:.2}, diffuse {:.2}, shadow {:.2}",
            c.predicted,
            c.random,
            c.primary,
            c.diffuse,
            c.shadow
        );
    }
    for p in &r.peers {
        print_peer(r, p)?;
    }
    Ok(())
}

/// An instanced scene's JSON also says how many instances place how many unique
/// triangles (`triangles` counts them placed).
fn add_instancing(json: &mut serde_json::Value, scene: &Scene) {
    if scene.instances.is_empty() {
        return;
    }
    let instancing = scene.instancing();
    json["instances"] = instancing.instances.len().into();
    json["unique_triangles"] = instancing.unique_triangles().into();
    json["instanced_triangles"] = instancing.instanced_triangles().into();
    json["flattened_bytes"] = scene.flattened_bytes().into();
}

/// `--accel all`: every structure on the same ray sets, as one table (or one JSON object
/// with a `structures` array).
fn run_all(
    args: &BenchArgs,
    scene: &Scene,
    cfg: &BenchConfig,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let quiet = args.json;
    let results = pool.install(|| {
        bench::run_all(scene, cfg, &AccelKind::ALL, &mut |r| {
            if !quiet {
                eprintln!("  done: {}", r.params.kind.label());
            }
        })
    })?;
    if args.json {
        let structures: Vec<serde_json::Value> = results.iter().map(|r| r.to_json()).collect();
        let mut json = serde_json::json!({
            "scene": scene.name,
            "triangles": scene.placed_triangles(),
            "threads": results.first().map_or(0, |r| r.threads),
            "structures": structures,
        });
        add_instancing(&mut json, scene);
        out!("{}", json);
        return Ok(());
    }
    out!(
        "{}: {} triangles, {} threads, {}×{} ray sets (Mrays/s; mean nodes visited / triangle tests per ray)",
        scene.name,
        scene.placed_triangles(),
        results.first().map_or(0, |r| r.threads),
        cfg.width,
        cfg.height
    );
    out!(
        "  {:<17} {:>9} {:>8} {:>23} {:>23} {:>23}",
        "structure",
        "build ms",
        "MiB",
        "primary",
        "diffuse",
        "shadow"
    );
    for r in &results {
        let cell = |s: &bench::RaySetResult| {
            let m = s.mean.unwrap_or_default();
            format!(
                "{:>7.2} {:>7.1} /{:>7.1}",
                s.mrays_per_s(),
                m.nodes,
                m.triangle_tests
            )
        };
        let note = if r.sampled > 1 {
            format!("  (1 in {} rays)", r.sampled)
        } else {
            String::new()
        };
        out!(
            "  {:<17} {:>9.2} {:>8.2} {:>23} {:>23} {:>23}{note}",
            r.params.kind.label(),
            r.report.build_ms(),
            r.report.mib(),
            cell(&r.primary),
            cell(&r.diffuse),
            cell(&r.shadow)
        );
    }
    // Same rays and one closest-hit rule: every structure that traced every ray must find
    // exactly the first one's hits.
    let counts = |r: &bench::BenchResult| [r.primary.hits, r.diffuse.hits, r.shadow.hits];
    let full: Vec<_> = results.iter().filter(|r| r.sampled == 1).collect();
    let differing: Vec<&str> = full
        .iter()
        .filter(|r| counts(r) != counts(full[0]))
        .map(|r| r.params.kind.label())
        .collect();
    if let Some(first) = full.first() {
        let [p, d, s] = counts(first);
        if differing.is_empty() {
            out!(
                "  hits: {p} primary, {d} diffuse, {s} occluded shadow rays, the same for every structure that traced every ray"
            );
        } else {
            out!(
                "  hit counts differ from the first structure's: {}",
                differing.join(", ")
            );
        }
    }
    Ok(())
}

/// `--builders`: every BVH builder on the same ray sets, as one table (or one JSON object
/// with a `builders` array); with `--tradeoff` also the build-versus-trace study.
fn run_builders(
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
        std::fs::write(&csv_path, tradeoff::csv(&scene.name, &lines))
            .with_context(|| format!("cannot write {}", csv_path.display()))?;
        let svg_path = plot::save(&tradeoff::figure(&scene.name, threads, &lines), &plot_path)?;
        written = Some((csv_path, plot_path, svg_path));
    }
    let scatter = match scatter_rows {
        Some(earlier) => Some(write_sah_scatter(args, earlier, &scene.name, &results)?),
        None => None,
    };
    if args.json {
        let builders: Vec<serde_json::Value> = results.iter().map(|r| r.to_json()).collect();
        let best: Vec<serde_json::Value> = tradeoff::best_ranges(&lines)
            .iter()
            .map(|b| {
                serde_json::json!({
                    "builder": lines[b.line].builder,
                    "from_rays": b.from_rays,
                    "to_rays": b.to_rays,
                })
            })
            .collect();
        out!(
            "{}",
            serde_json::json!({
                "scene": scene.name,
                "triangles": scene.placed_triangles(),
                "threads": threads,
                "builders": builders,
                "tradeoff_best": args.tradeoff.then_some(best),
            })
        );
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

/// The peer's numbers beside bvhlab's, as ratios bvhlab / peer (above 1: bvhlab is faster).
fn print_peer(r: &bench::BenchResult, p: &bench::PeerResult) -> Result<()> {
    let build_ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    out!(
        "  {} on the same rays and threads (primary hits on another triangle: {} ties within \
         rounding, {} at another depth or hit against miss):",
        p.name,
        p.tied_primary_hits,
        p.differing_primary_hits
    );
    // The peer's column is as wide as its name ("Embree 3, instanced" is wider than a number)
    // and two spaces.
    let w = p.name.chars().count().max(12) + 2;
    out!(
        "  {:<22} {:>12} {:>w$} {:>10}",
        "",
        "bvhlab",
        p.name,
        "ratio"
    );
    let (ours, theirs) = (r.report.build_ms(), build_ms(p.build));
    out!(
        "  {:<22} {:>9.2} ms {:>v$.2} ms {:>9.2}×",
        "build",
        ours,
        theirs,
        theirs / ours.max(1e-9),
        v = w - 3
    );
    for (name, a, b) in [
        ("primary", &r.primary, &p.primary),
        ("primary in packets", &r.primary_packets, &p.primary_packets),
        ("diffuse", &r.diffuse, &p.diffuse),
        ("shadow", &r.shadow, &p.shadow),
    ] {
        let (x, y) = (a.mrays_per_s(), b.mrays_per_s());
        out!(
            "  {name:<22} {x:>7.2} Mr/s {y:>v$.2} Mr/s {:>9.2}×",
            x / y.max(1e-9),
            v = w - 5
        );
    }
    Ok(())
}

fn run_accuracy(
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
        random_rays: args.random_rays,
        crossing_rays: args.crossing_rays,
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
    std::fs::write(&csv_path, accuracy::csv(&rows))
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let svg_path = plot::save(&accuracy::pareto_plot(&rows), &plot_path)?;
    if args.json {
        let json: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| {
                serde_json::json!({
                    "scene": r.scene, "builder": r.builder.label,
                    "intersector": r.intersector.label(), "build_ms": r.build_ms,
                    "sah_vs_full_sweep": r.sah_vs_sweep,
                    "primary_mrays_s": r.sets[0].mrays_per_s(),
                    "diffuse_mrays_s": r.sets[1].mrays_per_s(),
                    "shadow_mrays_s": r.sets[2].mrays_per_s(),
                    "ns_per_ray": r.ns_per_ray(),
                    "crossing_rays": r.crossings.rays,
                    "leaks": r.crossings.missed + r.crossings.passed_through,
                    "compared_rays": r.agreement.rays,
                    "mismatches": r.agreement.mismatches,
                })
            })
            .collect();
        out!("{}", serde_json::Value::Array(json));
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

/// `--scaling`: every structure at every size, as a table, a CSV, plots and fitted slopes.
fn run_scaling(args: &BenchArgs, width: u32, height: u32) -> Result<()> {
    if args.build.accel == Some(super::AccelArg::All) {
        anyhow::bail!("--scaling always runs every structure: leave out --accel all");
    }
    if args.view.eye.is_some() || args.view.look.is_some() || args.view.light.is_some() {
        anyhow::bail!(
            "--scaling traces each scene's own view: leave out --eye, --look and --light"
        );
    }
    let name = args.scene.as_str();
    let sizes = args
        .sizes
        .clone()
        .unwrap_or_else(|| scaling::DEFAULT_SIZES.to_vec());
    let (planned, note) = scaling::plan_sizes(name, &sizes)?;
    let cfg = ScalingConfig {
        scene: name.to_string(),
        sizes,
        kinds: AccelKind::ALL.to_vec(),
        params: args.build.structure_params_for(AccelKind::Bvh),
        width,
        height,
        runs: args.runs,
        intersector: args.intersector.kind(),
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
    std::fs::write(&csv_path, scaling::csv(&rows))
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let svg_path = plot::save(&scaling::figure(&rows), &plot_path)?;
    let threads = rows.first().map_or(0, |r| r.threads);
    if args.json {
        out!(
            "{}",
            serde_json::json!({
                "scene": name,
                "threads": threads,
                "width": width,
                "height": height,
                "note": note,
                "rows": rows.iter().map(|r| r.to_json()).collect::<Vec<_>>(),
                "slopes": slopes.iter().map(|s| s.to_json()).collect::<Vec<_>>(),
            })
        );
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

/// The CSV and plot paths of a study: `--csv` and `--plot`, or `<study>-<scene>.csv|png`.
/// The SAH check of every builder: its prediction, and each ray set's measured cost per
/// ray with its share of the prediction.
fn sah_check_table(results: &[bench::BenchResult]) -> Result<()> {
    out!("  SAH predicted against measured (cost per ray, and % of the SAH cost):");
    out!(
        "  {:<28} {:>9} {:>15} {:>15} {:>15} {:>15}",
        "builder",
        "SAH cost",
        "random lines",
        "primary",
        "diffuse",
        "shadow"
    );
    for r in results {
        let Some(c) = &r.sah_check else { continue };
        let cell = |m: f64| format!("{m:>7.1} ({:>3.0} %)", 100.0 * m / c.predicted);
        out!(
            "  {:<28} {:>9.2} {:>15} {:>15} {:>15} {:>15}",
            bench::builder_label(&r.params.bvh),
            c.predicted,
            cell(c.random),
            cell(c.primary),
            cell(c.diffuse),
            cell(c.shadow)
        );
    }
    Ok(())
}

/// The `--sah-scatter` files: the CSV and the plot.
fn sah_scatter_paths(args: &BenchArgs) -> (PathBuf, PathBuf) {
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

/// The rows already in the `--sah-scatter` CSV (none if it does not exist yet).
fn read_sah_scatter(args: &BenchArgs) -> Result<Vec<sah_scatter::Row>> {
    let (csv_path, _) = sah_scatter_paths(args);
    match std::fs::read_to_string(&csv_path) {
        Ok(text) => sah_scatter::parse_csv(&text)
            .map_err(|e| anyhow::anyhow!("{} is not a SAH scatter CSV: {e}", csv_path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Vec::new()),
        Err(e) => Err(e).with_context(|| format!("cannot read {}", csv_path.display())),
    }
}

/// `--sah-scatter`: this scene's rows merged into the CSV's, and the plot of them all.
fn write_sah_scatter(
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
    std::fs::write(&csv_path, sah_scatter::csv(&rows))
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let svg_path = plot::save(&sah_scatter::figure(&rows), &plot_path)?;
    Ok((csv_path, plot_path, svg_path))
}

fn output_paths(args: &BenchArgs, study: &str, scene: &str) -> (PathBuf, PathBuf) {
    let stem = super::render::sanitize(scene);
    let csv = args
        .csv
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{study}-{stem}.csv")));
    let plot = args
        .plot
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{study}-{stem}.png")));
    (csv, plot)
}

/// `--rotation-sweep`: the walls turned from 0° to 45°, each builder traced from each angle's
/// view; a table, a CSV and a plot.
fn run_rotation_sweep(args: &BenchArgs, width: u32, height: u32) -> Result<()> {
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
            "--rotation-sweep turns the walls: use --scene walls (or walls:N), not {}",
            args.scene
        ),
    };
    if args.view.eye.is_some() || args.view.look.is_some() || args.view.light.is_some() {
        anyhow::bail!(
            "--rotation-sweep traces each angle's own view: leave out --eye, --look and --light"
        );
    }
    if args.build.accel.is_some_and(|a| a != super::AccelArg::Bvh) {
        anyhow::bail!("--rotation-sweep compares BVH builders: leave out --accel");
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
        intersector: args.intersector.kind(),
        embree: false,
        embree_robust: false,
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
    std::fs::write(&csv_path, rotation::csv(&rows))
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let svg_path = plot::save(&rotation::figure(&rows, threads), &plot_path)?;
    if args.json {
        let rows: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| {
                serde_json::json!({
                    "degrees": r.degrees,
                    "builder": r.builder,
                    "build_ms": r.build_ms,
                    "duplicated_references": r.duplicated_references,
                    "mean_nodes": r.nodes,
                    "mean_triangle_tests": r.triangle_tests,
                    "primary_mrays_per_s": r.primary_mrays,
                    "diffuse_mrays_per_s": r.diffuse_mrays,
                })
            })
            .collect();
        out!(
            "{}",
            serde_json::json!({ "threads": threads, "rows": rows })
        );
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
