//! The charts `bvhlab bench` writes (the Pareto front, cost against N on log–log axes): scatter
//! and line plots over `plotters`, saved as PNG with an SVG beside it, with labels that never
//! overlap, in the font the binary already embeds for egui (no system fonts).

use crate::output::{self, OutputError};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::prelude::*;
use plotters::style::Color as _;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};
use std::path::{Path, PathBuf};
use std::sync::Once;

pub type Color = [u8; 3];

/// How an axis maps values to positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scale {
    #[default]
    Linear,
    /// log10(v); values that are not positive are left out.
    Log,
    /// log10(1 + v) for v ≥ 0, so 0 sits at the bottom and large values read as on a log axis.
    SymLog,
}

impl Scale {
    fn position(self, v: f64) -> Option<f64> {
        let t = match self {
            Scale::Linear => v,
            Scale::Log if v > 0.0 => v.log10(),
            Scale::Log => return None,
            Scale::SymLog => (1.0 + v.max(0.0)).log10(),
        };
        t.is_finite().then_some(t)
    }

    fn value_at(self, t: f64) -> f64 {
        match self {
            Scale::Linear => t,
            Scale::Log => 10f64.powf(t),
            Scale::SymLog => 10f64.powf(t) - 1.0,
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Axis {
    pub label: String,
    pub scale: Scale,
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mark {
    /// Filled dots.
    #[default]
    Points,
    /// A line through the points, with dots.
    Line,
    /// A thin line through the points with a ring around each (to mark chosen points of
    /// other series, as a Pareto front).
    Rings,
}

#[derive(Clone, Debug, Default)]
pub struct Series {
    /// The legend entry; an empty name keeps the series out of the legend.
    pub name: String,
    pub color: Color,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
    /// A short text beside each point (none if empty).
    pub labels: Vec<String>,
}

/// One plot area with its axes.
#[derive(Clone, Debug, Default)]
pub struct Chart {
    pub title: String,
    pub x: Axis,
    pub y: Axis,
    pub series: Vec<Series>,
}

/// One or more charts side by side under a title, with one legend at the right (entries by
/// series name, over all charts) and lines of notes under it.
#[derive(Clone, Debug, Default)]
pub struct Figure {
    pub title: String,
    pub charts: Vec<Chart>,
    pub notes: Vec<String>,
    /// The whole picture, in pixels.
    pub size: (u32, u32),
}

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("cannot draw the chart: {0}")]
    Draw(String),
    #[error(transparent)]
    Output(#[from] OutputError),
}

fn draw_err<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// The font family every text uses: egui's Ubuntu Light, embedded in the binary, under the
/// generic name an SVG viewer also understands.
const FONT: &str = "sans-serif";

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a font egui ships and loads itself; only a broken build could fail.
        let _ = register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

fn rgb(c: Color) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Indices of the points no other point beats on both axes (smaller x and smaller y are
/// better), in order of x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// A picture this module can save: a figure of charts, or the hierarchy diagram (`icicle`).
pub trait Drawing {
    /// The whole picture, in pixels.
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError>;
}

impl Drawing for Figure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        draw(self, root)
    }
}

/// Draws `figure` into a PNG at `png` and an SVG beside it (same stem, `.svg`); returns the
/// SVG's path.
pub fn save(figure: &impl Drawing, png: &Path) -> Result<PathBuf, PlotError> {
    check(png)?;
    let image = render_png(figure)?;
    let rgba = image::DynamicImage::ImageRgb8(image).into_rgba8();
    let svg = render_svg(figure)?;
    // Both written before either is put in place: a failure leaves neither.
    let bytes = output::png_bytes(rgba.as_raw(), rgba.width(), rgba.height(), png)?;
    let png_file = output::stage(png, &bytes)?;
    let svg_path = png.with_extension("svg");
    let svg_file = output::stage(&svg_path, svg.as_bytes())?;
    png_file.commit()?;
    svg_file.commit()?;
    Ok(svg_path)
}

/// Checks that a chart can be written to `png` (and its SVG beside it), before the work
/// that makes it.
pub fn check(png: &Path) -> Result<(), OutputError> {
    output::check(png, &["png"])
}

/// The figure as an RGB image.
pub fn render_png(figure: &impl Drawing) -> Result<image::RgbImage, PlotError> {
    let (w, h) = figure.size();
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = bitmap_text::GlyphText(BitMapBackend::with_buffer(&mut buf, (w, h)))
            .into_drawing_area();
        figure.draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    image::RgbImage::from_raw(w, h, buf)
        .ok_or_else(|| PlotError::Draw("the pixel buffer has the wrong size".into()))
}

/// The figure as an SVG document (text as `<text>` elements).
pub fn render_svg(figure: &impl Drawing) -> Result<String, PlotError> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, figure.size()).into_drawing_area();
        figure.draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// A rectangle in pixels: left, top, width, height.
type Rect = (i32, i32, i32, i32);

/// Whether `a` and `b` come within 2 pixels of each other.
fn overlaps(a: Rect, b: Rect) -> bool {
    const GAP: i32 = 2;
    a.0 < b.0 + b.2 + GAP && b.0 < a.0 + a.2 + GAP && a.1 < b.1 + b.3 + GAP && b.1 < a.1 + a.3 + GAP
}

/// The legend entries: each series name once, in order of first appearance.
fn legend(figure: &Figure) -> Vec<(String, Color, Mark)> {
    let mut out: Vec<(String, Color, Mark)> = Vec::new();
    for s in figure.charts.iter().flat_map(|c| &c.series) {
        if !s.name.is_empty() && !out.iter().any(|(n, _, _)| *n == s.name) {
            out.push((s.name.clone(), s.color, s.mark));
        }
    }
    out
}

fn draw<DB: DrawingBackend>(
    figure: &Figure,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError> {
    register_fonts();
    root.fill(&WHITE).map_err(draw_err)?;
    let (w, _) = figure.size;
    let title_font = font(22.0);
    let text_width = |text: &str, style: &TextStyle| {
        root.estimate_text_size(text, style)
            .map(|(tw, _)| tw as i32)
            .unwrap_or(text.chars().count() as i32 * 8)
    };

    // The legend column at the right, as wide as its longest line.
    let entries = legend(figure);
    let legend_font = font(15.0);
    let note_font = font(14.0);
    let legend_w = entries
        .iter()
        .map(|(n, _, _)| 34 + text_width(n, &legend_font))
        .chain(figure.notes.iter().map(|n| text_width(n, &note_font)))
        .max()
        .unwrap_or(0)
        + 30;
    let (top, plots) = root.split_vertically(44);
    top.draw(&Text::new(
        figure.title.clone(),
        (20, 12),
        title_font.pos(Pos::new(HPos::Left, VPos::Top)),
    ))
    .map_err(draw_err)?;
    let (plots, side) = plots.split_horizontally(w as i32 - legend_w.min(w as i32 / 2));

    let mut y = 40;
    for (name, color, mark) in &entries {
        let c = rgb(*color);
        match mark {
            Mark::Points => {
                side.draw(&Circle::new((14, y), 5, c.filled()))
                    .map_err(draw_err)?;
            }
            Mark::Line => {
                side.draw(&PathElement::new(vec![(2, y), (26, y)], c.stroke_width(2)))
                    .map_err(draw_err)?;
                side.draw(&Circle::new((14, y), 4, c.filled()))
                    .map_err(draw_err)?;
            }
            Mark::Rings => {
                side.draw(&PathElement::new(vec![(2, y), (26, y)], c.stroke_width(1)))
                    .map_err(draw_err)?;
                side.draw(&Circle::new((14, y), 7, c.stroke_width(2)))
                    .map_err(draw_err)?;
            }
        }
        side.draw(&Text::new(
            name.clone(),
            (34, y),
            legend_font.pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
        y += 24;
    }
    y += 12;
    for note in &figure.notes {
        side.draw(&Text::new(
            note.clone(),
            (4, y),
            note_font.pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
        y += 20;
    }

    let n = figure.charts.len().max(1);
    let panels = plots.split_evenly((1, n));
    for (chart, area) in figure.charts.iter().zip(&panels) {
        draw_chart(chart, area, root)?;
    }
    Ok(())
}

/// The range of an axis over `values` (already mapped to the axis), padded a little; zero
/// stays the bottom of a symmetric-log axis.
fn axis_range(scale: Scale, values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    let (lo, hi) = if lo.is_finite() && hi.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    };
    let span = hi - lo;
    let pad = if span > 0.0 {
        span * 0.06
    } else if scale == Scale::Linear {
        lo.abs().max(1.0) * 0.1
    } else {
        0.5
    };
    match scale {
        // Always room up to 1 (log10 2), and nothing below 0.
        Scale::SymLog => (0.0, (hi + pad).max(0.35)),
        Scale::Linear if lo >= 0.0 && lo - pad < 0.0 => (0.0, hi + pad),
        _ => (lo - pad, hi + pad),
    }
}

/// Tick positions on the axis (in axis units) with their labels, and the positions of the
/// light grid lines between them.
fn ticks(scale: Scale, lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let inside = |t: f64| t >= lo - 1e-9 && t <= hi + 1e-9;
    match scale {
        Scale::Linear => {
            let step = nice_step(hi - lo, 6);
            let light = step / 5.0;
            let along = |step: f64| {
                let first = (lo / step).ceil() as i64;
                let last = (hi / step).floor() as i64;
                (first..=last).map(move |k| k as f64 * step)
            };
            (along(step).collect(), along(light).collect())
        }
        Scale::Log => {
            let decades = hi - lo;
            let mantissas: &[f64] = if decades <= 1.2 {
                &[1.0, 2.0, 3.0, 5.0]
            } else if decades <= 2.5 {
                &[1.0, 2.0, 5.0]
            } else {
                &[1.0]
            };
            // At most about 8 decade labels.
            let every = (decades / 8.0).ceil().max(1.0) as i64;
            let (mut bold, mut light) = (Vec::new(), Vec::new());
            for k in (lo.floor() as i64)..=(hi.ceil() as i64) {
                for m in 1..10 {
                    let t = (m as f64).log10() + k as f64;
                    if !inside(t) {
                        continue;
                    }
                    if mantissas.contains(&(m as f64)) && k.rem_euclid(every) == 0 {
                        bold.push(t);
                    } else if decades <= 6.0 {
                        light.push(t);
                    }
                }
            }
            (bold, light)
        }
        Scale::SymLog => {
            let mut bold = vec![0.0];
            let mut light = Vec::new();
            for k in 0..=12 {
                let base = 10f64.powi(k);
                let t = (1.0 + base).log10();
                if inside(t) {
                    bold.push(t);
                }
                for m in 2..10 {
                    let t = (1.0 + m as f64 * base).log10();
                    if inside(t) {
                        light.push(t);
                    }
                }
            }
            (bold, light)
        }
    }
}

/// A step of 1, 2 or 5 × 10^k giving at most about `target` intervals over `span`.
fn nice_step(span: f64, target: usize) -> f64 {
    let span = if span > 0.0 { span } else { 1.0 };
    let raw = span / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= target as f64)
        .unwrap_or(10.0 * mag)
}

/// A tick value as a short label: 0.5, 20, 3k, 10k, 1M, 2e-5.
pub fn format_tick(v: f64) -> String {
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    let a = v.abs();
    if a < 1e-12 {
        "0".into()
    } else if a >= 1e9 {
        format!("{}G", trim(format!("{:.2}", v / 1e9)))
    } else if a >= 1e6 {
        format!("{}M", trim(format!("{:.2}", v / 1e6)))
    } else if a >= 1e3 {
        format!("{}k", trim(format!("{:.2}", v / 1e3)))
    } else if a >= 0.01 {
        trim(format!("{v:.3}"))
    } else {
        format!("{v:.0e}")
    }
}

/// A linear axis in axis units (log10 for a log axis) with our own tick and grid positions.
struct AxisCoord {
    range: std::ops::Range<f64>,
    bold: Vec<f64>,
    light: Vec<f64>,
}

impl Ranged for AxisCoord {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let span = self.range.end - self.range.start;
        let f = if span > 0.0 {
            (value - self.range.start) / span
        } else {
            0.5
        };
        limit.0 + (f * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.light.clone()
        } else {
            self.bold.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.range.clone()
    }
}

fn draw_chart<DB: DrawingBackend>(
    chart: &Chart,
    area: &DrawingArea<DB, Shift>,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError> {
    let (sx, sy) = (chart.x.scale, chart.y.scale);
    // Every point mapped to the axes; points a log axis cannot show are left out.
    let mapped: Vec<Vec<Option<(f64, f64)>>> = chart
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .map(|&(x, y)| Some((sx.position(x)?, sy.position(y)?)))
                .collect()
        })
        .collect();
    let all = || mapped.iter().flatten().flatten();
    let (x0, x1) = axis_range(sx, all().map(|p| p.0));
    let (y0, y1) = axis_range(sy, all().map(|p| p.1));
    let (x_bold, x_light) = ticks(sx, x0, x1);
    let (y_bold, y_light) = ticks(sy, y0, y1);

    let mut builder = ChartBuilder::on(area);
    builder
        .margin(12)
        .margin_right(24)
        .x_label_area_size(52)
        .y_label_area_size(64);
    if !chart.title.is_empty() {
        builder.caption(chart.title.clone(), font(17.0));
    }
    let mut ctx = builder
        .build_cartesian_2d(
            AxisCoord {
                range: x0..x1,
                bold: x_bold,
                light: x_light,
            },
            AxisCoord {
                range: y0..y1,
                bold: y_bold,
                light: y_light,
            },
        )
        .map_err(draw_err)?;
    let x_fmt = |t: &f64| format_tick(sx.value_at(*t));
    let y_fmt = |t: &f64| format_tick(sy.value_at(*t));
    ctx.configure_mesh()
        .x_desc(chart.x.label.clone())
        .y_desc(chart.y.label.clone())
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style(font(14.0))
        .axis_desc_style(font(15.0))
        .bold_line_style(RGBColor(200, 200, 200).stroke_width(1))
        .light_line_style(RGBColor(236, 236, 236).stroke_width(1))
        .draw()
        .map_err(draw_err)?;

    for (s, pts) in chart.series.iter().zip(&mapped) {
        let c = rgb(s.color);
        let pts: Vec<(f64, f64)> = pts.iter().flatten().copied().collect();
        match s.mark {
            Mark::Points => {}
            Mark::Line => {
                ctx.draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
                    .map_err(draw_err)?;
            }
            Mark::Rings => {
                ctx.draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(1)))
                    .map_err(draw_err)?;
                ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 7, c.stroke_width(2))))
                    .map_err(draw_err)?;
                continue;
            }
        }
        ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
            .map_err(draw_err)?;
    }

    // Point labels: each at the first spot near its point that covers no other label, no
    // point and nothing outside the plot area.
    let label_font = font(13.0);
    let plot = ctx.plotting_area();
    let ((px0, py0), (px1, py1)) = {
        let r = plot.get_pixel_range();
        ((r.0.start, r.1.start), (r.0.end, r.1.end))
    };
    let dots: Vec<Rect> = chart
        .series
        .iter()
        .zip(&mapped)
        .flat_map(|(s, pts)| {
            let r = if s.mark == Mark::Rings { 8 } else { 4 };
            pts.iter().flatten().map(move |&p| (p, r))
        })
        .map(|(p, r)| {
            let (x, y) = ctx.backend_coord(&p);
            (x - r, y - r, 2 * r + 1, 2 * r + 1)
        })
        .collect();
    let mut placed: Vec<Rect> = Vec::new();
    for (s, pts) in chart.series.iter().zip(&mapped) {
        for (label, p) in s.labels.iter().zip(pts) {
            let (Some(p), false) = (p, label.is_empty()) else {
                continue;
            };
            let (x, y) = ctx.backend_coord(p);
            let (tw, th) = root
                .estimate_text_size(label, &label_font)
                .map(|(a, b)| (a as i32, b as i32))
                .unwrap_or((label.len() as i32 * 7, 13));
            let spots = [
                (7, -th - 2),
                (7, 3),
                (-tw - 7, -th - 2),
                (-tw - 7, 3),
                (-tw / 2, -th - 8),
                (-tw / 2, 8),
                (9, -th / 2),
                (-tw - 9, -th / 2),
                (7, -2 * th - 4),
                (7, th + 6),
                (-tw - 7, -2 * th - 4),
                (-tw - 7, th + 6),
            ];
            let fits = |r: Rect| {
                r.0 >= px0
                    && r.1 >= py0
                    && r.0 + r.2 <= px1
                    && r.1 + r.3 <= py1
                    && !placed.iter().any(|&q| overlaps(r, q))
                    && !dots.iter().any(|&d| overlaps(r, d))
            };
            let Some(r) = spots
                .iter()
                .map(|&(dx, dy)| (x + dx, y + dy, tw, th))
                .find(|&r| fits(r))
            else {
                // Nowhere free: leave this label out rather than draw it over another.
                continue;
            };
            placed.push(r);
            root.draw(&Text::new(
                label.clone(),
                (r.0, r.1),
                label_font
                    .color(&rgb(s.color))
                    .pos(Pos::new(HPos::Left, VPos::Top)),
            ))
            .map_err(draw_err)?;
        }
    }
    Ok(())
}

