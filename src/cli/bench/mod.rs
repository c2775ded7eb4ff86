//! `bvhlab bench`: build times and Mrays/s on the standard ray sets of a view, and the
//! studies behind it as subcommands, one file each: `accuracy`, `scaling`, `builders`
//! (with `tradeoff` and `sah-scatter`, which start from the builders' table) and
//! `rotation-sweep`; `--accel all` and the peers' rows are in `timing.rs`.

mod accuracy;
mod builders;
mod rotation;
mod scaling;
mod timing;

use super::{BuildArgs, ViewArgs, check_size, load_scene, thread_pool};
use anyhow::{Result, bail};
use bvhlab::accel::AccelKind;
use bvhlab::bench::{self, BenchConfig};
use bvhlab::geometry::IntersectorKind;
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// What every form of `bench` takes: the scene and view, the image, the threads, the
/// repetitions, the intersector and the structure.
#[derive(Args, Clone)]
pub struct BenchCommon {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, required = true)]
    pub scene: Option<String>,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Image width (default: 1024, or 256 for `scaling`).
    #[arg(long, value_parser = crate::cli::parse_side)]
    pub width: Option<u32>,
    /// Image height (default: 768, or 192 for `scaling`).
    #[arg(long, value_parser = crate::cli::parse_side)]
    pub height: Option<u32>,
    /// Worker threads, at most 4 × the cores (default: all cores).
    #[arg(long, value_parser = crate::cli::parse_threads)]
    pub threads: Option<usize>,
    /// Builds to time; the best is reported (1 to 1000).
    #[arg(long, default_value_t = 5, value_parser = crate::cli::repeats::<u32>)]
    pub builds: u32,
    /// Runs over each ray set; the best is reported (1 to 1000).
    #[arg(long, default_value_t = 5, value_parser = crate::cli::repeats::<u32>)]
    pub runs: u32,
    /// Print exactly one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Ray–triangle test of the timed runs.
    #[arg(long, value_enum, default_value_t = IntersectorKind::Watertight)]
    pub intersector: IntersectorKind,
    #[command(flatten)]
    pub build: BuildArgs,
    /// The EPO of the SAH check (`sah-scatter`'s third predictor).
    #[command(flatten)]
    pub epo: crate::cli::EpoArgs,
}

/// Where a study writes its table and chart.
#[derive(Args, Clone, Default)]
pub struct StudyFiles {
    /// The CSV file (default: <study>-<scene>.csv; sah-scatter.csv for `sah-scatter`).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// The plot PNG, with an SVG beside it (default: <study>-<scene>.png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `bvhlab bench`: build times and Mrays/s on the standard ray sets of a view, or one of
/// the studies.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct BenchCommand {
    #[command(subcommand)]
    pub study: Option<Study>,
    #[command(flatten)]
    pub common: BenchCommon,
    /// Also build and trace with Embree 3 on the same rays and threads, and print the
    /// ratios (needs a build with `--features embree`).
    #[arg(long)]
    pub embree: bool,
    /// Also Embree 3 built with its robust flag (RTC_SCENE_FLAG_ROBUST: the structures and
    /// tests it offers against rays slipping through shared edges), as a second peer with
    /// --embree or on its own (needs a build with `--features embree`).
    #[arg(long)]
    pub embree_robust: bool,
    /// Which of Embree's builders builds it: low (its Morton builder, beside --builder
    /// lbvh), medium (its default) or high (spatial splits, beside --builder sbvh).
    #[arg(long, value_enum, default_value_t = bench::EmbreeQuality::default())]
    pub embree_quality: bench::EmbreeQuality,
    /// Also tinybvh's BVH8_CPU (its fastest CPU layout), from its default build and from
    /// its SBVH, on the same rays and threads (needs a build with `--features tinybvh`).
    #[arg(long)]
    pub tinybvh: bool,
}

