//! `bvhlab render --compare '<B flags>'`: the command's own build flags are configuration
//! A; the quoted flags, read as the same build flags over A's, are configuration B. Both
//! trace the same view; the PNG shows A | B or the difference B − A, and the summary
//! compares their counters.

use super::BuildArgs;
use anyhow::{Result, anyhow, bail};
use bvhlab::accel::StructureParams;
use bvhlab::render::compare::{CompareView, compare_image, compared_counters, summarize};
use bvhlab::render::{Frame, Mode, RenderSettings};
use bvhlab::scene::Scene;
use bvhlab::with_intersector;
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser};
use std::path::Path;

/// The build flags of configuration B, as `--compare` takes them.
#[derive(Parser)]
#[command(name = "--compare", no_binary_name = true, disable_help_flag = true)]
struct CompareFlags {
    #[command(flatten)]
    build: BuildArgs,
}

/// The flags `flags` gives, and only those: without their defaults, so that applied over
/// a configuration they change only what they name.
fn given(flags: &str) -> Result<ArgMatches> {
    if flags.trim().is_empty() {
        bail!("--compare needs B's build flags, e.g. --compare '--builder sbvh'");
    }
    CompareFlags::command()
        .mut_args(|arg| arg.default_value(None))
        .try_get_matches_from(flags.split_whitespace())
        .map_err(|e| {
            let message = e.render().to_string();
            let first = message.lines().next().unwrap_or_default();
            anyhow!(
                "bad --compare flags '{flags}': {}",
                first.trim_start_matches("error: ")
            )
        })
}

/// Configuration B: A's build flags with the ones `flags` gives replaced.
pub fn b_over_a(a: &BuildArgs, flags: &str) -> Result<BuildArgs> {
    let mut b = a.clone();
    b.update_from_arg_matches(&given(flags)?)?;
    Ok(b)
}

/// The app's configuration B for `bvhlab screenshot --compare`: `a` with the build flags
/// `flags` gives.
pub fn params_over(a: &StructureParams, flags: &str) -> Result<StructureParams> {
    let mut b = BuildArgs {
        accel: None,
        params: *a,
    };
    b.update_from_arg_matches(&given(flags)?)?;
    let b = b.structure_params_for(b.accel.map_or(Ok(a.kind), |k| k.kind())?);
    // Fail here rather than in the window.
    b.validate()
        .map_err(|e| anyhow!("bad --compare flags '{flags}': {e}"))?;
    Ok(b)
}

