//! BVH construction: a pure function of (triangles, parameters) → tree + build report.
//!
//! Every strategy runs the same top-down recursion: compute the node's bounds, ask the
//! strategy where to split (or whether to stop), partition the primitives in place, recurse.
//! The strategies differ only in the split they choose:
//! - object median: equal counts on both sides, along the widest axis of the centroids;
//! - spatial median: the midpoint of the centroid bounds;
//! - full-sweep SAH: every position between sorted centroids, on all three axes;
//! - binned SAH: the boundaries between B equal-width buckets, on all three axes.
//!
//! LBVH (`lbvh`) builds bottom-up instead, from primitives sorted along a Morton curve, and
//! treelet restructuring (`treelet`) then improves that tree's SAH cost locally.
//!
//! The SBVH (`sbvh`) adds spatial splits to the binned SAH: a triangle's reference may be
//! cut in two, each part bounded by the triangle clipped to its side. Pre-splitting
//! (`presplit`) cuts the largest triangles' references before LBVH or binned SAH sees them.
//!
//! Primitives are represented by their bounding boxes; "centroid" means the centre of a
//! primitive's box, as in pbrt and Embree.

mod lbvh;
pub mod linked_tree;
mod median;
mod partitions;
pub mod presplit;
mod prim;
mod radix_sort;
mod sah_binned;
mod sah_sweep;
mod sbvh;
pub mod split_costs;
mod subset_terms;
pub mod treelet;

pub(crate) use lbvh::triangle_codes_into;
pub(crate) use prim::{NodeInfo, PrimRef, Split};
pub(crate) use radix_sort::sort_from_with as radix_sort_from_with;
pub use split_costs::split_costs;

use super::node::{Node, Nodes};
use super::report::{BuildPhases, BuildReport};
use super::{Bvh, TraversalOrder};
use crate::accel::progress::BuildProgress;
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;
use sah_binned::Scratch;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A BVH builder: the split strategy of the top-down builders, or a bottom-up one. The
/// CLI's `--builder` and the presets' `strategy` name it.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
pub enum Strategy {
    /// Equal counts on both sides, along the widest axis of the centroids.
    ObjectMedian,
    /// The midpoint of the centroid bounds.
    SpatialMedian,
    /// The SAH at every position between sorted centroids, on all three axes.
    SahSweep,
    /// The SAH at the boundaries of B equal-width buckets, on all three axes (--buckets).
    #[default]
    SahBinned,
    /// Karras 2012: Morton codes, radix sort, radix tree; leaves collapsed by the SAH.
    Lbvh,
    /// LBVH then Karras–Aila treelet restructuring (--treelet-size, --rounds).
    LbvhTreelet,
    /// Binned SAH with spatial splits, Stich et al. 2009 (--split-alpha, --split-budget).
    Sbvh,
}

impl Strategy {
    pub const ALL: [Strategy; 7] = [
        Strategy::ObjectMedian,
        Strategy::SpatialMedian,
        Strategy::SahSweep,
        Strategy::SahBinned,
        Strategy::Lbvh,
        Strategy::LbvhTreelet,
        Strategy::Sbvh,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Strategy::ObjectMedian => "object median",
            Strategy::SpatialMedian => "spatial median",
            Strategy::SahSweep => "full-sweep SAH",
            Strategy::SahBinned => "binned SAH",
            Strategy::Lbvh => "LBVH",
            Strategy::LbvhTreelet => "LBVH + treelets",
            Strategy::Sbvh => "SBVH",
        }
    }

    /// Whether `presplit` applies: the builders that cannot split references themselves.
    pub fn takes_presplit(self) -> bool {
        matches!(
            self,
            Strategy::Lbvh | Strategy::LbvhTreelet | Strategy::SahBinned
        )
    }
}

