//! Two configurations side by side: the same scene and view traced with configuration A
//! (pinned) and configuration B (the current one), shown as A | B (left half A, right half
//! B) or as the per-pixel difference B − A of a counter through a diverging colour map
//! centred on zero, with a summary: totals and means for A and B, and the share of pixels
//! B made cheaper, left equal or made dearer.

use super::colormap::to_rgba8;
use super::heat::HeatStyle;
use super::{Frame, Mode, RayKind, colorize_styled, per_triangle};
use crate::accel::Counter;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// How two traced frames are shown.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum,
)]
pub enum CompareView {
    /// Configuration B alone, as without a pinned A (the app's choice; the CLI compares).
    #[default]
    #[value(skip)]
    BOnly,
    /// Left half from A, right half from B, a line between them.
    Split,
    /// Per pixel B − A of the heatmap's counter: blue where B is cheaper, red where dearer.
    Difference,
}

impl CompareView {
    pub const ALL: [CompareView; 3] = [
        CompareView::BOnly,
        CompareView::Split,
        CompareView::Difference,
    ];

    pub fn label(self) -> &'static str {
        match self {
            CompareView::BOnly => "B only",
            CompareView::Split => "A | B",
            CompareView::Difference => "B − A",
        }
    }

    /// The next view, for the key that cycles them.
    pub fn next(self) -> CompareView {
        match self {
            CompareView::BOnly => CompareView::Split,
            CompareView::Split => CompareView::Difference,
            CompareView::Difference => CompareView::BOnly,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompareError {
    #[error("the frames differ in size ({0}×{1} against {2}×{3})")]
    SizeMismatch(u32, u32, u32, u32),
    #[error("the difference B − A needs a heatmap mode (nodes, boxes, triangles, …), not {0}")]
    NotAHeatmap(String),
}

fn check_sizes(a: &Frame, b: &Frame) -> Result<(), CompareError> {
    if (a.width, a.height) != (b.width, b.height) || a.samples.len() != b.samples.len() {
        return Err(CompareError::SizeMismatch(
            a.width, a.height, b.width, b.height,
        ));
    }
    Ok(())
}

/// Per pixel, B's count minus A's count of `counter` for `rays`.
pub fn difference(
    a: &Frame,
    b: &Frame,
    counter: Counter,
    rays: RayKind,
) -> Result<Vec<i64>, CompareError> {
    check_sizes(a, b)?;
    Ok(a.samples
        .iter()
        .zip(&b.samples)
        .map(|(sa, sb)| {
            i64::from(sb.counters(rays).get(counter)) - i64::from(sa.counters(rays).get(counter))
        })
        .collect())
}

/// One counter of A against B over the same pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CompareSummary {
    #[serde(serialize_with = "counter_label")]
    pub counter: Counter,
    #[serde(serialize_with = "rays_label")]
    pub rays: RayKind,
    /// The pixels compared: every pixel for primary rays; for shadow rays, the pixels where
    /// A or B traced one (a hit).
    pub pixels: u64,
    pub total_a: u64,
    pub total_b: u64,
    /// Pixels where B counted less than A, the same, more.
    pub cheaper: u64,
    pub equal: u64,
    pub dearer: u64,
}

fn counter_label<S: serde::Serializer>(c: &Counter, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(c.label())
}

fn rays_label<S: serde::Serializer>(r: &RayKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(r.label())
}

impl CompareSummary {
    /// Mean per compared pixel.
    pub fn mean_a(&self) -> f64 {
        self.total_a as f64 / self.pixels.max(1) as f64
    }

    pub fn mean_b(&self) -> f64 {
        self.total_b as f64 / self.pixels.max(1) as f64
    }

    /// Total of B − A.
    pub fn total_difference(&self) -> i64 {
        self.total_b as i64 - self.total_a as i64
    }

    pub fn mean_difference(&self) -> f64 {
        self.total_difference() as f64 / self.pixels.max(1) as f64
    }

    /// B's total against A's in per cent (−20 = B does a fifth less work); `None` when A
    /// counted nothing.
    pub fn percent_change(&self) -> Option<f64> {
        (self.total_a > 0).then(|| 100.0 * self.total_difference() as f64 / self.total_a as f64)
    }

    /// Shares of the compared pixels, in [0, 1]: cheaper, equal, dearer under B.
    pub fn shares(&self) -> [f64; 3] {
        let n = self.pixels.max(1) as f64;
        [self.cheaper, self.equal, self.dearer].map(|k| k as f64 / n)
    }

    /// The summary as lines of text, as the CLI prints it and the app shows it.
    pub fn lines(&self) -> Vec<String> {
        let [cheaper, equal, dearer] = self.shares().map(|s| 100.0 * s);
        let change = self
            .percent_change()
            .map(|p| format!(" ({p:+.1} %)"))
            .unwrap_or_default();
        vec![
            format!(
                "{} ({}), {} pixels",
                self.counter.label(),
                self.rays.label(),
                self.pixels
            ),
            format!("  A: total {}, mean {:.2}", self.total_a, self.mean_a()),
            format!("  B: total {}, mean {:.2}", self.total_b, self.mean_b()),
            format!(
                "  B − A: total {:+}{change}, mean {:+.2}",
                self.total_difference(),
                self.mean_difference()
            ),
            format!(
                "  pixels cheaper under B {cheaper:.1} %, equal {equal:.1} %, dearer {dearer:.1} %"
            ),
        ]
    }
}

/// Compares `counter` of `rays` between A's and B's frames of the same view.
pub fn summarize(
    a: &Frame,
    b: &Frame,
    counter: Counter,
    rays: RayKind,
) -> Result<CompareSummary, CompareError> {
    check_sizes(a, b)?;
    let mut s = CompareSummary {
        counter,
        rays,
        pixels: 0,
        total_a: 0,
        total_b: 0,
        cheaper: 0,
        equal: 0,
        dearer: 0,
    };
    for (sa, sb) in a.samples.iter().zip(&b.samples) {
        if rays == RayKind::Shadow && !sa.is_hit() && !sb.is_hit() {
            continue;
        }
        let (ca, cb) = (
            sa.counters(rays).get(counter),
            sb.counters(rays).get(counter),
        );
        s.pixels += 1;
        s.total_a += u64::from(ca);
        s.total_b += u64::from(cb);
        match cb.cmp(&ca) {
            std::cmp::Ordering::Less => s.cheaper += 1,
            std::cmp::Ordering::Equal => s.equal += 1,
            std::cmp::Ordering::Greater => s.dearer += 1,
        }
    }
    Ok(s)
}

/// The counters a comparison reports for `mode`: the heatmap's own counter, or for the
/// other modes the two the lecture weighs, nodes visited and triangle tests of primary rays.
pub fn compared_counters(mode: Mode) -> Vec<(Counter, RayKind)> {
    match mode {
        Mode::Heatmap(c, r) => vec![(c, r)],
        _ => vec![
            (Counter::NodesVisited, RayKind::Primary),
            (Counter::TriangleTests, RayKind::Primary),
        ],
    }
}

/// The cool–warm diverging map (Moreland 2009) at nine points: blue below zero, grey at
/// zero, red above, the two sides equally bright at equal distances from zero.
const COOL_WARM: [[u8; 3]; 9] = [
    [59, 76, 192],
    [98, 130, 234],
    [141, 176, 254],
    [184, 208, 249],
    [221, 221, 221],
    [245, 196, 173],
    [244, 154, 123],
    [222, 96, 77],
    [180, 4, 38],
];

/// The colour of `x` in [−1, 1] (clamped; 0 is the neutral grey), as sRGB values in [0, 1].
pub fn diverging(x: f32) -> Vec3 {
    let x = if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) };
    let f = (x + 1.0) * 0.5 * (COOL_WARM.len() - 1) as f32;
    let i = (f as usize).min(COOL_WARM.len() - 2);
    let w = f - i as f32;
    let c = |k: usize| Vec3::from(COOL_WARM[k].map(|v| v as f32 / 255.0));
    c(i).lerp(c(i + 1), w)
}

