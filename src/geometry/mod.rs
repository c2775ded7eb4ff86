//! Geometry of the lecture's first slides: rays, axis-aligned boxes with the slab test,
//! triangles and the ray–triangle intersectors.

pub mod aabb;
pub mod clip;
pub mod frustum;
pub mod hull;
pub mod intersect;
pub mod overlap;
pub mod ray;
pub mod simd;
pub mod slab;
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

/// How far (relative) box culling reaches past the best hit's f32 t. A hit's f32 t can lie
/// 10–20 ulps from the plane's true distance (a slanted ray through long, thin triangles),
/// so a triangle whose computed t is below the best one may sit in a box whose computed
/// entry is above it: on stacked coplanar triangles in an axis-aligned plane, a walk that
/// stopped at the best t itself skipped such boxes and named another triangle than brute
/// force. Traversals enter every box up to the best t widened by this (`T_SCALE`); it is
/// far above the error of any but ill-conditioned hits (a grazing ray, a sliver).
pub const HIT_T_ERROR: f32 = 1.0 / 16384.0;