/// Plain-data build parameters, shared by the app, the CLI and the tests. The field is the
/// preset key; the flag is `--` and the field in kebab case unless named below.
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
pub struct BuildParams {
    /// The builder: split strategy.
    #[arg(long = "builder", value_name = "BUILDER", value_enum, default_value_t = BuildParams::default().strategy)]
    #[param(label = "split strategy")]
    pub strategy: Strategy,
    /// Bucket count B for binned SAH and the SBVH (2..=256).
    #[arg(long, default_value_t = BuildParams::default().buckets, value_parser = crate::accel::params::whole_in(MIN_BUCKETS, MAX_BUCKETS))]
    #[param(label = "buckets B", range = MIN_BUCKETS..=MAX_BUCKETS, log, when = Self::uses_buckets)]
    pub buckets: u32,
    /// Maximum number of triangles in a leaf (1..=4096).
    #[arg(long = "max-leaf", value_name = "MAX_LEAF", default_value_t = BuildParams::default().max_leaf_size, value_parser = crate::accel::params::whole_in(1, MAX_LEAF_SIZE))]
    #[param(label = "max leaf size", range = 1..=64)]
    pub max_leaf_size: u32,
    /// SAH cost of a traversal step (a node visit with its box tests).
    #[arg(long, default_value_t = BuildParams::default().c_trav, allow_negative_numbers = true)]
    #[param(label = "C_trav", range = 0.0..=10.0)]
    pub c_trav: f32,
    /// SAH cost of a ray–triangle test.
    #[arg(long, default_value_t = BuildParams::default().c_isect, allow_negative_numbers = true)]
    #[param(label = "C_isect", range = 0.05..=10.0)]
    pub c_isect: f32,
    /// lbvh-treelet: leaves n of a treelet (5..=9).
    #[arg(long, default_value_t = BuildParams::default().treelet_size)]
    #[param(label = "treelet size n", range = MIN_TREELET_SIZE..=MAX_TREELET_SIZE, when = Self::uses_treelets)]
    pub treelet_size: u32,
    /// lbvh-treelet: rounds of treelet restructuring (0..=16).
    #[arg(long = "rounds", value_name = "ROUNDS", default_value_t = BuildParams::default().treelet_rounds)]
    #[param(label = "treelet rounds", range = 0..=MAX_TREELET_ROUNDS, when = Self::uses_treelets)]
    pub treelet_rounds: u32,
    /// sbvh: try spatial splits where the object split's children overlap by more than this
    /// fraction of the root's surface area, the overlap threshold α (0..=1).
    #[arg(long, default_value_t = BuildParams::default().split_alpha, allow_negative_numbers = true)]
    #[param(label = "overlap threshold α", range = 1e-8..=1.0, log, when = Self::uses_spatial_splits)]
    pub split_alpha: f32,
    /// sbvh: the overlap penalty κ. Weighed against a spatial split, an object split costs
    /// its SAH cost × (1 + κ · its children's overlap area / the node's area), for the rays
    /// that front-to-back order cannot stop early in that overlap (0..=16; 0 = the plain
    /// SAH).
    #[arg(long, default_value_t = BuildParams::default().overlap_penalty, allow_negative_numbers = true)]
    #[param(label = "overlap penalty κ", range = 0.0..=MAX_OVERLAP_PENALTY, when = Self::uses_spatial_splits)]
    pub overlap_penalty: f32,
    /// sbvh: at most this many duplicated references, as a fraction of the triangle count
    /// (0..=16).
    #[arg(long, default_value_t = BuildParams::default().split_budget, allow_negative_numbers = true)]
    #[param(label = "split budget × N", range = 0.0..=MAX_SPLIT_BUDGET, when = Self::uses_spatial_splits)]
    pub split_budget: f32,
    /// lbvh, lbvh-treelet, sah-binned: pre-split the triangles that waste most box area
    /// (cut along the Morton grid), adding at most this many references as a fraction of
    /// the triangle count (0..=16; 0 = off).
    #[arg(long, default_value_t = BuildParams::default().presplit, allow_negative_numbers = true)]
    #[param(label = "pre-split budget × N", range = 0.0..=MAX_SPLIT_BUDGET, when = Self::takes_presplit)]
    pub presplit: f32,
    /// lbvh and sah-binned, as BVH4, BVH8 or two levels: make the wide nodes straight from
    /// the builder's splits, with no BVH2 in between. For the LBVH, the radix tree's splits
    /// grouped W to a node with leaves of at most four triangles (or --max-leaf, if fewer):
    /// about three times as fast as its BVH2 collapsed, for scenes rebuilt every frame, at
    /// a higher SAH cost. For binned SAH, its splits grouped W to a node as they are made:
    /// a faster build with the BVH2's leaves, at a slightly higher SAH cost than the
    /// collapse's. Under two levels, both the BLASes and the top level. Pre-splitting does
    /// not apply to it.
    #[arg(long, default_value_t = BuildParams::default().direct_wide, action = clap::ArgAction::Set)]
    #[param(label = "wide nodes straight from the splits (no BVH2)", when = Self::takes_direct_wide, scope = "wide")]
    pub direct_wide: bool,
    /// two-level: partial re-braiding; the top level may open large instances into
    /// references to their BLAS's subtrees, largest first, up to this many extra references
    /// per instance, counting at least 40 960 instances (0..=16; 0 = one reference per
    /// instance).
    // How: `two_level::rebraid`.
    #[arg(long, default_value_t = BuildParams::default().rebraid, allow_negative_numbers = true)]
    #[param(label = "re-braiding budget per instance", range = 0.0..=MAX_REBRAID, log, scope = "two-level")]
    pub rebraid: f32,
}

