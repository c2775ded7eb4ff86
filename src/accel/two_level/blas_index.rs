//! Where a BLAS holds each of its mesh's triangles, and each node's parent: what a walk
//! from one placed triangle up its levels reads (its EPO, its share of the SAH cost).

use crate::accel::bvh::Bvh8;
use crate::accel::bvh::wide::LaneKind;
use crate::accel::epo::by_triangle::ByTriangle;

/// Where a BLAS holds each of its mesh's triangles.
pub(super) struct BlasIndex {
    pub parent: Vec<u32>,
    /// Per triangle, the leaf lanes holding it as (node, first slot), and the triangles in
    /// leaf order.
    pub lanes: ByTriangle<(u32, u32)>,
}

impl BlasIndex {
    pub fn of(blas: &Bvh8, triangles: usize) -> BlasIndex {
        let mut parent = vec![u32::MAX; blas.nodes.len()];
        let mut held = Vec::new();
        for (n, node) in blas.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                match node.lane_kind(lane) {
                    LaneKind::Interior(c) => parent[c as usize] = n as u32,
                    LaneKind::Leaf { first, count } => held.extend(
                        (first..first + count)
                            .map(|slot| (blas.prim_indices[slot as usize], (n as u32, first))),
                    ),
                    LaneKind::Unused => {}
                }
            }
        }
        BlasIndex {
            parent,
            lanes: ByTriangle::of(triangles, || held.iter().copied()),
        }
    }

    pub fn lanes_of(&self, t: usize) -> &[(u32, u32)] {
        self.lanes.of_triangle(t)
    }
}
