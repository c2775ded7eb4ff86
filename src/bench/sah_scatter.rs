//! The SAH's prediction against the measured cost per ray, as a scatter plot over builders
//! and scenes (`bvhlab bench sah-scatter`). Each point is one tree on one
//! scene: across, the SAH cost it predicts; up, the cost per ray measured. On the line
//! y = x the prediction is exact; below it the rays cost less than the SAH assumes. A third
//! chart puts the tree's EPO across instead, and each scene's notes say how well each
//! predictor orders its trees by measured cost (Spearman's ρ, `rank_correlation`).
//!
//! A run covers one scene; its rows go into a CSV that keeps the other scenes' rows, so the
//! plot gathers every scene measured so far (running a scene again replaces its rows).

use super::plot::{Axis, Chart, Color, Figure, Mark, Scale, Series};
use super::rank_correlation::spearman;
use super::sah_check::SahCheck;
use std::fmt::Write as _;

/// One tree on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    pub builder: String,
    pub check: SahCheck,
}

const HEADER: &str = "scene,builder,c_trav,c_isect,predicted,random,primary,diffuse,shadow,epo";
/// The header before EPO was measured: its rows are read without one.
const HEADER_WITHOUT_EPO: &str =
    "scene,builder,c_trav,c_isect,predicted,random,primary,diffuse,shadow";

/// The rows as CSV (names quoted, since a builder's label may hold commas).
pub fn csv(rows: &[Row]) -> String {
    let mut out = format!("{HEADER}\n");
    for r in rows {
        let c = &r.check;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{}",
            quote(&r.scene),
            quote(&r.builder),
            c.c_trav,
            c.c_isect,
            c.predicted,
            c.random,
            c.primary,
            c.diffuse,
            c.shadow,
            c.epo.map(|e| e.to_string()).unwrap_or_default()
        );
    }
    out
}

fn quote(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

/// Splits one CSV line into fields, honouring quotes.
fn fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(ch) = chars.next() {
        match ch {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                out.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            _ => out.last_mut().unwrap().push(ch),
        }
    }
    out
}

/// Reads rows written by `csv`; an error names the line that is wrong.
pub fn parse_csv(text: &str) -> Result<Vec<Row>, String> {
    let mut lines = text.lines().enumerate();
    let width = match lines.next() {
        Some((_, h)) if h.trim() == HEADER => 10,
        Some((_, h)) if h.trim() == HEADER_WITHOUT_EPO => 9,
        _ => return Err(format!("the first line is not the header \"{HEADER}\"")),
    };
    let mut rows = Vec::new();
    for (k, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f = fields(line);
        let number = |i: usize| -> Result<f64, String> {
            // Costs and counts: finite, not negative, and within f32 where they are read so.
            match f[i].trim().parse::<f64>() {
                Ok(x) if x.is_finite() && x >= 0.0 && x <= f64::from(f32::MAX) => Ok(x),
                Ok(_) => Err(format!(
                    "line {}: \"{}\" is not a cost (a finite number, at least 0)",
                    k + 1,
                    f[i]
                )),
                Err(_) => Err(format!("line {}: \"{}\" is not a number", k + 1, f[i])),
            }
        };
        if f.len() != width {
            return Err(format!("line {}: {} fields, not {width}", k + 1, f.len()));
        }
        rows.push(Row {
            scene: f[0].clone(),
            builder: f[1].clone(),
            check: SahCheck {
                c_trav: number(2)? as f32,
                c_isect: number(3)? as f32,
                predicted: number(4)?,
                epo: match f.get(9) {
                    Some(e) if !e.trim().is_empty() => Some(number(9)?),
                    _ => None,
                },
                random: number(5)?,
                primary: number(6)?,
                diffuse: number(7)?,
                shadow: number(8)?,
            },
        });
    }
    Ok(rows)
}

