//! Refit after motion: keep the tree's topology, recompute every box bottom-up. O(nodes),
//! far cheaper than a rebuild, and exact — but the boxes of a tree built for the old
//! positions may now overlap more, which the SAH cost before and after shows.

use super::Bvh;
use crate::geometry::{Aabb, Triangle};

/// SAH cost of the tree before and after a refit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefitReport {
    pub sah_before: f64,
    pub sah_after: f64,
}

/// A refit keeps the topology, so it needs exactly the triangles the tree was built over.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("refit needs the {built} triangles the tree was built over, got {given}: rebuild instead")]
pub struct RefitError {
    pub built: usize,
    pub given: usize,
}

impl Bvh {
    /// Takes the moved triangles (`scene` in scene order, the same count as at build time)
    /// and updates every box. Children come after their parents in `nodes`, so one pass from
    /// the back sees both children of a node before the node itself.
    pub fn refit(
        &mut self,
        scene: &[Triangle],
        c_trav: f32,
        c_isect: f32,
    ) -> Result<RefitReport, RefitError> {
        if scene.len() != self.triangles.len() {
            return Err(RefitError {
                built: self.triangles.len(),
                given: scene.len(),
            });
        }
        let sah_before = self.sah_cost(c_trav, c_isect);
        for (dst, &src) in self.triangles.iter_mut().zip(&self.prim_indices) {
            *dst = scene[src as usize];
        }
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let bounds = if node.is_leaf() {
                self.triangles[node.prim_range()]
                    .iter()
                    .fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
            } else {
                let l = node.left_first as usize;
                self.nodes[l].bounds().union(self.nodes[l + 1].bounds())
            };
            self.nodes[i].set_bounds(bounds);
        }
        Ok(RefitReport {
            sah_before,
            sah_after: self.sah_cost(c_trav, c_isect),
        })
    }
}
