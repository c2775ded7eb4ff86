//! `bvhlab render`: a scene through the CPU ray tracer into a PNG.

use super::{BuildArgs, ViewArgs, check_size, load_scene};
use anyhow::{Result, bail};
use bvhlab::accel::Counter;
use bvhlab::accel::hierarchy::{Shade, Width};
use bvhlab::geometry::IntersectorKind;
use bvhlab::render::compare::CompareView;
use bvhlab::render::{self, RayKind, RenderSettings, ViewMode};
use bvhlab::scene::Scene;
use bvhlab::with_intersector;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Args)]
pub struct RenderArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    /// Output PNG.
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t = ViewMode::Shaded)]
    pub mode: ViewMode,
    /// For heatmaps: count the shadow rays instead of the primary rays.
    #[arg(long)]
    pub shadow: bool,
    /// For heatmaps: the count at the top of the colour scale, at least 1 (default: the
    /// frame's maximum).
    #[arg(long, value_parser = crate::cli::at_least_one::<u32>)]
    pub heat_max: Option<u32>,
    #[arg(long, default_value_t = 1024, value_parser = crate::cli::parse_side)]
    pub width: u32,
    #[arg(long, default_value_t = 768, value_parser = crate::cli::parse_side)]
    pub height: u32,
    /// Vertical field of view in degrees.
    #[arg(long, value_parser = crate::cli::parse_fov)]
    pub fov: Option<f32>,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Ray–triangle test used by every ray.
    #[arg(long, value_enum, default_value_t = IntersectorKind::Watertight)]
    pub intersector: IntersectorKind,
    #[command(flatten)]
    pub build: BuildArgs,
    /// Compare with a second configuration B: build flags in one quoted argument, read over
    /// this command's own (configuration A), e.g. --compare '--builder sbvh'. The PNG shows
    /// both (--compare-view) and the summary compares their counters.
    #[arg(long, value_name = "B FLAGS", allow_hyphen_values = true)]
    pub compare: Option<String>,
    /// With --compare: A | B side by side, or the difference B − A of the heatmap's counter.
    #[arg(long, value_enum, requires = "compare", default_value_t = CompareView::Split)]
    pub compare_view: CompareView,
    /// Draw the structure's tree (BVH2 unless --accel names another) as a hierarchy
    /// diagram instead of the scene: one row per depth, each node within its parent.
    #[arg(long, conflicts_with_all = ["compare", "mode", "shadow", "heat_max"])]
    pub tree: bool,
    /// With --tree: what a node's width is proportional to among its siblings.
    #[arg(long, value_enum, requires = "tree", default_value_t = Width::Triangles)]
    pub tree_width: Width,
    /// With --tree: what a node's colour shows.
    #[arg(long, value_enum, requires = "tree", default_value_t = Shade::Depth)]
    pub tree_color: Shade,
    /// A crack study instead of the scene: an exact ray through every shared edge (5
    /// points each) and closed vertex fan in view, as `bvhlab stress` aims them; those the
    /// --intersector lets slip through are red dots on the greyed picture. Prints the counts
    /// of all three intersectors on the same rays.
    #[arg(long, conflicts_with_all = ["compare", "mode", "shadow", "heat_max", "tree"])]
    pub cracks: bool,
    /// With --cracks: move the scene, camera and light by (D, D, D) first (in f64, then
    /// rounded to f32), e.g. 1e5: far from the origin the coordinates are coarse.
    #[arg(long, value_name = "D", requires = "cracks", default_value_t = 0.0,
          value_parser = parse_offset, allow_hyphen_values = true)]
    pub offset: f64,
    /// With --cracks: draw the crossings that held too, as faint blue dots.
    #[arg(long, requires = "cracks")]
    pub held: bool,
}

/// `--offset D`: a finite number (whether f32 resolves the scene there is checked once it
/// is loaded).
fn parse_offset(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(d) if d.is_finite() => Ok(d),
        _ => Err(format!("'{text}' is not a finite number")),
    }
}