/// `earlier` with its rows of the scenes in `new` replaced by `new`'s, scenes in the order
/// they were first measured.
pub fn merge(earlier: Vec<Row>, new: Vec<Row>) -> Vec<Row> {
    let mut rows: Vec<Row> = earlier
        .into_iter()
        .filter(|r| !new.iter().any(|n| n.scene == r.scene))
        .collect();
    rows.extend(new);
    rows
}

/// How well each predictor orders one scene's trees by the measured cost of each ray set:
/// Spearman's ρ over the trees (`None` with fewer than three, or all tied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correlations {
    /// Random lines, primary, diffuse and shadow rays.
    pub sah: [Option<f64>; 4],
    pub epo: [Option<f64>; 4],
}

impl Correlations {
    pub const RAY_SETS: [&str; 4] = ["random lines", "primary", "diffuse", "shadow"];

    pub fn of(checks: &[SahCheck]) -> Correlations {
        let measured = |c: &SahCheck| [c.random, c.primary, c.diffuse, c.shadow];
        let rho = |predictor: &dyn Fn(&SahCheck) -> Option<f64>| {
            std::array::from_fn(|k| {
                let pairs: Option<Vec<(f64, f64)>> = checks
                    .iter()
                    .map(|c| Some((predictor(c)?, measured(c)[k])))
                    .collect();
                let (x, y): (Vec<f64>, Vec<f64>) = pairs?.into_iter().unzip();
                spearman(&x, &y)
            })
        };
        Correlations {
            sah: rho(&|c| Some(c.predicted)),
            epo: rho(&|c| c.epo),
        }
    }
}

impl Correlations {
    /// "SAH 0.99 0.95 0.99 0.92 · EPO 0.93 …", the ray sets in the order of `RAY_SETS`.
    pub fn compact(&self) -> String {
        let list = |rho: &[Option<f64>; 4]| {
            rho.iter()
                .map(|r| r.map_or("–".to_string(), |r| format!("{r:.2}")))
                .collect::<Vec<_>>()
                .join(" ")
        };
        format!("SAH {} · EPO {}", list(&self.sah), list(&self.epo))
    }
}

impl std::fmt::Display for Correlations {
    /// "SAH 0.93 0.86 0.89 0.71 · EPO …" in the order of `RAY_SETS`, "–" where unknown.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let list = |rho: &[Option<f64>; 4]| {
            rho.iter()
                .zip(Self::RAY_SETS)
                .map(|(r, set)| match r {
                    Some(r) => format!("{set} {r:.2}"),
                    None => format!("{set} –"),
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        write!(f, "SAH: {}; EPO: {}", list(&self.sah), list(&self.epo))
    }
}

/// A predictor's name and its value for a check (`None` where it was not measured).
type Predictor<'a> = (&'a str, &'a dyn Fn(&SahCheck) -> Option<f64>);

/// Colour-blind-safe colours, one per scene.
const PALETTE: [Color; 6] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
];

