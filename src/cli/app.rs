//! `bvhlab` (no command) and `bvhlab app`: the explorer window; `bvhlab screenshot`: the same
//! window in a given state, saved to a PNG.

use super::compare::params_over;
use super::{check_size, load_scene};
use anyhow::Result;
use bvhlab::accel::{AccelKind, StructureParams};
use bvhlab::app::preset::Sequence;
use bvhlab::app::screenshot::{ScreenshotPlan, Shot};
use bvhlab::app::{Launch, run as run_app};
use bvhlab::render::compare::CompareView;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Args, Default)]
pub struct AppArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file
    /// (default: the last one).
    #[arg(long)]
    pub scene: Option<String>,
    /// Start from the default settings and remember nothing.
    #[arg(long)]
    pub fresh: bool,
    /// The structure to build (default: the last one; on a fresh start the fastest layout
    /// this machine traces).
    #[arg(long, value_enum)]
    pub accel: Option<AccelKind>,
    /// Open at a preset: `lecture` (the built-in lecture), `lecture:N` (its step N), a
    /// preset file, or `FILE:N`. It sets the scene, structure, view and camera.
    #[arg(long, value_name = "lecture[:N]|FILE[:N]", conflicts_with_all = ["scene", "accel"])]
    pub preset: Option<String>,
}

pub fn run(args: AppArgs) -> Result<()> {
    // A bad preset or scene is an error here, before any window opens.
    let preset = args.preset.as_deref().map(Sequence::open).transpose()?;
    let loaded = args.scene.as_deref().map(load_scene).transpose()?;
    run_app(Launch {
        scene: args.scene,
        loaded,
        accel: args.accel,
        fresh: args.fresh,
        screenshot: None,
        preset,
    })
}

#[derive(ValueEnum, Clone, Copy)]
pub enum ShotArg {
    Shaded,
    /// Heatmap of nodes visited.
    Nodes,
    /// Heatmap of ray–box tests.
    Boxes,
    /// Heatmap of ray–triangle tests.
    Triangles,
    /// The boxes of one BVH level over the shaded scene.
    Levels,
    /// An object dragged away and the tree refitted, with the SAH cost chart.
    Refit,
}

#[derive(Args)]
pub struct ScreenshotArgs {
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    #[arg(long, value_enum, default_value_t = ShotArg::Shaded)]
    pub mode: ShotArg,
    /// Window width in pixels (default 1400, or what the screen has room for; a size given
    /// is the size saved, or an error).
    #[arg(long, value_parser = crate::cli::parse_side)]
    pub width: Option<u32>,
    /// Window height in pixels (default 860, or what the screen has room for).
    #[arg(long, value_parser = crate::cli::parse_side)]
    pub height: Option<u32>,
    /// The structure to build.
    #[arg(long, value_enum, default_value_t = AccelKind::Bvh)]
    pub accel: AccelKind,
    /// For `--mode levels`: the depth shown (default 3).
    #[arg(long)]
    pub level: Option<u32>,
    /// Open the tree walk at this node (0 = the root), with its bucket-cost plot.
    #[arg(long)]
    pub walk: Option<u32>,
    /// With --accel two-level: select this instance; the levels view then goes on below
    /// the TLAS's levels with its BLAS's (give --level past the TLAS's depth to see them).
    #[arg(long)]
    pub instance: Option<usize>,
    /// Replay the ray through this point of the view, given as fractions u,v of its width
    /// and height (0,0 top left), and show it in the shot; the camera then turns 45° so the
    /// ray is seen from the side.
    #[arg(long, value_parser = parse_fraction_pair)]
    pub replay: Option<[f32; 2]>,
    /// With --replay: the visit shown, counted from 1 (default: the last).
    #[arg(long, requires = "replay", value_parser = crate::cli::at_least_one::<usize>)]
    pub replay_visit: Option<usize>,
    /// Pin the configuration (--accel and the defaults) as A, then change to B: build flags
    /// in one quoted argument, as `render --compare` takes them, e.g. '--builder
    /// object-median'. The shot shows the comparison and its summary.
    #[arg(long, value_name = "B FLAGS", allow_hyphen_values = true)]
    pub compare: Option<String>,
    /// With --compare: A | B side by side, or the difference B − A (heatmap modes).
    #[arg(long, value_enum, requires = "compare", default_value_t = CompareView::Split)]
    pub compare_view: CompareView,
    /// Open at a preset (`lecture`, `lecture:N`, a preset file, `FILE:N`): its scene,
    /// structure, view, overlays and camera replace --scene, --accel and --mode, and its
    /// caption is shown above the view.
    #[arg(long, value_name = "lecture[:N]|FILE[:N]")]
    pub preset: Option<String>,
    /// The presentation layout: the view fills the window under one slim bar with the
    /// caption (Tab or F11 in the app).
    #[arg(long)]
    pub presentation: bool,
    /// The UI scale, as the app's slider sets it (0.75..=2.5).
    #[arg(long, default_value_t = 1.0, value_parser = parse_ui_scale)]
    pub ui_scale: f32,
    /// Open the hierarchy diagram under the view (with --replay, the ray's path is drawn
    /// through its cells; with --walk, the walk's node is outlined).
    #[arg(long, conflicts_with = "presentation")]
    pub tree: bool,
}