impl BuildParams {
    /// Whether the builder bins by B buckets (binned SAH, SBVH).
    pub fn uses_buckets(&self) -> bool {
        matches!(self.strategy, Strategy::SahBinned | Strategy::Sbvh)
    }

    /// Whether the builder restructures treelets.
    pub fn uses_treelets(&self) -> bool {
        self.strategy == Strategy::LbvhTreelet
    }

    /// Whether the builder tries spatial splits.
    pub fn uses_spatial_splits(&self) -> bool {
        self.strategy == Strategy::Sbvh
    }

    /// Whether `direct_wide` applies: the LBVH's and binned SAH's wide trees.
    pub fn takes_direct_wide(&self) -> bool {
        matches!(self.strategy, Strategy::Lbvh | Strategy::SahBinned)
    }

    /// Whether the wide trees are built straight from the builder's splits, with no BVH2
    /// (`direct_wide`).
    pub fn builds_direct_wide(&self) -> bool {
        self.direct_wide && self.takes_direct_wide()
    }

    /// Whether the wide trees are built straight from the Morton order: the build a scene
    /// rebuilt every frame uses (`WideBvh::rebuild_morton`).
    pub fn builds_morton_wide(&self) -> bool {
        self.builds_direct_wide() && self.strategy == Strategy::Lbvh
    }

    /// The leaf size of a wide tree built straight from the Morton order: `max_leaf_size`
    /// within one block of triangles.
    pub fn direct_wide_leaf_size(&self) -> u32 {
        self.max_leaf_size.min(crate::geometry::simd::BLOCK as u32)
    }

    /// The builder of the wide trees, as build reports name it.
    pub fn wide_builder_label(&self) -> &'static str {
        if !self.builds_direct_wide() {
            self.strategy.label()
        } else if self.strategy == Strategy::Lbvh {
            "LBVH, wide nodes straight from the Morton order"
        } else {
            "binned SAH, wide nodes straight from its splits"
        }
    }

    /// The keys of the controls that the wide trees' own setting switches off where it
    /// applies (BVH4, BVH8, the two levels): the pre-split budget when the wide nodes come
    /// straight from the splits, which split no reference (the build refuses it,
    /// `BuildError::PresplitDirectWide`). `presplit`'s own rule cannot say so: a BVH2 of
    /// the same parameters takes it.
    pub fn off_when_wide(&self) -> &'static [&'static str] {
        if self.builds_direct_wide() {
            &["presplit"]
        } else {
            &[]
        }
    }

    /// Whether `presplit` applies (see `Strategy::takes_presplit`).
    pub fn takes_presplit(&self) -> bool {
        self.strategy.takes_presplit()
    }
}

impl crate::accel::controls::ControlValue for Strategy {
    fn visit(
        &mut self,
        control: &crate::accel::controls::Control,
        visitor: &mut dyn crate::accel::controls::ControlVisitor,
    ) {
        let label = |s: Strategy| match s {
            Strategy::Sbvh => "SBVH (spatial splits)",
            s => s.label(),
        };
        crate::accel::controls::choose(self, &Strategy::ALL, label, control, visitor);
    }
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            strategy: Strategy::SahBinned,
            buckets: 16,
            max_leaf_size: 8,
            c_trav: 1.0,
            c_isect: 1.0,
            treelet_size: 7,
            treelet_rounds: 3,
            split_alpha: 1e-5,
            overlap_penalty: 0.0,
            split_budget: 1.0,
            presplit: 0.0,
            direct_wide: false,
            rebraid: DEFAULT_REBRAID,
        }
    }
}

