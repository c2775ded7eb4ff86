//! `bvhlab render --compare '<B flags>'`: the command's own build flags are configuration
//! A; the quoted flags, read as the same build flags over A's, are configuration B. Both
//! trace the same view; the PNG shows A | B or the difference B − A, and the summary
//! compares their counters.

use super::{BuildArgs, OrderArg};
use anyhow::{Context, Result, anyhow, bail};
use bvhlab::app::settings::{Pinned, Settings, StrategyChoice};
use bvhlab::render::compare::{CompareView, compare_image, compared_counters, summarize};
use bvhlab::render::{Frame, Mode, RenderSettings};
use bvhlab::scene::Scene;
use bvhlab::with_intersector;
use clap::parser::ValueSource;
use clap::{CommandFactory, FromArgMatches, Parser, ValueEnum};
use std::path::Path;

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq)]
pub enum CompareViewArg {
    /// Left half from A, right half from B, a line between them.
    Split,
    /// Per pixel B − A of the heatmap's counter: blue where B is cheaper, red where dearer.
    Difference,
}

impl CompareViewArg {
    pub fn view(self) -> CompareView {
        match self {
            CompareViewArg::Split => CompareView::Split,
            CompareViewArg::Difference => CompareView::Difference,
        }
    }
}

/// The build flags of configuration B, as `--compare` takes them.
#[derive(Parser)]
#[command(name = "--compare", no_binary_name = true, disable_help_flag = true)]
struct CompareFlags {
    #[command(flatten)]
    build: BuildArgs,
}

/// Copies into `b` the fields of `given` whose flag `is_set` (given on the command line);
/// returns the names of every field, which are the flags' ids.
macro_rules! given_over {
    ($b:ident, $given:ident, $is_set:ident; $($field:ident),* $(,)?) => {{
        $( if $is_set(stringify!($field)) { $b.$field = $given.$field.clone(); } )*
        &[$(stringify!($field)),*]
    }};
}

fn overlay(
    b: &mut BuildArgs,
    given: &BuildArgs,
    is_set: impl Fn(&str) -> bool,
) -> &'static [&'static str] {
    given_over!(b, given, is_set;
        accel, mailbox, builder, buckets, treelet_size, rounds, split_alpha, overlap_penalty,
        split_budget, presplit, rebraid, max_leaf, c_trav, c_isect, order, kd_c_trav, kd_c_isect, empty_bonus,
        kd_max_depth, kd_max_leaf, kd_bins, lambda, octree_max_leaf, octree_max_depth, simd,
    )
}

/// Configuration B: A's build flags with the ones `flags` gives replaced.
pub fn b_over_a(a: &BuildArgs, flags: &str) -> Result<BuildArgs> {
    let (given, is_set) = parse(flags)?;
    let mut b = a.clone();
    overlay(&mut b, &given, is_set);
    Ok(b)
}

/// The flags of `flags`, and which of them it gives (the others hold their defaults).
fn parse(flags: &str) -> Result<(BuildArgs, impl Fn(&str) -> bool)> {
    let matches = CompareFlags::command()
        .try_get_matches_from(flags.split_whitespace())
        .map_err(|e| {
            let message = e.render().to_string();
            let first = message.lines().next().unwrap_or_default();
            anyhow!(
                "bad --compare flags '{flags}': {}",
                first.trim_start_matches("error: ")
            )
        })?;
    let given = CompareFlags::from_arg_matches(&matches)?.build;
    let is_set = move |id: &str| matches.value_source(id) == Some(ValueSource::CommandLine);
    Ok((given, is_set))
}

