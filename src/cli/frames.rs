//! `bvhlab frames`: frame times of the explorer app's worker (no window), at preview and
//! full resolution, and the drag-to-refitted-frame time.

use super::{BuildArgs, ViewArgs, load_scene};
use anyhow::{Result, anyhow};
use bvhlab::app::timing::frames;
use clap::Args;

#[derive(Args)]
pub struct FramesArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, conflicts_with = "preset")]
    pub scene: Option<String>,
    /// Instead of one scene: step through a preset sequence (`lecture`, `lecture:N`, a
    /// preset file, `FILE:N`) as the app shows it, timing each step's first image and full
    /// frame from the step opening. As in the app, each step prefetches the next while it
    /// is shown; a step given alone (`lecture:N`) opens cold.
    #[arg(long, value_name = "lecture[:N]|FILE[:N]")]
    pub preset: Option<String>,
    /// With --preset: the view's size in pixels, 1280 × 720 unless given (--scene times
    /// 640×360 and 1280×720).
    #[arg(long, value_parser = crate::cli::parse_side)]
    pub width: Option<u32>,
    #[arg(long, value_parser = crate::cli::parse_side)]
    pub height: Option<u32>,
    /// With --preset: one JSON object, its `steps` array holding each step's
    /// `first_image_ms`, `full_frame_ms` and `prefetched`.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Frames per measurement (the median is reported; 1 to 1000).
    #[arg(long, default_value_t = 15, value_parser = crate::cli::repeats::<usize>)]
    pub runs: usize,
    #[command(flatten)]
    pub build: BuildArgs,
}

pub fn run(args: FramesArgs) -> Result<()> {
    let Some(spec) = &args.scene else {
        if args.preset.is_none() {
            anyhow::bail!(
                "say what to time: --scene (one view's frames) or --preset (the lecture's steps)"
            );
        }
        return lecture(&args);
    };
    if args.json {
        anyhow::bail!("--json is for --preset (the steps' times); --scene prints a table");
    }
    if args.width.is_some() || args.height.is_some() {
        anyhow::bail!("--width and --height are for --preset: --scene times 640×360 and 1280×720");
    }
    let scene = load_scene(spec)?;
    let _scene_held = scene.hold_budget();
    let camera = (args.view.eye.is_some() || args.view.look.is_some())
        .then(|| args.view.camera(&scene))
        .transpose()?;
    let sizes = [(640, 360, true), (640, 360, false), (1280, 720, false)];
    let params = args.build.structure_params(&scene)?;
    crate::cli::check_given_apply(&params)?;
    params.validate()?;
    let r = frames::run(spec, &params, camera, &sizes, args.runs).map_err(|e| anyhow!(e))?;
    out!(
        "{}: {} triangles, {}, {} threads",
        r.scene,
        r.triangles,
        params.kind.title(),
        rayon::current_num_threads()
    );
    for f in &r.frames {
        out!(
            "  {:>4}×{:<4} {:<8} {:<30} {:>7.1} ms/frame  ({:.1} frames/s)",
            f.width,
            f.height,
            if f.preview { "preview" } else { "full" },
            f.mode.label(),
            f.median.as_secs_f64() * 1e3,
            1.0 / f.median.as_secs_f64().max(1e-9)
        );
        if let Some(c) = f.counted {
            out!(
                "  {:>9} {:<8} {:<30} {:>7.1} ms until its counters are in (counted pass after the image)",
                "",
                "",
                "",
                c.as_secs_f64() * 1e3
            );
        }
    }
    let two_level = params.kind.places_instances();
    for d in &r.drags {
        let flat = match (two_level, d.flat_refit) {
            (false, _) => String::new(),
            (true, Some(f)) => format!(
                "; a flattened BVH2 refits it in {:.1} ms",
                f.as_secs_f64() * 1e3
            ),
            (true, None) => "; too large to flatten".into(),
        };
        out!(
            "  drag, {:<30} {:>7.1} ms/step   ({:.1} frames/s; {} {:.2} ms, trace {:.1} ms{flat})",
            d.mode.label(),
            d.median.as_secs_f64() * 1e3,
            d.fps,
            if two_level {
                "top-level refit"
            } else if params.kind.can_refit() {
                "refit"
            } else {
                "rebuild"
            },
            d.refit.as_secs_f64() * 1e3,
            d.trace.as_secs_f64() * 1e3
        );
    }
    if r.drags.is_empty() {
        out!("  (no drag: the scene does not store its triangles to move them)");
    } else if two_level {
        out!(
            "  (a drag step moves one instance of {} triangles, refits the top level, and traces the {}×{} preview)",
            r.moved,
            sizes[0].0,
            sizes[0].1
        );
    } else {
        out!(
            "  (a drag step moves {} triangles, refits or rebuilds, and traces the {}×{} preview)",
            r.moved,
            sizes[0].0,
            sizes[0].1
        );
    }
    Ok(())
}

/// `frames --preset`: each step of a sequence, timed as the app shows it.
fn lecture(args: &FramesArgs) -> Result<()> {
    let spec = args.preset.as_deref().unwrap_or("lecture");
    crate::cli::refuse_unused(
        &["preset", "width", "height", "json"],
        "each step of --preset sets its own scene, camera and structure (the flags are for \
         --scene)",
    )?;
    let (width, height) = (args.width.unwrap_or(1280), args.height.unwrap_or(720));
    crate::cli::check_size(width, height, 2)?;
    let (mut sequence, index) = bvhlab::app::preset::Sequence::open(spec)?;
    // `NAME:N` times step N alone (numbered N).
    let alone = spec
        .rsplit_once(':')
        .is_some_and(|(_, n)| n.parse::<usize>().is_ok());
    if alone {
        sequence.presets = vec![sequence.presets[index].clone()];
    }
    let mut steps =
        bvhlab::app::timing::lecture::run(&sequence, width, height).map_err(|e| anyhow!(e))?;
    if alone {
        steps.iter_mut().for_each(|s| s.step = index + 1);
    }
    if args.json {
        let json = serde_json::json!({
            "preset": spec,
            "width": width,
            "height": height,
            "threads": rayon::current_num_threads(),
            "steps": steps,
        });
        out!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    out!(
        "{spec}: {} steps at {}×{}, {} threads (ms from opening the step)",
        steps.len(),
        width,
        height,
        rayon::current_num_threads()
    );
    for s in &steps {
        out!(
            "  {:>2} {:<34} first image {:>8.1}  full frame {:>8.1}{}",
            s.step,
            s.title,
            s.first_image_ms,
            s.full_frame_ms,
            if s.prefetched { "  (prefetched)" } else { "" }
        );
    }
    Ok(())
}