pub const MIN_BUCKETS: u32 = 2;
pub const MAX_BUCKETS: u32 = 256;
pub const MAX_LEAF_SIZE: u32 = 4096;
pub const MIN_TREELET_SIZE: u32 = treelet::MIN_TREELET as u32;
pub const MAX_TREELET_SIZE: u32 = treelet::MAX_TREELET as u32;
/// More rounds change nothing: each round only roots treelets at subtrees of at least
/// n·2^round primitives.
pub const MAX_TREELET_ROUNDS: u32 = 16;
/// Budgets for duplicated references (SBVH) and pre-splits, as fractions of the triangle
/// count: at most this many times more references than triangles, beyond the first.
pub const MAX_SPLIT_BUDGET: f32 = 16.0;
/// The largest overlap penalty κ the SBVH accepts.
pub const MAX_OVERLAP_PENALTY: f32 = 16.0;
/// The two levels' re-braiding budget by default, and at most (extra references per
/// instance; `two_level::rebraid::SMALL_SCENE` says why a tenth).
pub const DEFAULT_REBRAID: f32 = 0.1;
pub const MAX_REBRAID: f32 = 16.0;

impl BuildParams {
    pub fn with_strategy(strategy: Strategy) -> Self {
        BuildParams {
            strategy,
            ..Default::default()
        }
    }

    /// The same parameters with references kept whole (no spatial splits, no pre-splits):
    /// for primitives that are boxes rather than triangles, such as the top level's
    /// instances. The SBVH becomes the binned SAH it extends.
    pub fn whole_references(&self) -> Self {
        BuildParams {
            strategy: match self.strategy {
                Strategy::Sbvh => Strategy::SahBinned,
                s => s,
            },
            presplit: 0.0,
            ..*self
        }
    }

    pub fn validate(&self) -> Result<(), BuildError> {
        if !(MIN_BUCKETS..=MAX_BUCKETS).contains(&self.buckets) {
            return Err(BuildError::Buckets(self.buckets));
        }
        if !(1..=MAX_LEAF_SIZE).contains(&self.max_leaf_size) {
            return Err(BuildError::LeafSize(self.max_leaf_size));
        }
        if !(MIN_TREELET_SIZE..=MAX_TREELET_SIZE).contains(&self.treelet_size) {
            return Err(BuildError::TreeletSize(self.treelet_size));
        }
        if self.treelet_rounds > MAX_TREELET_ROUNDS {
            return Err(BuildError::TreeletRounds(self.treelet_rounds));
        }
        for (name, value, max) in [
            ("split budget", self.split_budget, MAX_SPLIT_BUDGET),
            ("presplit budget", self.presplit, MAX_SPLIT_BUDGET),
            ("re-braiding budget", self.rebraid, MAX_REBRAID),
            ("overlap threshold α", self.split_alpha, 1.0),
            (
                "overlap penalty κ",
                self.overlap_penalty,
                MAX_OVERLAP_PENALTY,
            ),
        ] {
            if !(0.0..=max).contains(&value) {
                return Err(BuildError::Fraction { name, value, max });
            }
        }
        for (name, value) in [("C_trav", self.c_trav), ("C_isect", self.c_isect)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(BuildError::Cost { name, value });
            }
        }
        if self.c_isect == 0.0 {
            return Err(BuildError::Cost {
                name: "C_isect",
                value: 0.0,
            });
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum BuildError {
    #[error("bucket count {0} is outside {MIN_BUCKETS}..={MAX_BUCKETS}")]
    Buckets(u32),
    #[error("maximum leaf size {0} is outside 1..={MAX_LEAF_SIZE}")]
    LeafSize(u32),
    #[error("treelet size {0} is outside {MIN_TREELET_SIZE}..={MAX_TREELET_SIZE} leaves")]
    TreeletSize(u32),
    #[error("{0} treelet rounds is more than {MAX_TREELET_ROUNDS}")]
    TreeletRounds(u32),
    #[error("{name} {value} is outside 0..={max}")]
    Fraction {
        name: &'static str,
        value: f32,
        max: f32,
    },
    #[error("{name} = {value} must be {}", crate::accel::params::cost_rule(name))]
    Cost { name: &'static str, value: f32 },
    #[error(
        "the pre-split budget (--presplit) must be 0 for wide nodes built straight from the splits (--direct-wide), which split no reference"
    )]
    PresplitDirectWide,
    #[error("triangle {0} has a NaN or infinite vertex")]
    NonFinite(usize),
    #[error("{0} triangles is more than a BVH with 32-bit indices can hold")]
    TooMany(usize),
    #[error(
        "{0} triangle references is more than a wide BVH's lanes can address (at most {max})",
        max = crate::accel::bvh::wide::collapse::MAX_REFERENCES
    )]
    TooManyForWide(usize),
}

