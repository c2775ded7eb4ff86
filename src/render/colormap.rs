//! Colour maps for heatmaps: viridis, perceptually uniform and readable in greyscale and by
//! most colour-blind viewers, so equal steps in count look like equal steps in colour.

use glam::Vec3;

/// Viridis sampled at nine evenly spaced points (matplotlib's table), interpolated linearly.
const VIRIDIS: [[f32; 3]; 9] = [
    [0.267004, 0.004874, 0.329415],
    [0.282623, 0.140926, 0.457517],
    [0.253935, 0.265254, 0.529983],
    [0.206756, 0.371758, 0.553117],
    [0.163625, 0.471133, 0.558148],
    [0.127568, 0.566949, 0.550556],
    [0.134692, 0.658636, 0.517649],
    [0.266941, 0.748751, 0.440573],
    [0.993248, 0.906157, 0.143936],
];

/// The colour of `x` in [0, 1] (clamped), as sRGB-encoded values in [0, 1].
pub fn viridis(x: f32) -> Vec3 {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let f = x * (VIRIDIS.len() - 1) as f32;
    let i = (f as usize).min(VIRIDIS.len() - 2);
    let w = f - i as f32;
    Vec3::from(VIRIDIS[i]).lerp(Vec3::from(VIRIDIS[i + 1]), w)
}

/// Linear → sRGB transfer, for shaded images.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// `to_rgba8`'s rounding of `linear_to_srgb(c)` without the power per channel (see
/// `Srgb8`).
pub fn srgb8(c: f32) -> u8 {
    Srgb8::tables().code(c)
}

/// The 255 linear values at which the 8-bit sRGB code steps up (found once by bisection),
/// and a table of 4096 cells over [0, 1] that gives each cell's first code, so a colour is
/// one look-up and a step or two up the table (a frame colours three channels per pixel:
/// take the tables once for many).
pub struct Srgb8 {
    steps: [f32; 255],
    cells: [u8; SRGB8_CELLS + 1],
}

const SRGB8_CELLS: usize = 4096;

impl Srgb8 {
    pub fn tables() -> &'static Srgb8 {
        static TABLES: std::sync::OnceLock<Box<Srgb8>> = std::sync::OnceLock::new();
        TABLES.get_or_init(|| {
            // Code k + 1 starts where the exact transfer reaches (k + 0.5) / 255; the
            // bisection on f32 finds the first linear value whose rounded code is k + 1.
            let steps: [f32; 255] = std::array::from_fn(|k| {
                let code = |x: f32| (linear_to_srgb(x) * 255.0 + 0.5) as u32;
                let (mut lo, mut hi) = (0.0f32, 1.0f32);
                for _ in 0..40 {
                    let mid = 0.5 * (lo + hi);
                    if code(mid) > k as u32 {
                        hi = mid
                    } else {
                        lo = mid
                    }
                }
                hi
            });
            // A cell's code is that of its lower end: every c in the cell has that code or
            // more.
            let cells = std::array::from_fn(|i| {
                let low = i as f32 / SRGB8_CELLS as f32;
                steps.partition_point(|&step| step <= low) as u8
            });
            Box::new(Srgb8 { steps, cells })
        })
    }

    /// The 8-bit sRGB code of linear `c`.
    #[inline]
    pub fn code(&self, c: f32) -> u8 {
        // NaN and c ≤ 0 fall in cell 0; the cast saturates, so c ≥ 1 falls in the last.
        let cell = ((c * SRGB8_CELLS as f32) as usize).min(SRGB8_CELLS);
        let mut code = self.cells[cell] as usize;
        while code < 255 && self.steps[code] <= c {
            code += 1;
        }
        code as u8
    }
}

pub fn to_rgba8(srgb: Vec3) -> [u8; 4] {
    let q = |c: f32| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [q(srgb.x), q(srgb.y), q(srgb.z), 255]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb8_rounds_as_the_exact_transfer_does() {
        let exact = |c: f32| to_rgba8(Vec3::splat(linear_to_srgb(c)))[0];
        let mut samples: Vec<f32> = (0..=1_000_000).map(|i| i as f32 / 1e6).collect();
        samples.extend([-1.0, -0.0, 0.0, 1e-30, 0.003_130_8, 1.0, 1.5, f32::INFINITY]);
        for c in samples {
            assert_eq!(srgb8(c), exact(c), "{c}");
        }
        assert_eq!(srgb8(f32::NAN), 0);
    }
}
