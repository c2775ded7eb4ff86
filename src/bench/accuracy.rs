//! Run time against error, behind `bvhlab bench accuracy`: every intersector with every
//! builder (object/spatial median, full-sweep SAH, binned SAH B = 2…64, LBVH, LBVH + treelets)
//! gives build time, SAH
//! cost, Mrays/s, leak and mismatch rates; written as CSV and as a Pareto plot.

use super::compare::{self, Agreement};
use super::plot::{self, Axis, Chart, Color, Figure, Mark, Scale, Series};
use super::rays::RaySets;
use super::stress::crossing::{self, CrossingReport, Topology};
use super::{RaySetResult, time_sets};
use crate::accel::bvh::{BuildError, BuildParams, Bvh, Strategy, build};
use crate::geometry::{IntersectorKind, Ray};
use crate::scene::{Camera, Scene};
use crate::with_intersector;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct AccuracyConfig {
    pub camera: Camera,
    pub light: Vec3,
    pub width: u32,
    pub height: u32,
    /// Builds per builder (the best time counts) and runs per ray set (the best counts).
    pub builds: u32,
    pub runs: u32,
    /// Random rays compared with the reference, besides the standard sets.
    pub random_rays: usize,
    /// Rays crossing the surface exactly at shared edges and vertices.
    pub crossing_rays: usize,
    pub seed: u64,
}

/// A builder of the comparison: its parameters and labels.
#[derive(Clone, Debug, PartialEq)]
pub struct Builder {
    pub label: String,
    /// Short label for the plot.
    pub short: String,
    pub params: BuildParams,
}

/// Object median, spatial median, full-sweep SAH, binned SAH with B = 2, 4, 8, 16, 32, 64,
/// LBVH, LBVH + treelets, both with pre-splits, and SBVH.
pub fn builders() -> Vec<Builder> {
    let with = |strategy, buckets| BuildParams {
        strategy,
        buckets,
        ..BuildParams::default()
    };
    let mut out = vec![
        Builder {
            label: "object median".into(),
            short: "obj".into(),
            params: with(Strategy::ObjectMedian, 16),
        },
        Builder {
            label: "spatial median".into(),
            short: "spa".into(),
            params: with(Strategy::SpatialMedian, 16),
        },
        Builder {
            label: "full-sweep SAH".into(),
            short: "sweep".into(),
            params: with(Strategy::SahSweep, 16),
        },
    ];
    for b in [2, 4, 8, 16, 32, 64] {
        out.push(Builder {
            label: format!("binned SAH B={b}"),
            short: format!("B{b}"),
            params: with(Strategy::SahBinned, b),
        });
    }
    out.push(Builder {
        label: "LBVH".into(),
        short: "lbvh".into(),
        params: with(Strategy::Lbvh, 16),
    });
    out.push(Builder {
        label: "LBVH + treelets".into(),
        short: "treelet".into(),
        params: with(Strategy::LbvhTreelet, 16),
    });
    let presplit = |strategy| BuildParams {
        presplit: PRESPLIT_BUDGET,
        ..with(strategy, 16)
    };
    out.push(Builder {
        label: "LBVH (pre-split)".into(),
        short: "lbvh+ps".into(),
        params: presplit(Strategy::Lbvh),
    });
    out.push(Builder {
        label: "LBVH + treelets (pre-split)".into(),
        short: "treelet+ps".into(),
        params: presplit(Strategy::LbvhTreelet),
    });
    out.push(Builder {
        label: "SBVH".into(),
        short: "sbvh".into(),
        params: with(Strategy::Sbvh, 16),
    });
    out
}

/// The pre-split budget the comparisons use: at most 30 % more references than triangles.
pub const PRESPLIT_BUDGET: f32 = 0.3;

/// One intersector with one builder on one scene.
#[derive(Clone, Debug)]
pub struct AccuracyRow {
    pub scene: String,
    pub triangles: usize,
    pub builder: Builder,
    pub intersector: IntersectorKind,
    pub threads: usize,
    pub build_ms: f64,
    pub sah_cost: f64,
    /// SAH cost divided by the full sweep's.
    pub sah_vs_sweep: f64,
    /// Primary, diffuse and shadow sets.
    pub sets: [RaySetResult; 3],
    pub crossings: CrossingReport,
    pub agreement: Agreement,
}