/// Beyond this depth every strategy splits at the object median, which halves the count:
/// the tree stays shallower than `MAX_DEPTH` whatever the input, so neither the build's
/// recursion nor a traversal stack can overflow.
const MEDIAN_FALLBACK_DEPTH: u32 = 64;
/// An upper bound on the depth of any tree `build` returns.
pub const MAX_DEPTH: usize = MEDIAN_FALLBACK_DEPTH as usize + 33;
/// Subtrees with at least this many primitives are built in parallel.
const PARALLEL_SUBTREE: usize = 4096;
/// Passes over at least this many primitives are split across threads.
pub(crate) const PARALLEL_PASS: usize = 32 * 1024;

/// The time the splits near the root spent binning and partitioning: nodes of at least
/// `PARALLEL_PASS` primitives, whose passes run on all threads. Summed over those nodes
/// (two of them may run at once, one per thread).
#[derive(Default)]
pub struct TopSplitClock {
    binning_ns: AtomicU64,
    partition_ns: AtomicU64,
    /// Nodes whose binning was timed.
    nodes: AtomicU64,
}

impl TopSplitClock {
    pub fn add_binning(&self, t: Duration) {
        self.binning_ns
            .fetch_add(t.as_nanos() as u64, Ordering::Relaxed);
        self.nodes.fetch_add(1, Ordering::Relaxed);
    }

    pub fn add_partition(&self, t: Duration) {
        self.partition_ns
            .fetch_add(t.as_nanos() as u64, Ordering::Relaxed);
    }

    /// Both times, as the build report's phases; none for a tree with no node that large
    /// (a phase of 0.00 ms would read as a broken timer).
    pub fn add_phases(&self, phases: &mut BuildPhases) {
        if self.nodes.load(Ordering::Relaxed) == 0 {
            return;
        }
        let read = |a: &AtomicU64| Duration::from_nanos(a.load(Ordering::Relaxed));
        phases.add("binning near the root", read(&self.binning_ns));
        phases.add("partition near the root", read(&self.partition_ns));
    }
}

/// Builds a BVH over `triangles`. Triangle indices in hits are indices into `triangles`.
pub fn build(
    triangles: &[Triangle],
    params: &BuildParams,
) -> Result<(Bvh, BuildReport), BuildError> {
    build_with_progress(triangles, params, &BuildProgress::default())
}

/// `build`, counting into `progress` the triangles already placed in finished subtrees, so
/// another thread can show how far a long build is; an abandoned build halves the rest
/// by count instead of searching for splits.
pub fn build_with_progress(
    triangles: &[Triangle],
    params: &BuildParams,
    progress: &BuildProgress,
) -> Result<(Bvh, BuildReport), BuildError> {
    let (bvh, phases, build_time) = build_tree_of(triangles, params, progress, LeafCopy::Made)?;
    let mut report = BuildReport::new(&bvh, params, build_time);
    report.phases = phases;
    Ok((bvh, report))
}

/// `build_with_progress` for a BVH2 made only to be collapsed into a wide tree: its
/// triangles are not copied into leaf order (`Bvh::triangles` is left empty, and
/// `WideBvh::collapse_over` reads the scene's through `prim_indices` as it packs its
/// blocks), and no report is made of it; its phases and time are returned instead. The
/// copy was a 2.2 ms phase of conference's 62 ms BVH8 build and 12 MB of fresh memory;
/// without it the build takes about 2 % less (docs/wide-bvh.md).
pub(crate) fn build_shape_with_progress(
    triangles: &[Triangle],
    params: &BuildParams,
    progress: &BuildProgress,
) -> Result<(Bvh, BuildPhases, Duration), BuildError> {
    build_tree_of(triangles, params, progress, LeafCopy::Skipped)
}

/// Whether a build copies the triangles into leaf order (`Bvh::triangles`).
#[derive(Clone, Copy, PartialEq, Eq)]
enum LeafCopy {
    Made,
    Skipped,
}

