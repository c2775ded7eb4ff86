//! The two levels as the explorer draws them. The top level's boxes are one tree of levels,
//! in world space, whose leaves hold references (`TwoLevel::outline`). Below the leaves of
//! one selected instance hangs that instance's BLAS: its boxes live in the mesh's own space
//! and are drawn where the instance's transform places them, as oriented boxes (a rotated,
//! scaled or mirrored box is no longer axis-aligned in the world). An instance left whole
//! hangs its BLAS's root below its one leaf; one opened by re-braiding hangs each of its
//! references' subtrees below the leaf that holds it. Only the selected BLAS is outlined, so
//! the memory is the top level's and one mesh's, whatever the scene places.

use super::TwoLevel;
use crate::accel::Outline;
use crate::accel::bvh::{Bvh8, Subtree};
use crate::geometry::Aabb;
use glam::{Affine3A, Vec3};
use std::collections::HashMap;
use std::sync::Arc;

/// Where a ray crosses from the top level into the selected instance's BLAS: the top
/// level's outline leaf holding one of its references, and the BLAS outline node (the
/// reference's subtree) the walk continues at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlasEntry {
    pub tlas_leaf: u32,
    pub blas_node: u32,
}

/// One instance's BLAS for the explorer, with what places it.
#[derive(Clone, Debug, PartialEq)]
pub struct InstanceOutline {
    pub instance: usize,
    pub mesh: usize,
    /// Object space → world space.
    pub transform: Affine3A,
    /// One entry per reference of the instance, in the BLAS outline's order: a single one
    /// at the BLAS's root for an instance left whole; none for an instance of an empty
    /// mesh, which is in no leaf.
    pub entries: Vec<BlasEntry>,
    /// The BLAS's nodes, boxes in the mesh's own space; leaves reference the mesh's
    /// triangles (0..triangle_count).
    pub blas: Arc<Outline>,
    pub triangle_count: usize,
    /// The flattened number of the instance's first triangle: mesh triangle k is
    /// `first_triangle + k` in hits.
    pub first_triangle: u64,
}

impl InstanceOutline {
    /// The BLAS outline node the walk enters below top-level leaf `leaf`, if that leaf holds
    /// one of the instance's references.
    pub fn entry_below(&self, leaf: u32) -> Option<u32> {
        self.entries
            .iter()
            .find(|e| e.tlas_leaf == leaf)
            .map(|e| e.blas_node)
    }

    /// The top-level leaf above BLAS outline node `node`, if a reference enters there.
    pub fn leaf_above(&self, node: u32) -> Option<u32> {
        self.entries
            .iter()
            .find(|e| e.blas_node == node)
            .map(|e| e.tlas_leaf)
    }

    /// The first top-level leaf that holds the instance.
    pub fn first_leaf(&self) -> Option<u32> {
        self.entries.first().map(|e| e.tlas_leaf)
    }

    /// The eight corners of BLAS node `node`'s box, placed in the world (an oriented box;
    /// bit k of a corner's number picks the box's max on axis k).
    pub fn world_corners(&self, node: usize) -> [Vec3; 8] {
        let b = &self.blas.nodes[node].bounds;
        std::array::from_fn(|k| {
            let corner = Vec3::select(
                glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0),
                b.max,
                b.min,
            );
            self.transform.transform_point3(corner)
        })
    }

    /// The world box around BLAS node `node`'s placed box.
    pub fn world_bounds(&self, node: usize) -> Aabb {
        if self.blas.nodes[node].bounds.is_empty() {
            return Aabb::EMPTY;
        }
        Aabb::from_points(self.world_corners(node))
    }

    /// Whether world point `p` lies in BLAS node `node`'s placed box, up to `tolerance`
    /// of the box's size: `p` carried into the mesh's own space by the inverse transform.
    pub fn placed_box_contains(&self, node: usize, p: Vec3, tolerance: f32) -> bool {
        let b = &self.blas.nodes[node].bounds;
        let q = self.transform.inverse().transform_point3(p);
        let pad = (b.max - b.min).max_element() * tolerance;
        (q.cmpge(b.min - pad) & q.cmple(b.max + pad)).all()
    }

    /// The flattened numbers of the triangles under BLAS node `node`, sorted.
    pub fn triangles_under(&self, node: usize) -> Vec<u64> {
        self.blas
            .triangles_under(node)
            .into_iter()
            .map(|t| self.first_triangle + t as u64)
            .collect()
    }
}

