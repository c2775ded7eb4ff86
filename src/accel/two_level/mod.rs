//! The two-level structure: "a BVH is itself an intersectable primitive". One bottom-level
//! BVH (BLAS) per unique mesh, built once in the mesh's own space, and a top-level BVH
//! (TLAS) over the instances' world boxes; moving an object only changes the top level.
//! Both levels are BVH8s (the BVH2 collapsed, traced with SIMD slab tests): the fastest
//! layout, as a two-level ray takes as many steps as a flat one and more. The top level's
//! leaves hold references, each an instance and a subtree of its BLAS: whole instances,
//! or with partial re-braiding (`rebraid`) the large ones opened into their BLAS's subtrees.
//! Each leaf slot keeps what a ray needs to enter its reference in one cache line (`leaf`).
//! Coherent primary rays walk the top level in packets (`packet`).

mod blas_index;
mod end_points;
mod epo;
mod leaf;
pub mod outline;
mod packet;
pub mod rebraid;
pub mod refit;
mod sah;
mod traverse;
mod triangle_cost;

pub use leaf::LeafReference;
pub use outline::{BlasEntry, InstanceOutline, ReferenceLocator};
pub use rebraid::Reference;
pub use refit::{MovedReference, TopLevelIndex};
pub use triangle_cost::PlacedCosts;

