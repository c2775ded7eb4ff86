//! The two-level structure: "a BVH is itself an intersectable primitive". One bottom-level
//! BVH (BLAS) per unique mesh, built once in the mesh's own space, and a top-level BVH
//! (TLAS) over the instances' world boxes; moving an object only changes the top level.

mod traverse;

use super::bvh::{self, BuildError, Bvh};
use super::{BuildParams, Outline, OutlineNode, StructureReport, TraversalOrder};
use crate::geometry::Triangle;
use crate::scene::{Instance, Instancing, TransformError};
use glam::Affine3A;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// A TLAS over instances of BLASes. Hits name triangles of the flattened scene: instance
/// after instance, each mesh's triangles in order.
#[derive(Clone, Debug)]
pub struct TwoLevel {
    /// One BVH per unique mesh, over its object-space triangles.
    pub blases: Vec<Bvh>,
    pub instances: Vec<Instance>,
    /// The flattened index of each instance's first triangle (64-bit: instancing places
    /// more triangles than 32 bits can number).
    pub first_triangle: Vec<u64>,
    /// The top level: a BVH2 whose leaves hold one instance each (its `prim_indices` are
    /// instance indices; it keeps no triangles).
    pub tlas: Bvh,
    pub order: TraversalOrder,
    /// The build parameters, kept to rebuild the top level when an instance moves.
    pub params: BuildParams,
}

/// Why an instance could not be moved.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum MoveError {
    #[error("there is no instance {0}")]
    NoInstance(usize),
    #[error(transparent)]
    Transform(#[from] TransformError),
    #[error(transparent)]
    Build(#[from] BuildError),
}

/// The most flattened triangles the explorer's outline lists (64 Mi references, 256 MiB).
const OUTLINE_MAX_REFS: u64 = 1 << 26;

/// How long each level took to build.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelTimes {
    pub blas: Duration,
    pub tlas: Duration,
}

