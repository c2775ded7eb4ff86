//! The hierarchy diagram (`accel::hierarchy`) as a picture (`bvhlab render --tree`): one
//! row per depth, each node a cell within its parent's span, coloured by the chosen
//! quantity on the viridis scale, with the colour bar and what the widths mean below it.
//! A folded cell (its subtree too narrow to draw) is marked by a dark band at its foot.

use super::{Drawing, PlotError, draw_err, font, register_fonts};
use crate::accel::hierarchy::{Diagram, Shade};
use crate::render::colormap::{to_rgba8, viridis};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// The diagram with its captions.
pub struct Icicle<'a> {
    pub title: String,
    /// What the widths mean and how much is folded.
    pub subtitle: String,
    pub diagram: &'a Diagram,
    pub shade: Shade,
    pub size: (u32, u32),
}

/// Margins around the cells: the row labels at the left, the captions above, the colour
/// bar below.
const LEFT: i32 = 64;
const RIGHT: i32 = 16;
const TOP: i32 = 76;
const BOTTOM: i32 = 70;

fn shade_color(t: f64) -> RGBColor {
    let [r, g, b, _] = to_rgba8(viridis(t as f32));
    RGBColor(r, g, b)
}

impl Drawing for Icicle<'_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        register_fonts();
        root.fill(&WHITE).map_err(draw_err)?;
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        let text = |s: &str, at: (i32, i32), size: f64, h_pos: HPos| {
            root.draw(&Text::new(
                s.to_string(),
                at,
                font(size).pos(Pos::new(h_pos, VPos::Top)),
            ))
            .map_err(draw_err)
        };
        text(&self.title, (16, 10), 22.0, HPos::Left)?;
        text(&self.subtitle, (16, 42), 15.0, HPos::Left)?;
        let d = self.diagram;
        let (x_span, y_span) = ((w - LEFT - RIGHT).max(1), (h - TOP - BOTTOM).max(1));
        let row = (y_span as f64 / f64::from(d.rows + 1)).max(1.0);
        // Row labels every few rows, as many as fit.
        let every = ((18.0 / row).ceil() as u32).max(1);
        for depth in (0..=d.rows).step_by(every as usize) {
            let y = TOP + (f64::from(depth) * row) as i32;
            text(&format!("{depth}"), (LEFT - 8, y), 13.0, HPos::Right)?;
        }
        text("depth", (8, TOP - 20), 13.0, HPos::Left)?;
        for c in &d.cells {
            let x0 = LEFT + (c.x0 * x_span as f64).round() as i32;
            let x1 = (LEFT + (c.x1 * x_span as f64).round() as i32).max(x0 + 1);
            let y0 = TOP + (f64::from(c.depth) * row).round() as i32;
            let y1 = (TOP + (f64::from(c.depth + 1) * row).round() as i32).max(y0 + 1);
            let [r, g, b, _] = d.color(self.shade, c.value);
            let color = RGBColor(r, g, b);
            root.draw(&Rectangle::new([(x0, y0), (x1, y1)], color.filled()))
                .map_err(draw_err)?;
            // A hairline between cells wide and tall enough to keep one.
            if x1 - x0 >= 4 && y1 - y0 >= 4 {
                root.draw(&Rectangle::new([(x0, y0), (x1, y1)], WHITE.stroke_width(1)))
                    .map_err(draw_err)?;
            }
            if c.folded {
                let band = ((y1 - y0) / 4).max(1);
                root.draw(&Rectangle::new(
                    [(x0, y1 - band), (x1, y1)],
                    RGBColor(40, 40, 40).filled(),
                ))
                .map_err(draw_err)?;
            }
        }
        // The colour bar, with its ends.
        let bar_y = h - BOTTOM + 18;
        let bar_w = (x_span / 2).max(1);
        for k in 0..bar_w {
            let t = f64::from(k) / f64::from((bar_w - 1).max(1));
            root.draw(&Rectangle::new(
                [(LEFT + k, bar_y), (LEFT + k + 1, bar_y + 14)],
                shade_color(t).filled(),
            ))
            .map_err(draw_err)?;
        }
        let (lo, hi) = d.range;
        let number = |v: f64| {
            if self.shade == Shade::Depth || (v >= 1.0 && v.fract() == 0.0) {
                format!("{v:.0}")
            } else {
                format!("{v:.2e}")
            }
        };
        let scale = if self.shade.is_log() {
            " (log scale)"
        } else {
            ""
        };
        text(&number(lo), (LEFT, bar_y + 18), 13.0, HPos::Left)?;
        text(&number(hi), (LEFT + bar_w, bar_y + 18), 13.0, HPos::Right)?;
        text(
            &format!("colour: {}{scale}", self.shade.label()),
            (LEFT + bar_w + 16, bar_y),
            15.0,
            HPos::Left,
        )?;
        Ok(())
    }
}