/// The pixels of a difference image, and the symmetric scale: ±`scale` maps to the ends
/// of the diverging map (`scale`, or without one the largest |B − A|, at least 1).
pub fn color_difference(diff: &[i64], scale: Option<u32>) -> (Vec<u8>, u32) {
    let scale = scale
        .unwrap_or_else(|| {
            diff.iter()
                .map(|d| d.unsigned_abs())
                .max()
                .unwrap_or(0)
                .min(u64::from(u32::MAX)) as u32
        })
        .max(1);
    let rgba = diff
        .iter()
        .flat_map(|&d| to_rgba8(diverging(d as f32 / scale as f32)))
        .collect();
    (rgba, scale)
}

/// Marks where A ends and B begins.
const DIVIDER: [u8; 4] = [255, 255, 255, 255];

/// The A | B image: columns left of the middle from `a`, the rest from `b`, a divider line
/// down the middle and the letters A and B in the top corners.
pub fn split(a: &[u8], b: &[u8], width: u32, height: u32) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let mut out = b.to_vec();
    let middle = w / 2;
    for y in 0..h {
        let row = y * w * 4;
        out[row..row + middle * 4].copy_from_slice(&a[row..row + middle * 4]);
    }
    // A line two pixels wide (one on a narrow image) centred on the middle.
    let line = if w >= 8 { 2 } else { 1 };
    for y in 0..h {
        for x in middle.saturating_sub(line / 2)..(middle + line.div_ceil(2)).min(w) {
            let p = (y * w + x) * 4;
            out[p..p + 4].copy_from_slice(&DIVIDER);
        }
    }
    // Letters about a twentieth of the image high, from 7 pixels up.
    let scale = (height / 180).max(1) as usize;
    let margin = 2 * scale;
    if w >= 2 * (GLYPH_W + 4) * scale && h >= (GLYPH_H + 4) * scale {
        draw_label(&mut out, w, h, margin, margin, &GLYPH_A, scale);
        let x = w - margin - (GLYPH_W + 2) * scale;
        draw_label(&mut out, w, h, x, margin, &GLYPH_B, scale);
    }
    out
}