/// `mode` as `--mode` spells it.
pub fn mode_flag(mode: ViewMode) -> String {
    mode.to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string())
}

/// Refuses a heatmap of a count the structure never makes (`ViewMode::missing_counts`):
/// all zeros that would look like a measurement. `side` names A or B in a comparison.
pub fn check_counts(
    mode: ViewMode,
    side: Option<&str>,
    build: &BuildArgs,
    scene: &Scene,
) -> Result<()> {
    let kind = build.accel_to_trace(scene).kind()?;
    let params = build.structure_params_for(kind);
    if let Some(reason) = mode.missing_counts(&params) {
        let who = match side {
            Some(side) => format!("{side} ({})", kind.title()),
            None => kind.title().to_string(),
        };
        let hint = if mode.is_two_level() {
            if side.is_none() {
                "add --accel two-level"
            } else {
                "compare two-level structures"
            }
        } else if mode == ViewMode::TriangleCost {
            "use --accel bvh, bvh4, bvh8, kdtree, octree or two-level"
        } else {
            "use --accel kdtree, grid or octree with --mailbox false"
        };
        bail!(
            "--mode {} shows nothing under {who}: {reason}; {hint}",
            mode_flag(mode)
        );
    }
    Ok(())
}

pub fn run(args: RenderArgs) -> Result<()> {
    check_size(
        args.width,
        args.height,
        if args.compare.is_some() { 2 } else { 1 },
    )?;
    if let Some(out) = &args.out {
        bvhlab::output::check(out, &["png"])?;
    }
    let scene = load_scene(&args.scene)?;
    // The structure and the image must fit beside the scene.
    let _scene_held = scene.hold_budget();
    let mut camera = args.view.camera(&scene)?;
    if let Some(fov) = args.fov {
        camera.fov_y_deg = fov;
    }
    if !args.mode.is_heatmap() {
        for (given, flag) in [
            (args.shadow, "--shadow"),
            (args.heat_max.is_some(), "--heat-max"),
        ] {
            if given {
                bail!(
                    "{flag} is for heatmaps; --mode {} is not one",
                    mode_flag(args.mode)
                );
            }
        }
    }
    let mode = args.mode.render_mode(args.shadow);
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        camera,
        light: args.view.light(&scene),
        mode,
        heat_max: args.heat_max,
        shadows: true,
        counters: true,
    };
    let kind = args.intersector;
    let out_or_default = |suffix: &str| {
        args.out.clone().unwrap_or_else(|| {
            PathBuf::from(format!("bvhlab-{}{suffix}.png", sanitize(&scene.name)))
        })
    };
    if args.tree {
        return super::tree::run(&scene, &args, &settings, &out_or_default("-tree"));
    }
    if args.cracks {
        return super::cracks::run(&scene, &args, &settings, &out_or_default("-cracks"));
    }
    if let Some(flags) = &args.compare {
        if args.mode.colours_triangles() {
            bail!(
                "--compare does not compare --mode {}: render each configuration on its own",
                mode_flag(args.mode)
            );
        }
        let out = out_or_default("-compare");
        return super::compare::run(&scene, &settings, &args, flags, &out);
    }
    check_counts(args.mode, None, &args.build, &scene)?;
    let traced = args.build.accel_to_trace(&scene).kind()?;
    if args.mode == ViewMode::Repeated && args.build.structure_params_for(traced).mailbox {
        eprintln!(
            "note: with mailboxing on no triangle is tested twice, so the map is all zeros \
             (--mailbox false shows the repeats)"
        );
    }
    let built = args.build.build_to_trace(&scene)?;
    // The image is traced beside the scene and its structure: all three must fit.
    let _held = bvhlab::budget::hold(built.structure.bytes() as u64);
    check_size(args.width, args.height, 1)?;
    let frame = if args.mode.colours_triangles() {
        let params = args.build.structure_params_for(traced);
        triangle_frame(&built.structure, &params, &scene, &settings, kind)?
    } else {
        with_intersector!(kind, I => render::render_with::<_, I>(&built.structure, &scene, &settings))
    };
    let out = out_or_default("");
    frame.save_png(&out)?;
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
            "  {:<13} mean (max): {:.1} ({}) nodes visited, {:.1} ({}) box tests, {:.1} ({}) triangle tests, {:.1} ({}) repeated",
            rays.label(),
            c(Counter::NodesVisited).mean,
            c(Counter::NodesVisited).max,
            c(Counter::BoxTests).mean,
            c(Counter::BoxTests).max,
            c(Counter::TriangleTests).mean,
            c(Counter::TriangleTests).max,
            c(Counter::RepeatedTests).mean,
            c(Counter::RepeatedTests).max,
        );
        if c(Counter::TopNodesVisited).max > 0 {
            out!(
                "  {:<13} mean (max): {:.1} ({}) top-level nodes, {:.1} ({}) bottom-level nodes, {:.1} ({}) instances entered",
                "",
                c(Counter::TopNodesVisited).mean,
                c(Counter::TopNodesVisited).max,
                c(Counter::BottomNodesVisited).mean,
                c(Counter::BottomNodesVisited).max,
                c(Counter::InstancesEntered).mean,
                c(Counter::InstancesEntered).max,
            );
        }
    }
    if let Some(values) = frame.triangle_values(mode) {
        print_triangle_values(mode, values, frame.heat_max)?;
    } else if let Some(max) = frame.heat_max {
        out!("heatmap scale: 0 (dark purple) to {max} (yellow)");
    }
    Ok(())
}

