//! The `bvhlab` command line: render, stats and bench over the library.

use anyhow::{Context, Result, bail};
use bvhlab::accel::bvh::{BuildParams, Strategy, TraversalOrder, build};
use bvhlab::accel::{BruteForce, Counter};
use bvhlab::bench::{self, BenchConfig};
use bvhlab::render::{self, Mode, RayKind, RenderSettings};
use bvhlab::scene::{Camera, Scene};
use clap::{Args, Parser, Subcommand, ValueEnum};
use glam::Vec3;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "bvhlab",
    version,
    about = "How bounding volume hierarchies make ray–scene queries fast: render, inspect and benchmark.",
    long_about = "How bounding volume hierarchies make ray–scene queries fast: render, inspect and \
                  benchmark.\n\nWithout a command, renders the default scene (cornell) to \
                  bvhlab-cornell.png.\n\nScenes are built-in names (cornell, teapot-in-stadium, \
                  grass, walls, walls-rotated, same-centroid, same-bbox, soup, sphere; most take a \
                  size as NAME:N, e.g. soup:50000) or paths to .obj files."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG through the CPU ray tracer.
    Render(RenderArgs),
    /// Build a BVH and print its build report as a table.
    Stats(StatsArgs),
    /// Time builds and the standard primary, diffuse and shadow ray sets.
    Bench(BenchArgs),
}

#[derive(Args, Clone)]
struct BuildArgs {
    /// Split strategy.
    #[arg(long, value_enum, default_value_t = BuilderArg::SahBinned)]
    builder: BuilderArg,
    /// Bucket count B for binned SAH (2..=256).
    #[arg(long, default_value_t = BuildParams::default().buckets)]
    buckets: u32,
    /// Maximum number of triangles in a leaf (1..=4096).
    #[arg(long, default_value_t = BuildParams::default().max_leaf_size)]
    max_leaf: u32,
    /// SAH cost of a traversal step.
    #[arg(long, default_value_t = BuildParams::default().c_trav)]
    c_trav: f32,
    /// SAH cost of a ray–triangle test.
    #[arg(long, default_value_t = BuildParams::default().c_isect)]
    c_isect: f32,
    /// Child order in closest-hit traversal.
    #[arg(long, value_enum, default_value_t = OrderArg::FrontToBack)]
    order: OrderArg,
}

#[derive(ValueEnum, Clone, Copy)]
enum BuilderArg {
    ObjectMedian,
    SpatialMedian,
    SahSweep,
    SahBinned,
}

#[derive(ValueEnum, Clone, Copy)]
enum OrderArg {
    FrontToBack,
    Naive,
}

#[derive(ValueEnum, Clone, Copy)]
enum AccelArg {
    /// The BVH built with the --builder parameters.
    Bvh,
    /// Every triangle for every ray.
    BruteForce,
    /// Every triangle, after testing the scene's bounding box.
    BruteForceBbox,
}

#[derive(ValueEnum, Clone, Copy, PartialEq)]
enum ModeArg {
    Shaded,
    Normals,
    Depth,
    /// Heatmap of nodes visited.
    Nodes,
    /// Heatmap of ray–box tests.
    Boxes,
    /// Heatmap of ray–triangle tests.
    Triangles,
}

impl BuildArgs {
    fn params(&self) -> BuildParams {
        BuildParams {
            strategy: match self.builder {
                BuilderArg::ObjectMedian => Strategy::ObjectMedian,
                BuilderArg::SpatialMedian => Strategy::SpatialMedian,
                BuilderArg::SahSweep => Strategy::SahSweep,
                BuilderArg::SahBinned => Strategy::SahBinned,
            },
            buckets: self.buckets,
            max_leaf_size: self.max_leaf,
            c_trav: self.c_trav,
            c_isect: self.c_isect,
        }
    }

    fn order(&self) -> TraversalOrder {
        match self.order {
            OrderArg::FrontToBack => TraversalOrder::FrontToBack,
            OrderArg::Naive => TraversalOrder::Naive,
        }
    }
}

