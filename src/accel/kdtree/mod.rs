//! The SAH k-d tree: axis-aligned split planes chosen by the surface area heuristic among
//! the "perfect splits" (the bounds of each triangle clipped to the node's cell), a bonus
//! for cutting off empty space, front-to-back traversal over t intervals, and mailboxing
//! for the triangles that several cells reference.

mod build;
mod events;
mod node;
mod outline;
mod split;
mod split_costs;
mod traverse;

pub use build::{build, build_with_progress};
pub use node::KdNode;

use crate::geometry::{Aabb, Triangle};

/// How a node's split plane is searched for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum KdSplit {
    /// Every perfect-split candidate, by sorting the clipped bounds' start, end and planar
    /// events along each axis and sweeping them once (Wald & Havran 2006).
    Sweep,
    /// The boundaries between this many equal-width bins of the node's cell on each axis.
    Binned(u32),
}

impl KdSplit {
    pub fn label(self) -> String {
        match self {
            KdSplit::Sweep => "perfect splits, event sweep".to_string(),
            KdSplit::Binned(b) => format!("binned, {b} bins"),
        }
    }
}

/// Plain-data build parameters, shared by the app, the CLI and the tests. The preset keys
/// and the flags carry a `kd` prefix where the BVH has a parameter of the same name.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    serde::Serialize,
    serde::Deserialize,
    clap::Args,
    bvhlab_derive::Controls,
)]
#[serde(default)]
pub struct KdParams {
    /// k-d tree: SAH cost of a traversal step (a node and its plane distance).
    #[serde(rename = "kd_c_trav")]
    #[arg(id = "kd_c_trav", long = "kd-c-trav", value_name = "KD_C_TRAV", default_value_t = KdParams::default().c_trav)]
    #[param(label = "C_trav", range = 0.0..=10.0)]
    pub c_trav: f32,
    /// k-d tree: SAH cost of a ray–triangle test.
    #[serde(rename = "kd_c_isect")]
    #[arg(id = "kd_c_isect", long = "kd-c-isect", value_name = "KD_C_ISECT", default_value_t = KdParams::default().c_isect)]
    #[param(label = "C_isect", range = 0.05..=100.0, log)]
    pub c_isect: f32,
    /// k-d tree: a split with an empty side costs (1 − bonus) × its SAH cost, since rays
    /// skip empty space in one step (0..1).
    #[serde(rename = "kd_empty_bonus")]
    #[arg(id = "kd_empty_bonus", long = "empty-bonus", value_name = "EMPTY_BONUS", default_value_t = KdParams::default().empty_bonus)]
    #[param(label = "empty bonus", range = 0.0..=0.95)]
    pub empty_bonus: f32,
    /// k-d tree: depth bound (0 = 8 + 1.3·log2 N, as pbrt; at most 64).
    #[serde(rename = "kd_max_depth")]
    #[arg(id = "kd_max_depth", long = "kd-max-depth", value_name = "KD_MAX_DEPTH", default_value_t = KdParams::default().max_depth, value_parser = crate::accel::params::whole_in(0, MAX_DEPTH))]
    #[param(label = "depth bound (0: 8 + 1.3 log2 N)", range = 0..=MAX_DEPTH)]
    pub max_depth: u32,
    /// k-d tree: nodes with this many references or fewer become leaves.
    #[serde(rename = "kd_max_leaf_size")]
    #[arg(id = "kd_max_leaf_size", long = "kd-max-leaf", value_name = "KD_MAX_LEAF", default_value_t = KdParams::default().max_leaf_size, value_parser = crate::accel::params::whole_in(1, MAX_LEAF_SIZE))]
    #[param(label = "max leaf size", range = 1..=64)]
    pub max_leaf_size: u32,
    /// k-d tree: split candidates from B bins per axis instead of the exact event sweep
    /// (0 = the sweep).
    #[serde(rename = "kd_bins", with = "kd_bins")]
    #[arg(id = "kd_bins", long = "kd-bins", value_name = "KD_BINS", value_parser = kd_bins::parse, default_value = "0")]
    #[param(label = "perfect splits by exact event sweep", range = MIN_BINS..=MAX_BINS, log)]
    pub split: KdSplit,
    /// Traversal skips triangles the ray has tested already (a toggle, no rebuild; the
    /// structure's own `mailbox` setting is what the app and the CLI change).
    #[serde(skip)]
    #[arg(skip = true)]
    pub mailbox: bool,
    /// The build stops splitting before the leaves hold more than this many references
    /// per triangle in total.
    #[serde(skip)]
    #[arg(skip = KdParams::default().max_references_factor)]
    pub max_references_factor: f32,
}

