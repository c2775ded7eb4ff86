//! A rendered frame: RGBA pixels, what each pixel's rays found and cost, and a summary.
//! The per-pixel samples are kept so a frame can be recoloured (another mode, another
//! heatmap scale) without tracing again.

use crate::accel::{Counter, Counters};
use glam::Vec3;
use std::time::Duration;

/// What the rays of one pixel found, and the work they took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Distance to the closest hit, +∞ for a miss.
    pub t: f32,
    /// Scene triangle index of the closest hit, `u64::MAX` for a miss.
    pub triangle: u64,
    /// Unit geometric normal of the hit, facing the ray.
    pub normal: Vec3,
    /// Diffuse colour of the hit object.
    pub albedo: Vec3,
    /// Cosine of the angle to the light, 0 when the light is behind the surface.
    pub cos_light: f32,
    /// Whether the shadow ray reached the light.
    pub lit: bool,
    pub primary: Counters,
    pub shadow: Counters,
}

impl Sample {
    pub fn is_hit(&self) -> bool {
        self.triangle != u64::MAX
    }

    pub fn counters(&self, rays: RayKind) -> &Counters {
        match rays {
            RayKind::Primary => &self.primary,
            RayKind::Shadow => &self.shadow,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RayKind {
    #[default]
    Primary,
    Shadow,
}

impl RayKind {
    pub fn label(self) -> &'static str {
        match self {
            RayKind::Primary => "primary rays",
            RayKind::Shadow => "shadow rays",
        }
    }
}

/// Mean and maximum of one counter over the pixels that traced such a ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CounterSummary {
    pub total: u64,
    pub mean: f64,
    pub max: u32,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameSummary {
    pub primary_rays: u64,
    pub primary_hits: u64,
    pub shadow_rays: u64,
    pub shadow_occluded: u64,
    /// Wall time of tracing (both ray kinds), without colouring.
    pub trace_time: Duration,
    /// `[ray kind][counter]` as in `RayKind` and `Counter::ALL` order.
    pub counters: [[CounterSummary; Counter::ALL.len()]; 2],
}

impl FrameSummary {
    pub fn rays(&self) -> u64 {
        self.primary_rays + self.shadow_rays
    }

    pub fn mrays_per_s(&self) -> f64 {
        let s = self.trace_time.as_secs_f64();
        if s > 0.0 {
            self.rays() as f64 / s / 1e6
        } else {
            0.0
        }
    }

    /// Whether the frame was traced with counting (a quick preview may not count).
    pub fn counted(&self) -> bool {
        self.counters.iter().flatten().any(|c| c.total > 0)
    }

    pub fn counter(&self, rays: RayKind, which: Counter) -> &CounterSummary {
        let k = Counter::ALL.iter().position(|&c| c == which).unwrap_or(0);
        &self.counters[rays as usize][k]
    }

    /// The frame's totals, maxima and means, summed over chunks of pixels on every thread
    /// (integer sums and maxima: the same summary whatever the thread count).
    #[cfg(test)]
    pub(crate) fn from_samples(samples: &[Sample], trace_time: Duration, shadows: bool) -> Self {
        use rayon::prelude::*;
        samples
            .par_chunks(1 << 14)
            .map(|chunk| Self::sum_of(chunk, shadows))
            .reduce(FrameSummary::default, Self::merged)
            .with_means(trace_time)
    }

    /// Sums (of `sum_of` and `merged`) made a summary: the means taken, the time set.
    pub(crate) fn with_means(mut self, trace_time: Duration) -> Self {
        self.trace_time = trace_time;
        for (r, n) in [(0, self.primary_rays), (1, self.shadow_rays)] {
            for cs in &mut self.counters[r] {
                cs.mean = cs.total as f64 / n.max(1) as f64;
            }
        }
        self
    }

    /// The ray counts, totals and maxima of `samples` (means not yet taken).
    pub(crate) fn sum_of(samples: &[Sample], shadows: bool) -> Self {
        let mut s = FrameSummary::default();
        for sample in samples {
            s.primary_rays += 1;
            if sample.is_hit() {
                s.primary_hits += 1;
                s.shadow_rays += u64::from(shadows);
                s.shadow_occluded += u64::from(!sample.lit);
            }
            for (r, c) in [(0, &sample.primary), (1, &sample.shadow)] {
                for (k, which) in Counter::ALL.into_iter().enumerate() {
                    let v = c.get(which);
                    let cs = &mut s.counters[r][k];
                    cs.total += v as u64;
                    cs.max = cs.max.max(v);
                }
            }
        }
        s
    }

    /// The ray counts of `samples` traced without counting: their counters are all zero,
    /// so only rays, hits and shadowed hits are summed.
    pub(crate) fn sum_of_uncounted(samples: &[Sample], shadows: bool) -> Self {
        let mut s = FrameSummary {
            primary_rays: samples.len() as u64,
            ..Default::default()
        };
        for sample in samples.iter().filter(|s| s.is_hit()) {
            s.primary_hits += 1;
            s.shadow_occluded += u64::from(!sample.lit);
        }
        s.shadow_rays = if shadows { s.primary_hits } else { 0 };
        s
    }

    /// Two chunks' sums as one.
    pub(crate) fn merged(mut a: Self, b: Self) -> Self {
        a.primary_rays += b.primary_rays;
        a.primary_hits += b.primary_hits;
        a.shadow_rays += b.shadow_rays;
        a.shadow_occluded += b.shadow_occluded;
        for (ra, rb) in a.counters.iter_mut().zip(&b.counters) {
            for (x, y) in ra.iter_mut().zip(rb) {
                x.total += y.total;
                x.max = x.max.max(y.max);
            }
        }
        a
    }
}

#[derive(Clone, Debug, Default)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first, 4 bytes per pixel.
    pub rgba: Vec<u8>,
    pub samples: Vec<Sample>,
    pub summary: FrameSummary,
    /// The count that maps to the top of the heatmap colour scale in `rgba`, if it is one.
    pub heat_max: Option<u32>,
    /// Per-triangle values the frame is coloured by in the modes that colour triangles,
    /// worked out once (`Frame::triangle_values_for`).
    pub per_triangle: super::per_triangle::Slots,
}

/// A frame's samples go back to the pool for the next frame.
impl Drop for Frame {
    fn drop(&mut self) {
        super::sample_pool::give_back(std::mem::take(&mut self.samples));
    }
}

impl Frame {
    pub fn sample(&self, x: u32, y: u32) -> Option<&Sample> {
        (x < self.width && y < self.height).then(|| &self.samples[(y * self.width + x) as usize])
    }

