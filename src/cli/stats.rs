//! `bvhlab stats`: the build report of a structure as a table, or as JSON (`--json`), with
//! the tree's two predictors of trace cost, its SAH cost and its EPO.

use super::{BuildArgs, EpoArgs, load_scene};
use anyhow::Result;
use bvhlab::accel::epo::Epo;
use bvhlab::accel::report::Detail;
use bvhlab::accel::{Built, StructureParams};
use bvhlab::scene::Scene;
use clap::Args;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long the EPO may take before `stats` says it is still at work.
const SLOW_EPO: Duration = Duration::from_secs(3);
const SLOW_EPO_NOTE: &str = "still computing the EPO: the exact EPO clips every triangle \
    into every box it crosses, which takes long where the boxes overlap much; \
    `--epo estimate` gives it in a fraction of the time, with a standard error";

#[derive(Args)]
pub struct StatsArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    #[command(flatten)]
    pub build: BuildArgs,
    /// The report as one JSON object (keys below) instead of a table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub epo: EpoArgs,
}

/// The report's JSON: the measures every structure has, the tree's predictors (null for a
/// structure that is not a tree the SAH describes), and every row of the table by its name.
#[derive(Serialize)]
struct StatsJson {
    scene: String,
    accel: &'static str,
    triangles: usize,
    build_ms: f64,
    bytes: usize,
    nodes: usize,
    leaves: usize,
    empty_leaves: usize,
    max_depth: u32,
    references_per_triangle: f64,
    largest_leaf: usize,
    c_trav: Option<f32>,
    c_isect: Option<f32>,
    sah_cost: Option<f64>,
    epo: Option<f64>,
    /// An estimated EPO's (two levels placing too many triangles to clip) standard error
    /// and end points; null when exact.
    epo_std_error: Option<f64>,
    epo_end_points: Option<u64>,
    epo_ms: Option<f64>,
    details: BTreeMap<String, serde_json::Value>,
}

/// The tree's SAH cost and EPO with the costs they weigh with, and the EPO's time.
struct Predictors {
    c_trav: f32,
    c_isect: f32,
    sah_cost: f64,
    epo: Option<(Epo, f64)>,
}

fn predictors(
    built: &Built,
    params: &StructureParams,
    scene: &Scene,
    args: &StatsArgs,
) -> Option<Predictors> {
    let (sah_cost, c_trav, c_isect) = built.structure.sah_cost(params)?;
    let start = Instant::now();
    // The exact EPO of a tree whose boxes overlap heavily (a soup of a million triangles:
    // 40 s) can take long; say so once, with the faster way, rather than seem to hang.
    let told = AtomicBool::new(false);
    let tell_if_slow = || {
        if start.elapsed() > SLOW_EPO && !told.swap(true, Ordering::Relaxed) {
            eprintln!("{SLOW_EPO_NOTE}");
        }
        false
    };
    let epo = built
        .structure
        .epo_by(params, scene, args.epo.way(), &tell_if_slow);
    Some(Predictors {
        c_trav,
        c_isect,
        sah_cost,
        epo: epo.map(|e| (e, start.elapsed().as_secs_f64() * 1e3)),
    })
}

pub fn run(args: StatsArgs) -> Result<()> {
    let scene = load_scene(&args.scene)?;
    // The structure must fit beside the scene it is built over.
    let _held = scene.hold_budget();
    let built = args.build.build(&scene)?;
    let params = args.build.structure_params(&scene)?;
    let predicted = predictors(&built, &params, &scene, &args);
    let report = &built.report;
    if args.json {
        let p = predicted.as_ref();
        let json = StatsJson {
            scene: scene.name.clone(),
            accel: report.structure,
            triangles: report.triangles,
            build_ms: report.build_ms(),
            bytes: report.bytes,
            nodes: report.nodes,
            leaves: report.leaves,
            empty_leaves: report.empty_leaves,
            max_depth: report.max_depth,
            references_per_triangle: report.references_per_triangle(),
            largest_leaf: report.largest_leaf,
            c_trav: p.map(|p| p.c_trav),
            c_isect: p.map(|p| p.c_isect),
            sah_cost: p.map(|p| p.sah_cost),
            epo: p.and_then(|p| p.epo.map(|e| e.0.value)),
            epo_std_error: p.and_then(|p| Some(p.epo?.0.estimate?.std_error)),
            epo_end_points: p.and_then(|p| Some(p.epo?.0.estimate?.end_points)),
            epo_ms: p.and_then(|p| p.epo.map(|e| e.1)),
            details: report
                .details
                .iter()
                .map(|(k, v)| (k.clone(), detail_json(v)))
                .collect(),
        };
        out!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    out!("scene: {} ({} objects)", scene.name, scene.objects.len());
    let mut rows: Vec<_> = scene
        .instancing_rows()
        .into_iter()
        .map(|(k, v)| (format!("scene {k}"), v))
        .chain(report.rows())
        .collect();
    if let Some((p, (epo, epo_ms))) = predicted.as_ref().and_then(|p| Some((p, p.epo?))) {
        // Beside the SAH cost, the other predictor.
        let at = rows
            .iter()
            .position(|(k, _)| k.starts_with("SAH cost"))
            .map_or(rows.len(), |i| i + 1);
        let share = format!("{:.0} % of the SAH cost", 100.0 * epo.value / p.sah_cost);
        let (name, value) = match (epo.estimate, built.structure.kind().has_sah_cost()) {
            (None, true) => (
                "EPO (end-point overlap)",
                format!("{} ({share})", epo.label(3)),
            ),
            (None, false) => ("EPO, both levels", format!("{} ({share})", epo.label(3))),
            (Some(e), flat) => (
                match flat {
                    true => "EPO (end-point overlap, estimated)",
                    false => "EPO, both levels (estimated)",
                },
                format!(
                    "{} ({share}; {} end points drawn by area)",
                    epo.label(3),
                    e.end_points
                ),
            ),
        };
        rows.splice(
            at..at,
            [
                (name.to_string(), value),
                ("EPO computed in".to_string(), format!("{epo_ms:.2} ms")),
            ],
        );
    }
    let width = rows
        .iter()
        .map(|(k, _)| k.chars().count())
        .max()
        .unwrap_or(0);
    for (k, v) in rows {
        out!("  {k:<width$}  {v}");
    }
    Ok(())
}

/// A row's value as what it is: a count or a number as a number, a time in milliseconds.
fn detail_json(d: &Detail) -> serde_json::Value {
    match d {
        Detail::Text(t) => t.clone().into(),
        Detail::Count(n) => (*n).into(),
        Detail::Time(t) => (t.as_secs_f64() * 1e3).into(),
        Detail::Number(x, _) => (*x).into(),
    }
}
