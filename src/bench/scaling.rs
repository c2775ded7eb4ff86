//! How the cost of a ray grows with the scene, behind `bvhlab bench scaling`: every structure
//! traces the same view of a built-in scene at sizes from 10³ to 10⁶ triangles, and the slope of
//! log(cost) against log(N) tells brute force's ∝ N from a grid's ∝ N^(1/3) and a tree's ∝ log N.

use super::plot::{Axis, Chart, Color, Figure, Mark, Scale, Series};
use super::rays::RaySets;
use super::{mean_work, time_set};
use crate::accel::structure::{self, AccelKind, StructureError};
use crate::accel::{Accel, NoStats, StructureParams};
use crate::geometry::{IntersectorKind, Ray};
use crate::scene::builtin::TEAPOT_IN_STADIUM_MIN_TRIANGLES;
use crate::scene::{Scene, SceneError};
use crate::with_intersector;

/// The built-in scenes whose size N can be set.
pub const SCENES: [&str; 4] = ["soup", "sphere", "grass", "teapot-in-stadium"];

/// 10³ to 10⁶ triangles, about three points a decade.
/// Brute force over a large scene traces every k-th ray only, so that a pass over the rays
/// takes at most about this many triangle tests (its means per ray stay exact).
pub const BRUTE_FORCE_TESTS: usize = 1 << 28;

pub const DEFAULT_SIZES: [usize; 7] = [1_000, 3_000, 10_000, 30_000, 100_000, 300_000, 1_000_000];

#[derive(Clone, Debug)]
pub struct ScalingConfig {
    /// One of `SCENES`, without a size.
    pub scene: String,
    /// Triangle counts to build the scene at.
    pub sizes: Vec<usize>,
    /// The structures to compare, each with `params`' settings.
    pub kinds: Vec<AccelKind>,
    pub params: StructureParams,
    pub width: u32,
    pub height: u32,
    /// Timed runs over the rays (the best counts).
    pub runs: u32,
    pub intersector: IntersectorKind,
}

#[derive(Debug, thiserror::Error)]
pub enum ScalingError {
    #[error(
        "scene '{0}' has no size to scale: the scaling study takes one of {scenes}, without \
         ':N' (it sets the size itself)",
        scenes = SCENES.join(", ")
    )]
    NotScalable(String),
    #[error("the scaling study needs at least one size and one structure")]
    Empty,
    #[error("size {0} is given twice in --sizes")]
    Duplicate(usize),
    #[error(
        "sizes {} and {} of sphere both make {triangles} triangles (it fills its last ring): \
         give sizes further apart", sizes.0, sizes.1
    )]
    SameScene {
        sizes: (usize, usize),
        triangles: usize,
    },
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Build(#[from] StructureError),
}

/// One structure at one scene size.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ScalingRow {
    pub scene: String,
    /// The size asked for; `triangles` is what the scene has (spheres fill their last ring).
    pub size: usize,
    pub triangles: usize,
    #[serde(rename = "structure", serialize_with = "label_of")]
    pub kind: AccelKind,
    pub threads: usize,
    pub build_ms: f64,
    /// Primary rays of the view, and how many were traced (brute force over a large scene
    /// traces every `sampled`-th only).
    pub rays: usize,
    #[serde(rename = "rays_traced")]
    pub traced: usize,
    #[serde(rename = "sampled_every")]
    pub sampled: usize,
    pub hits: usize,
    /// Mean nodes visited and triangle tests per traced primary ray (exact per ray).
    #[serde(rename = "mean_nodes")]
    pub nodes: f64,
    #[serde(rename = "mean_triangle_tests")]
    pub triangle_tests: f64,
    /// Wall-clock nanoseconds per ray over the traced rays, best of the runs.
    pub ns_per_ray: f64,
}

/// The three costs the study measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    TriangleTests,
    Nodes,
    NsPerRay,
}

impl Metric {
    pub const ALL: [Metric; 3] = [Metric::TriangleTests, Metric::Nodes, Metric::NsPerRay];

    pub fn label(self) -> &'static str {
        match self {
            Metric::TriangleTests => "triangle_tests",
            Metric::Nodes => "nodes",
            Metric::NsPerRay => "ns_per_ray",
        }
    }

    pub fn of(self, r: &ScalingRow) -> f64 {
        match self {
            Metric::TriangleTests => r.triangle_tests,
            Metric::Nodes => r.nodes,
            Metric::NsPerRay => r.ns_per_ray,
        }
    }
}