impl TwoLevel {
    /// Instance `instance`'s BLAS for the explorer, with the top-level leaf it hangs
    /// below; `None` for no such instance.
    pub fn instance_outline(&self, instance: usize) -> Option<InstanceOutline> {
        let placed = self.instances.get(instance)?;
        let blas = self.blases.get(placed.mesh)?;
        let outline = blas.outline();
        let refs = self.references_of(instance);
        // The top-level leaves of the instance's references, and the BLAS outline's
        // interior nodes by wide node and leaves by first slot.
        let leaf_of: HashMap<u32, u32> = self
            .leaf_references()
            .iter()
            .enumerate()
            .filter(|(_, r)| refs.contains(&(**r as usize)))
            .map(|(k, &r)| (r, k as u32))
            .collect();
        let wide_index = blas.outline_index();
        let leaf_index: HashMap<(u32, u32), u32> = outline
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.is_leaf())
            .map(|(k, n)| (n.refs, k as u32))
            .collect();
        let mut entries: Vec<BlasEntry> = refs
            .filter_map(|r| {
                let s = self.references[r].subtree;
                Some(BlasEntry {
                    tlas_leaf: *leaf_of.get(&(r as u32))?,
                    blas_node: match s.is_leaf() {
                        true => *leaf_index.get(&(s.index(), s.count()))?,
                        false => *wide_index.get(s.index() as usize)?,
                    },
                })
            })
            .collect();
        entries.sort_by_key(|e| e.blas_node);
        Some(InstanceOutline {
            instance,
            mesh: placed.mesh,
            transform: placed.transform,
            entries,
            blas: Arc::new(outline),
            triangle_count: blas.triangle_count,
            first_triangle: self.first_triangle[instance],
        })
    }

    /// The instance that places flattened triangle `t`.
    pub fn instance_of_triangle(&self, t: u64) -> Option<usize> {
        // Instances of empty meshes share their first triangle with the next: the last
        // instance starting at or before `t` is the one that places it, if any does.
        let i = self
            .first_triangle
            .partition_point(|&f| f <= t)
            .checked_sub(1)?;
        self.triangle_range(i).contains(&t).then_some(i)
    }

    /// For each node of `outline()`, the reference its leaf holds (`u32::MAX` for an
    /// interior node): the top level's leaves hold one reference each.
    pub fn leaf_references(&self) -> Vec<u32> {
        let tlas = self.tlas.outline();
        (0..tlas.nodes.len())
            .map(|k| match tlas.nodes[k].is_leaf() {
                true => tlas.leaf_refs(k).first().copied().unwrap_or(u32::MAX),
                false => u32::MAX,
            })
            .collect()
    }

    /// For each node of `outline()`, the instance of the reference its leaf holds
    /// (`u32::MAX` for an interior node).
    pub fn leaf_instances(&self) -> Vec<u32> {
        self.leaf_references()
            .into_iter()
            .map(|r| match r {
                u32::MAX => u32::MAX,
                r => self.references[r as usize].instance,
            })
            .collect()
    }

    /// Finds, for any flattened triangle, the reference through which rays reach it.
    pub fn reference_locator(&self) -> ReferenceLocator {
        ReferenceLocator {
            blases: self.blases.iter().map(BlasParents::new).collect(),
        }
    }

    /// The reference through which rays reach flattened triangle `t` (`locator` made for
    /// this structure): the triangle's leaf in its mesh's BLAS, then up the BLAS to the
    /// first subtree the instance's references name. `None` for no such triangle.
    pub fn reference_of_triangle(&self, locator: &ReferenceLocator, t: u64) -> Option<u32> {
        let i = self.instance_of_triangle(t)?;
        let refs = self.references_of(i);
        if refs.len() == 1 {
            return Some(refs.start as u32);
        }
        let names = &self.references[refs.clone()];
        let parents = locator.blases.get(self.instances[i].mesh)?;
        let local = (t - self.first_triangle[i]) as usize;
        let (mut node, lane) = *parents.leaf_of_triangle.get(local)?;
        let blas = &self.blases[self.instances[i].mesh];
        let mut subtree = blas.nodes[node as usize].child[lane as usize];
        loop {
            // The instance's references are sorted by subtree.
            if let Ok(k) = names.binary_search_by_key(&subtree, |r| r.subtree) {
                return Some((refs.start + k) as u32);
            }
            if subtree == Subtree::ROOT {
                return None;
            }
            subtree = Subtree::node(node);
            node = parents.parent.get(node as usize).copied().unwrap_or(0);
        }
    }
}

/// Each BLAS's tree read upwards: per triangle, the leaf lane that holds it (one of them,
/// for a split one), and per node, its parent.
#[derive(Clone, Debug)]
struct BlasParents {
    leaf_of_triangle: Vec<(u32, u8)>,
    parent: Vec<u32>,
}

impl BlasParents {
    fn new(blas: &Bvh8) -> Self {
        let mut leaf_of_triangle = vec![(0u32, 0u8); blas.triangle_count];
        let mut parent = vec![0u32; blas.nodes.len()];
        for (n, node) in blas.nodes.iter().enumerate().rev() {
            for lane in 0..node.child_count() {
                match node.interior(lane) {
                    Some(c) => parent[c] = n as u32,
                    None => {
                        for &t in &blas.prim_indices[node.child[lane].slots()] {
                            leaf_of_triangle[t as usize] = (n as u32, lane as u8);
                        }
                    }
                }
            }
        }
        BlasParents {
            leaf_of_triangle,
            parent,
        }
    }
}

/// The tree of every BLAS read upwards, to find which reference reaches a triangle
/// (`TwoLevel::reference_of_triangle`): a few bytes per unique triangle, made on demand.
#[derive(Clone, Debug, Default)]
pub struct ReferenceLocator {
    blases: Vec<BlasParents>,
}