fn parse_ui_scale(s: &str) -> Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|x| (0.75..=2.5).contains(x))
        .ok_or_else(|| format!("expected a UI scale from 0.75 to 2.5, got '{s}'"))
}

fn parse_fraction_pair(s: &str) -> Result<[f32; 2], String> {
    let bad = || format!("expected u,v with each between 0 and 1, got '{s}'");
    let (u, v) = s.split_once(',').ok_or_else(bad)?;
    let f = |t: &str| {
        t.trim()
            .parse::<f32>()
            .ok()
            .filter(|x| (0.0..=1.0).contains(x))
            .ok_or_else(bad)
    };
    Ok([f(u)?, f(v)?])
}

pub fn screenshot(args: ScreenshotArgs) -> Result<()> {
    let exact = args.width.is_some() || args.height.is_some();
    let (width, height) = (args.width.unwrap_or(1400), args.height.unwrap_or(860));
    check_size(width, height, 2)?;
    bvhlab::output::check(&args.out, &["png"])?;
    let shot = match args.mode {
        ShotArg::Shaded => Shot::Shaded,
        ShotArg::Nodes => Shot::Nodes,
        ShotArg::Boxes => Shot::Boxes,
        ShotArg::Triangles => Shot::Triangles,
        ShotArg::Levels => Shot::Levels,
        ShotArg::Refit => Shot::Refit,
    };
    let preset = args.preset.as_deref().map(Sequence::open).transpose()?;
    // Fail before opening a window when the scene cannot load.
    match &preset {
        Some((sequence, i)) => bvhlab::scene::Scene::load(&sequence.presets[*i].scene)?,
        None => bvhlab::scene::Scene::load(&args.scene)?,
    };
    if args.level.is_some() && shot != Shot::Levels {
        anyhow::bail!("--level is the depth of --mode levels");
    }
    let accel = args.accel;
    if args.instance.is_some() && !accel.places_instances() {
        anyhow::bail!("--instance selects an instance of the two levels: use --accel two-level");
    }
    let mut plan = ScreenshotPlan::new(args.out, shot, width, height);
    plan.exact_size = exact;
    plan.level = args.level;
    plan.presentation = args.presentation;
    plan.tree = args.tree;
    plan.ui_scale = args.ui_scale;
    plan.walk = args.walk;
    plan.instance = args.instance;
    plan.replay = args.replay.map(|at| bvhlab::app::screenshot::ReplayShot {
        at,
        visit: args.replay_visit.unwrap_or(usize::MAX),
    });
    if let Some(flags) = &args.compare {
        let mut a = bvhlab::app::settings::Settings {
            structure: StructureParams::of_kind(accel),
            ..Default::default()
        };
        plan.apply(&mut a);
        let view = args.compare_view;
        if view == CompareView::Difference && !a.mode.is_heatmap() {
            anyhow::bail!(
                "--compare-view difference needs a heatmap --mode (nodes, boxes, triangles), not {}",
                a.mode.label()
            );
        }
        plan.compare = Some(bvhlab::app::screenshot::CompareShot {
            b: params_over(&a.structure, flags)?,
            view,
        });
    }
    // The scene is loaded here, so a bad one is an error before the window opens.
    let loaded = load_scene(&args.scene)?;
    if let Some(i) = args.instance {
        let n = loaded.instancing().instances.len();
        if i >= n {
            anyhow::bail!(
                "there is no instance {i}: {} has {n}, 0 to {}",
                loaded.name,
                n - 1
            );
        }
    }
    run_app(Launch {
        scene: Some(args.scene),
        loaded: Some(loaded),
        accel: Some(accel),
        fresh: true,
        screenshot: Some(plan),
        preset,
    })
}
