//! The binary bounding volume hierarchy (BVH2): a tree of boxes over the triangles, built by
//! median or SAH splits or bottom-up as an LBVH (with treelet restructuring), traversed front
//! to back, refitted after motion.

pub mod build;
pub mod node;
pub mod packet;
pub mod refit;
pub mod report;
pub mod traverse;
pub mod validate;
pub mod wide;

pub(crate) use build::build_shape_with_progress;
pub use build::{BuildError, BuildParams, Strategy, build, build_with_progress, split_costs};
pub use node::{Node, Nodes};
pub use report::{BuildReport, TreeStats};
pub use wide::{Bvh4, Bvh8, Subtree, WideBvh};

use crate::geometry::Triangle;
use rayon::prelude::*;

/// Which child a traversal visits first (the CLI's `--order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum TraversalOrder {
    /// The child whose box the ray enters first, the other pushed with its entry distance
    /// and skipped if a closer hit has been found by the time it is popped.
    #[default]
    FrontToBack,
    /// Left child first, always: the teaching baseline.
    Naive,
}

impl TraversalOrder {
    pub const ALL: [TraversalOrder; 2] = [TraversalOrder::FrontToBack, TraversalOrder::Naive];

    pub fn label(self) -> &'static str {
        match self {
            TraversalOrder::FrontToBack => "front-to-back",
            TraversalOrder::Naive => "naive",
        }
    }
}

/// A BVH2 over a copy of the scene's triangles, stored in leaf order so that a leaf's
/// triangles are contiguous in memory.
///
/// Leaves hold triangle *references*. Spatial splits (SBVH) and pre-splitting give a
/// triangle several references, each in a different leaf whose box bounds only its part of
/// the triangle; the triangle is then copied once per reference, and the hit still names it
/// by its one scene index.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// Node 0 is the root; a node's two children are adjacent and come after it.
    pub nodes: Nodes,
    /// Leaf order → scene triangle index (repeated for a triangle with several references).
    pub prim_indices: Vec<u32>,
    /// The scene's triangles in leaf order, one copy per reference.
    pub triangles: Vec<Triangle>,
    /// Distinct scene triangles the tree was built over.
    pub triangle_count: usize,
    pub order: TraversalOrder,
}

impl Bvh {
    pub fn root(&self) -> &Node {
        &self.nodes[0]
    }

    /// Tree depth of every node (root = 0); parents precede children, so one forward pass
    /// suffices.
    pub fn node_depths(&self) -> Vec<u32> {
        let mut depth = vec![0u32; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_leaf() {
                let l = n.left_first as usize;
                depth[l] = depth[i] + 1;
                depth[l + 1] = depth[i] + 1;
            }
        }
        depth
    }

    /// Parent of every node (the root's parent is `u32::MAX`).
    pub fn parents(&self) -> Vec<u32> {
        let mut parent = vec![u32::MAX; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_leaf() {
                let l = n.left_first as usize;
                parent[l] = i as u32;
                parent[l + 1] = i as u32;
            }
        }
        parent
    }

    /// Scene triangle indices under node `index`.
    pub fn triangles_under(&self, index: usize) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![index];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if n.is_leaf() {
                out.extend_from_slice(&self.prim_indices[n.prim_range()]);
            } else {
                stack.push(n.left_first as usize + 1);
                stack.push(n.left_first as usize);
            }
        }
        out
    }

    /// The SAH cost of the whole tree: the expected cost of tracing a random ray that hits
    /// the root, C = Σ_interior SA(n)/SA(root)·C_trav + Σ_leaves SA(l)/SA(root)·N_l·C_isect.
    pub fn sah_cost(&self, c_trav: f32, c_isect: f32) -> f64 {
        let root_area = self.root().bounds().surface_area() as f64;
        if root_area <= 0.0 {
            // A flat or point-like scene: every ray that hits the root hits everything.
            return c_isect as f64 * self.triangle_count as f64;
        }
        let term = |n: &Node| {
            let area = n.bounds().surface_area() as f64;
            if n.is_leaf() {
                area * n.count as f64 * c_isect as f64
            } else {
                area * c_trav as f64
            }
        };
        // In parallel, but summed in a fixed order so the same tree always costs the same.
        let parts: Vec<f64> = self
            .nodes
            .pairs()
            .par_chunks(4096)
            .map(|c| c.iter().flat_map(|p| &p.0).map(term).sum())
            .collect();
        (term(self.root()) + parts.iter().sum::<f64>()) / root_area
    }

    /// References beyond one per triangle: what spatial splits or pre-splitting duplicated.
    pub fn duplicated_references(&self) -> usize {
        self.prim_indices.len() - self.triangle_count
    }

    /// Memory used by nodes, triangles and the index map.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
            + self.triangles.len() * std::mem::size_of::<Triangle>()
            + self.prim_indices.len() * std::mem::size_of::<u32>()
    }
}

impl Bvh {
    /// The tree for the explorer: outline node i is BVH node i (parents precede children
    /// and siblings are adjacent), leaves reference scene triangles.
    pub fn outline(&self) -> crate::accel::Outline {
        let depth = self.node_depths();
        let parent = self.parents();
        let nodes = self
            .nodes
            .iter()
            .enumerate()
            .map(|(i, n)| crate::accel::OutlineNode {
                bounds: n.bounds(),
                depth: depth[i],
                parent: parent[i],
                first_child: if n.is_leaf() { 0 } else { n.left_first },
                child_count: if n.is_leaf() { 0 } else { 2 },
                refs: if n.is_leaf() {
                    (n.left_first, n.count)
                } else {
                    (0, 0)
                },
                plane: None,
            })
            .collect();
        crate::accel::Outline {
            nodes,
            refs: self.prim_indices.clone(),
        }
    }
}
