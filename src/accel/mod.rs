//! Acceleration structures: every structure answers the same two queries (closest hit and
//! any hit) through the `Accel` interface, generic over the ray–triangle test and over a
//! statistics sink, so the fast path and the teaching path are the same code.

pub mod brute_force;
pub mod bvh;
pub mod stats;

pub use brute_force::BruteForce;
pub use bvh::{BuildParams, Bvh, Strategy, TraversalOrder};
pub use stats::{Counter, Counters, NoStats, Stats};

use crate::geometry::{Intersector, Ray};

/// The closest hit of a ray: distance, barycentrics and the scene's triangle index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub triangle: u32,
}

pub trait Accel: Sync {
    /// The nearest triangle hit with t in (ray.tmin, ray.tmax).
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit>;

    /// Whether any triangle is hit with t in (ray.tmin, ray.tmax): the shadow-ray query,
    /// which may stop at the first hit it finds.
    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool;
}