/// A frame coloured by its triangles' values (`render::per_triangle`): traced, the values
/// worked out from every pixel's rays, then coloured.
fn triangle_frame(
    structure: &bvhlab::accel::Structure,
    params: &bvhlab::accel::StructureParams,
    scene: &Scene,
    settings: &RenderSettings,
    kind: IntersectorKind,
) -> Result<render::Frame> {
    let mut frame =
        with_intersector!(kind, I => render::trace_with::<_, I>(structure, scene, settings));
    let start = std::time::Instant::now();
    let values = with_intersector!(kind, I => frame.triangle_values_for::<I>(
        settings.mode, structure, params, scene, settings, 1, &|| false,
    ));
    if let Err(reason) = values {
        bail!("--mode shows nothing here: {reason}");
    }
    out!(
        "per-triangle values worked out in {:.1} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    frame.recolor(settings.mode, settings.heat_max);
    Ok(frame)
}

/// The legend of a frame coloured by its triangles' values.
fn print_triangle_values(
    mode: render::Mode,
    v: &render::per_triangle::TriangleValues,
    top: Option<u32>,
) -> Result<()> {
    let triangles = v.triangles.max(1) as f64;
    let (lo, hi) = v.shown;
    match mode {
        render::Mode::TriangleCost => {
            out!(
                "SAH cost per triangle: the tree's {:.4} over {} triangles (mean {:.3e}); the \
                 triangles shown cost {lo:.3e} to {hi:.3e}",
                v.total,
                v.triangles,
                v.total / triangles
            );
            let mid = render::per_triangle::log_value_at(0.5, v.shown);
            out!("colour scale (log): {lo:.3e} (dark purple), {mid:.3e} (teal), {hi:.3e} (yellow)");
        }
        _ => {
            let untested = v.triangles - v.above_zero;
            out!(
                "tests per triangle: {} tests by {} rays on {} triangles ({} never tested); the \
                 most on a triangle shown: {hi}",
                v.total,
                v.rays,
                v.triangles,
                untested
            );
            if let Some(max) = top {
                out!("colour scale: 0 (dark purple) to {max} (yellow)");
            }
        }
    }
    Ok(())
}

pub fn sanitize(name: &str) -> String {
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
