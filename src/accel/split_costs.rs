//! What the bucket-cost plot draws for one node of any structure that chooses its splits
//! by the SAH: every candidate plane the builder weighs, its cost, and the leaf's cost.

use crate::geometry::Aabb;

/// How the candidates were found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitMethod {
    /// The B − 1 bucket boundaries per axis of binned SAH.
    Binned { buckets: u32 },
    /// Every position between sorted centroids, N − 1 per axis.
    Sweep,
    /// A k-d tree's perfect splits: every clipped triangle bound, on each axis.
    KdPerfect,
    /// A k-d tree's bin boundaries, bins − 1 per axis.
    KdBinned { bins: u32 },
}

impl SplitMethod {
    /// What the candidates are, for the plot's caption.
    pub fn describe(self, triangles: usize) -> String {
        match self {
            SplitMethod::Binned { buckets } => {
                format!(
                    "{} bucket boundaries per axis (binned SAH, B = {buckets})",
                    buckets - 1
                )
            }
            SplitMethod::Sweep => format!(
                "all {} positions per axis (full-sweep SAH)",
                triangles.saturating_sub(1)
            ),
            SplitMethod::KdPerfect => "every clipped triangle bound (perfect splits)".into(),
            SplitMethod::KdBinned { bins } => format!("{} bin boundaries per axis", bins - 1),
        }
    }
}

/// One candidate split plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitCandidate {
    pub axis: usize,
    /// The plane's position along `axis`, in world units.
    pub position: f32,
    /// C_trav + Σ S_child/S_N·N_child·C_isect (for a k-d tree, with the empty-space bonus
    /// where a side is empty).
    pub cost: f32,
    /// Triangles on each side.
    pub left: u32,
    pub right: u32,
}

/// The candidates of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitCosts {
    pub method: SplitMethod,
    pub triangles: usize,
    /// The node's box (a BVH node: the bounds of its triangles; a k-d node: its cell).
    pub bounds: Aabb,
    /// In the order the builder offers them.
    pub candidates: Vec<SplitCandidate>,
    /// C_isect·N: what the node costs as a leaf.
    pub leaf_cost: f32,
    /// The split the builder takes: the first of the cheapest candidates (a binned boundary
    /// after an empty bucket repeats the one before and is not taken).
    pub cheapest: Option<SplitCandidate>,
}

impl SplitCosts {
    /// Whether the cheapest split costs less than a leaf.
    pub fn split_pays(&self) -> bool {
        self.cheapest.is_some_and(|c| c.cost < self.leaf_cost)
    }
}