#[derive(Args, Clone)]
struct ViewArgs {
    /// Camera position x,y,z (default: the scene's view).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<Vec3>,
    /// Point the camera looks at x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    look: Option<Vec3>,
    /// Point light position x,y,z (default: the scene's light).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    light: Option<Vec3>,
}

impl ViewArgs {
    fn camera(&self, scene: &Scene) -> Result<Camera> {
        let default = scene.camera();
        let cam = Camera {
            eye: self.eye.unwrap_or(default.eye),
            look_at: self.look.unwrap_or(default.look_at),
            ..default
        };
        if cam.eye == cam.look_at {
            bail!("--eye and --look must be different points");
        }
        Ok(cam)
    }

    fn light(&self, scene: &Scene) -> Vec3 {
        self.light.unwrap_or_else(|| scene.light())
    }
}

#[derive(Args)]
struct RenderArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Output PNG.
    #[arg(long, short)]
    out: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t = ModeArg::Shaded)]
    mode: ModeArg,
    /// For heatmaps: count the shadow rays instead of the primary rays.
    #[arg(long)]
    shadow: bool,
    /// For heatmaps: the count at the top of the colour scale (default: the frame's maximum).
    #[arg(long)]
    heat_max: Option<u32>,
    #[arg(long, default_value_t = 1024)]
    width: u32,
    #[arg(long, default_value_t = 768)]
    height: u32,
    /// Vertical field of view in degrees.
    #[arg(long)]
    fov: Option<f32>,
    #[command(flatten)]
    view: ViewArgs,
    /// Acceleration structure.
    #[arg(long, value_enum, default_value_t = AccelArg::Bvh)]
    accel: AccelArg,
    #[command(flatten)]
    build: BuildArgs,
}

#[derive(Args)]
struct StatsArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[command(flatten)]
    build: BuildArgs,
}

#[derive(Args)]
struct BenchArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj file.
    #[arg(long)]
    scene: String,
    #[command(flatten)]
    view: ViewArgs,
    #[arg(long, default_value_t = 1024)]
    width: u32,
    #[arg(long, default_value_t = 768)]
    height: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Builds to time; the best is reported.
    #[arg(long, default_value_t = 5)]
    builds: u32,
    /// Runs over each ray set; the best is reported.
    #[arg(long, default_value_t = 5)]
    runs: u32,
    /// Print exactly one JSON object.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    build: BuildArgs,
}

/// `println!` that returns an error instead of panicking when stdout is closed (as in
/// `bvhlab bench | head -1`); `main` treats a broken pipe as a normal end.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*)?
    }};
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("expected x,y,z, got '{s}'"));
    };
    let f = |v: &str| {
        v.parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("'{v}' is not a finite number"))
    };
    Ok(Vec3::new(f(x)?, f(y)?, f(z)?))
}

fn load_scene(spec: &str) -> Result<Scene> {
    Scene::load(spec).with_context(|| format!("cannot load scene '{spec}'"))
}

fn check_size(width: u32, height: u32) -> Result<()> {
    if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
        bail!("image size {width}×{height} must be within 1..=16384 on each side");
    }
    Ok(())
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    let result = match cli.command {
        None => {
            let out = PathBuf::from("bvhlab-cornell.png");
            let args = RenderArgs::parse_defaults(out.clone());
            run_render(args)
        }
        Some(Command::Render(args)) => run_render(args),
        Some(Command::Stats(args)) => run_stats(args),
        Some(Command::Bench(args)) => run_bench(args),
    };
    match result {
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            Ok(())
        }
        other => other,
    }
}

impl RenderArgs {
    fn parse_defaults(out: PathBuf) -> Self {
        let mut args = match Cli::parse_from(["bvhlab", "render"]).command {
            Some(Command::Render(a)) => a,
            _ => unreachable!("the render subcommand parses to Render"),
        };
        args.out = Some(out);
        args
    }
}