const GLYPH_W: usize = 5;
const GLYPH_H: usize = 7;
/// 5 × 7 bitmaps of the two labels, a row per byte (bit 4 = leftmost column).
const GLYPH_A: [u8; GLYPH_H] = [
    0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
];
const GLYPH_B: [u8; GLYPH_H] = [
    0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110,
];

/// A white letter on a dark box with one glyph pixel of margin, `scale` pixels per glyph
/// pixel, its box's top left at (x0, y0).
fn draw_label(rgba: &mut [u8], w: usize, h: usize, x0: usize, y0: usize, glyph: &[u8], s: usize) {
    let (bw, bh) = ((GLYPH_W + 2) * s, (GLYPH_H + 2) * s);
    for y in y0..(y0 + bh).min(h) {
        for x in x0..(x0 + bw).min(w) {
            let (gx, gy) = ((x - x0) / s, (y - y0) / s);
            let on = (1..=GLYPH_W).contains(&gx)
                && (1..=GLYPH_H).contains(&gy)
                && glyph[gy - 1] & (1 << (GLYPH_W - gx)) != 0;
            let p = (y * w + x) * 4;
            if on {
                rgba[p..p + 4].copy_from_slice(&[255, 255, 255, 255]);
            } else {
                // Darken what is behind, so the letter reads on any image.
                for c in &mut rgba[p..p + 3] {
                    *c /= 4;
                }
            }
        }
    }
}

