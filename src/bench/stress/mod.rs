//! The numerical stress suite behind `bvhlab stress`: watertightness on closed meshes at
//! every offset and scale, the slab test against an exact reference, degenerate triangles,
//! closest-hit agreement with the f64 reference, and shadow-ray self-intersection.

pub mod crossing;
pub mod degenerate;
pub mod grazing;
pub mod instanced;
pub mod leaks;
pub mod meshes;
#[cfg(feature = "embree")]
pub mod peer;
pub mod shadow;
pub mod slab;
pub mod suite;

use crate::bench::rays::splitmix64;
use glam::DVec3;

/// A small seeded generator (splitmix64): the stress cases are the same on every run.
pub struct Rng(pub u64);

impl Rng {
    /// The generator for case `index` of a run seeded by `seed`.
    pub fn for_case(seed: u64, index: u64) -> Self {
        Rng(splitmix64(seed ^ index.wrapping_mul(0x9e37_79b9_7f4a_7c15)))
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