/// The split search as the presets and the CLI spell it: a bin count, 0 for the sweep.
mod kd_bins {
    use super::KdSplit;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(split: &KdSplit, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u32(match split {
            KdSplit::Sweep => 0,
            KdSplit::Binned(b) => *b,
        })
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<KdSplit, D::Error> {
        Ok(from_bins(u32::deserialize(d)?))
    }

    fn from_bins(bins: u32) -> KdSplit {
        match bins {
            0 => KdSplit::Sweep,
            b => KdSplit::Binned(b),
        }
    }

    pub fn parse(text: &str) -> Result<KdSplit, String> {
        text.parse::<u32>()
            .map(from_bins)
            .map_err(|e| format!("'{text}' is not a bin count: {e}"))
    }
}

impl Default for KdParams {
    fn default() -> Self {
        // Measured on sponza, sibenik and conference: a triangle test costs about two
        // traversal steps here, and a larger empty bonus or leaf size made rays test more
        // triangles than the steps it saved.
        KdParams {
            c_trav: 1.0,
            c_isect: 2.0,
            empty_bonus: 0.3,
            max_depth: 0,
            max_leaf_size: 1,
            split: KdSplit::Sweep,
            mailbox: true,
            max_references_factor: 3.0,
        }
    }
}

/// Bound on any tree's depth: the build recursion and the traversal stack stay this small.
pub const MAX_DEPTH: u32 = 64;
pub const MAX_LEAF_SIZE: u32 = 4096;
pub const MIN_BINS: u32 = 2;
pub const MAX_BINS: u32 = 1024;
/// Leaves store their reference count in 30 bits; the triangle count is limited well below.
pub const MAX_TRIANGLES: usize = 1 << 28;

impl KdParams {
    pub fn validate(&self) -> Result<(), KdError> {
        for (name, value) in [("C_trav", self.c_trav), ("C_isect", self.c_isect)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(KdError::Cost { name, value });
            }
        }
        if self.c_isect == 0.0 {
            return Err(KdError::Cost {
                name: "C_isect",
                value: 0.0,
            });
        }
        if !(0.0..1.0).contains(&self.empty_bonus) {
            return Err(KdError::EmptyBonus(self.empty_bonus));
        }
        if self.max_depth > MAX_DEPTH {
            return Err(KdError::Depth(self.max_depth));
        }
        if !(1..=MAX_LEAF_SIZE).contains(&self.max_leaf_size) {
            return Err(KdError::LeafSize(self.max_leaf_size));
        }
        if let KdSplit::Binned(b) = self.split
            && !(MIN_BINS..=MAX_BINS).contains(&b)
        {
            return Err(KdError::Bins(b));
        }
        if !(self.max_references_factor.is_finite() && self.max_references_factor >= 1.0) {
            return Err(KdError::ReferencesFactor(self.max_references_factor));
        }
        Ok(())
    }

    /// The depth bound for `n` triangles.
    pub fn depth_bound(&self, n: usize) -> u32 {
        if self.max_depth != 0 {
            return self.max_depth;
        }
        let auto = 8.0 + 1.3 * (n.max(1) as f64).log2();
        (auto.round() as u32).min(MAX_DEPTH)
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum KdError {
    #[error("{name} = {value} must be {}", crate::accel::params::cost_rule(name))]
    Cost { name: &'static str, value: f32 },
    #[error("empty bonus {0} is outside [0, 1)")]
    EmptyBonus(f32),
    #[error("maximum depth {0} is more than {MAX_DEPTH} (0 chooses it from the triangle count)")]
    Depth(u32),
    #[error("maximum leaf size {0} is outside 1..={MAX_LEAF_SIZE}")]
    LeafSize(u32),
    #[error("bin count {0} is outside {MIN_BINS}..={MAX_BINS}")]
    Bins(u32),
    #[error("reference cap factor {0} must be finite and at least 1")]
    ReferencesFactor(f32),
    #[error("triangle {0} has a NaN or infinite vertex")]
    NonFinite(usize),
    #[error("{0} triangles is more than a k-d tree can hold ({MAX_TRIANGLES})")]
    TooMany(usize),
}

/// A k-d tree over a copy of the scene's triangles (indexed as in the scene).
#[derive(Clone, Debug)]
pub struct KdTree {
    /// Node 0 is the root; an interior node's below child follows it, the above child is
    /// stored in the node.
    pub nodes: Vec<KdNode>,
    /// The leaves' triangle references (scene indices), each leaf's contiguous.
    pub refs: Vec<u32>,
    pub triangles: Vec<Triangle>,
    /// The root cell: the triangles' bounds.
    pub bounds: Aabb,
    /// Skip triangles the ray has tested already; flipping it needs no rebuild.
    pub mailbox: bool,
    c_trav: f32,
    c_isect: f32,
    /// The build's depth bound: no leaf lies deeper, so a traversal stack holds at most
    /// this many cells.
    pub(crate) depth_bound: u32,
}

impl KdTree {
    /// Memory of the structure: nodes, references and the triangles.
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.nodes.len() * std::mem::size_of::<KdNode>()
            + self.refs.len() * std::mem::size_of::<u32>()
            + self.triangles.len() * std::mem::size_of::<Triangle>()
    }

    /// References in all leaves (one-triangle leaves hold theirs inline).
    pub fn references(&self) -> usize {
        self.nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.count() as usize)
            .sum()
    }
}

/// The split search as a toggle (the exact sweep) and, when binned, a slider of bins.
impl crate::accel::controls::ControlValue for KdSplit {
    fn visit(
        &mut self,
        control: &crate::accel::controls::Control,
        visitor: &mut dyn crate::accel::controls::ControlVisitor,
    ) {
        let mut sweep = *self == KdSplit::Sweep;
        visitor.flag(control, &mut sweep);
        match (sweep, &mut *self) {
            (true, _) => *self = KdSplit::Sweep,
            (false, KdSplit::Sweep) => *self = KdSplit::Binned(32),
            (false, KdSplit::Binned(bins)) => {
                let bins_control = crate::accel::controls::Control {
                    label: "bins",
                    ..control.clone()
                };
                visitor.whole(&bins_control, bins);
            }
        }
    }
}