/// The exponents k of cost ∝ N^k of one structure, per metric (`None` where fewer than two
/// points have a positive cost).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Slopes {
    #[serde(rename = "structure", serialize_with = "label_of")]
    pub kind: AccelKind,
    /// Least squares over every size.
    #[serde(rename = "all_sizes", serialize_with = "by_metric")]
    pub all: [Option<f64>; 3],
    /// Least squares over the larger half of the sizes.
    #[serde(rename = "upper_half", serialize_with = "by_metric")]
    pub upper: [Option<f64>; 3],
}

/// A structure in the JSON: its label, as the tables print it.
fn label_of<S: serde::Serializer>(kind: &AccelKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(kind.label())
}

/// A slope per metric in the JSON: an object keyed by the metrics' labels.
fn by_metric<S: serde::Serializer>(slopes: &[Option<f64>; 3], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = s.serialize_map(Some(3))?;
    for (metric, v) in Metric::ALL.iter().zip(slopes) {
        map.serialize_entry(metric.label(), v)?;
    }
    map.end()
}

/// The spec of `scene` at about `triangles` triangles (`grass` has two per blade, on a
/// two-triangle ground).
pub fn sized_spec(scene: &str, triangles: usize) -> Result<String, ScalingError> {
    match scene {
        "soup" | "sphere" | "teapot-in-stadium" => Ok(format!("{scene}:{triangles}")),
        "grass" => Ok(format!(
            "grass:{}",
            triangles.saturating_sub(2).div_ceil(2).max(1)
        )),
        _ => Err(ScalingError::NotScalable(scene.to_string())),
    }
}

/// The sizes to run, in increasing order, with a note when some had to change: the teapot
/// alone has more triangles than the smallest sizes, so those become the plainest stadium.
pub fn plan_sizes(
    scene: &str,
    sizes: &[usize],
) -> Result<(Vec<usize>, Option<String>), ScalingError> {
    sized_spec(scene, 1)?;
    let mut out: Vec<usize> = sizes.to_vec();
    out.sort_unstable();
    if let Some(twice) = out.windows(2).find(|w| w[0] == w[1]) {
        return Err(ScalingError::Duplicate(twice[0]));
    }
    let mut note = None;
    if scene == "teapot-in-stadium" && out.iter().any(|&n| n < TEAPOT_IN_STADIUM_MIN_TRIANGLES) {
        out = out
            .into_iter()
            .map(|n| n.max(TEAPOT_IN_STADIUM_MIN_TRIANGLES))
            .collect();
        note = Some(format!(
            "sizes below {TEAPOT_IN_STADIUM_MIN_TRIANGLES} (the teapot and the plainest stadium) \
             run at {TEAPOT_IN_STADIUM_MIN_TRIANGLES}"
        ));
    }
    out.sort_unstable();
    out.dedup();
    // The sphere rounds up to fill its last ring: two sizes may make one scene.
    if scene == "sphere"
        && let Some(w) = out.windows(2).find(|w| {
            crate::scene::builtin::sphere_triangles(w[0])
                == crate::scene::builtin::sphere_triangles(w[1])
        })
    {
        return Err(ScalingError::SameScene {
            sizes: (w[0], w[1]),
            triangles: crate::scene::builtin::sphere_triangles(w[0]),
        });
    }
    Ok((out, note))
}