mod bitmap_text;
pub mod icicle;

#[cfg(test)]
mod tests {
    use super::*;

    fn figure(x: Scale, y: Scale, points: Vec<(f64, f64)>) -> Figure {
        Figure {
            title: "a test".into(),
            charts: vec![Chart {
                title: "panel".into(),
                x: Axis {
                    label: "triangles".into(),
                    scale: x,
                },
                y: Axis {
                    label: "tests per ray".into(),
                    scale: y,
                },
                series: vec![Series {
                    name: "brute force".into(),
                    color: [0, 114, 178],
                    points,
                    mark: Mark::Line,
                    labels: vec!["a".into(), "b".into()],
                }],
            }],
            notes: vec!["a note".into()],
            size: (640, 400),
        }
    }

    /// The contents of the SVG's `<text>` elements.
    pub fn svg_texts(svg: &str) -> Vec<String> {
        svg.split("</text>")
            .filter_map(|part| {
                let start = part.rfind("<text")?;
                let body = &part[start..];
                Some(body[body.find('>')? + 1..].trim().to_string())
            })
            .collect()
    }

    #[test]
    fn log_axes_from_a_thousand_to_a_million_give_png_and_svg() {
        let fig = figure(Scale::Log, Scale::Log, vec![(1e3, 1e3), (1e6, 1e6)]);
        let png = render_png(&fig).unwrap();
        assert_eq!((png.width(), png.height()), (640, 400));
        // Something besides the white background was drawn.
        assert!(png.pixels().any(|p| p.0 != [255, 255, 255]));
        let svg = render_svg(&fig).unwrap();
        assert!(svg.contains("<svg"));
        let texts = svg_texts(&svg);
        for label in ["1k", "10k", "100k", "1M", "brute force", "a note", "a test"] {
            assert!(texts.iter().any(|t| t == label), "{label}: {texts:?}");
        }
        let dir = std::env::temp_dir().join(format!("bvhlab-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let svg_path = save(&fig, &dir.join("log.png")).unwrap();
        assert_eq!(svg_path, dir.join("log.svg"));
        assert!(std::fs::metadata(dir.join("log.png")).unwrap().len() > 0);
        assert!(std::fs::metadata(&svg_path).unwrap().len() > 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn symlog_keeps_zero_and_log_leaves_out_what_it_cannot_show() {
        let fig = figure(Scale::Log, Scale::SymLog, vec![(10.0, 0.0), (100.0, 5e3)]);
        assert!(svg_texts(&render_svg(&fig).unwrap()).contains(&"0".to_string()));
        let fig = figure(Scale::Log, Scale::Log, vec![(0.0, 1.0), (-1.0, 2.0)]);
        assert!(render_png(&fig).is_ok());
    }

    #[test]
    fn ticks_and_labels() {
        let (bold, _) = ticks(Scale::Log, 3.0, 6.0);
        let labels: Vec<String> = bold
            .iter()
            .map(|&t| format_tick(Scale::Log.value_at(t)))
            .collect();
        assert_eq!(labels, ["1k", "10k", "100k", "1M"]);
        assert_eq!(format_tick(0.5), "0.5");
        assert_eq!(format_tick(30.0), "30");
        assert_eq!(format_tick(0.0), "0");
    }

    #[test]
    fn pareto_front_keeps_what_nothing_beats() {
        let points = [(1.0, 10.0), (2.0, 0.0), (3.0, 5.0), (0.5, 20.0), (2.5, 0.0)];
        assert_eq!(pareto_front(&points), vec![3, 0, 1]);
    }
}