/// The build of `build_with_progress`: the tree, its phases and its time.
fn build_tree_of(
    triangles: &[Triangle],
    params: &BuildParams,
    progress: &BuildProgress,
    copy: LeafCopy,
) -> Result<(Bvh, BuildPhases, Duration), BuildError> {
    params.validate()?;
    if triangles.len() >= (u32::MAX / 2) as usize {
        return Err(BuildError::TooMany(triangles.len()));
    }
    if let Some(i) = triangles.par_iter().position_any(|t| !t.is_finite()) {
        return Err(BuildError::NonFinite(i));
    }
    let start = Instant::now();
    let mut phases = BuildPhases::default();
    let presplit = params.presplit > 0.0 && params.strategy.takes_presplit();
    let refs = if presplit {
        let refs = presplit::references(triangles, params.presplit);
        phases.add("pre-splitting", start.elapsed());
        refs
    } else {
        let refs = whole_references(triangles);
        phases.add("references", start.elapsed());
        refs
    };
    let bvh = match params.strategy {
        Strategy::Lbvh | Strategy::LbvhTreelet if !triangles.is_empty() => {
            let (nodes, prim_indices, lbvh_phases) = lbvh::build(&refs, params);
            phases.times.extend(lbvh_phases.times);
            phases.sah_before_rounds = lbvh_phases.sah_before_rounds;
            phases.sah_after_round = lbvh_phases.sah_after_round;
            progress.add(triangles.len());
            in_leaf_order(triangles, nodes, prim_indices, copy)
        }
        Strategy::Sbvh if !triangles.is_empty() => {
            // The same phases as the other top-down builds, so that a slow SBVH build shows
            // where its time went (the clipping happens in the recursion).
            let recursion = Instant::now();
            let tree = sbvh::build(triangles, params, progress);
            phases.add("splits (whole recursion)", recursion.elapsed());
            progress.add(triangles.len());
            phases.spatial_splits = Some((tree.spatial_splits, tree.unsplit));
            let leaf_order = Instant::now();
            let bvh = in_leaf_order(triangles, Nodes::from_flat(&tree.nodes), tree.prims, copy);
            if copy == LeafCopy::Made {
                phases.add("leaf order", leaf_order.elapsed());
            }
            bvh
        }
        _ => build_tree(triangles, refs, params, progress, &mut phases, copy),
    };
    // Two pieces of a pre-split triangle may share a leaf: one test of it is enough.
    let bvh = if presplit {
        without_repeats_in_leaves(bvh)
    } else {
        bvh
    };
    Ok((bvh, phases, start.elapsed()))
}

/// One reference per triangle: its whole box.
pub(crate) fn whole_references(triangles: &[Triangle]) -> Vec<PrimRef> {
    triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| PrimRef::new(t.bounds(), i as u32))
        .collect()
}

/// The BVH over `nodes` with the triangles copied into leaf order (unless `copy` says not).
fn in_leaf_order(
    triangles: &[Triangle],
    nodes: Nodes,
    prim_indices: Vec<u32>,
    copy: LeafCopy,
) -> Bvh {
    let leaf_triangles = match copy {
        LeafCopy::Made => prim_indices
            .par_iter()
            .map(|&i| triangles[i as usize])
            .collect(),
        LeafCopy::Skipped => Vec::new(),
    };
    Bvh {
        nodes,
        prim_indices,
        triangles: leaf_triangles,
        triangle_count: triangles.len(),
        order: TraversalOrder::default(),
    }
}

/// `bvh` with each leaf holding a triangle at most once (the leaf's box already bounds all
/// the pieces it had of it). Leaves keep their boxes; the leaf order is compacted.
fn without_repeats_in_leaves(mut bvh: Bvh) -> Bvh {
    let mut prim_indices = Vec::with_capacity(bvh.prim_indices.len());
    let mut triangles = Vec::with_capacity(bvh.triangles.len());
    for i in 0..bvh.nodes.len() {
        let node = bvh.nodes[i];
        if !node.is_leaf() {
            continue;
        }
        let first = prim_indices.len();
        for k in node.prim_range() {
            let t = bvh.prim_indices[k];
            if !prim_indices[first..].contains(&t) {
                prim_indices.push(t);
                // (No copy to compact in a tree built without one.)
                if let Some(&tri) = bvh.triangles.get(k) {
                    triangles.push(tri);
                }
            }
        }
        bvh.nodes[i] = Node::leaf(
            node.bounds(),
            first as u32,
            (prim_indices.len() - first) as u32,
        );
    }
    bvh.prim_indices = prim_indices;
    bvh.triangles = triangles;
    bvh
}