/// Builds the BLASes of `scene`'s meshes in parallel with `params`, then the TLAS over its
/// instances, counting placed unique triangles into `progress`.
pub fn build(
    scene: &Instancing,
    params: &BuildParams,
    progress: &AtomicUsize,
) -> Result<(TwoLevel, StructureReport), BuildError> {
    params.validate()?;
    let instanced = scene.instanced_triangles();
    for mesh in &scene.meshes {
        if mesh.len() >= (u32::MAX / 2) as usize {
            return Err(BuildError::TooMany(mesh.len()));
        }
    }
    if scene.instances.len() >= (u32::MAX / 2) as usize {
        return Err(BuildError::TooMany(scene.instances.len()));
    }
    let mut first_triangle = Vec::with_capacity(scene.instances.len());
    let mut next = 0u64;
    for i in scene.instances.iter() {
        first_triangle.push(next);
        next += scene.meshes.get(i.mesh).map_or(0, |m| m.len()) as u64;
    }

    let start = Instant::now();
    let blases = scene
        .meshes
        .par_iter()
        .enumerate()
        .map(|(m, triangles)| {
            bvh::build_with_progress(triangles, params, progress)
                .map(|(blas, _)| blas)
                .map_err(|e| match e {
                    // Name the triangle as the flattened scene numbers it, where it is placed.
                    BuildError::NonFinite(t) => BuildError::NonFinite(
                        scene
                            .instances
                            .iter()
                            .position(|i| i.mesh == m)
                            .map_or(t, |i| first_triangle[i] as usize + t),
                    ),
                    e => e,
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let blas_time = start.elapsed();

    let start = Instant::now();
    let tlas = build_tlas(&blases, &scene.instances, params)?;
    let times = LevelTimes {
        blas: blas_time,
        tlas: start.elapsed(),
    };
    progress.store(scene.unique_triangles(), Ordering::Relaxed);
    let two_level = TwoLevel {
        blases,
        instances: scene.instances.to_vec(),
        first_triangle,
        tlas,
        order: TraversalOrder::default(),
        params: *params,
    };
    let report = two_level.report(instanced, times);
    Ok((two_level, report))
}

/// The top level over the instances' world boxes, one instance per leaf. The BVH builder
/// sees primitives only as boxes, so each box goes in as the triangle from its min corner
/// to its max corner, whose bounds are exactly that box. Instances of empty meshes are left
/// out: no ray can hit them.
fn build_tlas(
    blases: &[Bvh],
    instances: &[Instance],
    params: &BuildParams,
) -> Result<Bvh, BuildError> {
    let mut boxes = Vec::with_capacity(instances.len());
    let mut placed = Vec::with_capacity(instances.len());
    for (i, instance) in instances.iter().enumerate() {
        let Some(blas) = blases.get(instance.mesh) else {
            continue;
        };
        let world = instance.world_bounds(&blas.root().bounds());
        if !world.is_empty() {
            boxes.push(Triangle::new(world.min, world.max, world.max));
            placed.push(i as u32);
        }
    }
    let tlas_params = BuildParams {
        max_leaf_size: 1,
        ..params.whole_references()
    };
    let (mut tlas, _) = bvh::build(&boxes, &tlas_params).map_err(|e| match e {
        BuildError::NonFinite(b) => BuildError::NonFinite(placed[b] as usize),
        e => e,
    })?;
    for p in &mut tlas.prim_indices {
        *p = placed[*p as usize];
    }
    tlas.triangles = Vec::new();
    Ok(tlas)
}

impl TwoLevel {
    /// Memory of both levels, the BLASes' copies of the unique triangles included.
    pub fn bytes(&self) -> usize {
        self.blases.iter().map(Bvh::bytes).sum::<usize>()
            + self.tlas.bytes()
            + self.instances.len() * std::mem::size_of::<Instance>()
            + self.first_triangle.len() * std::mem::size_of::<u32>()
    }

    /// Places instance `i` by `transform` and rebuilds the top level only: the meshes do
    /// not change, so neither do their BLASes. The lecture's dynamic scene: millions of
    /// triangles, but only hundreds of objects to sort again.
    pub fn move_instance(&mut self, i: usize, transform: Affine3A) -> Result<(), MoveError> {
        let instance = self.instances.get_mut(i).ok_or(MoveError::NoInstance(i))?;
        let old = std::mem::replace(instance, Instance::new(instance.mesh, transform)?);
        match build_tlas(&self.blases, &self.instances, &self.params) {
            Ok(mut tlas) => {
                tlas.order = self.order;
                self.tlas = tlas;
                Ok(())
            }
            Err(e) => {
                // Moved out of range (a box beyond f32): the instance stays where it was.
                self.instances[i] = old;
                Err(e.into())
            }
        }
    }

    /// Sets the child order of both levels (no rebuild).
    pub fn set_order(&mut self, order: TraversalOrder) {
        self.order = order;
        self.tlas.order = order;
        for blas in &mut self.blases {
            blas.order = order;
        }
    }

    /// The flattened triangles instance `i` places.
    fn triangle_range(&self, i: usize) -> std::ops::Range<u64> {
        let first = self.first_triangle[i];
        let count = self
            .blases
            .get(self.instances[i].mesh)
            .map_or(0, |b| b.triangle_count as u64);
        first..first + count
    }

    /// The top level for the explorer: its nodes, each leaf referencing the flattened
    /// triangles of its instance; only the boxes for a scene placing more than
    /// `OUTLINE_MAX_REFS` triangles, whose list would not fit in memory.
    pub fn outline(&self) -> Outline {
        let tlas = self.tlas.outline();
        let placed: u64 = (0..self.instances.len())
            .map(|i| self.triangle_range(i).end - self.triangle_range(i).start)
            .sum();
        let listed = placed <= OUTLINE_MAX_REFS;
        let mut refs = Vec::new();
        let nodes = tlas
            .nodes
            .iter()
            .enumerate()
            .map(|(k, n)| {
                let mut node: OutlineNode = n.clone();
                if n.is_leaf() {
                    let start = refs.len() as u32;
                    for &i in tlas.leaf_refs(k).iter().filter(|_| listed) {
                        refs.extend(self.triangle_range(i as usize).map(|t| t as u32));
                    }
                    node.refs = (start, refs.len() as u32 - start);
                }
                node
            })
            .collect();
        Outline { nodes, refs }
    }

    fn report(&self, instanced: usize, times: LevelTimes) -> StructureReport {
        let depth = |b: &Bvh| b.node_depths().into_iter().max().unwrap_or(0);
        let blas_nodes: usize = self.blases.iter().map(|b| b.nodes.len()).sum();
        let blas_leaves: usize = self
            .blases
            .iter()
            .map(|b| b.nodes.iter().filter(|n| n.is_leaf()).count())
            .sum();
        let tlas_leaves = self.tlas.nodes.iter().filter(|n| n.is_leaf()).count();
        let empty_leaves = std::iter::once(&self.tlas)
            .chain(&self.blases)
            .flat_map(|b| b.nodes.iter())
            .filter(|n| n.is_leaf() && n.count == 0)
            .count();
        let unique: usize = self.blases.iter().map(|b| b.triangle_count).sum();
        let largest_leaf = self
            .blases
            .iter()
            .flat_map(|b| b.nodes.iter().filter(|n| n.is_leaf()).map(|n| n.count))
            .max()
            .unwrap_or(0) as usize;
        let ms = |d: Duration| format!("{:.2} ms", d.as_secs_f64() * 1e3);
        StructureReport {
            structure: "two-level",
            triangles: instanced,
            build_time: times.blas + times.tlas,
            bytes: self.bytes(),
            nodes: self.tlas.nodes.len() + blas_nodes,
            leaves: tlas_leaves + blas_leaves,
            empty_leaves,
            max_depth: depth(&self.tlas) + self.blases.iter().map(depth).max().unwrap_or(0),
            references: instanced,
            largest_leaf,
            details: vec![
                ("instances".into(), self.instances.len().to_string()),
                ("unique meshes".into(), self.blases.len().to_string()),
                ("unique triangles".into(), unique.to_string()),
                ("TLAS nodes".into(), self.tlas.nodes.len().to_string()),
                ("BLAS nodes".into(), blas_nodes.to_string()),
                ("BLAS builds".into(), ms(times.blas)),
                ("TLAS build".into(), ms(times.tlas)),
            ],
            caps_hit: Vec::new(),
        }
    }
}
