//! The sparse adaptive octree: the scene's bounds made cubical, a cell split into its eight
//! octants while it holds more than a few triangles, only the non-empty octants stored. It
//! adapts where the uniform grid cannot: the lecture's teapot in a stadium gets small cells
//! around the teapot and large ones in the empty stadium.

mod build;
mod traverse;

pub use build::{build, build_with_progress};

use super::grid::SHARED;
use super::{Outline, OutlineNode};
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use thiserror::Error;

/// The deepest `max_depth` may be: cells down to 2⁻¹⁶ of the root's side.
pub const MAX_DEPTH: u32 = 16;

/// The largest `max_leaf_size`.
pub const MAX_LEAF_SIZE: u32 = 1 << 16;

/// Splitting stops once the tree holds this many references per triangle (plus a small
/// allowance for tiny scenes): a guard against triangles much larger than the cells being
/// copied into every octant level after level.
pub const MAX_REFERENCES_PER_TRIANGLE: usize = 16;

#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    clap::Args,
    bvhlab_derive::Controls,
)]
#[serde(default)]
pub struct OctreeParams {
    /// Octree: a cell holding more triangles than this is split (1..=65536).
    #[serde(rename = "octree_max_leaf_size")]
    #[arg(id = "octree_max_leaf_size", long = "octree-max-leaf", value_name = "OCTREE_MAX_LEAF", default_value_t = OctreeParams::default().max_leaf_size, value_parser = crate::accel::params::whole_in(1, MAX_LEAF_SIZE))]
    #[param(label = "max leaf size", range = 1..=64)]
    pub max_leaf_size: u32,
    /// Octree: cells at this depth are not split (0..=16; the root is depth 0).
    #[serde(rename = "octree_max_depth")]
    #[arg(id = "octree_max_depth", long = "octree-max-depth", value_name = "OCTREE_MAX_DEPTH", default_value_t = OctreeParams::default().max_depth, value_parser = crate::accel::params::whole_in(0, MAX_DEPTH))]
    #[param(label = "max depth", range = 0..=MAX_DEPTH)]
    pub max_depth: u32,
    /// Skip triangles the ray has tested already (they are listed in every cell they
    /// overlap); the octree's `mailbox` field switches it without a rebuild.
    #[serde(skip)]
    #[arg(skip = true)]
    pub mailbox: bool,
}

impl Default for OctreeParams {
    fn default() -> Self {
        OctreeParams {
            max_leaf_size: 8,
            // Deep enough for the teapot in a 200-unit stadium (cells of 0.02 units), shallow
            // enough that the reference budget is not spent on the first dense region the
            // build reaches (measured on teapot-in-stadium and sponza).
            max_depth: 13,
            mailbox: true,
        }
    }
}

impl OctreeParams {
    pub fn validate(&self) -> Result<(), OctreeError> {
        if !(1..=MAX_LEAF_SIZE).contains(&self.max_leaf_size) {
            return Err(OctreeError::LeafSize(self.max_leaf_size));
        }
        if self.max_depth > MAX_DEPTH {
            return Err(OctreeError::Depth(self.max_depth));
        }
        Ok(())
    }
}

#[derive(Clone, Debug, Error, PartialEq)]
pub enum OctreeError {
    #[error("maximum leaf size {0} is outside 1..={MAX_LEAF_SIZE}")]
    LeafSize(u32),
    #[error("maximum depth {0} is more than {MAX_DEPTH}")]
    Depth(u32),
    #[error("triangle {0} has a NaN or infinite vertex")]
    NonFinite(usize),
    #[error("{0} triangles is more than an octree with 31-bit indices can hold")]
    TooMany(usize),
}

/// An octree node: a leaf lists `count` references from `first`; an inner node has a child
/// for each set bit of `mask` (bit o: octant o, whose bit k is set for the upper half on
/// axis k), stored in octant order from `first`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Node {
    pub first: u32,
    pub count: u32,
    pub mask: u8,
}

impl Node {
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.mask == 0
    }

    /// The node index of octant `o`'s child, if it has one.
    #[inline(always)]
    pub fn child(&self, o: u32) -> Option<u32> {
        (self.mask >> o & 1 == 1)
            .then(|| self.first + (u32::from(self.mask) & ((1 << o) - 1)).count_ones())
    }
}

/// A sparse octree over a copy of the scene's triangles.
#[derive(Clone, Debug)]
pub struct Octree {
    /// The root cube: minimum corner and side, in f64 (cells halve exactly).
    pub(crate) root_min: DVec3,
    pub(crate) root_size: f64,
    /// The root cube in f32, rounded outwards: the box of the entry test.
    pub(crate) bounds: Aabb,
    /// Node 0 is the root; children come after their parent, siblings contiguous.
    pub(crate) nodes: Vec<Node>,
    /// Leaf references, `SHARED` set on triangles listed in several leaves.
    pub(crate) refs: Vec<u32>,
    pub(crate) triangles: Vec<Triangle>,
    /// Skip triangles the ray has tested already.
    pub mailbox: bool,
}

impl Octree {
    /// Memory of the octree, triangles included.
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Octree>()
            + std::mem::size_of::<Node>() * self.nodes.len()
            + 4 * self.refs.len()
            + std::mem::size_of::<Triangle>() * self.triangles.len()
    }

    /// The root cube.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// What the app draws: every stored cell with its depth; leaves with their triangles.
    /// The indices are the octree's own (parents first, siblings contiguous).
    pub fn outline(&self) -> Outline {
        let mut cells = vec![(self.root_min, self.root_size, 0u32, u32::MAX); self.nodes.len()];
        let mut nodes = Vec::with_capacity(self.nodes.len());
        for (i, n) in self.nodes.iter().enumerate() {
            let (min, size, depth, parent) = cells[i];
            let half = size * 0.5;
            for o in 0..8 {
                if let Some(c) = n.child(o) {
                    let corner = DVec3::new(
                        f64::from(o & 1),
                        f64::from(o >> 1 & 1),
                        f64::from(o >> 2 & 1),
                    );
                    cells[c as usize] = (min + corner * half, half, depth + 1, i as u32);
                }
            }
            let leaf = n.is_leaf();
            nodes.push(OutlineNode {
                bounds: Aabb::new(min.as_vec3(), (min + size).as_vec3()),
                depth,
                parent,
                first_child: if leaf { 0 } else { n.first },
                child_count: if leaf { 0 } else { n.mask.count_ones() },
                refs: if leaf { (n.first, n.count) } else { (0, 0) },
                plane: None,
            });
        }
        Outline {
            nodes,
            refs: self.refs.iter().map(|&id| id & !SHARED).collect(),
        }
    }
}
