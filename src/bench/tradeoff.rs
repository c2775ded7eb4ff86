//! The build-versus-trace trade-off (Karras and Aila 2013, Figure 1): a frame costs the build
//! plus the tracing, T(N) = t_build + N / R for N rays traced at R rays per second. A fast
//! builder wins when few rays are traced, a slow one with a better tree when many are; the
//! lines cross where t_build,a + N/R_a = t_build,b + N/R_b.

use super::plot::{Axis, Chart, Color, Figure, Mark, Scale, Series};
use std::fmt::Write as _;

/// The range of rays per frame the trade-off spans, as the paper's figure does.
pub const MIN_RAYS: f64 = 1e5;
pub const MAX_RAYS: f64 = 1e11;

/// One builder's measured build time and diffuse ray rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    pub builder: String,
    pub build_s: f64,
    /// Diffuse rays per second.
    pub rays_per_s: f64,
}

impl Line {
    /// Seconds to build and then trace `rays` rays.
    pub fn total_s(&self, rays: f64) -> f64 {
        self.build_s + rays / self.rays_per_s
    }
}

/// A stretch of rays per frame over which one line is the cheapest.
#[derive(Clone, Debug, PartialEq)]
pub struct Best {
    pub line: usize,
    pub from_rays: f64,
    pub to_rays: f64,
}

/// Where the lines `a` and `b` cross, if they do at a positive ray count.
fn crossing(a: &Line, b: &Line) -> Option<f64> {
    let per_ray = 1.0 / a.rays_per_s - 1.0 / b.rays_per_s;
    let n = (b.build_s - a.build_s) / per_ray;
    (n.is_finite() && n > 0.0).then_some(n)
}

/// The cheapest line over [`MIN_RAYS`, `MAX_RAYS`], stretch by stretch, each boundary the
/// exact crossing of the two lines it separates. Lines with no rate are left out.
pub fn best_ranges(lines: &[Line]) -> Vec<Best> {
    let usable: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].rays_per_s > 0.0 && lines[i].build_s.is_finite())
        .collect();
    if usable.is_empty() {
        return Vec::new();
    }
    let cheapest = |rays: f64| {
        usable
            .iter()
            .copied()
            .min_by(|&a, &b| lines[a].total_s(rays).total_cmp(&lines[b].total_s(rays)))
            .unwrap_or(usable[0])
    };
    // Sample densely on the log axis for the order of the winners, then place each
    // boundary at the exact crossing.
    const SAMPLES: usize = 6001;
    let (lo, hi) = (MIN_RAYS.log10(), MAX_RAYS.log10());
    let mut out: Vec<Best> = Vec::new();
    for k in 0..SAMPLES {
        let rays = 10f64.powf(lo + (hi - lo) * k as f64 / (SAMPLES - 1) as f64);
        let line = cheapest(rays);
        match out.last_mut() {
            Some(b) if b.line == line => b.to_rays = rays,
            Some(b) => {
                let at = crossing(&lines[b.line], &lines[line]).unwrap_or(rays);
                b.to_rays = at;
                out.push(Best {
                    line,
                    from_rays: at,
                    to_rays: rays,
                });
            }
            None => out.push(Best {
                line,
                from_rays: MIN_RAYS,
                to_rays: rays,
            }),
        }
    }
    out
}

/// The CSV: one row per line and ray count (10 per decade).
pub fn csv(scene: &str, lines: &[Line]) -> String {
    let mut s = String::from("scene,builder,build_s,diffuse_mrays_per_s,rays,total_s\n");
    let (lo, hi) = (MIN_RAYS.log10() as i32, MAX_RAYS.log10() as i32);
    for l in lines {
        for k in 10 * lo..=10 * hi {
            let rays = 10f64.powf(k as f64 / 10.0);
            let _ = writeln!(
                s,
                "{scene},{},{:.6},{:.3},{rays:.0},{:.6}",
                l.builder,
                l.build_s,
                l.rays_per_s / 1e6,
                l.total_s(rays)
            );
        }
    }
    s
}

const PALETTE: [Color; 10] = [
    [140, 140, 140],
    [86, 180, 233],
    [0, 114, 178],
    [230, 159, 0],
    [240, 200, 90],
    [204, 121, 167],
    [160, 60, 130],
    [0, 158, 115],
    [100, 200, 160],
    [213, 94, 0],
];

/// Total time against rays per frame on log axes, one line per builder, the ranges where
/// each is best beside the legend.
pub fn figure(scene: &str, threads: usize, lines: &[Line]) -> Figure {
    let (lo, hi) = (MIN_RAYS.log10(), MAX_RAYS.log10());
    let points = |l: &Line| {
        (0..=60)
            .map(|k| {
                let rays = 10f64.powf(lo + (hi - lo) * k as f64 / 60.0);
                (rays, l.total_s(rays))
            })
            .collect()
    };
    let series = lines
        .iter()
        .enumerate()
        .map(|(i, l)| Series {
            name: l.builder.clone(),
            color: PALETTE[i % PALETTE.len()],
            points: points(l),
            mark: Mark::Line,
            labels: Vec::new(),
        })
        .collect();
    let mut notes = vec!["best for rays per frame:".to_string()];
    for b in best_ranges(lines) {
        notes.push(format!(
            "{}: {} to {}",
            lines[b.line].builder,
            format_rays(b.from_rays),
            format_rays(b.to_rays)
        ));
    }
    Figure {
        title: format!(
            "{scene}: build + trace time against rays per frame (diffuse rays, {threads} threads)"
        ),
        charts: vec![Chart {
            title: String::new(),
            x: Axis {
                label: "rays per frame N".into(),
                scale: Scale::Log,
            },
            y: Axis {
                label: "build + trace time (s)".into(),
                scale: Scale::Log,
            },
            series,
        }],
        notes,
        size: (1300, 700),
    }
}

/// A ray count for a reader: 7.2 M, 61 G.
pub fn format_rays(n: f64) -> String {
    let (v, unit) = if n >= 1e9 {
        (n / 1e9, " G")
    } else if n >= 1e6 {
        (n / 1e6, " M")
    } else if n >= 1e3 {
        (n / 1e3, " k")
    } else {
        (n, "")
    };
    format!(
        "{}{unit}",
        super::plot::format_tick((v * 100.0).round() / 100.0)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(name: &str, build_s: f64, mrays: f64) -> Line {
        Line {
            builder: name.into(),
            build_s,
            rays_per_s: mrays * 1e6,
        }
    }

    #[test]
    fn the_fast_builder_wins_few_rays_and_the_good_one_many() {
        // 0.01 s at 10 Mrays/s against 1 s at 20 Mrays/s: they cross where
        // 0.01 + N/1e7 = 1 + N/2e7, at N = 0.99 · 2e7 = 1.98e7.
        let lines = [line("fast", 0.01, 10.0), line("good", 1.0, 20.0)];
        let best = best_ranges(&lines);
        assert_eq!(best.len(), 2);
        assert_eq!((best[0].line, best[1].line), (0, 1));
        assert!((best[0].to_rays - 1.98e7).abs() < 1.0, "{best:?}");
        assert_eq!(best[0].to_rays, best[1].from_rays);
        assert_eq!(best[0].from_rays, MIN_RAYS);
        assert!(best[1].to_rays >= MAX_RAYS * 0.999);
        // A line slower to build and to trace is never best.
        let lines = [line("a", 0.01, 10.0), line("worse", 0.02, 5.0)];
        assert_eq!(best_ranges(&lines).len(), 1);
    }
}
