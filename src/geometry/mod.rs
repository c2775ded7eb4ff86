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

/// The relative error a watertight hit's f32 t is trusted to: a hit whose error bound is
/// larger (a thin triangle, a grazing ray) is placed in f64 instead. Traversals enter every
/// box up to the best t widened by this (`T_SCALE`), so a triangle whose computed t is
/// below the best one is never skipped because its box begins beyond it: in a fan of
/// coplanar triangles the f32 t of each can lie 10–20 ulps from the plane's.
pub const HIT_T_ERROR: f32 = 1.0 / 65536.0;
