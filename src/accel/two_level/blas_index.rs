//! Where a BLAS holds each of its mesh's triangles, and each node's parent: what a walk
//! from one placed triangle up its levels reads (its EPO, its share of the SAH cost).

use crate::accel::bvh::Bvh8;
use crate::accel::bvh::wide::LaneKind;

/// Where a BLAS holds each of its mesh's triangles.
pub(super) struct BlasIndex {
    pub parent: Vec<u32>,
    /// `lanes[start[t]..start[t + 1]]`: the leaf lanes holding triangle t, as (node, first
    /// slot).
    start: Vec<u32>,
    lanes: Vec<(u32, u32)>,
    /// The triangles in leaf order, those no leaf holds last.
    pub order: Vec<u32>,
}

impl BlasIndex {
    pub fn of(blas: &Bvh8, triangles: usize) -> BlasIndex {
        let mut parent = vec![u32::MAX; blas.nodes.len()];
        let mut held = Vec::new();
        for (n, node) in blas.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                match node.lane_kind(lane) {
                    LaneKind::Interior(c) => parent[c as usize] = n as u32,
                    LaneKind::Leaf { first, count } => {
                        for slot in first..first + count {
                            let t = blas.prim_indices[slot as usize];
                            if (t as usize) < triangles {
                                held.push((t, n as u32, first));
                            }
                        }
                    }
                    LaneKind::Unused => {}
                }
            }
        }
        let mut start = vec![0u32; triangles + 1];
        for &(t, _, _) in &held {
            start[t as usize + 1] += 1;
        }
        for t in 0..triangles {
            start[t + 1] += start[t];
        }
        let mut next = start.clone();
        let mut lanes = vec![(0, 0); held.len()];
        let mut order = Vec::with_capacity(triangles);
        for &(t, n, first) in &held {
            let t = t as usize;
            if next[t] == start[t] {
                order.push(t as u32);
            }
            lanes[next[t] as usize] = (n, first);
            next[t] += 1;
        }
        order.extend((0..triangles as u32).filter(|&t| start[t as usize] == start[t as usize + 1]));
        BlasIndex {
            parent,
            start,
            lanes,
            order,
        }
    }

    pub fn lanes_of(&self, t: usize) -> &[(u32, u32)] {
        &self.lanes[self.start[t] as usize..self.start[t + 1] as usize]
    }
}