    /// Writes the image as a PNG, whole (`crate::output`).
    pub fn save_png(&self, path: &std::path::Path) -> Result<(), crate::output::OutputError> {
        crate::output::write_png(&self.rgba, self.width, self.height, path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Summed over chunks on every thread, the summary is the one-pass summary.
    #[test]
    fn the_summary_of_many_chunks_is_the_summary_of_one() {
        let samples: Vec<Sample> = (0..100_003u32)
            .map(|i| {
                let mut s = Sample::default();
                if i % 3 != 0 {
                    s.t = 1.0;
                    s.triangle = u64::from(i);
                    s.lit = i % 5 != 0;
                }
                s.primary.nodes_visited = i % 97;
                s.primary.triangle_tests = (i * 7) % 131;
                s.shadow.box_tests = (i * 13) % 1009;
                s
            })
            .collect();
        let one = FrameSummary::sum_of(&samples, true);
        let chunked = FrameSummary::from_samples(&samples, Duration::ZERO, true);
        assert_eq!(chunked.primary_rays, 100_003);
        assert_eq!(
            (
                chunked.primary_hits,
                chunked.shadow_rays,
                chunked.shadow_occluded
            ),
            (one.primary_hits, one.shadow_rays, one.shadow_occluded)
        );
        for (a, b) in chunked
            .counters
            .iter()
            .flatten()
            .zip(one.counters.iter().flatten())
        {
            assert_eq!((a.total, a.max), (b.total, b.max));
        }
        let nodes = chunked.counter(RayKind::Primary, Counter::NodesVisited);
        assert_eq!(nodes.max, 96);
        assert!((nodes.mean - nodes.total as f64 / 100_003.0).abs() < 1e-12);
    }

    /// Samples without counts sum to the same rays, hits and shadowed hits either way.
    #[test]
    fn an_uncounted_sum_is_the_full_sum_of_samples_without_counts() {
        let samples: Vec<Sample> = (0..5_000u32)
            .map(|i| {
                let mut s = Sample::default();
                if i % 3 != 0 {
                    s.triangle = u64::from(i);
                    s.lit = i % 7 != 0;
                }
                s
            })
            .collect();
        for shadows in [false, true] {
            assert_eq!(
                FrameSummary::sum_of_uncounted(&samples, shadows),
                FrameSummary::sum_of(&samples, shadows)
            );
        }
    }
}