/// The app's configuration B for `bvhlab screenshot --compare`: `a` with the build flags
/// `flags` gives.
pub fn settings_over(a: &Settings, flags: &str) -> Result<Pinned> {
    let (given, is_set) = parse(flags)?;
    let mut s = a.clone();
    if is_set("accel")
        && let Some(accel) = given.accel
    {
        s.accel = accel.kind()?;
    }
    if is_set("simd")
        && let Some(simd) = given.simd
    {
        s.simd = simd.level();
    }
    let b = &given;
    macro_rules! set {
        ($($flag:ident => $field:ident = $value:expr),* $(,)?) => {
            $( if is_set(stringify!($flag)) { s.$field = $value; } )*
        };
    }
    set!(
        mailbox => mailbox = b.mailbox,
        builder => strategy = StrategyChoice::from(b.builder.strategy()),
        buckets => buckets = b.buckets,
        treelet_size => treelet_size = b.treelet_size,
        rounds => treelet_rounds = b.rounds,
        split_alpha => split_alpha = b.split_alpha,
        overlap_penalty => overlap_penalty = b.overlap_penalty,
        split_budget => split_budget = b.split_budget,
        presplit => presplit = b.presplit,
        rebraid => rebraid = b.rebraid,
        max_leaf => max_leaf_size = b.max_leaf,
        c_trav => c_trav = b.c_trav,
        c_isect => c_isect = b.c_isect,
        order => naive_order = matches!(b.order, OrderArg::Naive),
        kd_c_trav => kd_c_trav = b.kd_c_trav,
        kd_c_isect => kd_c_isect = b.kd_c_isect,
        empty_bonus => kd_empty_bonus = b.empty_bonus,
        kd_max_depth => kd_max_depth = b.kd_max_depth,
        kd_max_leaf => kd_max_leaf_size = b.kd_max_leaf,
        kd_bins => kd_bins = b.kd_bins,
        lambda => grid_lambda = b.lambda,
        octree_max_leaf => octree_max_leaf_size = b.octree_max_leaf,
        octree_max_depth => octree_max_depth = b.octree_max_depth,
    );
    // Fail here rather than in the window.
    s.structure_params()
        .validate()
        .map_err(|e| anyhow!("bad --compare flags '{flags}': {e}"))?;
    Ok(Pinned::of(&s))
}

/// Traces A (`a`) and B (`flags` over `a`) with `settings`, writes the comparison to `out`
/// and prints the summary.
pub fn run(
    scene: &Scene,
    settings: &RenderSettings,
    intersector: bvhlab::geometry::IntersectorKind,
    a: &BuildArgs,
    flags: &str,
    view: CompareViewArg,
    out: &Path,
) -> Result<()> {
    let view = view.view();
    if view == CompareView::Difference && !matches!(settings.mode, Mode::Heatmap(..)) {
        bail!(
            "--compare-view difference needs a heatmap --mode (nodes, boxes, triangles, \
             repeated, top-nodes, bottom-nodes, instances), not {}",
            settings.mode.label()
        );
    }
    let b = b_over_a(a, flags)?;
    let trace = |name: &str, args: &BuildArgs| -> Result<Frame> {
        eprint!("{name}: ");
        let built = args.build_to_trace(scene)?;
        Ok(with_intersector!(intersector, I =>
            bvhlab::render::trace_with::<_, I>(&built.structure, scene, settings)))
    };
    let frame_a = trace("A", a)?;
    let frame_b = trace("B", &b)?;
    let (rgba, scale) = compare_image(&frame_a, &frame_b, settings.mode, settings.heat_max, view)?;
    image::save_buffer(
        out,
        &rgba,
        frame_b.width,
        frame_b.height,
        image::ExtendedColorType::Rgba8,
    )
    .with_context(|| format!("cannot write {}", out.display()))?;
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

    fn a_with(args: &[&str]) -> BuildArgs {
        CompareFlags::try_parse_from(args.iter().copied())
            .unwrap()
            .build
    }

    #[test]
    fn b_changes_only_the_flags_it_gives() {
        let a = a_with(&["--max-leaf", "8", "--builder", "lbvh", "--buckets", "16"]);
        let b = b_over_a(&a, "--builder sbvh").unwrap();
        assert!(matches!(b.builder, super::super::BuilderArg::Sbvh));
        assert_eq!((b.max_leaf, b.buckets), (8, 16));
        let b = b_over_a(&a, "--max-leaf 2 --accel kdtree --mailbox false").unwrap();
        assert_eq!((b.max_leaf, b.mailbox), (2, false));
        assert!(matches!(b.builder, super::super::BuilderArg::Lbvh));
        // No flags: B is A.
        let b = b_over_a(&a, "").unwrap();
        assert_eq!(b.max_leaf, a.max_leaf);
    }

    #[test]
    fn every_build_flag_can_be_given_to_b() {
        let a = a_with(&[]);
        let mut b = a.clone();
        let names = overlay(&mut b, &a, |_| false);
        let mut ids: Vec<String> = CompareFlags::command()
            .get_arguments()
            .map(|arg| arg.get_id().to_string())
            .collect();
        ids.sort();
        let mut names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        names.sort();
        assert_eq!(ids, names);
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
