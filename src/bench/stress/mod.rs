//! The numerical stress suite behind `bvhlab stress`: watertightness on closed meshes at
//! every offset and scale, the slab test against an exact reference, degenerate triangles,
//! closest-hit agreement with the f64 reference, and shadow-ray self-intersection.

pub mod leaks;
pub mod meshes;
pub mod slab;