/// The top-down build: a recursion of splits, both children of a large node built as
/// parallel tasks. Its phases: the splits near the root (binning and partition, whose
/// passes use every thread), the whole recursion, and the copy into leaf order.
fn build_tree(
    triangles: &[Triangle],
    mut refs: Vec<PrimRef>,
    params: &BuildParams,
    progress: &BuildProgress,
    phases: &mut BuildPhases,
    copy: LeafCopy,
) -> Bvh {
    let n = refs.len();
    let clock = TopSplitClock::default();
    let start = Instant::now();
    let nodes = if n == 0 {
        Nodes::from_flat(&[Node::leaf(Aabb::EMPTY, 0, 0)])
    } else {
        // A subtree over n primitives has at most 2n − 2 descendants. Giving each subtree a
        // fixed slice of that size lets both halves be built in parallel into disjoint
        // slices of one array; `compact` then squeezes out the slots leaves did not use.
        // Filled on every thread: the first touch of its pages is a large part of its cost.
        let mut slots = Vec::with_capacity(2 * n - 1);
        slots.par_extend(rayon::iter::repeat_n(Node::default(), 2 * n - 1));
        let builder = Builder {
            params,
            progress,
            clock: &clock,
        };
        let info = NodeInfo::of(&refs);
        let root = builder.subtree(&mut refs, 0, 0, info, &mut slots[1..], 1);
        slots[0] = root;
        if n < PARALLEL_SUBTREE {
            progress.add(n);
        }
        Nodes::compact(&slots)
    };
    let recursion = start.elapsed();
    if params.strategy == Strategy::SahBinned {
        clock.add_phases(phases);
    }
    phases.add("splits (whole recursion)", recursion);
    let start = Instant::now();
    let prim_indices: Vec<u32> = refs.iter().map(|r| r.index).collect();
    let bvh = in_leaf_order(triangles, nodes, prim_indices, copy);
    if copy == LeafCopy::Made {
        phases.add("leaf order", start.elapsed());
    }
    bvh
}

/// The top-down builders' choice of splits, node by node; the wide tree built straight from
/// binned SAH (`wide::sah`) makes the same choices.
#[derive(Clone, Copy)]
pub(crate) struct Builder<'a> {
    pub params: &'a BuildParams,
    pub clock: &'a TopSplitClock,
    /// Counted per sequential subtree, not per leaf, to keep the atomic out of the way.
    pub progress: &'a BuildProgress<'a>,
}

