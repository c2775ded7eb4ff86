//! How a heatmap maps counts to colours: the curve (linear, or logarithmic so a few
//! extreme pixels do not push the rest to black), the top of the scale (a fixed maximum
//! shared between views, the frame's maximum, or a percentile that clips the extremes), and
//! the shaded scene faintly under the colours so the geometry stays recognisable.

use super::Sample;
use super::colormap::viridis;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The darkest a pixel of the underlay gets (a face turned from the light, or a miss).
const UNDERLAY_FLOOR: f32 = 0.6;

/// The curve from counts to the colour scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
pub enum HeatCurve {
    #[default]
    Linear,
    /// log(1 + count) / log(1 + max).
    Log,
}

impl HeatCurve {
    pub const ALL: [HeatCurve; 2] = [HeatCurve::Linear, HeatCurve::Log];

    pub fn label(self) -> &'static str {
        match self {
            HeatCurve::Linear => "linear",
            HeatCurve::Log => "log",
        }
    }

    /// Where `count` sits on the scale from 0 to `max` (0..=1).
    pub fn position(self, count: f32, max: f32) -> f32 {
        let x = match self {
            HeatCurve::Linear => count / max.max(1.0),
            HeatCurve::Log => (1.0 + count).ln() / (1.0 + max.max(1.0)).ln(),
        };
        x.clamp(0.0, 1.0)
    }

    /// The count at position `x` of the scale (for the legend's middle label).
    pub fn count_at(self, x: f32, max: u32) -> u32 {
        match self {
            HeatCurve::Linear => (x * max as f32).round() as u32,
            HeatCurve::Log => ((1.0 + max as f32).powf(x) - 1.0).round() as u32,
        }
    }
}

/// A heatmap's colouring beyond its maximum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HeatStyle {
    #[serde(rename = "heat_curve")]
    pub curve: HeatCurve,
    /// Without a fixed maximum: the top of the scale is this percentile of the pixels'
    /// counts (e.g. 99), so a few extreme pixels do not set it; `None`: the maximum.
    #[serde(rename = "heat_clip_percentile")]
    pub clip_percentile: Option<f32>,
    /// The shaded scene under the colours: each hit pixel is darkened by how the surface
    /// faces the light, each miss dimmed.
    #[serde(rename = "heat_underlay")]
    pub underlay: bool,
}

impl HeatStyle {
    /// The top of the scale: the fixed `heat_max`, else the percentile or the maximum of
    /// `counts`.
    pub fn top(&self, heat_max: Option<u32>, max: u32, counts: impl Fn() -> Vec<u32>) -> u32 {
        if let Some(m) = heat_max {
            return m.max(1);
        }
        match self.clip_percentile {
            Some(p) => {
                let mut all = counts();
                if all.is_empty() {
                    return max.max(1);
                }
                let k = ((p / 100.0).clamp(0.0, 1.0) * (all.len() - 1) as f32).round() as usize;
                let (_, v, _) = all.select_nth_unstable(k);
                (*v).max(1)
            }
            None => max.max(1),
        }
    }

    /// The colour of `count` on a scale topped at `max`, over sample `s`.
    pub fn color(&self, count: u32, max: u32, s: &Sample) -> Vec3 {
        self.color_at(self.curve.position(count as f32, max as f32), s)
    }

    /// The colour at position `x` (0..=1) of the scale, over sample `s`.
    pub fn color_at(&self, x: f32, s: &Sample) -> Vec3 {
        let c = viridis(x);
        if !self.underlay {
            return c;
        }
        // Faces towards the light bright, away from it darker, misses as the darkest
        // face: the hue (the count) stays readable against the legend.
        let shade = if s.is_hit() {
            UNDERLAY_FLOOR + (1.0 - UNDERLAY_FLOOR) * s.cos_light.clamp(0.0, 1.0)
        } else {
            UNDERLAY_FLOOR
        };
        c * shade
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curves_span_the_scale_and_the_percentile_clips() {
        for curve in HeatCurve::ALL {
            assert_eq!(curve.position(0.0, 100.0), 0.0);
            assert_eq!(curve.position(100.0, 100.0), 1.0);
            assert_eq!(curve.position(500.0, 100.0), 1.0, "beyond the top: the top");
            assert_eq!(curve.count_at(1.0, 100), 100);
        }
        // The log curve lifts the low counts: 10 of 1000 is a third of the way up.
        assert!(HeatCurve::Log.position(10.0, 1000.0) > 0.3);
        assert!(HeatCurve::Linear.position(10.0, 1000.0) < 0.02);
        let style = HeatStyle {
            clip_percentile: Some(99.0),
            ..HeatStyle::default()
        };
        // 990 pixels of 1..=10 and 10 extreme ones: the 99th percentile is not extreme.
        let counts = || {
            (0..1000u32)
                .map(|i| if i < 990 { 1 + i % 10 } else { 10_000 })
                .collect()
        };
        assert!(style.top(None, 10_000, counts) <= 10);
        assert_eq!(
            style.top(Some(50), 10_000, counts),
            50,
            "a fixed maximum wins"
        );
        assert_eq!(HeatStyle::default().top(None, 10_000, counts), 10_000);
    }
}