/// The studies behind `bench`, one file each.
#[derive(Subcommand)]
pub enum Study {
    /// Run time against error: every intersector with every builder (object median,
    /// spatial median, full-sweep SAH, binned SAH with B = 2..64, LBVH, LBVH + treelets);
    /// writes a CSV and a Pareto plot.
    Accuracy {
        #[command(flatten)]
        common: BenchCommon,
        #[command(flatten)]
        files: StudyFiles,
        /// Random rays compared with the f64 reference besides the ray sets.
        #[arg(long, default_value_t = 100_000)]
        random_rays: usize,
        /// Rays crossing the surface exactly at shared edges and vertices.
        #[arg(long, default_value_t = 100_000)]
        crossing_rays: usize,
    },
    /// How the cost per primary ray grows with the scene: every structure on the scene's
    /// own view at sizes from 10^3 to 10^6 triangles (soup, sphere, grass or
    /// teapot-in-stadium), one build per point; writes a CSV and log-log plots and prints
    /// the slopes.
    Scaling {
        #[command(flatten)]
        common: BenchCommon,
        #[command(flatten)]
        files: StudyFiles,
        /// The triangle counts, comma-separated (default:
        /// 1000,3000,10000,30000,100000,300000,1000000).
        #[arg(long, value_delimiter = ',', value_parser = crate::cli::whole_number::<usize>)]
        sizes: Option<Vec<usize>>,
    },
    /// Every BVH builder (object median, spatial median, full-sweep SAH, binned SAH, LBVH,
    /// LBVH + treelets, SBVH, and binned SAH, LBVH and LBVH + treelets again with
    /// pre-splits: --presplit, or 0.3) on the same ray sets, as one table: build ms, SAH
    /// cost, duplicated references, and Mrays/s with its percentage of SBVH's. Each BVH2 is
    /// traced as it is, or collapsed to the layout --accel bvh4 or bvh8 names (its build
    /// time then includes the collapse).
    Builders {
        #[command(flatten)]
        common: BenchCommon,
    },
    /// The builders' table, then build + trace time against N diffuse rays per frame
    /// (10^5 to 10^11) from each builder's build time and diffuse Mrays/s: a CSV, a log–log
    /// plot, and for which range of N each builder is best.
    Tradeoff {
        #[command(flatten)]
        common: BenchCommon,
        #[command(flatten)]
        files: StudyFiles,
    },
    /// The builders' table, then each tree's SAH cost against its measured cost per ray
    /// (random lines and the view's rays) as a scatter plot: the scene's rows go into the
    /// CSV (default sah-scatter.csv) beside the rows of other scenes already there, and the
    /// plot shows them all.
    SahScatter {
        #[command(flatten)]
        common: BenchCommon,
        #[command(flatten)]
        files: StudyFiles,
    },
    /// Turn the walls (--scene walls or walls:N) from 0° to 45° in steps of 5° and trace
    /// each angle's own view with binned SAH, SBVH, SBVH with the overlap penalty (κ = 1,
    /// --split-budget 16, unless --overlap-penalty is given) and pre-split LBVH + treelets:
    /// mean nodes visited, triangle tests and Mrays/s against the angle, as a table, a CSV
    /// and a plot.
    RotationSweep {
        #[command(flatten)]
        common: BenchCommon,
        #[command(flatten)]
        files: StudyFiles,
    },
}

impl BenchCommand {
    /// The run's settings, with the study's flag set.
    fn settings(self) -> Result<BenchArgs> {
        let (common, files) = match &self.study {
            None => (self.common.clone(), StudyFiles::default()),
            Some(
                Study::Accuracy { common, files, .. }
                | Study::Scaling { common, files, .. }
                | Study::Tradeoff { common, files }
                | Study::SahScatter { common, files }
                | Study::RotationSweep { common, files },
            ) => (common.clone(), files.clone()),
            Some(Study::Builders { common }) => (common.clone(), StudyFiles::default()),
        };
        let Some(scene) = common.scene else {
            bail!("--scene is required: the scene to benchmark");
        };
        let mut args = BenchArgs {
            scene,
            view: common.view,
            width: common.width,
            height: common.height,
            threads: common.threads,
            builds: common.builds,
            runs: common.runs,
            json: common.json,
            embree: self.embree,
            embree_robust: self.embree_robust,
            embree_quality: self.embree_quality,
            tinybvh: self.tinybvh,
            intersector: common.intersector,
            epo: common.epo.way(),
            accuracy: false,
            builders: false,
            tradeoff: false,
            sah_scatter: false,
            rotation_sweep: false,
            scaling: false,
            sizes: None,
            csv: files.csv,
            plot: files.plot,
            random_rays: 0,
            crossing_rays: 0,
            build: common.build,
        };
        match self.study {
            None => {}
            Some(Study::Accuracy {
                random_rays,
                crossing_rays,
                ..
            }) => {
                args.accuracy = true;
                args.random_rays = random_rays;
                args.crossing_rays = crossing_rays;
            }
            Some(Study::Scaling { sizes, .. }) => {
                args.scaling = true;
                args.sizes = sizes;
            }
            Some(Study::Builders { .. }) => args.builders = true,
            Some(Study::Tradeoff { .. }) => args.tradeoff = true,
            Some(Study::SahScatter { .. }) => args.sah_scatter = true,
            Some(Study::RotationSweep { .. }) => args.rotation_sweep = true,
        }
        Ok(args)
    }
}