/// Two charts: the random lines the SAH assumes, and the view's rays (primary, diffuse and
/// shadow together); one colour per scene, and the line where measured equals predicted.
pub fn figure(rows: &[Row]) -> Figure {
    let mut scenes: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    let (lo, hi) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
        let c = &r.check;
        let values = [c.predicted, c.random, c.primary, c.diffuse, c.shadow];
        (
            values.iter().copied().fold(lo, f64::min),
            values.iter().copied().fold(hi, f64::max),
        )
    });
    let identity = Series {
        name: "measured = predicted".into(),
        color: [120, 120, 120],
        points: vec![(lo * 0.9, lo * 0.9), (hi * 1.1, hi * 1.1)],
        mark: Mark::Line,
        labels: Vec::new(),
    };
    // Across: a predictor.
    let chart = |title: &str, across: Predictor, measured: &dyn Fn(&SahCheck) -> Vec<f64>| {
        let mut series: Vec<Series> = scenes
            .iter()
            .enumerate()
            .map(|(i, &scene)| Series {
                name: scene.to_string(),
                color: PALETTE[i % PALETTE.len()],
                points: rows
                    .iter()
                    .filter(|r| r.scene == scene)
                    .filter_map(|r| Some((across.1(&r.check).filter(|&x| x > 0.0)?, r)))
                    .flat_map(|(x, r)| measured(&r.check).into_iter().map(move |m| (x, m)))
                    .collect(),
                mark: Mark::Points,
                labels: Vec::new(),
            })
            .collect();
        // The SAH predicts the cost itself; EPO only its overlap share, so no line.
        if across.0.starts_with("SAH") {
            series.push(identity.clone());
        }
        Chart {
            title: title.into(),
            x: Axis {
                label: across.0.into(),
                scale: Scale::Log,
            },
            y: Axis {
                label: "measured C_trav·nodes + C_isect·tests per ray".into(),
                scale: Scale::Log,
            },
            series,
        }
    };
    let sah: Predictor = ("SAH cost (predicted cost per ray)", &|c| Some(c.predicted));
    let epo: Predictor = ("EPO (end-point overlap)", &|c| c.epo);
    let mut notes = vec!["measured / predicted:".to_string()];
    let percent_range = |ratios: Vec<f64>| {
        let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().copied().fold(0.0, f64::max);
        format!("{:.0}–{:.0} %", 100.0 * lo, 100.0 * hi)
    };
    for &scene in &scenes {
        let of_scene = || {
            rows.iter()
                .filter(move |r| r.scene == scene)
                .map(|r| &r.check)
        };
        let random = of_scene().map(|c| c.random / c.predicted).collect();
        let view = of_scene()
            .flat_map(|c| [c.primary, c.diffuse, c.shadow].map(|m| m / c.predicted))
            .collect();
        notes.push(format!(
            "{scene}: random lines {}, view's rays {}",
            percent_range(random),
            percent_range(view)
        ));
    }
    notes.push("how each predictor orders the trees by measured cost".into());
    notes.push("(Spearman's ρ on random lines, primary, diffuse, shadow rays):".into());
    for &scene in &scenes {
        let checks: Vec<SahCheck> = rows
            .iter()
            .filter(|r| r.scene == scene)
            .map(|r| r.check)
            .collect();
        notes.push(format!("{scene}: {}", Correlations::of(&checks).compact()));
    }
    Figure {
        title: format!(
            "SAH predicted against measured: {} trees on {} scene{}",
            rows.len(),
            scenes.len(),
            if scenes.len() == 1 { "" } else { "s" }
        ),
        charts: vec![
            chart(
                "random lines through the scene box (the SAH's assumption)",
                sah,
                &|c| vec![c.random],
            ),
            chart("the view's primary, diffuse and shadow rays", sah, &|c| {
                vec![c.primary, c.diffuse, c.shadow]
            }),
            chart("the view's rays against the tree's EPO", epo, &|c| {
                vec![c.primary, c.diffuse, c.shadow]
            }),
        ],
        notes,
        size: (2100, 760),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, builder: &str, predicted: f64) -> Row {
        Row {
            scene: scene.into(),
            builder: builder.into(),
            check: SahCheck {
                c_trav: 1.0,
                c_isect: 2.0,
                predicted,
                epo: Some(predicted * 0.1),
                random: predicted * 0.3,
                primary: predicted * 0.7,
                diffuse: predicted * 0.8,
                shadow: predicted * 0.5,
            },
        }
    }

    #[test]
    fn csv_round_trip_keeps_quoted_names() {
        let rows = vec![
            row("sponza", "binned SAH, B = 16", 67.7),
            row("a \"quoted\" scene", "LBVH", 89.25),
        ];
        assert_eq!(parse_csv(&csv(&rows)).unwrap(), rows);
    }

    #[test]
    fn bad_csv_names_the_line() {
        assert!(parse_csv("nonsense\n").unwrap_err().contains("header"));
        let text = format!("{HEADER}\n\"s\",\"b\",1,1,x,1,1,1,1,1\n");
        assert!(parse_csv(&text).unwrap_err().contains("line 2"));
        let text = format!("{HEADER}\n\"s\",\"b\",1\n");
        assert!(parse_csv(&text).unwrap_err().contains("fields"));
        for bad in ["nan", "-inf", "-5", "1e300"] {
            let text = format!("{HEADER}\n\"s\",\"b\",1,1,{bad},1,1,1,1,1\n");
            assert!(
                parse_csv(&text).unwrap_err().contains("not a cost"),
                "{bad}"
            );
        }
    }

    #[test]
    fn a_csv_from_before_epo_reads_without_it_and_the_epo_chart_skips_its_rows() {
        let old = format!("{HEADER_WITHOUT_EPO}\n\"s\",\"b\",1,2,10,3,7,8,5\n");
        let rows = parse_csv(&old).unwrap();
        assert_eq!(rows[0].check.epo, None);
        assert_eq!(rows[0].check.predicted, 10.0);
        let mut mixed = rows.clone();
        mixed.push(row("s", "c", 20.0));
        let f = figure(&mixed);
        assert_eq!(f.charts[2].series[0].points.len(), 3);
        // Written again, the row keeps its empty EPO.
        assert_eq!(parse_csv(&csv(&mixed)).unwrap(), mixed);
        // An old header with ten fields is still wrong.
        let text = format!("{HEADER_WITHOUT_EPO}\n\"s\",\"b\",1,2,10,3,7,8,5,1\n");
        assert!(parse_csv(&text).unwrap_err().contains("not 9"));
    }

    #[test]
    fn correlations_say_how_each_predictor_orders_the_trees() {
        // The SAH orders these trees as the rays do; EPO in reverse.
        let mut checks: Vec<SahCheck> = [10.0, 20.0, 30.0]
            .iter()
            .map(|&p| row("a", "x", p).check)
            .collect();
        for (c, e) in checks.iter_mut().zip([3.0, 2.0, 1.0]) {
            c.epo = Some(e);
        }
        let r = Correlations::of(&checks);
        assert_eq!(r.sah, [Some(1.0); 4]);
        assert_eq!(r.epo, [Some(-1.0); 4]);
        checks[1].epo = None;
        assert_eq!(Correlations::of(&checks).epo, [None; 4]);
        assert!(
            r.to_string()
                .starts_with("SAH: random lines 1.00, primary 1.00")
        );
    }

    #[test]
    fn a_scene_measured_again_replaces_its_rows() {
        let earlier = vec![row("a", "x", 1.0), row("b", "x", 2.0), row("a", "y", 3.0)];
        let merged = merge(earlier, vec![row("a", "z", 4.0)]);
        assert_eq!(merged, vec![row("b", "x", 2.0), row("a", "z", 4.0)]);
    }

    #[test]
    fn the_figure_has_a_colour_per_scene_and_the_identity_line() {
        let rows = vec![
            row("a", "x", 10.0),
            row("a", "y", 20.0),
            row("b", "x", 30.0),
        ];
        let f = figure(&rows);
        assert_eq!(f.charts.len(), 3);
        for chart in &f.charts[..2] {
            let names: Vec<&str> = chart.series.iter().map(|s| s.name.as_str()).collect();
            assert_eq!(names, ["a", "b", "measured = predicted"]);
        }
        // EPO across: no identity line, the same points moved to x = EPO.
        let names: Vec<&str> = f.charts[2].series.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        assert_eq!(f.charts[2].series[0].points[0], (1.0, 7.0));
        // Random lines: one point per tree; the view's rays: three.
        assert_eq!(f.charts[0].series[0].points, [(10.0, 3.0), (20.0, 6.0)]);
        assert_eq!(f.charts[1].series[1].points.len(), 3);
        assert!(
            f.notes
                .iter()
                .any(|n| n == "a: random lines 30–30 %, view's rays 50–80 %")
        );
    }
}
