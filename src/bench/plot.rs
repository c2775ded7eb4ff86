//! A small scatter plot drawn straight into a PNG, for the Pareto plot of time against error:
//! no plotting stack and no system fonts (text uses `font8x8`'s public-domain bitmap font).

use image::{Rgb, RgbImage};

pub type Color = [u8; 3];

#[derive(Clone, Debug)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub color: Color,
    pub label: String,
}

#[derive(Clone, Debug, Default)]
pub struct ScatterPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub points: Vec<Point>,
    /// (name, colour) entries of the legend; without a colour, a line of text.
    pub legend: Vec<(String, Option<Color>)>,
    /// The y axis is log10(1 + y), so that 0 has a place at the bottom.
    pub symlog_y: bool,
    /// The x axis is logarithmic (all x must be positive).
    pub log_x: bool,
}

const WHITE: Color = [255, 255, 255];
const BLACK: Color = [0, 0, 0];
const GREY: Color = [215, 215, 215];

/// Indices of the points no other point beats on both axes (smaller x and smaller y are
/// better), in order of x.
pub fn pareto_front(points: &[Point]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .x
            .total_cmp(&points[b].x)
            .then(points[a].y.total_cmp(&points[b].y))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].y < best {
            best = points[i].y;
            front.push(i);
        }
    }
    front
}

/// Draws `text` with its top-left corner at (x, y), each font pixel `scale` pixels wide.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, scale: i64, color: Color) {
    for (k, ch) in text.chars().enumerate() {
        let glyph = font8x8::legacy::BASIC_LEGACY
            .get(ch as usize)
            .copied()
            .unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    let px = x + (k as i64 * 8 + col) * scale;
                    let py = y + row as i64 * scale;
                    fill_rect(img, px, py, scale, scale, color);
                }
            }
        }
    }
}

/// Width in pixels of `text` at `scale`.
pub fn text_width(text: &str, scale: i64) -> i64 {
    text.chars().count() as i64 * 8 * scale
}

fn put(img: &mut RgbImage, x: i64, y: i64, color: Color) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, Rgb(color));
    }
}

fn fill_rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, color: Color) {
    for yy in y..y + h {
        for xx in x..x + w {
            put(img, xx, yy, color);
        }
    }
}

fn line(img: &mut RgbImage, (x0, y0): (i64, i64), (x1, y1): (i64, i64), color: Color) {
    let steps = (x1 - x0).abs().max((y1 - y0).abs()).max(1);
    for s in 0..=steps {
        let x = x0 + (x1 - x0) * s / steps;
        let y = y0 + (y1 - y0) * s / steps;
        put(img, x, y, color);
    }
}

fn disc(img: &mut RgbImage, cx: i64, cy: i64, r: i64, color: Color) {
    for y in -r..=r {
        for x in -r..=r {
            if x * x + y * y <= r * r {
                put(img, cx + x, cy + y, color);
            }
        }
    }
}

/// "Nice" tick positions covering [lo, hi]: steps of 1, 2 or 5 × 10^k.
fn ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= target as f64)
        .unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + step * 1e-9 {
        out.push(t);
        t += step;
    }
    out
}

