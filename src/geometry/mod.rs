//! Geometry of the lecture's first slides: rays, axis-aligned boxes with the slab test,
//! triangles and the ray–triangle intersectors.

pub mod aabb;
pub mod clip;
pub mod frustum;
pub mod intersect;
pub mod overlap;
pub mod ray;
pub mod rayfile;
pub mod simd;
pub mod spawn;
pub mod triangle;

pub use aabb::Aabb;
pub use intersect::{Intersector, IntersectorKind, MollerTrumbore, ReferenceF64, Watertight};
pub use ray::Ray;
pub use triangle::Triangle;

/// The unit roundoff of f32 arithmetic (half an ulp of 1.0).
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// γ(n) = nε / (1 − nε): the bound on the relative error of n chained f32 operations
/// (Higham; pbrt §6.8). Used wherever the code must be conservative in floating point.
pub const fn gamma(n: i32) -> f32 {
    let ne = n as f32 * MACHINE_EPSILON;
    ne / (1.0 - ne)
}
