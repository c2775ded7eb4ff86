//! What the app and the reports see of a built k-d tree: its cells with their split planes
//! as an `Outline`, its SAH cost, and the shared `StructureReport`.

use super::{KdParams, KdTree};
use crate::accel::{Outline, OutlineNode, StructureReport};
use crate::geometry::Aabb;
use std::time::Duration;

impl KdTree {
    /// Visits every node with its cell and depth, parents before children.
    fn walk(&self, mut visit: impl FnMut(usize, &Aabb, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![(0usize, self.bounds, 0u32)];
        while let Some((i, cell, depth)) = stack.pop() {
            visit(i, &cell, depth);
            let n = &self.nodes[i];
            if !n.is_leaf() {
                let (below, above) = split_cell(&cell, n.axis(), n.split());
                stack.push((n.above_child(), above, depth + 1));
                stack.push((i + 1, below, depth + 1));
            }
        }
    }

    /// The tree's SAH cost: C_trav for every interior node and C_isect for every reference
    /// in a leaf, each weighted by its cell's area relative to the root's.
    pub fn sah_cost(&self) -> f64 {
        let root_area = self.bounds.surface_area() as f64;
        if root_area <= 0.0 {
            return self.c_isect as f64 * self.references() as f64;
        }
        let mut cost = 0.0;
        self.walk(|i, cell, _| {
            let n = &self.nodes[i];
            let p = cell.surface_area() as f64 / root_area;
            cost += p * if n.is_leaf() {
                self.c_isect as f64 * n.count() as f64
            } else {
                self.c_trav as f64
            };
        });
        cost
    }

    /// Every node as the explorer draws it: its cell, and for interior nodes the split
    /// plane as a flat box spanning the cell. Children are numbered contiguously.
    pub fn outline(&self) -> Outline {
        self.numbered_outline().0
    }

    /// For each of the tree's nodes, its number in `outline()` (the replay names nodes by
    /// the tree's own numbers, the diagram by the outline's).
    pub fn outline_index(&self) -> Vec<u32> {
        let kd_index = self.numbered_outline().1;
        let mut index = vec![u32::MAX; self.nodes.len()];
        for (at, &kd) in kd_index.iter().enumerate() {
            index[kd] = at as u32;
        }
        index
    }

    /// The outline and, for each of its nodes, the tree's node it is.
    fn numbered_outline(&self) -> (Outline, Vec<usize>) {
        let mut out = Outline::default();
        if self.nodes.is_empty() {
            return (out, Vec::new());
        }
        // Breadth first, so that each pair of children gets consecutive numbers.
        let mut kd_index = vec![0usize];
        out.nodes.push(OutlineNode {
            bounds: self.bounds,
            depth: 0,
            parent: u32::MAX,
            first_child: 0,
            child_count: 0,
            refs: (0, 0),
            plane: None,
        });
        let mut i = 0;
        while i < out.nodes.len() {
            let n = self.nodes[kd_index[i]];
            let cell = out.nodes[i].bounds;
            if n.is_leaf() {
                let tris = n.leaf_refs(&self.refs);
                out.nodes[i].refs = (out.refs.len() as u32, tris.len() as u32);
                out.refs.extend_from_slice(tris);
            } else {
                let (below, above) = split_cell(&cell, n.axis(), n.split());
                let depth = out.nodes[i].depth + 1;
                let first = out.nodes.len() as u32;
                let node = &mut out.nodes[i];
                node.first_child = first;
                node.child_count = 2;
                node.plane = Some(plane_box(&cell, n.axis(), n.split()));
                for (child, bounds) in [(kd_index[i] + 1, below), (n.above_child(), above)] {
                    kd_index.push(child);
                    out.nodes.push(OutlineNode {
                        bounds,
                        depth,
                        parent: i as u32,
                        first_child: 0,
                        child_count: 0,
                        refs: (0, 0),
                        plane: None,
                    });
                }
            }
            i += 1;
        }
        (out, kd_index)
    }

    pub(super) fn report(
        &self,
        params: &KdParams,
        depth_bound: u32,
        build_time: Duration,
        caps_hit: Vec<String>,
    ) -> StructureReport {
        let (mut leaves, mut empty, mut max_depth, mut references, mut largest) = (0, 0, 0, 0, 0);
        self.walk(|i, _, depth| {
            let n = &self.nodes[i];
            if n.is_leaf() {
                let c = n.count() as usize;
                leaves += 1;
                empty += usize::from(c == 0);
                max_depth = max_depth.max(depth);
                references += c;
                largest = largest.max(c);
            }
        });
        let details = vec![
            ("split search".to_string(), params.split.label()),
            (
                "C_trav / C_isect".to_string(),
                format!("{} / {}", params.c_trav, params.c_isect),
            ),
            ("empty bonus".to_string(), format!("{}", params.empty_bonus)),
            (
                "max leaf size".to_string(),
                params.max_leaf_size.to_string(),
            ),
            ("depth bound".to_string(), depth_bound.to_string()),
            (
                "reference cap".to_string(),
                format!("{} × triangles", params.max_references_factor),
            ),
            (
                "mailbox".to_string(),
                if self.mailbox { "on" } else { "off" }.to_string(),
            ),
            ("SAH cost".to_string(), format!("{:.2}", self.sah_cost())),
        ];
        let details = details.into_iter().map(|(k, v)| (k, v.into())).collect();
        StructureReport {
            structure: "kdtree",
            triangles: self.triangles.len(),
            build_time,
            bytes: self.bytes(),
            nodes: self.nodes.len(),
            leaves,
            empty_leaves: empty,
            max_depth,
            references,
            largest_leaf: largest,
            details,
            caps_hit,
        }
    }
}

fn split_cell(cell: &Aabb, axis: usize, pos: f32) -> (Aabb, Aabb) {
    let (mut below, mut above) = (*cell, *cell);
    below.max[axis] = pos;
    above.min[axis] = pos;
    (below, above)
}

fn plane_box(cell: &Aabb, axis: usize, pos: f32) -> Aabb {
    let mut b = *cell;
    b.min[axis] = pos;
    b.max[axis] = pos;
    b
}
