//! The rotated walls, measured: the lecture's slide (a BVH several times slower once the
//! walls turn 30°) as a curve. The walls are turned from 0° to 45° and each builder's tree
//! is traced from the scene's own (turned) view: mean nodes visited, triangle tests and
//! Mrays/s against the angle. Axis-aligned boxes fit the walls only at 0°; spatial splits
//! and pre-splits cut the references down to what the boxes lose.

use super::plot::{Axis, Chart, Color, Figure, Mark, Scale, Series};
use super::{BenchConfig, BenchError, builder_label, run_builders};
use crate::accel::bvh::{BuildParams, Strategy};
use crate::scene::{Scene, SceneError, builtin};
use std::fmt::Write as _;

/// 0°, 5°, …, 45°.
pub const DEFAULT_ANGLES: [f32; 10] = [0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0];

/// The overlap penalty and split budget of the sweep's second SBVH: what the rotated walls
/// need (README, "The rotated walls, measured").
pub const WALLS_OVERLAP_PENALTY: f32 = 1.0;
pub const WALLS_SPLIT_BUDGET: f32 = 16.0;

/// The builders of the sweep: binned SAH, SBVH, SBVH with the overlap penalty (κ = 1 and a
/// budget of 16 N unless `base` sets a penalty already) and pre-split LBVH + treelets, with
/// the other parameters (and the pre-split budget, if set) from `base`.
pub fn builders(base: &BuildParams) -> Vec<BuildParams> {
    let presplit = if base.presplit > 0.0 {
        base.presplit
    } else {
        super::accuracy::PRESPLIT_BUDGET
    };
    let sbvh = BuildParams {
        strategy: Strategy::Sbvh,
        ..*base
    };
    let mut out = vec![
        BuildParams {
            strategy: Strategy::SahBinned,
            presplit: 0.0,
            ..*base
        },
        sbvh,
    ];
    if base.overlap_penalty == 0.0 {
        out.push(BuildParams {
            overlap_penalty: WALLS_OVERLAP_PENALTY,
            split_budget: WALLS_SPLIT_BUDGET.max(base.split_budget),
            ..sbvh
        });
    }
    out.push(BuildParams {
        strategy: Strategy::LbvhTreelet,
        presplit,
        ..*base
    });
    out
}

/// One builder at one angle.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RotationRow {
    pub degrees: f32,
    pub builder: String,
    pub build_ms: f64,
    pub duplicated_references: usize,
    /// Mean per primary ray.
    #[serde(rename = "mean_nodes")]
    pub nodes: f64,
    #[serde(rename = "mean_triangle_tests")]
    pub triangle_tests: f64,
    #[serde(rename = "primary_mrays_per_s")]
    pub primary_mrays: f64,
    #[serde(rename = "diffuse_mrays_per_s")]
    pub diffuse_mrays: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum RotationError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Bench(#[from] BenchError),
}

/// Runs every builder on the walls (`walls`, N walls per `size`) at every angle, each angle
/// traced from its own view at `cfg`'s image size; `cfg.camera` and `cfg.light` are replaced
/// by the turned scene's.
pub fn run(
    walls: Option<usize>,
    angles: &[f32],
    cfg: &BenchConfig,
    done: &mut dyn FnMut(&RotationRow),
) -> Result<Vec<RotationRow>, RotationError> {
    let mut rows = Vec::new();
    for &degrees in angles {
        let mut spec = builtin::walls_rotated_spec(degrees);
        if let Some(n) = walls {
            let _ = write!(spec, ":{n}");
        }
        let scene = Scene::load(&spec)?;
        let _held = scene.hold_budget();
        let cfg = BenchConfig {
            camera: scene.camera(),
            light: scene.light(),
            ..cfg.clone()
        };
        let results = run_builders(&scene, &cfg, &builders(&cfg.params.bvh), &mut |_| {})?;
        for r in results {
            let mean = r.primary.mean.unwrap_or_default();
            let row = RotationRow {
                degrees,
                builder: builder_label(&r.params.bvh),
                build_ms: r.report.build_ms(),
                duplicated_references: r.duplicated_references(),
                nodes: mean.nodes,
                triangle_tests: mean.triangle_tests,
                primary_mrays: r.primary.mrays_per_s(),
                diffuse_mrays: r.diffuse.mrays_per_s(),
            };
            done(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}

pub fn csv(rows: &[RotationRow]) -> String {
    let mut s = String::from(
        "degrees,builder,build_ms,duplicated_references,mean_nodes,mean_triangle_tests,\
         primary_mrays_per_s,diffuse_mrays_per_s\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.3},{},{:.3},{:.3},{:.3},{:.3}",
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
    s
}

const PALETTE: [Color; 4] = [[0, 114, 178], [213, 94, 0], [204, 121, 167], [0, 158, 115]];

/// Three panels against the angle: nodes visited, triangle tests, primary Mrays/s.
pub fn figure(rows: &[RotationRow], threads: usize) -> Figure {
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if !names.contains(&r.builder.as_str()) {
            names.push(&r.builder);
        }
    }
    let panel = |title: &str, y: &str, of: fn(&RotationRow) -> f64| Chart {
        title: title.into(),
        x: Axis {
            label: "rotation of the walls (degrees)".into(),
            scale: Scale::Linear,
        },
        y: Axis {
            label: y.into(),
            scale: Scale::Linear,
        },
        series: names
            .iter()
            .enumerate()
            .map(|(i, name)| Series {
                name: name.to_string(),
                color: PALETTE[i % PALETTE.len()],
                points: rows
                    .iter()
                    .filter(|r| r.builder == *name)
                    .map(|r| (r.degrees as f64, of(r)))
                    .collect(),
                mark: Mark::Line,
                labels: Vec::new(),
            })
            .collect(),
    };
    Figure {
        title: "walls turned about +Y: cost per primary ray against the angle".into(),
        charts: vec![
            panel("nodes visited", "mean nodes visited per ray", |r| r.nodes),
            panel("triangle tests", "mean triangle tests per ray", |r| {
                r.triangle_tests
            }),
            panel(
                "speed",
                &format!("primary Mrays/s ({threads} threads)"),
                |r| r.primary_mrays,
            ),
        ],
        notes: Vec::new(),
        size: (1560, 560),
    }
}
