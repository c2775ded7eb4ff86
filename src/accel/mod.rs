//! Acceleration structures: every structure answers the same two queries (closest hit and
//! any hit) through the `Accel` interface, generic over the ray–triangle test and over a
//! statistics sink, so the fast path and the teaching path are the same code.

pub mod brute_force;
pub mod bvh;
pub mod controls;
#[cfg(feature = "embree")]
pub mod embree;
pub mod epo;
pub mod grid;
pub mod hierarchy;
pub mod hit;
pub mod instances;
pub mod kdtree;
pub mod mailbox;
pub mod memory;
pub mod octree;
pub mod outline;
pub mod params;
pub mod progress;
pub mod query;
pub mod rayfile;
pub mod replay;
pub mod report;
pub mod sah_check;
pub mod split_costs;
pub mod stats;
pub mod structure;
#[cfg(feature = "tinybvh")]
pub mod tinybvh;
pub mod triangle_cost;
pub mod two_level;
pub mod visit_index;

pub use brute_force::BruteForce;
pub use bvh::{BuildParams, Bvh, Strategy, TraversalOrder};
pub use hit::{BestHit, Hit};
pub use kdtree::{KdParams, KdSplit, KdTree};
pub use mailbox::Mailbox;
pub use outline::{Outline, OutlineNode};
pub use params::StructureParams;
pub use replay::{Recorder, Step};
pub use report::StructureReport;
pub use stats::{Counter, Counters, NoStats, Stats};
pub use structure::{AccelKind, Built, Structure, StructureError};
pub use two_level::TwoLevel;

use crate::geometry::{Intersector, Ray};

pub trait Accel: Sync {
    /// The nearest triangle hit with t in (ray.tmin, ray.tmax).
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit>;

    /// Whether any triangle is hit with t in (ray.tmin, ray.tmax): the shadow-ray query,
    /// which may stop at the first hit it finds.
    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool;

    /// The closest hit of each ray of a batch of coherent rays (a tile of primary rays),
    /// without counting: the same hits as `closest_hit` ray by ray. Structures that can
    /// trace rays together override it.
    fn closest_hits<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = self.closest_hit::<I, _>(ray, &mut NoStats);
        }
    }
}