/// Runs the study on the current rayon pool, calling `done` after each row.
pub fn run(
    cfg: &ScalingConfig,
    done: &mut dyn FnMut(&ScalingRow),
) -> Result<Vec<ScalingRow>, ScalingError> {
    let (sizes, _) = plan_sizes(&cfg.scene, &cfg.sizes)?;
    if sizes.is_empty() || cfg.kinds.is_empty() {
        return Err(ScalingError::Empty);
    }
    let mut rows = Vec::new();
    for size in sizes {
        let scene = Scene::load(&sized_spec(&cfg.scene, size)?)?;
        // Each size's structures must fit beside it (the one before is dropped by now).
        let _held = scene.hold_budget();
        let camera = scene.camera();
        let cam = camera.rays(cfg.width, cfg.height);
        let primary: Vec<Ray> = (0..cfg.height)
            .flat_map(|y| (0..cfg.width).map(move |x| (x, y)))
            .map(|(x, y)| cam.pixel_center(x, y))
            .collect();
        for &kind in &cfg.kinds {
            let params = StructureParams { kind, ..cfg.params };
            let built = structure::build_scene(&scene, &params, &Default::default())?;
            let accel = &built.structure;
            let sampled = if kind.is_brute_force() {
                (scene.triangles.len() * primary.len()).div_ceil(BRUTE_FORCE_TESTS)
            } else {
                1
            }
            .max(1);
            let rays: Vec<Ray> = primary.iter().step_by(sampled).copied().collect();
            let timed = with_intersector!(cfg.intersector, I => time_set(&rays, cfg.runs, |r| {
                accel.closest_hit::<I, _>(r, &mut NoStats).is_some()
            }));
            let sets = RaySets {
                primary: rays,
                ..Default::default()
            };
            let [work, _, _] = mean_work(accel, &sets);
            let row = ScalingRow {
                scene: cfg.scene.clone(),
                size,
                triangles: scene.triangles.len(),
                kind,
                threads: rayon::current_num_threads(),
                build_ms: built.report.build_ms(),
                rays: primary.len(),
                traced: sets.primary.len(),
                sampled,
                hits: timed.hits,
                nodes: work.nodes,
                triangle_tests: work.triangle_tests,
                ns_per_ray: timed.best.as_secs_f64() * 1e9 / sets.primary.len().max(1) as f64,
            };
            done(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The least-squares slope of log(y) against log(x) over the points with positive x and y.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    if logs.len() < 2 {
        return None;
    }
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The structures in the order of their first row.
fn kinds(rows: &[ScalingRow]) -> Vec<AccelKind> {
    let mut out = Vec::new();
    for r in rows {
        if !out.contains(&r.kind) {
            out.push(r.kind);
        }
    }
    out
}

/// The slopes of every structure in `rows`.
pub fn slopes(rows: &[ScalingRow]) -> Vec<Slopes> {
    kinds(rows)
        .into_iter()
        .map(|kind| {
            let mine: Vec<&ScalingRow> = rows.iter().filter(|r| r.kind == kind).collect();
            // The larger half of the sizes (at least two).
            let mut sizes: Vec<usize> = mine.iter().map(|r| r.triangles).collect();
            sizes.sort_unstable();
            let cut = sizes[sizes.len().saturating_sub(sizes.len().div_ceil(2).max(2))];
            let fit = |metric: Metric, from: usize| {
                let points: Vec<(f64, f64)> = mine
                    .iter()
                    .filter(|r| r.triangles >= from)
                    .map(|r| (r.triangles as f64, metric.of(r)))
                    .collect();
                log_log_slope(&points)
            };
            Slopes {
                kind,
                all: Metric::ALL.map(|m| fit(m, 0)),
                upper: Metric::ALL.map(|m| fit(m, cut)),
            }
        })
        .collect()
}

pub const CSV_HEADER: &str = "scene,size,triangles,structure,threads,build_ms,rays,\
rays_traced,sampled_every,hits,mean_nodes,mean_triangle_tests,ns_per_ray";

/// The rows as CSV with `CSV_HEADER`.
pub fn csv(rows: &[ScalingRow]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        out.push_str(&format!(
            "{},{},{},{},{},{:.3},{},{},{},{},{:.3},{:.3},{:.2}\n",
            r.scene,
            r.size,
            r.triangles,
            r.kind.label(),
            r.threads,
            r.build_ms,
            r.rays,
            r.traced,
            r.sampled,
            r.hits,
            r.nodes,
            r.triangle_tests,
            r.ns_per_ray
        ));
    }
    out
}

/// Colour of the structure at `index` in `AccelKind::ALL` (Okabe–Ito, then greys).
pub fn color(kind: AccelKind) -> Color {
    const PALETTE: [Color; 8] = [
        [0, 114, 178],
        [213, 94, 0],
        [0, 158, 115],
        [204, 121, 167],
        [230, 159, 0],
        [86, 180, 233],
        [0, 0, 0],
        [140, 140, 140],
    ];
    let i = AccelKind::ALL.iter().position(|&k| k == kind).unwrap_or(0);
    PALETTE[i % PALETTE.len()]
}

fn fmt_slope(s: Option<f64>) -> String {
    s.map_or("-".into(), |s| format!("{s:.2}"))
}

/// Three log–log panels (triangle tests, nodes visited, ns per primary ray against N), one line
/// per structure, the fitted slopes beside the legend.
pub fn figure(rows: &[ScalingRow]) -> Figure {
    let scene = rows.first().map_or("", |r| r.scene.as_str());
    let threads = rows.first().map_or(1, |r| r.threads);
    let kinds = kinds(rows);
    let panel = |metric: Metric, title: &str, y: &str| Chart {
        title: title.into(),
        x: Axis {
            label: "triangles N".into(),
            scale: Scale::Log,
        },
        y: Axis {
            label: y.into(),
            scale: Scale::Log,
        },
        series: kinds
            .iter()
            .map(|&k| Series {
                name: k.title().into(),
                color: color(k),
                points: rows
                    .iter()
                    .filter(|r| r.kind == k)
                    .map(|r| (r.triangles as f64, metric.of(r)))
                    .collect(),
                mark: Mark::Line,
                labels: Vec::new(),
            })
            .collect(),
    };
    let mut notes = vec![
        "slope of log cost / log N".to_string(),
        "(tests, nodes, ns):".into(),
    ];
    for s in slopes(rows) {
        notes.push(format!(
            "{}: {}, {}, {}",
            s.kind.label(),
            fmt_slope(s.all[0]),
            fmt_slope(s.all[1]),
            fmt_slope(s.all[2])
        ));
    }
    notes.push(String::new());
    notes.push("1: ~N;  1/3: ~N^(1/3)".into());
    notes.push("near 0: ~log N or flat".into());
    if let Some(k) = rows
        .iter()
        .filter(|r| r.sampled > 1)
        .map(|r| r.sampled)
        .max()
    {
        notes.push(String::new());
        notes.push("brute force at large N traces".into());
        notes.push(format!("1 ray in k, k up to {k}"));
    }
    Figure {
        title: format!("{scene}: cost per primary ray against scene size"),
        charts: vec![
            panel(
                Metric::TriangleTests,
                "triangle tests",
                "mean triangle tests per ray",
            ),
            panel(Metric::Nodes, "nodes visited", "mean nodes visited per ray"),
            panel(
                Metric::NsPerRay,
                "time",
                &format!("ns per ray ({threads} threads, wall clock)"),
            ),
        ],
        notes,
        size: (1560, 560),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slopes_of_power_laws() {
        let line = |k: f64| -> Vec<(f64, f64)> {
            [1e3, 1e4, 1e5, 1e6]
                .iter()
                .map(|&n| (n, 3.0 * f64::powf(n, k)))
                .collect()
        };
        for k in [1.0, 1.0 / 3.0, 0.0] {
            let s = log_log_slope(&line(k)).unwrap();
            assert!((s - k).abs() < 1e-9, "{k}: {s}");
        }
        assert_eq!(log_log_slope(&[(1e3, 1.0)]), None);
        assert_eq!(log_log_slope(&[(1e3, 0.0), (1e4, 0.0)]), None);
    }

    #[test]
    fn sizes_and_specs() {
        assert_eq!(sized_spec("soup", 1000).unwrap(), "soup:1000");
        assert_eq!(sized_spec("grass", 1000).unwrap(), "grass:499");
        assert!(sized_spec("cornell", 1000).is_err());
        assert!(sized_spec("my.obj", 1000).is_err());
        let (sizes, note) = plan_sizes("teapot-in-stadium", &DEFAULT_SIZES).unwrap();
        assert_eq!(sizes[0], TEAPOT_IN_STADIUM_MIN_TRIANGLES);
        assert_eq!(sizes.len(), 5);
        assert!(note.is_some());
        let (sizes, note) = plan_sizes("soup", &[800, 200]).unwrap();
        assert_eq!((sizes, note), (vec![200, 800], None));
        assert!(matches!(
            plan_sizes("soup", &[800, 200, 800]),
            Err(ScalingError::Duplicate(800))
        ));
        // Two sizes the sphere rounds to one scene; sizes it tells apart pass.
        assert!(matches!(
            plan_sizes("sphere", &[1, 2]),
            Err(ScalingError::SameScene { triangles: 6, .. })
        ));
        assert!(plan_sizes("sphere", &[1000, 2000]).is_ok());
        for n in [1, 7, 1000, 20_000] {
            assert_eq!(
                crate::scene::builtin::sphere_triangles(n),
                crate::scene::Scene::load(&format!("sphere:{n}"))
                    .unwrap()
                    .triangles
                    .len()
            );
        }
    }
}