fn format_tick(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 {
        format!("1e{}", v.log10().round() as i32)
    } else if v.fract().abs() < 1e-9 {
        format!("{}", v as i64)
    } else {
        let s = format!("{v:.2}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Renders the plot; the Pareto front is drawn as a line through its points, which get a
/// black ring.
pub fn render(plot: &ScatterPlot, width: u32, height: u32) -> RgbImage {
    let mut img = RgbImage::from_pixel(width, height, Rgb(WHITE));
    let (w, h) = (width as i64, height as i64);
    let (left, right, top, bottom) = (90i64, 300i64, 50i64, 70i64);
    let (pw, ph) = (w - left - right, h - top - bottom);
    let ty = |y: f64| {
        if plot.symlog_y {
            (1.0 + y.max(0.0)).log10()
        } else {
            y
        }
    };
    let tx = |x: f64| if plot.log_x { x.max(1e-300).log10() } else { x };
    let xs: Vec<f64> = plot.points.iter().map(|p| tx(p.x)).collect();
    let ys: Vec<f64> = plot.points.iter().map(|p| ty(p.y)).collect();
    let fold = |v: &[f64], f: fn(f64, f64) -> f64, init: f64| v.iter().copied().fold(init, f);
    let (mut x0, mut x1) = (
        fold(&xs, f64::min, f64::INFINITY),
        fold(&xs, f64::max, f64::NEG_INFINITY),
    );
    if !x0.is_finite() || !x1.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    let pad = ((x1 - x0) * 0.06).max(x1.abs() * 0.01).max(1e-9);
    let (x0, x1) = (x0 - pad, x1 + pad);
    let (x0, x1) = if plot.log_x {
        (x0, x1)
    } else {
        (x0.max(0.0), x1)
    };
    let y1 = fold(&ys, f64::max, 0.0).max(if plot.symlog_y { 1.0 } else { 1e-9 }) * 1.1;
    let y0 = 0.0;
    let px = |x: f64| left + ((x - x0) / (x1 - x0) * pw as f64).round() as i64;
    let py = |y: f64| top + ph - ((y - y0) / (y1 - y0) * ph as f64).round() as i64;

    // Grid and ticks.
    let x_ticks: Vec<(f64, String)> = if plot.log_x {
        let (lo, hi) = (10f64.powf(x0), 10f64.powf(x1));
        // Every integer mantissa when the axis spans about a decade, else 1, 2, 5.
        let mantissas: &[f64] = if x1 - x0 < 1.3 {
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
        } else {
            &[1.0, 2.0, 5.0]
        };
        let mut out = Vec::new();
        for k in (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32) {
            for &m in mantissas {
                let v = m * 10f64.powi(k);
                if v >= lo && v <= hi {
                    out.push((v.log10(), format_tick(v)));
                }
            }
        }
        out
    } else {
        ticks(x0, x1, 8)
            .into_iter()
            .map(|v| (v, format_tick(v)))
            .collect()
    };
    for (t, label) in x_ticks {
        let x = px(t);
        line(&mut img, (x, top), (x, top + ph), GREY);
        draw_text(
            &mut img,
            x - text_width(&label, 1) / 2,
            top + ph + 8,
            &label,
            1,
            BLACK,
        );
    }
    let y_ticks: Vec<(f64, String)> = if plot.symlog_y {
        (0..=9)
            .map(|k| if k == 0 { 0.0 } else { 10f64.powi(k - 1) })
            .filter(|&v| ty(v) <= y1)
            .map(|v| (ty(v), format_tick(v)))
            .collect()
    } else {
        ticks(y0, y1, 6)
            .into_iter()
            .map(|v| (v, format_tick(v)))
            .collect()
    };
    for (v, label) in y_ticks {
        let y = py(v);
        line(&mut img, (left, y), (left + pw, y), GREY);
        draw_text(
            &mut img,
            left - 8 - text_width(&label, 1),
            y - 4,
            &label,
            1,
            BLACK,
        );
    }
    line(&mut img, (left, top + ph), (left + pw, top + ph), BLACK);
    line(&mut img, (left, top), (left, top + ph), BLACK);

    // Pareto front, then the points and their labels.
    let front = pareto_front(&plot.points);
    for pair in front.windows(2) {
        let (a, b) = (&plot.points[pair[0]], &plot.points[pair[1]]);
        line(
            &mut img,
            (px(tx(a.x)), py(ty(a.y))),
            (px(tx(b.x)), py(ty(b.y))),
            BLACK,
        );
    }
    // Labels go to the first nearby spot that overlaps no earlier label.
    let mut placed: Vec<(i64, i64, i64, i64)> = Vec::new();
    for (i, p) in plot.points.iter().enumerate() {
        let (x, y) = (px(tx(p.x)), py(ty(p.y)));
        if front.contains(&i) {
            disc(&mut img, x, y, 6, BLACK);
        }
        disc(&mut img, x, y, 4, p.color);
        let w = text_width(&p.label, 1);
        let spots = [
            (7, -10),
            (7, 4),
            (7, -20),
            (7, 14),
            (-w - 7, -10),
            (-w - 7, 4),
            (7, -30),
            (7, 24),
        ];
        let overlaps = |r: (i64, i64, i64, i64)| {
            placed
                .iter()
                .any(|q| r.0 < q.0 + q.2 && q.0 < r.0 + r.2 && r.1 < q.1 + q.3 && q.1 < r.1 + r.3)
        };
        let (dx, dy) = spots
            .iter()
            .copied()
            .find(|&(dx, dy)| !overlaps((x + dx, y + dy, w, 9)))
            .unwrap_or(spots[0]);
        placed.push((x + dx, y + dy, w, 9));
        draw_text(&mut img, x + dx, y + dy, &p.label, 1, p.color);
    }

    // Title, axis labels, legend (entries without a colour are notes).
    draw_text(&mut img, left, 8, &plot.title, 2, BLACK);
    let xl = &plot.x_label;
    draw_text(
        &mut img,
        left + pw / 2 - text_width(xl, 1) / 2,
        h - 30,
        xl,
        1,
        BLACK,
    );
    draw_text(&mut img, 8, top - 16, &plot.y_label, 1, BLACK);
    let lx = left + pw + 20;
    for (k, (name, color)) in plot.legend.iter().enumerate() {
        let y = top + 10 + k as i64 * 18;
        if let Some(color) = color {
            disc(&mut img, lx + 5, y + 4, 5, *color);
        }
        draw_text(&mut img, lx + 16, y, name, 1, BLACK);
    }
    let y = top + 10 + plot.legend.len() as i64 * 18 + 10;
    disc(&mut img, lx + 5, y + 4, 6, BLACK);
    disc(&mut img, lx + 5, y + 4, 4, WHITE);
    draw_text(&mut img, lx + 16, y, "Pareto front", 1, BLACK);
    img
}
