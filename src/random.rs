//! SplitMix64 (Steele, Lea and Flood 2014): the one seeded mixing function behind the
//! built-in scenes' placement, the ray sets' directions and the stress cases. Tiny, fast and
//! plenty for test inputs; the same seed gives the same scene and rays on every run.
//! Builders and traversals never draw from it: a tree depends on its input alone.

use glam::{DVec3, Vec3};
use std::f32::consts::PI;

/// The golden-ratio step SplitMix64 adds to its state.
pub const GOLDEN: u64 = 0x9e37_79b9_7f4a_7c15;

/// One SplitMix64 output for the state `x`: `x` advanced by `GOLDEN`, then mixed.
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(GOLDEN);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A direction on the hemisphere around the unit normal `n`, with density ∝ cos θ, from a
/// deterministic hash of `key` (the same rays every run).
pub fn cosine_direction(n: Vec3, key: u64) -> Vec3 {
    let h = splitmix64(key ^ GOLDEN);
    let r1 = (h >> 40) as f32 / (1u64 << 24) as f32;
    let r2 = ((h >> 16) & 0xff_ffff) as f32 / (1u64 << 24) as f32;
    let phi = 2.0 * PI * r1;
    let r = r2.sqrt();
    let (t, b) = n.any_orthonormal_pair();
    let local = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r2).max(0.0).sqrt());
    (t * local.x + b * local.y + n * local.z).normalize()
}

/// A seeded stream whose state is its last output (`state = splitmix64(state)`): the
/// stress cases and the unit tests' random inputs, the same on every run.
pub struct Rng(pub u64);

impl Rng {
    /// The generator for case `index` of a run seeded by `seed`.
    pub fn for_case(seed: u64, index: u64) -> Self {
        Rng(splitmix64(seed ^ index.wrapping_mul(GOLDEN)))
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = splitmix64(self.0);
        self.0
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n.max(1)
    }

    pub fn coin(&mut self) -> bool {
        self.next_u64() & 1 == 0
    }

    /// Uniform in the unit ball.
    pub fn in_ball(&mut self) -> DVec3 {
        loop {
            let p = DVec3::new(self.unit(), self.unit(), self.unit()) * 2.0 - 1.0;
            if p.length_squared() <= 1.0 {
                return p;
            }
        }
    }

    /// +0.0 or −0.0.
    pub fn signed_zero(&mut self) -> f32 {
        if self.coin() { 0.0 } else { -0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference sequence for seed 1234567 (the generator's published test vector).
    #[test]
    fn splitmix64_gives_the_reference_sequence() {
        let mut state = 1_234_567u64;
        let mut next = || {
            let out = splitmix64(state);
            state = state.wrapping_add(GOLDEN);
            out
        };
        assert_eq!(next(), 6_457_827_717_110_365_317);
        assert_eq!(next(), 3_203_168_211_198_807_973);
        assert_eq!(next(), 9_817_491_932_198_370_423);
    }
}