/// One row of `bench accuracy --json`.
#[derive(serde::Serialize)]
pub struct AccuracyJson {
    pub scene: String,
    pub builder: String,
    pub intersector: &'static str,
    pub build_ms: f64,
    pub sah_vs_full_sweep: f64,
    pub primary_mrays_s: f64,
    pub diffuse_mrays_s: f64,
    pub shadow_mrays_s: f64,
    pub ns_per_ray: f64,
    pub crossing_rays: u64,
    pub leaks: u64,
    pub compared_rays: u64,
    pub mismatches: u64,
}

impl AccuracyRow {
    /// The row as its JSON's fields.
    pub fn json(&self) -> AccuracyJson {
        AccuracyJson {
            scene: self.scene.clone(),
            builder: self.builder.label.clone(),
            intersector: self.intersector.label(),
            build_ms: self.build_ms,
            sah_vs_full_sweep: self.sah_vs_sweep,
            primary_mrays_s: self.sets[0].mrays_per_s(),
            diffuse_mrays_s: self.sets[1].mrays_per_s(),
            shadow_mrays_s: self.sets[2].mrays_per_s(),
            ns_per_ray: self.ns_per_ray(),
            crossing_rays: self.crossings.rays,
            leaks: self.crossings.missed + self.crossings.passed_through,
            compared_rays: self.agreement.rays,
            mismatches: self.agreement.mismatches,
        }
    }

    /// Wall-clock nanoseconds per ray over the three sets together.
    pub fn ns_per_ray(&self) -> f64 {
        let secs: f64 = self.sets.iter().map(|s| s.best.as_secs_f64()).sum();
        let rays: usize = self.sets.iter().map(|s| s.rays).sum();
        secs * 1e9 / rays.max(1) as f64
    }

    /// Leaks plus mismatches per million rays checked.
    pub fn errors_per_million(&self) -> f64 {
        let errors =
            self.crossings.missed + self.crossings.passed_through + self.agreement.mismatches;
        let rays = self.crossings.rays + self.agreement.rays;
        errors as f64 / rays.max(1) as f64 * 1e6
    }
}

/// Runs the comparison on the current rayon pool. `log` receives a line per builder.
pub fn run(
    scene: &Scene,
    cfg: &AccuracyConfig,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>, BuildError> {
    let tris = &scene.triangles;
    let (reference_bvh, _) = build(tris, &BuildParams::default())?;
    let sets = RaySets::standard(
        &reference_bvh,
        scene,
        &cfg.camera,
        cfg.light,
        cfg.width,
        cfg.height,
    );
    let mut compared: Vec<Ray> = Vec::new();
    compared.extend_from_slice(&sets.primary);
    compared.extend_from_slice(&sets.diffuse);
    compared.extend_from_slice(&sets.shadow);
    compared.extend(compare::random_rays(
        tris,
        &scene.bounds(),
        cfg.random_rays,
        cfg.seed,
    ));
    let reference = compare::reference_hits(&reference_bvh, &compared);
    let crossings = Topology::new(tris).crossings(tris, cfg.crossing_rays, cfg.seed);

    let mut rows = Vec::new();
    let mut sweep_cost = None;
    for builder in builders() {
        let mut best: Option<(Bvh, f64)> = None;
        for _ in 0..cfg.builds.max(1) {
            let (bvh, report) = build(tris, &builder.params)?;
            let ms = report.build_ms();
            if best.as_ref().is_none_or(|(_, b)| ms < *b) {
                best = Some((bvh, ms));
            }
        }
        let Some((bvh, build_ms)) = best else {
            unreachable!("at least one build ran")
        };
        let p = &builder.params;
        let sah_cost = bvh.sah_cost(p.c_trav, p.c_isect);
        if p.strategy == Strategy::SahSweep {
            sweep_cost = Some(sah_cost);
        }
        for kind in IntersectorKind::ALL {
            let (sets_result, crossing_result, agreement) = with_intersector!(kind, I => (
                time_sets::<_, I>(&bvh, &sets, cfg.runs),
                crossing::count::<_, I>(&bvh, tris, &crossings),
                compare::agreement::<_, _, I>(&bvh, &reference_bvh, tris, &compared, &reference),
            ));
            rows.push(AccuracyRow {
                scene: scene.name.clone(),
                triangles: tris.len(),
                builder: builder.clone(),
                intersector: kind,
                threads: rayon::current_num_threads(),
                build_ms,
                sah_cost,
                sah_vs_sweep: f64::NAN,
                sets: sets_result,
                crossings: crossing_result,
                agreement,
            });
        }
        log(&format!("{}: {}", scene.name, builder.label));
    }
    let sweep = sweep_cost.unwrap_or(f64::NAN);
    for r in &mut rows {
        r.sah_vs_sweep = r.sah_cost / sweep;
    }
    Ok(rows)
}

pub const CSV_HEADER: &str = "scene,triangles,threads,builder,intersector,build_ms,sah_cost,\
sah_vs_full_sweep,primary_mrays_s,diffuse_mrays_s,shadow_mrays_s,ns_per_ray,crossing_rays,\
leaks,leak_rate,compared_rays,ties,rounding,mismatches,mismatch_rate,max_rel_t_error";

/// The rows as CSV with `CSV_HEADER`.
pub fn csv(rows: &[AccuracyRow]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let leaks = r.crossings.missed + r.crossings.passed_through;
        let a = &r.agreement;
        out.push_str(&format!(
            "{},{},{},{},{},{:.3},{:.3},{:.4},{:.3},{:.3},{:.3},{:.2},{},{},{:.3e},{},{},{},{},{:.3e},{:.3e}\n",
            r.scene,
            r.triangles,
            r.threads,
            r.builder.label,
            r.intersector.label(),
            r.build_ms,
            r.sah_cost,
            r.sah_vs_sweep,
            r.sets[0].mrays_per_s(),
            r.sets[1].mrays_per_s(),
            r.sets[2].mrays_per_s(),
            r.ns_per_ray(),
            r.crossings.rays,
            leaks,
            r.crossings.leak_rate(),
            a.rays,
            a.ties,
            a.rounding,
            a.mismatches,
            a.mismatch_rate(),
            a.max_rel_t_error,
        ));
    }
    out
}