/// Runs the benchmark or the study asked for.
pub fn run(command: BenchCommand) -> Result<()> {
    run_settings(command.settings()?)
}

/// Every setting of a `bench` run, whichever form it was asked in: the plain run, or one
/// study (exactly one of the study flags set).
pub struct BenchArgs {
    pub scene: String,
    pub view: ViewArgs,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub threads: Option<usize>,
    pub builds: u32,
    pub runs: u32,
    pub json: bool,
    pub embree: bool,
    pub embree_robust: bool,
    pub embree_quality: bench::EmbreeQuality,
    pub tinybvh: bool,
    pub intersector: IntersectorKind,
    pub epo: bvhlab::accel::epo::EpoWay,
    pub accuracy: bool,
    pub builders: bool,
    pub tradeoff: bool,
    pub sah_scatter: bool,
    pub rotation_sweep: bool,
    pub scaling: bool,
    pub sizes: Option<Vec<usize>>,
    pub csv: Option<PathBuf>,
    pub plot: Option<PathBuf>,
    pub random_rays: usize,
    pub crossing_rays: usize,
    pub build: BuildArgs,
}

fn run_settings(args: BenchArgs) -> Result<()> {
    // A study's files are checked before its work, which can take minutes.
    if let Some(csv) = &args.csv {
        bvhlab::output::check(csv, &["csv"])?;
    }
    if let Some(png) = &args.plot {
        bvhlab::bench::plot::check(png)?;
    }
    if let (Some(csv), Some(png)) = (&args.csv, &args.plot) {
        bvhlab::output::check_distinct(csv, png, "the plot")?;
        bvhlab::output::check_distinct(csv, &png.with_extension("svg"), "the plot's SVG")?;
    }
    let (width, height) = if args.scaling {
        (args.width.unwrap_or(256), args.height.unwrap_or(192))
    } else {
        (args.width.unwrap_or(1024), args.height.unwrap_or(768))
    };
    let ray_sets = || {
        bvhlab::budget::check(
            format!("the ray sets of {width}×{height} pixels"),
            bvhlab::budget::times(
                width as u64 * height as u64,
                bvhlab::budget::RAY_SETS_BYTES_PER_PIXEL,
            ),
        )
    };
    check_size(width, height, 1)?;
    ray_sets()?;
    let embree = args.embree || args.embree_robust;
    if embree && !bench::EMBREE_AVAILABLE {
        anyhow::bail!(bench::EMBREE_MISSING);
    }
    if args.tinybvh && !bench::TINYBVH_AVAILABLE {
        anyhow::bail!(bench::TINYBVH_MISSING);
    }
    if !embree && super::was_given("embree-quality") {
        bail!("--embree-quality does nothing without --embree or --embree-robust");
    }
    let peers = embree || args.tinybvh;
    // A study that sets a parameter itself would ignore the flag.
    let sets_itself = [
        (
            args.builders || args.sah_scatter || args.rotation_sweep,
            "builder",
            "the study runs every builder",
        ),
        (
            args.accuracy,
            "intersector",
            "the study runs every intersector",
        ),
    ];
    for (study, flag, why) in sets_itself {
        if study && super::was_given(flag) {
            anyhow::bail!("--{flag} does nothing here: {why}");
        }
    }
    if args.scaling {
        return scaling::run_scaling(&args, width, height);
    }
    if args.rotation_sweep {
        return rotation::run_rotation_sweep(&args, width, height);
    }
    let load_start = std::time::Instant::now();
    let scene = load_scene(&args.scene)?;
    let load_time = load_start.elapsed();
    // The rays are made beside the scene: both must fit (the structure's own estimate is
    // checked beside them as it is built).
    let _held = scene.hold_budget();
    ray_sets()?;
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
        intersector: args.intersector,
        embree: args.embree,
        embree_robust: args.embree_robust,
        embree_quality: args.embree_quality,
        tinybvh: args.tinybvh,
        epo: args.epo,
    };
    let all = args.build.accel == Some(super::AccelArg::All);
    // One structure timed (not every structure, not a study's own builders): a parameter
    // given for another is an error.
    if !all && !compares_builds && !args.tradeoff && !args.scaling {
        super::check_given_apply(&cfg.params)?;
    }
    if all && (peers || args.accuracy) {
        anyhow::bail!(
            "--accel all times bvhlab's structures only: leave out --embree and --tinybvh (and `bench accuracy` takes one structure)"
        );
    }
    // Embree's instanced build needs no flattened triangles when the two levels are traced;
    // tinybvh is given the triangles.
    let peer_flattens = (embree && !cfg.params.kind.places_instances()) || args.tinybvh;
    if (peer_flattens || args.accuracy) && !scene.is_flattened() {
        anyhow::bail!(
            "--embree, --tinybvh and `bench accuracy` work on the scene's stored triangles: {} \
             places its instances without storing them (--embree with --accel two-level \
             compares Embree's instances instead)",
            scene.name
        );
    }
    if (args.builders || args.tradeoff || args.sah_scatter)
        && args.build.accel.is_some_and(|a| {
            !matches!(
                a,
                super::AccelArg::One(AccelKind::Bvh | AccelKind::Bvh4 | AccelKind::Bvh8)
            )
        })
    {
        anyhow::bail!(
            "bench builders, tradeoff and sah-scatter compare the BVH's builders: --accel bvh \
             (the default there), bvh4 or bvh8"
        );
    }
    cfg.params.validate()?;
    let pool = thread_pool(args.threads)?;
    if args.builders || args.tradeoff || args.sah_scatter {
        return builders::run_builders(&args, &scene, &cfg, &pool);
    }
    if args.accuracy {
        return accuracy::run_accuracy(&args, &scene, &cfg, &pool);
    }
    if all {
        return timing::run_all(&args, &scene, &cfg, &pool);
    }
    let result = pool.install(|| bench::run(&scene, &cfg))?;
    if args.json {
        let json = bench::json::SingleJson {
            run: result.json(),
            instancing: bench::json::InstancingJson::of(&scene),
            load_ms: load_time.as_secs_f64() * 1e3,
        };
        out!("{}", serde_json::to_string(&json)?);
        return Ok(());
    }
    let r = &result;
    let what = match &r.bvh_report {
        Some(b) => format!("BVH2, {}", b.params.strategy.label()),
        None if r.params.kind.is_wide() || r.params.kind.places_instances() => format!(
            "{}, {}, {} kernel",
            r.params.kind.title(),
            r.params.bvh.wide_builder_label(),
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
    let detail = |name: &str| r.report.detail(name).map(|v| v.to_string());
    if let (Some(blas), Some(tlas)) = (detail("BLAS builds"), detail("TLAS build")) {
        out!("  of which BLAS builds {blas}, TLAS build {tlas}");
    }
    if let Some(t) = r.wide_rebuild {
        out!(
            "  rebuilt into its own memory, as every frame of a moving scene: {:.2} ms (best of {})",
            t.as_secs_f64() * 1e3,
            cfg.builds.max(1)
        );
    }
    if let Some(t) = r.top_level_rebuild {
        out!(
            "  top level rebuilt over its references where they are: {:.2} ms (best of {})",
            t.as_secs_f64() * 1e3,
            cfg.builds.max(1)
        );
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
            let levels = if r.params.kind.places_instances() {
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
        timing::print_peer(r, p)?;
    }
    Ok(())
}

pub(super) fn output_paths(args: &BenchArgs, study: &str, scene: &str) -> (PathBuf, PathBuf) {
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
