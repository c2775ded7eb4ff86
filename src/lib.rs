//! bvhlab: how acceleration structures make ray–scene queries fast, shown and measured.
//!
//! One data flow runs through the crate:
//! `scene` (triangles in objects, camera, light) → `accel` (a structure built with plain-data
//! parameters, refitted after motion) → `render` (a frame of pixels with per-pixel counters).
//! The same traversal serves the fast path and the teaching path: it is generic over a
//! statistics sink, and `NoStats` compiles the counting away.
//! - `geometry`: rays, boxes and the robust slab test, triangles, the ray–triangle
//!   intersectors (watertight, Möller–Trumbore, an f64 reference), secondary-ray origins;
//! - `scene`: meshes and instances, OBJ and glTF loading, the built-in scenes (the island
//!   among them), the pinhole camera;
//! - `accel`: every structure of the lecture behind one interface: brute force, the BVH2
//!   (seven builders, traversal, refit) and its 4- and 8-wide SIMD collapses, the k-d tree,
//!   the uniform grid, the octree and the two-level structure over instances; their
//!   parameters in one model (`accel::params`) that the app, the CLI and the presets share;
//!   the SAH's prediction against random lines; the binary ray and hit files of
//!   `bvhlab trace`;
//! - `render`: the tile-parallel CPU renderer, its shading and heatmap modes, the view modes,
//!   the ray replay and the A | B comparison;
//! - `bench`: the standard ray sets and the benchmark behind `bvhlab bench`, the stress
//!   suite behind `bvhlab stress`, run time against error (`bench accuracy`), cost against
//!   scene size (`bench scaling`), the app's frame times, and the charts (over `plotters`);
//! - `app`: the egui explorer over all of it, with a worker thread that owns scene and tree;
//! - `random`: SplitMix64, the seeded generator of scenes, ray sets and stress cases.

pub mod accel;
pub mod app;
pub mod bench;
pub mod budget;
pub mod geometry;
pub mod huge_pages;
pub mod input;
pub mod output;
pub mod random;
pub mod render;
pub mod scene;
