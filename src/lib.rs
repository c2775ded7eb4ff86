//! bvhlab: how acceleration structures make ray–scene queries fast, shown and measured.
//!
//! One data flow runs through the crate:
//! `scene` (triangles in objects, camera, light) → `accel` (a structure built with plain-data
//! parameters, refitted after motion) → `render` (a frame of pixels with per-pixel counters).
//! The same traversal serves the fast path and the teaching path: it is generic over a
//! statistics sink, and `NoStats` compiles the counting away.
//! - `geometry`: rays, boxes and the robust slab test, triangles, the ray–triangle
//!   intersectors (watertight, Möller–Trumbore, an f64 reference), secondary-ray origins and
//!   the binary ray files of `bvhlab trace`;
//! - `scene`: OBJ loading, the built-in scenes, the pinhole camera;
//! - `accel`: brute force and the BVH (build strategies, traversal, refit);
//! - `render`: the tile-parallel CPU renderer, its shading and heatmap modes;
//! - `bench`: the standard ray sets and the benchmark behind `bvhlab bench`, the stress
//!   suite behind `bvhlab stress`, run time against error (`bench --accuracy`), cost against
//!   scene size (`bench --scaling`), the app's frame times, and the charts (over `plotters`);
//! - `app`: the egui explorer over all of it, with a worker thread that owns scene and tree.

pub mod accel;
pub mod app;
pub mod bench;
pub mod geometry;
pub mod huge_pages;
pub mod render;
pub mod scene;
