//! The two levels as the explorer draws them. The top level's boxes are one tree of levels,
//! in world space, whose leaves hold instances (`TwoLevel::outline`). Below the leaf of one
//! selected instance hangs that instance's BLAS: its boxes live in the mesh's own space and
//! are drawn where the instance's transform places them, as oriented boxes (a rotated,
//! scaled or mirrored box is no longer axis-aligned in the world). Only the selected BLAS is
//! outlined, so the memory is the top level's and one mesh's, whatever the scene places.

use super::TwoLevel;
use crate::accel::Outline;
use crate::geometry::Aabb;
use glam::{Affine3A, Vec3};
use std::sync::Arc;

/// One instance's BLAS for the explorer, with what places it.
#[derive(Clone, Debug, PartialEq)]
pub struct InstanceOutline {
    pub instance: usize,
    pub mesh: usize,
    /// Object space → world space.
    pub transform: Affine3A,
    /// The top level's outline node (a leaf) that holds the instance; `None` for an
    /// instance of an empty mesh, which is in no leaf.
    pub tlas_leaf: Option<u32>,
    /// The BLAS's nodes, boxes in the mesh's own space; leaves reference the mesh's
    /// triangles (0..triangle_count).
    pub blas: Arc<Outline>,
    pub triangle_count: usize,
    /// The flattened number of the instance's first triangle: mesh triangle k is
    /// `first_triangle + k` in hits.
    pub first_triangle: u64,
}

impl InstanceOutline {
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
        let tlas_leaf = self
            .leaf_instances()
            .iter()
            .position(|&i| i == instance as u32)
            .map(|k| k as u32);
        Some(InstanceOutline {
            instance,
            mesh: placed.mesh,
            transform: placed.transform,
            tlas_leaf,
            blas: Arc::new(blas.outline()),
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

    /// For each node of `outline()`, the instance its leaf holds (`u32::MAX` for an
    /// interior node): the top level's leaves hold one instance each.
    pub fn leaf_instances(&self) -> Vec<u32> {
        let tlas = self.tlas.outline();
        (0..tlas.nodes.len())
            .map(|k| match tlas.nodes[k].is_leaf() {
                true => tlas.leaf_refs(k).first().copied().unwrap_or(u32::MAX),
                false => u32::MAX,
            })
            .collect()
    }
}
