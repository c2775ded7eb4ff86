//! `bvhlab bench`: build times and Mrays/s on the standard ray sets of a view.

use super::{BuildArgs, IntersectorArg, ViewArgs, check_size, load_scene, thread_pool};
use anyhow::Result;
use bvhlab::bench::{self, BenchConfig};
use clap::Args;

#[derive(Args)]
pub struct BenchArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj file.
    #[arg(long)]
    pub scene: String,
    #[command(flatten)]
    pub view: ViewArgs,
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    #[arg(long, default_value_t = 768)]
    pub height: u32,
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
    /// Ray–triangle test of the timed runs.
    #[arg(long, value_enum, default_value_t = IntersectorArg::Watertight)]
    pub intersector: IntersectorArg,
    #[command(flatten)]
    pub build: BuildArgs,
}

pub fn run(args: BenchArgs) -> Result<()> {
    check_size(args.width, args.height)?;
    let scene = load_scene(&args.scene)?;
    let cfg = BenchConfig {
        camera: args.view.camera(&scene)?,
        light: args.view.light(&scene),
        width: args.width,
        height: args.height,
        params: args.build.params(),
        builds: args.builds,
        runs: args.runs,
        intersector: args.intersector.kind(),
    };
    cfg.params.validate()?;
    let pool = thread_pool(args.threads)?;
    let result = pool.install(|| bench::run(&scene, &cfg))?;
    if args.json {
        out!("{}", result.to_json());
        return Ok(());
    }
    let r = &result;
    out!(
        "{}: {} triangles, {} threads, {}, {} intersector",
        r.scene,
        r.triangles,
        r.threads,
        r.report.params.strategy.label(),
        r.intersector.label()
    );
    out!(
        "  build {:.2} ms (best of {}), SAH cost {:.2}, {} nodes",
        r.report.build_ms(),
        cfg.builds.max(1),
        r.report.tree.sah_cost,
        r.report.tree.nodes
    );
    for (name, set, what) in [
        ("primary", &r.primary, "hits"),
        ("diffuse", &r.diffuse, "hits"),
        ("shadow", &r.shadow, "occluded"),
    ] {
        out!(
            "  {name:<8} {:>9} rays  {:>9} {what:<8}  {:>7.2} Mrays/s",
            set.rays,
            set.hits,
            set.mrays_per_s()
        );
    }
    Ok(())
}