fn run_render(args: RenderArgs) -> Result<()> {
    check_size(args.width, args.height)?;
    let scene = load_scene(&args.scene)?;
    let mut camera = args.view.camera(&scene)?;
    if let Some(fov) = args.fov {
        if !(fov > 0.0 && fov < 180.0) {
            bail!("--fov {fov} must be between 0 and 180 degrees");
        }
        camera.fov_y_deg = fov;
    }
    let rays = if args.shadow {
        RayKind::Shadow
    } else {
        RayKind::Primary
    };
    let mode = match args.mode {
        ModeArg::Shaded => Mode::Shaded,
        ModeArg::Normals => Mode::Normals,
        ModeArg::Depth => Mode::Depth,
        ModeArg::Nodes => Mode::Heatmap(Counter::NodesVisited, rays),
        ModeArg::Boxes => Mode::Heatmap(Counter::BoxTests, rays),
        ModeArg::Triangles => Mode::Heatmap(Counter::TriangleTests, rays),
    };
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        camera,
        light: args.view.light(&scene),
        mode,
        heat_max: args.heat_max,
    };
    let frame = match args.accel {
        AccelArg::Bvh => {
            let (mut bvh, report) = build(&scene.triangles, &args.build.params())?;
            bvh.order = args.build.order();
            eprintln!(
                "built {} over {} triangles in {:.2} ms",
                report.params.strategy.label(),
                report.triangles,
                report.build_ms()
            );
            render::render(&bvh, &scene, &settings)
        }
        AccelArg::BruteForce => render_brute(&scene, false, &settings),
        AccelArg::BruteForceBbox => render_brute(&scene, true, &settings),
    };
    let out = args.out.unwrap_or_else(|| {
        let name = format!("bvhlab-{}.png", sanitize(&scene.name));
        PathBuf::from(name)
    });
    frame
        .save_png(&out)
        .with_context(|| format!("cannot write {}", out.display()))?;
    let s = &frame.summary;
    out!(
        "wrote {} ({}×{}, {}): {} rays in {:.1} ms, {:.2} Mrays/s",
        out.display(),
        frame.width,
        frame.height,
        mode.label(),
        s.rays(),
        s.trace_time.as_secs_f64() * 1e3,
        s.mrays_per_s()
    );
    for rays in [RayKind::Primary, RayKind::Shadow] {
        let c = |k| s.counter(rays, k);
        out!(
            "  {:<13} mean (max): {:.1} ({}) nodes visited, {:.1} ({}) box tests, {:.1} ({}) triangle tests",
            rays.label(),
            c(Counter::NodesVisited).mean,
            c(Counter::NodesVisited).max,
            c(Counter::BoxTests).mean,
            c(Counter::BoxTests).max,
            c(Counter::TriangleTests).mean,
            c(Counter::TriangleTests).max,
        );
    }
    if let Some(max) = frame.heat_max {
        out!("heatmap scale: 0 (dark purple) to {max} (yellow)");
    }
    Ok(())
}

fn render_brute(scene: &Scene, early_out: bool, settings: &RenderSettings) -> render::Frame {
    let accel = BruteForce::new(&scene.triangles, early_out);
    render::render(&accel, scene, settings)
}

fn sanitize(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn run_stats(args: StatsArgs) -> Result<()> {
    let scene = load_scene(&args.scene)?;
    let (_, report) = build(&scene.triangles, &args.build.params())?;
    out!("scene: {} ({} objects)", scene.name, scene.objects.len());
    let width = report
        .rows()
        .iter()
        .map(|(k, _)| k.chars().count())
        .max()
        .unwrap_or(0);
    for (k, v) in report.rows() {
        out!("  {k:<width$}  {v}");
    }
    Ok(())
}

fn run_bench(args: BenchArgs) -> Result<()> {
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
    };
    cfg.params.validate()?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start the worker threads")?;
    let result = pool.install(|| bench::run(&scene, &cfg))?;
    if args.json {
        out!("{}", result.to_json());
        return Ok(());
    }
    let r = &result;
    out!(
        "{}: {} triangles, {} threads, {}",
        r.scene,
        r.triangles,
        r.threads,
        r.report.params.strategy.label()
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_is_well_formed() {
        Cli::command().debug_assert();
    }

    #[test]
    fn vec3_parsing() {
        assert_eq!(parse_vec3("1,-2, 3.5"), Ok(Vec3::new(1.0, -2.0, 3.5)));
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,nan").is_err());
        assert!(parse_vec3("a,b,c").is_err());
    }
}