/// The image of A and B in `view` for `mode`, and the scale of its colour map: for a
/// heatmap split, both halves drawn in `style` up to one count (`heat_max`, or the larger
/// of the two frames' tops, so equal colours mean equal counts); for the difference, the
/// symmetric scale ±max of B − A.
pub fn compare_image(
    a: &Frame,
    b: &Frame,
    mode: Mode,
    heat_max: Option<u32>,
    style: &HeatStyle,
    view: CompareView,
) -> Result<(Vec<u8>, Option<u32>), CompareError> {
    match view {
        CompareView::BOnly => Ok(colorize_styled(b, mode, heat_max, style)),
        CompareView::Split => {
            check_sizes(a, b)?;
            let common = match mode {
                Mode::Heatmap(c, r) => Some(heat_max.unwrap_or_else(|| {
                    let top = |f: &Frame| {
                        style.top(None, f.summary.counter(r, c).max, || {
                            f.samples.iter().map(|s| s.counters(r).get(c)).collect()
                        })
                    };
                    top(a).max(top(b))
                })),
                // Each side's tests and costs on one scale, so the same colour is the same
                // value on both.
                Mode::TestsReceived(_) => {
                    let top = |f: &Frame| per_triangle::tests_top(f, mode, heat_max, style);
                    top(a).max(top(b))
                }
                _ => None,
            };
            let shown = per_triangle::shared_shown(&[a, b], mode);
            let paint = |f: &Frame| {
                per_triangle::colorize_on(f, mode, common, style, shown)
                    .unwrap_or_else(|| colorize_styled(f, mode, common, style))
            };
            let (left, _) = paint(a);
            let (right, scale) = paint(b);
            Ok((split(&left, &right, b.width, b.height), scale))
        }
        CompareView::Difference => {
            let Mode::Heatmap(counter, rays) = mode else {
                return Err(CompareError::NotAHeatmap(mode.label()));
            };
            let diff = difference(a, b, counter, rays)?;
            let (rgba, scale) = color_difference(&diff, heat_max);
            Ok((rgba, Some(scale)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Counters;
    use crate::render::Sample;

    /// A frame whose pixels counted these nodes visited (primary rays); every pixel a hit.
    fn frame_of(nodes: &[u32], width: u32) -> Frame {
        let samples: Vec<Sample> = nodes
            .iter()
            .map(|&n| Sample {
                triangle: 0,
                primary: Counters {
                    nodes_visited: n,
                    ..Default::default()
                },
                ..Default::default()
            })
            .collect();
        Frame {
            width,
            height: nodes.len() as u32 / width,
            summary: crate::render::FrameSummary::from_samples(&samples, Default::default(), true),
            samples,
            rgba: Vec::new(),
            heat_max: None,
            per_triangle: Default::default(),
        }
    }

    const NODES: Mode = Mode::Heatmap(Counter::NodesVisited, RayKind::Primary);

    #[test]
    fn identical_configurations_differ_nowhere() {
        let a = frame_of(&[3, 7, 0, 12, 5, 5], 3);
        let d = difference(&a, &a.clone(), Counter::NodesVisited, RayKind::Primary).unwrap();
        assert!(d.iter().all(|&x| x == 0));
        let s = summarize(&a, &a, Counter::NodesVisited, RayKind::Primary).unwrap();
        assert_eq!((s.cheaper, s.equal, s.dearer), (0, 6, 0));
        assert_eq!(s.total_difference(), 0);
        // Every pixel is the neutral grey of zero.
        let (rgba, _) = compare_image(
            &a,
            &a,
            NODES,
            None,
            &HeatStyle::default(),
            CompareView::Difference,
        )
        .unwrap();
        let grey = to_rgba8(diverging(0.0));
        assert!(rgba.chunks_exact(4).all(|p| p == grey));
    }

    #[test]
    fn a_minus_b_is_minus_b_minus_a() {
        let a = frame_of(&[3, 7, 0, 12, 5, 5], 3);
        let b = frame_of(&[4, 2, 0, 20, 5, 1], 3);
        let ab = difference(&b, &a, Counter::NodesVisited, RayKind::Primary).unwrap();
        let ba = difference(&a, &b, Counter::NodesVisited, RayKind::Primary).unwrap();
        assert_eq!(ba, vec![1, -5, 0, 8, 0, -4]);
        assert!(ab.iter().zip(&ba).all(|(x, y)| *x == -*y));
        // The colours mirror too: blue where one is cheaper, red where dearer, on one scale.
        let (rgba_ba, s_ba) = color_difference(&ba, None);
        let (rgba_ab, s_ab) = color_difference(&ab, None);
        assert_eq!(s_ba, s_ab);
        for (p, q) in rgba_ba.chunks_exact(4).zip(rgba_ab.chunks_exact(4)) {
            assert_eq!(p[0] > p[2], q[2] > q[0]);
        }
        for x in [0.25f32, 0.5, 1.0] {
            let (lo, hi) = (diverging(-x), diverging(x));
            assert!(lo.z > lo.x && hi.x > hi.z, "{x}");
        }
    }

    #[test]
    fn summary_of_a_small_known_case() {
        let a = frame_of(&[3, 7, 0, 12, 5, 5], 3);
        let b = frame_of(&[4, 2, 0, 20, 5, 1], 3);
        let s = summarize(&a, &b, Counter::NodesVisited, RayKind::Primary).unwrap();
        assert_eq!((s.pixels, s.total_a, s.total_b), (6, 32, 32));
        assert_eq!((s.cheaper, s.equal, s.dearer), (2, 2, 2));
        assert_eq!(s.total_difference(), 0);
        assert_eq!(s.mean_a(), 32.0 / 6.0);
        let b = frame_of(&[1, 1, 0, 10, 5, 5], 3);
        let s = summarize(&a, &b, Counter::NodesVisited, RayKind::Primary).unwrap();
        assert_eq!((s.total_b, s.total_difference()), (22, -10));
        assert_eq!(s.shares(), [0.5, 0.5, 0.0]);
        assert_eq!(s.percent_change(), Some(-31.25));
        assert!(s.lines().iter().any(|l| l.contains("total -10 (-31.2 %)")));
    }

    #[test]
    fn the_difference_scale_is_symmetric_and_centred() {
        let (rgba, scale) = color_difference(&[-4, 0, 2], None);
        assert_eq!(scale, 4);
        let px = |i: usize| [rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]];
        assert_eq!(px(0), [59, 76, 192]);
        assert_eq!(px(1), [221, 221, 221]);
        let (_, fixed) = color_difference(&[-4, 9], Some(2));
        assert_eq!(fixed, 2);
        assert_eq!(color_difference(&[0, 0], None).1, 1);
    }

    #[test]
    fn split_takes_the_left_half_from_a() {
        let (w, h) = (40u32, 20u32);
        let a = vec![10u8; (w * h * 4) as usize];
        let b = vec![200u8; (w * h * 4) as usize];
        let out = split(&a, &b, w, h);
        let at = |x: u32, y: u32| out[((y * w + x) * 4) as usize];
        assert_eq!(at(5, 15), 10);
        assert_eq!(at(35, 15), 200);
        assert_eq!(at(20, 15), 255, "the divider");
        // The labels sit in the top corners.
        assert_eq!(at(2 + 1, 2 + 1 + 3), 255, "A's bar");
    }

    #[test]
    fn mismatched_frames_and_shaded_differences_are_errors() {
        let a = frame_of(&[1, 2, 3, 4], 2);
        let b = frame_of(&[1, 2, 3, 4, 5, 6], 3);
        assert!(matches!(
            summarize(&a, &b, Counter::NodesVisited, RayKind::Primary),
            Err(CompareError::SizeMismatch(..))
        ));
        assert!(matches!(
            compare_image(
                &a,
                &a,
                Mode::Shaded,
                None,
                &HeatStyle::default(),
                CompareView::Difference
            ),
            Err(CompareError::NotAHeatmap(_))
        ));
    }
}