/// Traces A (`args`' build flags) and B (`flags` over A) with `settings`, writes the comparison to `out`
/// and prints the summary.
pub fn run(
    scene: &Scene,
    settings: &RenderSettings,
    args: &super::render::RenderArgs,
    flags: &str,
    out: &Path,
) -> Result<()> {
    let (a, mode, view, intersector) =
        (&args.build, args.mode, args.compare_view, args.intersector);
    if view == CompareView::Difference && !matches!(settings.mode, Mode::Heatmap(..)) {
        bail!(
            "--compare-view difference needs a heatmap --mode (nodes, boxes, triangles, \
             repeated, top-nodes, bottom-nodes, instances), not {}",
            super::render::mode_flag(mode)
        );
    }
    let b = b_over_a(a, flags)?;
    // B's parameters are checked before A is traced.
    let params_b = b.structure_params_for(b.accel_to_trace(scene).kind()?);
    params_b
        .validate()
        .map_err(|e| anyhow!("bad --compare flags '{flags}': {e}"))?;
    // The parameters name the structure too (`kind`).
    if params_b == a.structure_params_for(a.accel_to_trace(scene).kind()?) {
        bail!("--compare '{flags}' changes nothing: B is the same configuration as A");
    }
    for (name, args) in [("A", a), ("B", &b)] {
        super::render::check_counts(mode, Some(name), args, scene)?;
    }
    let trace = |name: &str, args: &BuildArgs| -> Result<Frame> {
        eprint!("{name}: ");
        let built = args.build_to_trace(scene)?;
        // Both frames are kept: they must fit beside the scene and this structure.
        let _held = bvhlab::budget::hold(built.structure.bytes() as u64);
        super::check_size(settings.width, settings.height, 2)?;
        Ok(with_intersector!(intersector, I =>
            bvhlab::render::trace_with::<_, I>(&built.structure, scene, settings)))
    };
    let frame_a = trace("A", a)?;
    let frame_b = trace("B", &b)?;
    let style = bvhlab::render::heat::HeatStyle::default();
    let (rgba, scale) = compare_image(
        &frame_a,
        &frame_b,
        settings.mode,
        settings.heat_max,
        &style,
        view,
    )?;
    bvhlab::output::write_png(&rgba, frame_b.width, frame_b.height, out)?;
    out!(
        "wrote {} ({}×{}, {}, {})",
        out.display(),
        frame_b.width,
        frame_b.height,
        settings.mode.label(),
        view.label()
    );
    for (counter, rays) in compared_counters(settings.mode) {
        for line in summarize(&frame_a, &frame_b, counter, rays)?.lines() {
            out!("{line}");
        }
    }
    match (view, scale) {
        (CompareView::Difference, Some(s)) => out!(
            "difference scale: -{s} (blue, B cheaper) through 0 (grey) to +{s} (red, B dearer)"
        ),
        (_, Some(max)) => out!("heatmap scale of both halves: 0 (dark purple) to {max} (yellow)"),
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use bvhlab::accel::{AccelKind, Strategy};

    fn a_with(args: &[&str]) -> BuildArgs {
        CompareFlags::try_parse_from(args.iter().copied())
            .unwrap()
            .build
    }

    #[test]
    fn b_changes_only_the_flags_it_gives() {
        let a = a_with(&["--max-leaf", "8", "--builder", "lbvh", "--buckets", "16"]);
        let b = b_over_a(&a, "--builder sbvh").unwrap();
        assert_eq!(b.params.bvh.strategy, Strategy::Sbvh);
        assert_eq!((b.params.bvh.max_leaf_size, b.params.bvh.buckets), (8, 16));
        let b = b_over_a(&a, "--max-leaf 2 --accel kdtree --mailbox false").unwrap();
        assert_eq!((b.params.bvh.max_leaf_size, b.params.mailbox), (2, false));
        assert_eq!(
            b.accel,
            Some(super::super::AccelArg::One(AccelKind::KdTree))
        );
        assert_eq!(b.params.bvh.strategy, Strategy::Lbvh);
        // No flags: nothing to compare.
        let e = b_over_a(&a, " ").err().unwrap().to_string();
        assert!(e.contains("needs B's build flags"), "{e}");
    }

    /// A's values that are not the defaults survive in B: the defaults of the flags B does
    /// not give never overwrite them.
    #[test]
    fn the_defaults_of_flags_not_given_do_not_reach_b() {
        let a = a_with(&[
            "--builder",
            "sbvh",
            "--buckets",
            "4",
            "--max-leaf",
            "3",
            "--c-trav",
            "2",
            "--c-isect",
            "3",
            "--treelet-size",
            "6",
            "--rounds",
            "1",
            "--split-alpha",
            "0.5",
            "--overlap-penalty",
            "1",
            "--split-budget",
            "0.5",
            "--presplit",
            "0.2",
            "--direct-wide",
            "true",
            "--rebraid",
            "2",
            "--order",
            "naive",
            "--kd-c-trav",
            "2",
            "--kd-c-isect",
            "3",
            "--empty-bonus",
            "0.1",
            "--kd-max-depth",
            "9",
            "--kd-max-leaf",
            "3",
            "--kd-bins",
            "16",
            "--lambda",
            "3",
            "--octree-max-leaf",
            "3",
            "--octree-max-depth",
            "5",
            "--mailbox",
            "false",
            "--simd",
            "portable",
        ]);
        let defaults = a_with(&[]).params;
        let b = b_over_a(&a, "--lambda 4").unwrap().params;
        assert_eq!(b.grid.lambda, 4.0);
        assert_eq!(
            StructureParams {
                grid: a.params.grid,
                ..b
            },
            a.params
        );
        // Every field of A differs from its default, so each one above was checked.
        let fields = |p: &StructureParams| match serde_json::to_value(p) {
            Ok(serde_json::Value::Object(map)) => map,
            _ => unreachable!(),
        };
        let (given, default) = (fields(&a.params), fields(&defaults));
        for (key, value) in &given {
            assert!(
                key == "accel" || default[key] != *value,
                "{key} is its default"
            );
        }
    }

    #[test]
    fn bad_b_flags_are_an_error_that_names_them() {
        let a = a_with(&[]);
        let e = b_over_a(&a, "--builder fastest").err().unwrap().to_string();
        assert!(e.contains("bad --compare flags '--builder fastest'"), "{e}");
        assert!(e.contains("fastest"), "{e}");
        let e = b_over_a(&a, "--no-such-flag").err().unwrap().to_string();
        assert!(e.contains("--no-such-flag"), "{e}");
    }
}