impl Builder<'_> {
    /// Builds the subtree over `refs` (which start at leaf-order index `first`) and returns
    /// its root. Its descendants go into `slots`, whose first entry is array index
    /// `slot_base`: a fixed slice for each child, whose halves are built in parallel, down
    /// to subtrees of fewer than `PARALLEL_SUBTREE` references, built on one thread
    /// (`sequential`).
    fn subtree(
        &self,
        refs: &mut [PrimRef],
        first: usize,
        depth: u32,
        info: NodeInfo,
        slots: &mut [Node],
        slot_base: usize,
    ) -> Node {
        let n = refs.len();
        if n < PARALLEL_SUBTREE {
            return sah_binned::with_scratch(|scratch| {
                let at = (slot_base, &mut 0, scratch);
                self.sequential(refs, first, depth, info, slots, at)
            });
        }
        let Some((m, left_info, right_info)) = self.split(refs, &info, depth) else {
            self.progress.add(n);
            return Node::leaf(info.bounds.to_aabb(), first as u32, n as u32);
        };
        debug_assert!(0 < m && m < n);
        let (pair, rest) = slots.split_at_mut(2);
        let (left_slots, right_slots) = rest.split_at_mut(2 * m - 2);
        let (left_refs, right_refs) = refs.split_at_mut(m);
        let left = move || {
            self.subtree(
                left_refs,
                first,
                depth + 1,
                left_info,
                left_slots,
                slot_base + 2,
            )
        };
        let right = move || {
            let base = slot_base + 2 * m;
            self.subtree(
                right_refs,
                first + m,
                depth + 1,
                right_info,
                right_slots,
                base,
            )
        };
        let (l, r) = rayon::join(left, right);
        // A subtree built on one thread is counted here, once (its leaves add nothing).
        for size in [m, n - m] {
            if size < PARALLEL_SUBTREE {
                self.progress.add(size);
            }
        }
        pair[0] = l;
        pair[1] = r;
        Node::interior(info.bounds.to_aabb(), slot_base as u32)
    }

    /// `subtree` on one thread: each interior node's pair goes to the next free slots of
    /// `slots` (`used` of them taken; `slots[0]` is array index `slot_base`), so the
    /// subtree's pairs lie one after another in depth-first order, the order
    /// `Nodes::compact` reads them in. Fixed slices per child, as the parallel part needs,
    /// left gaps wherever a child used fewer than its slice; the compaction then jumped
    /// over them, and waited on memory at each jump. The subtree's searches share one
    /// scratch, where each took its thread's out of a slot and put it back.
    fn sequential(
        &self,
        refs: &mut [PrimRef],
        first: usize,
        depth: u32,
        info: NodeInfo,
        slots: &mut [Node],
        (slot_base, used, scratch): (usize, &mut usize, &mut Scratch),
    ) -> Node {
        let n = refs.len();
        let Some((m, left_info, right_info)) = self.split_with(refs, &info, depth, Some(scratch))
        else {
            return Node::leaf(info.bounds.to_aabb(), first as u32, n as u32);
        };
        debug_assert!(0 < m && m < n);
        let at = *used;
        *used += 2;
        let (left_refs, right_refs) = refs.split_at_mut(m);
        let d = depth + 1;
        let l = self.sequential(
            left_refs,
            first,
            d,
            left_info,
            slots,
            (slot_base, used, scratch),
        );
        let r = self.sequential(
            right_refs,
            first + m,
            d,
            right_info,
            slots,
            (slot_base, used, scratch),
        );
        slots[at] = l;
        slots[at + 1] = r;
        Node::interior(info.bounds.to_aabb(), (slot_base + at) as u32)
    }

    /// Where to split `refs` (partitioning them so that `refs[..m]` is the left child), or
    /// `None` to make a leaf.
    pub(crate) fn split(&self, refs: &mut [PrimRef], info: &NodeInfo, depth: u32) -> Option<Split> {
        self.split_with(refs, info, depth, None)
    }

    /// `split`, binned SAH's search with `scratch` if given (else its thread's).
    fn split_with(
        &self,
        refs: &mut [PrimRef],
        info: &NodeInfo,
        depth: u32,
        scratch: Option<&mut Scratch>,
    ) -> Option<Split> {
        let n = refs.len();
        let p = self.params;
        let must_split = n > p.max_leaf_size as usize;
        if n == 1 {
            return None;
        }
        // Abandoned, or all centroids are equal: halving by count is the cheapest split
        // that keeps the leaf size limit.
        if self.progress.is_abandoned() {
            return must_split.then(|| prim::split_at(refs, n / 2));
        }
        if info.centroid_axis().1 {
            // All centroids are equal: no plane separates them, and no split can make rays
            // cheaper. Halve by count only so the leaf size limit still holds.
            return must_split.then(|| prim::split_at(refs, n / 2));
        }
        if depth >= MEDIAN_FALLBACK_DEPTH {
            return must_split.then(|| median::object_median(refs, info));
        }
        match p.strategy {
            Strategy::ObjectMedian => must_split.then(|| median::object_median(refs, info)),
            Strategy::SpatialMedian => must_split.then(|| median::spatial_median(refs, info)),
            Strategy::SahSweep => sah_sweep::split(refs, info, p),
            Strategy::SahBinned => sah_binned::split(refs, info, p, self.clock, scratch),
            // An empty input reaches no split; non-empty ones are built by `lbvh` or `sbvh`.
            Strategy::Lbvh | Strategy::LbvhTreelet | Strategy::Sbvh => None,
        }
    }
}

/// The SAH decision, in costs scaled by the parent's area so that a flat parent (area 0)
/// needs no division: split when the leaf would be too big or the split is cheaper,
/// C_trav·S_N + C_isect·(S_A·N_A + S_B·N_B) < C_isect·S_N·N.
fn sah_worth_splitting(n: usize, best_split_cost: f32, parent_area: f32, p: &BuildParams) -> bool {
    n > p.max_leaf_size as usize || best_split_cost < p.c_isect * parent_area * n as f32
}

/// The unnormalised SAH cost of a candidate split (see `sah_worth_splitting`).
fn sah_split_cost(
    parent_area: f32,
    area_a: f32,
    n_a: usize,
    area_b: f32,
    n_b: usize,
    p: &BuildParams,
) -> f32 {
    p.c_trav * parent_area + p.c_isect * (area_a * n_a as f32 + area_b * n_b as f32)
}