use super::bvh::wide::{CollapseParams, UnsupportedSimd};
use super::bvh::{self, BuildError, Bvh8, Subtree};
use super::{BuildParams, Outline, OutlineNode, StructureReport, TraversalOrder};
use crate::accel::progress::BuildProgress;
use crate::accel::report::Detail;
use crate::geometry::simd::SimdLevel;
use crate::geometry::{Aabb, Triangle, hull};
use crate::scene::{Instance, Instancing, TransformError};
use glam::{Affine3A, Vec3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// A TLAS over instances of BLASes. Hits name triangles of the flattened scene: instance
/// after instance, each mesh's triangles in order.
#[derive(Clone, Debug)]
pub struct TwoLevel {
    /// One BVH8 per unique mesh, over its object-space triangles.
    pub blases: Vec<Bvh8>,
    /// Each unique mesh's convex hull, for its rotated instances' world boxes.
    pub hulls: Vec<Option<MeshHull>>,
    pub instances: Vec<Instance>,
    /// The flattened index of each instance's first triangle (64-bit: instancing places
    /// more triangles than 32 bits can number).
    pub first_triangle: Vec<u64>,
    /// The top level's primitives: subtrees of the instances' BLASes (the roots alone
    /// without re-braiding), sorted by instance.
    pub references: Vec<Reference>,
    /// Instance i's references are `references[first_reference[i]..first_reference[i + 1]]`
    /// (none for an instance of an empty mesh).
    pub first_reference: Vec<u32>,
    /// The top level: a BVH8 whose leaf lanes hold one reference each (its `prim_indices`
    /// index `references`; it keeps no triangles).
    pub tlas: Bvh8,
    pub order: TraversalOrder,
    /// The slab kernel both levels run. Private: the traversal's `unsafe` kernels rely on it
    /// naming a level this CPU supports, which `set_simd` checks.
    simd: SimdLevel,
    /// The build parameters, kept to rebuild the top level.
    pub params: BuildParams,
    /// Where each reference sits in the TLAS, for refitting an instance's when it moves.
    pub top_index: TopLevelIndex,
    /// Per TLAS leaf slot (`tlas.prim_indices`' order), its reference ready to walk.
    pub leaves: Vec<LeafReference>,
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
    progress: &BuildProgress,
) -> Result<(TwoLevel, StructureReport), BuildError> {
    params.validate()?;
    if params.builds_direct_wide() && params.presplit > 0.0 {
        return Err(BuildError::PresplitDirectWide);
    }
    let instanced = scene.instanced_triangles();
    for mesh in &scene.meshes {
        if mesh.len() >= (u32::MAX / 2) as usize {
            return Err(BuildError::TooMany(mesh.len()));
        }
    }
    if scene.instances.len() >= (u32::MAX / 2) as usize {
        return Err(BuildError::TooMany(scene.instances.len()));
    }
    if scene.meshes.len() >= (u32::MAX / 2) as usize {
        return Err(BuildError::TooMany(scene.meshes.len()));
    }
    let mut first_triangle = Vec::with_capacity(scene.instances.len());
    let mut next = 0u64;
    for i in scene.instances.iter() {
        first_triangle.push(next);
        next += scene.meshes.get(i.mesh).map_or(0, |m| m.len()) as u64;
    }

    let start = Instant::now();
    // A hull serves only rotated or scaled instances, and pays only for a mesh placed many
    // times: its cost grows with the mesh, its gain with the instances.
    let mut turned = vec![0usize; scene.meshes.len()];
    for i in scene.instances.iter() {
        if let Some(t) = turned.get_mut(i.mesh) {
            *t += usize::from(!i.is_identity() && !i.is_translation());
        }
    }
    // The hulls are made beside the BLASes: a thread left idle by a build's serial top
    // takes a hull.
    let (blases, hulls) = rayon::join(
        || {
            (scene.meshes.par_iter().enumerate())
                .map(|(m, triangles)| {
                    build_blas(triangles, params, progress).map_err(|e| match e {
                        // Name the triangle as the flattened scene numbers it, where it is
                        // placed.
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
                .collect::<Result<Vec<_>, _>>()
        },
        || {
            (scene.meshes.par_iter().zip(&turned))
                .map(|(triangles, &turned)| {
                    let pays =
                        turned > 0 && turned * TRIANGLES_PER_HULLED_INSTANCE >= triangles.len();
                    pays.then(|| MeshHull::of(triangles)).flatten()
                })
                .collect::<Vec<Option<MeshHull>>>()
        },
    );
    let blases = blases?;
    let blas_time = start.elapsed();

    let start = Instant::now();
    let (tlas, references) = build_tlas(&blases, &hulls, &scene.instances, params)?;
    let times = LevelTimes {
        blas: blas_time,
        tlas: start.elapsed(),
    };
    progress.finish(scene.unique_triangles());
    let two_level = TwoLevel {
        top_index: TopLevelIndex::new(&tlas, references.len()),
        leaves: leaf_references(&tlas, &references, &scene.instances),
        first_reference: first_reference(&references, scene.instances.len()),
        references,
        blases,
        hulls,
        instances: scene.instances.to_vec(),
        first_triangle,
        tlas,
        order: TraversalOrder::default(),
        simd: SimdLevel::detect(),
        params: *params,
    };
    let report = two_level.report(instanced, times);
    Ok((two_level, report))
}

/// The BVH8 of one mesh: the BVH2 `params` build, collapsed, or with `direct_wide` the
/// wide tree straight from the builder's splits.
fn build_blas(
    triangles: &[Triangle],
    params: &BuildParams,
    progress: &BuildProgress,
) -> Result<Bvh8, BuildError> {
    if params.builds_direct_wide() {
        return Ok(Bvh8::direct(triangles, params, progress)?.0);
    }
    let (bvh2, _, _) = bvh::build_shape_with_progress(triangles, params, progress)?;
    let collapse = collapse_params(params, params.max_leaf_size);
    Ok(Bvh8::collapse_over(&bvh2, triangles, &collapse)?.0)
}

/// The collapse of a BVH2 built with `params` into a BVH8 with leaves of at most
/// `max_leaf_size` primitives.
fn collapse_params(params: &BuildParams, max_leaf_size: u32) -> CollapseParams {
    CollapseParams {
        c_trav: params.c_trav,
        c_isect: params.c_isect,
        max_leaf_size,
    }
}

/// How many levels of a BLAS's own boxes a reference's world box is made from: each box
/// at that depth is transformed and their union taken (`Reference::world_box`).
const WORLD_BOX_DEPTH: u32 = 2;

/// The world box of `instance` of `blas` as a whole (`hull`: its mesh's, if it has one).
pub fn instance_world_box(instance: &Instance, blas: &Bvh8, hull: Option<&MeshHull>) -> Aabb {
    rebraid::placed_box(instance, blas, hull, Subtree::ROOT)
}

/// A mesh gets a hull when it has a rotated or scaled instance for every this many of its
/// triangles: making a hull takes half a microsecond to one a triangle, on one thread
/// (14–59 ms for the island's trees of 60 000–120 000, placed 50 000 times each; 0.21 s for
/// its terrain of 295 000), while a single rotated instance of a large mesh gains one box.
const TRIANGLES_PER_HULLED_INSTANCE: usize = 1000;

/// A unique mesh's convex hull: its vertices, which place to a rotated instance's tightest
/// world box, and how far beyond it a mesh point may lie (`geometry::hull`).
#[derive(Clone, Debug)]
pub struct MeshHull {
    pub vertices: Vec<Vec3>,
    /// The vertices as columns, as they are placed.
    pub columns: hull::HullColumns,
    pub tolerance: f32,
}

impl MeshHull {
    /// The hull of `triangles`' corners; `None` for a flat mesh, or where rounding made the
    /// hull doubtful (its instances then take the box of their BLAS's boxes placed).
    pub fn of(triangles: &[Triangle]) -> Option<MeshHull> {
        let points: Vec<Vec3> = triangles.iter().flat_map(|t| t.v).collect();
        let vertices = hull::hull_vertices(&points)?;
        Some(MeshHull {
            columns: hull::HullColumns::new(&vertices),
            vertices,
            tolerance: hull::tolerance(&points),
        })
    }
}

/// For each instance, where its references start in `references` (sorted by instance),
/// and their end after the last.
fn first_reference(references: &[Reference], instances: usize) -> Vec<u32> {
    (0..=instances as u32)
        .map(|i| references.partition_point(|r| r.instance < i) as u32)
        .collect()
}

/// The references of the TLAS's leaf slots, in slot order.
fn leaf_references(
    tlas: &Bvh8,
    references: &[Reference],
    instances: &[Instance],
) -> Vec<LeafReference> {
    tlas.prim_indices
        .par_iter()
        .map(|&r| match references.get(r as usize) {
            Some(reference) => {
                LeafReference::new(reference, &instances[reference.instance as usize])
            }
            // A slot padding a leaf's block: never walked.
            None => LeafReference::UNUSED,
        })
        .collect()
}

/// The top level over the instances' references (`rebraid::references`, opened as
/// `params.rebraid` allows) and the references.
fn build_tlas(
    blases: &[Bvh8],
    hulls: &[Option<MeshHull>],
    instances: &[Instance],
    params: &BuildParams,
) -> Result<(Bvh8, Vec<Reference>), BuildError> {
    let placed = rebraid::references(blases, hulls, instances, params.rebraid);
    let boxes: Vec<Aabb> = placed.iter().map(|p| p.bounds).collect();
    let references: Vec<Reference> = placed.iter().map(|p| p.reference).collect();
    let tlas = build_top(&boxes, &references, params)?;
    Ok((tlas, references))
}

/// The top level over the world boxes `boxes` of `references`, one reference per leaf lane:
/// binned SAH's BVH2 collapsed, or with `direct_wide` the wide tree straight from the
/// builder's splits (the LBVH's Morton order: the builder for a top level rebuilt every
/// frame). The builders
/// see primitives only as boxes, so each box goes in as the triangle from its min corner to
/// its max corner, whose bounds are exactly that box. Instances of empty meshes have no
/// reference: no ray can hit them.
fn build_top(
    boxes: &[Aabb],
    references: &[Reference],
    params: &BuildParams,
) -> Result<Bvh8, BuildError> {
    let triangles: Vec<Triangle> = boxes
        .par_iter()
        .map(|b| Triangle::new(b.min, b.max, b.max))
        .collect();
    let instance_named = |e| match e {
        BuildError::NonFinite(b) => BuildError::NonFinite(references[b].instance as usize),
        e => e,
    };
    let tlas_params = BuildParams {
        max_leaf_size: 1,
        ..params.whole_references()
    };
    let mut tlas = if params.builds_direct_wide() {
        Bvh8::direct(&triangles, &tlas_params, &BuildProgress::default())
            .map_err(instance_named)?
            .0
    } else {
        let (tlas2, _) = bvh::build(&triangles, &tlas_params).map_err(instance_named)?;
        Bvh8::collapse_timed(&tlas2, &collapse_params(params, 1))?.0
    };
    tlas.blocks = Vec::new();
    Ok(tlas)
}

impl TwoLevel {
    /// Memory of both levels, the BLASes' copies of the unique triangles included.
    pub fn bytes(&self) -> usize {
        self.blases.iter().map(Bvh8::bytes).sum::<usize>()
            + self.tlas.bytes()
            + self.instances.len() * std::mem::size_of::<Instance>()
            + self.first_triangle.len() * std::mem::size_of::<u64>()
            + self.references.len() * std::mem::size_of::<Reference>()
            + self.first_reference.len() * std::mem::size_of::<u32>()
            + self.leaves.len() * std::mem::size_of::<LeafReference>()
    }

    /// The indices in `references` of instance `i`'s references.
    pub fn references_of(&self, i: usize) -> std::ops::Range<usize> {
        match (self.first_reference.get(i), self.first_reference.get(i + 1)) {
            (Some(&a), Some(&b)) => a as usize..b as usize,
            _ => 0..0,
        }
    }

    /// Places instance `i` by `transform` and updates the top level only: the meshes do
    /// not change, so neither do their BLASes (the lecture's dynamic scene: millions of
    /// triangles, but only hundreds of objects). The TLAS is refitted: the leaf boxes of
    /// the instance's references and the boxes above them (`refit`), far cheaper than
    /// sorting all references again. The references stay as they were opened.
    pub fn move_instance(&mut self, i: usize, transform: Affine3A) -> Result<(), MoveError> {
        let instance = self.instances.get_mut(i).ok_or(MoveError::NoInstance(i))?;
        let old = std::mem::replace(instance, Instance::new(instance.mesh, transform)?);
        // The new boxes of the instance's references, and where each sits in the TLAS:
        // in parallel for one opened into many, as each is a few reads far apart.
        let instance = self.instances[i];
        let moved: Vec<MovedReference> = self
            .references_of(i)
            .into_par_iter()
            .with_min_len(1024)
            .map(|r| MovedReference {
                bounds: self.references[r].world_box(&self.instances, &self.blases, &self.hulls),
                slot: self.top_index.slot_of(r),
                reference: r as u32,
                leaf_slot: self.top_index.leaf_slot_of(r).map(|k| k as u32),
            })
            .collect();
        if moved
            .iter()
            .any(|m| !(m.bounds.min.is_finite() && m.bounds.max.is_finite()))
        {
            // Moved out of range (a box beyond f32): the instance stays where it was.
            self.instances[i] = old;
            return Err(BuildError::NonFinite(i).into());
        }
        // An empty mesh's instance has no reference: the TLAS does not depend on it.
        refit::refit_references(&mut self.tlas, &self.top_index, &moved);
        // Its leaf slots carry its new inverse.
        for m in &moved {
            if let Some(k) = m.leaf_slot {
                let reference = &self.references[m.reference as usize];
                self.leaves[k as usize] = LeafReference::new(reference, &instance);
            }
        }
        Ok(())
    }

    /// Builds the top level again over the instances where they are now: the references
    /// as they were opened, each with the world box its last move gave it (the box its TLAS
    /// leaf holds), sorted anew; the BLASes stay. After moves, whose refits loosen the
    /// top level, this is its rebuild per frame; `build` opens the references anew.
    pub fn rebuild_top_level(&mut self) -> Result<(), BuildError> {
        let boxes: Vec<Aabb> = (0..self.references.len())
            .into_par_iter()
            .map(|r| match self.top_index.slot_of(r) {
                Some((node, lane)) => self.tlas.nodes[node as usize].child_bounds(lane as usize),
                None => self.references[r].world_box(&self.instances, &self.blases, &self.hulls),
            })
            .collect();
        let mut tlas = build_top(&boxes, &self.references, &self.params)?;
        tlas.order = self.order;
        // `self.simd` passed `set_simd`, so this cannot fail (and the new TLAS would keep the
        // level detected here if it did).
        let _ = tlas.set_simd(self.simd);
        self.top_index = TopLevelIndex::new(&tlas, self.references.len());
        self.leaves = leaf_references(&tlas, &self.references, &self.instances);
        self.tlas = tlas;
        Ok(())
    }

    /// Chooses the slab kernel of both levels (no rebuild); one this CPU lacks is an error
    /// and changes nothing.
    /// The slab kernel both levels run.
    pub fn simd(&self) -> SimdLevel {
        self.simd
    }

    pub fn set_simd(&mut self, level: SimdLevel) -> Result<(), UnsupportedSimd> {
        self.tlas.set_simd(level)?;
        for blas in &mut self.blases {
            blas.set_simd(level)?;
        }
        self.simd = level;
        Ok(())
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
    pub fn triangle_range(&self, i: usize) -> std::ops::Range<u64> {
        let first = self.first_triangle[i];
        let count = self
            .blases
            .get(self.instances[i].mesh)
            .map_or(0, |b| b.triangle_count as u64);
        first..first + count
    }

    /// The flattened triangles reference `r` reaches, sorted.
    pub fn reference_triangles(&self, r: usize) -> Vec<u64> {
        let reference = &self.references[r];
        let i = reference.instance as usize;
        let first = self.first_triangle[i];
        if reference.subtree == Subtree::ROOT {
            return self.triangle_range(i).collect();
        }
        self.blases[self.instances[i].mesh]
            .subtree_triangles(reference.subtree)
            .into_iter()
            .map(|t| first + t as u64)
            .collect()
    }

    /// The top level for the explorer: its nodes, each leaf referencing the flattened
    /// triangles its reference reaches; only the boxes for a scene placing more than
    /// `OUTLINE_MAX_REFS` triangles, whose list would not fit in memory.
    pub fn outline(&self) -> Outline {
        let tlas = self.tlas.outline();
        let placed: u64 = self.references.iter().map(|r| r.triangles as u64).sum();
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
                    for &r in tlas.leaf_refs(k).iter().filter(|_| listed) {
                        refs.extend(
                            self.reference_triangles(r as usize)
                                .iter()
                                .map(|&t| t as u32),
                        );
                    }
                    node.refs = (start, refs.len() as u32 - start);
                }
                node
            })
            .collect();
        Outline { nodes, refs }
    }

    /// The re-braiding budget and how much of it was used, for the report.
    fn rebraid_summary(&self) -> String {
        let f = self.params.rebraid;
        if f == 0.0 {
            return "off (one reference per instance)".into();
        }
        let whole = self
            .references
            .iter()
            .filter(|r| r.subtree == Subtree::ROOT)
            .count();
        let placed = (0..self.instances.len())
            .filter(|&i| !self.references_of(i).is_empty())
            .count();
        format!(
            "{} of {} instances opened, extra references ≤ {f} × max({placed}, {})",
            placed - whole,
            placed,
            rebraid::SMALL_SCENE
        )
    }

    /// The report after `rebuild_top_level` took `tlas`, `instanced` triangles placed:
    /// the BLASes kept as they were.
    pub fn top_level_report(&self, instanced: usize, tlas: Duration) -> StructureReport {
        let blas = Duration::ZERO;
        let mut report = self.report(instanced, LevelTimes { blas, tlas });
        for (name, value) in &mut report.details {
            if name == "BLAS builds" {
                *value = "kept".into();
            }
        }
        report
    }

    fn report(&self, instanced: usize, times: LevelTimes) -> StructureReport {
        let depth = |b: &Bvh8| b.depth;
        let blas_nodes: usize = self.blases.iter().map(|b| b.nodes.len()).sum();
        let blas_leaves: usize = self.blases.iter().map(Bvh8::leaf_count).sum();
        let tlas_leaves = self.tlas.leaf_count();
        let unique: usize = self.blases.iter().map(|b| b.triangle_count).sum();
        let largest_leaf = self
            .blases
            .iter()
            .flat_map(|b| {
                b.nodes.iter().flat_map(|n| {
                    (0..n.child_count())
                        .filter(|&l| !n.is_interior(l))
                        .map(|l| n.leaf_count(l))
                })
            })
            .max()
            .unwrap_or(0) as usize;
        StructureReport {
            structure: "two-level",
            triangles: instanced,
            build_time: times.blas + times.tlas,
            bytes: self.bytes(),
            nodes: self.tlas.nodes.len() + blas_nodes,
            leaves: tlas_leaves + blas_leaves,
            empty_leaves: 0,
            max_depth: depth(&self.tlas) + self.blases.iter().map(depth).max().unwrap_or(0),
            references: instanced,
            largest_leaf,
            details: vec![
                ("builder".into(), self.params.wide_builder_label().into()),
                ("instances".into(), Detail::count(self.instances.len())),
                (
                    "TLAS references".into(),
                    Detail::count(self.references.len()),
                ),
                ("re-braiding".into(), self.rebraid_summary().into()),
                ("unique meshes".into(), Detail::count(self.blases.len())),
                ("unique triangles".into(), Detail::count(unique)),
                ("TLAS nodes".into(), Detail::count(self.tlas.nodes.len())),
                ("BLAS nodes".into(), Detail::count(blas_nodes)),
                ("BLAS builds".into(), Detail::Time(times.blas)),
                ("TLAS build".into(), Detail::Time(times.tlas)),
                (
                    "SAH cost, both levels".into(),
                    Detail::Number(self.sah_cost(self.params.c_trav, self.params.c_isect), 3),
                ),
            ],
            caps_hit: Vec::new(),
        }
    }
}
