//! Ray–triangle intersectors behind one interface, so every structure can trace with any of
//! them: the watertight test is the default, Möller–Trumbore is the classic fast comparison.

mod moller_trumbore;
mod watertight;

pub use moller_trumbore::MollerTrumbore;
pub use watertight::Watertight;

use super::{Ray, Triangle};

/// Where a ray meets a triangle: the distance t and the barycentric coordinates (u, v) of
/// vertices 1 and 2 (vertex 0 has weight 1 − u − v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// A ray–triangle test. `RayData` holds what the test precomputes once per ray.
pub trait Intersector: Copy + Default + Send + Sync + 'static {
    type RayData: Copy;
    const NAME: &'static str;

    fn prepare(ray: &Ray) -> Self::RayData;

    /// The hit with t in the open interval (tmin, tmax), if any.
    fn intersect(
        data: &Self::RayData,
        ray: &Ray,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<TriangleHit>;
}
