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

pub use crate::random::Rng;