/// Colours of the intersectors in the plot.
pub fn color(kind: IntersectorKind) -> Color {
    match kind {
        IntersectorKind::Watertight => [0, 114, 178],
        IntersectorKind::MollerTrumbore => [213, 94, 0],
        IntersectorKind::F64 => [0, 158, 115],
    }
}

/// The Pareto plot of one scene's rows: ns per ray against errors per million rays, a colour
/// per intersector, a label per builder, the Pareto front as a ringed line.
pub fn pareto_plot(rows: &[AccuracyRow]) -> Figure {
    let scene = rows.first().map_or("", |r| r.scene.as_str());
    let threads = rows.first().map_or(1, |r| r.threads);
    let point = |r: &AccuracyRow| (r.ns_per_ray(), r.errors_per_million());
    let mut series: Vec<Series> = IntersectorKind::ALL
        .iter()
        .map(|&k| {
            let of_kind: Vec<&AccuracyRow> = rows.iter().filter(|r| r.intersector == k).collect();
            Series {
                name: k.label().to_string(),
                color: color(k),
                points: of_kind.iter().map(|r| point(r)).collect(),
                mark: Mark::Points,
                labels: of_kind.iter().map(|r| r.builder.short.clone()).collect(),
            }
        })
        .collect();
    let all: Vec<(f64, f64)> = rows.iter().map(point).collect();
    series.insert(
        0,
        Series {
            name: "Pareto front".into(),
            color: [0, 0, 0],
            points: plot::pareto_front(&all)
                .into_iter()
                .map(|i| all[i])
                .collect(),
            mark: Mark::Rings,
            labels: Vec::new(),
        },
    );
    Figure {
        title: format!("{scene}: run time against error"),
        charts: vec![Chart {
            title: String::new(),
            x: Axis {
                label: format!("ns per ray (primary + diffuse + shadow sets, {threads} threads)"),
                scale: Scale::Log,
            },
            y: Axis {
                label: "leaks + mismatches per million rays".into(),
                scale: Scale::SymLog,
            },
            series,
        }],
        notes: [
            "lower left is better",
            "",
            "obj: object median",
            "spa: spatial median",
            "sweep: full-sweep SAH",
            "Bn: binned SAH, n buckets",
            "lbvh: LBVH",
            "treelet: LBVH + treelets",
        ]
        .map(String::from)
        .to_vec(),
        size: (1100, 620),
    }
}
