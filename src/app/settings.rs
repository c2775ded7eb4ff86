//! What the app remembers between runs (eframe persistence): the build and view settings,
//! the UI scale and the recently opened files.

use super::preset::View;
use crate::accel::bvh::{BuildParams, Strategy, TraversalOrder};
use crate::accel::grid::GridParams;
use crate::accel::kdtree::{KdParams, KdSplit};
use crate::accel::octree::OctreeParams;
use crate::accel::{AccelKind, Counter, StructureParams};
use crate::geometry::simd::SimdLevel;
use crate::render::compare::CompareView;
use crate::render::{Mode, RayKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub const STORAGE_KEY: &str = "bvhlab-settings";
const MAX_RECENT: usize = 8;

/// The view modes the app offers, in plain data so they persist.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ViewMode {
    #[default]
    Shaded,
    Normals,
    Depth,
    Nodes,
    Boxes,
    Triangles,
    /// Triangle tests a ray repeated: spatial structures without mailboxing.
    Repeated,
    /// Two-level structures: nodes visited in the top level, in the bottom levels, and the
    /// instances entered.
    TopNodes,
    BottomNodes,
    Instances,
}

impl ViewMode {
    pub const ALL: [ViewMode; 10] = [
        ViewMode::Shaded,
        ViewMode::Normals,
        ViewMode::Depth,
        ViewMode::Nodes,
        ViewMode::Boxes,
        ViewMode::Triangles,
        ViewMode::Repeated,
        ViewMode::TopNodes,
        ViewMode::BottomNodes,
        ViewMode::Instances,
    ];

    pub fn label(self) -> &'static str {
        match self {
            ViewMode::Shaded => "shaded",
            ViewMode::Normals => "normals",
            ViewMode::Depth => "depth",
            ViewMode::Nodes => "nodes visited",
            ViewMode::Boxes => "box tests",
            ViewMode::Triangles => "triangle tests",
            ViewMode::Repeated => "repeated tests",
            ViewMode::TopNodes => "top-level nodes",
            ViewMode::BottomNodes => "bottom-level nodes",
            ViewMode::Instances => "instances entered",
        }
    }

    pub fn is_heatmap(self) -> bool {
        matches!(
            self,
            ViewMode::Nodes
                | ViewMode::Boxes
                | ViewMode::Triangles
                | ViewMode::Repeated
                | ViewMode::TopNodes
                | ViewMode::BottomNodes
                | ViewMode::Instances
        )
    }

    /// Whether the mode shows a count only a two-level structure makes.
    pub fn is_two_level(self) -> bool {
        matches!(
            self,
            ViewMode::TopNodes | ViewMode::BottomNodes | ViewMode::Instances
        )
    }

    pub fn render_mode(self, shadow: bool) -> Mode {
        let rays = if shadow {
            RayKind::Shadow
        } else {
            RayKind::Primary
        };
        match self {
            ViewMode::Shaded => Mode::Shaded,
            ViewMode::Normals => Mode::Normals,
            ViewMode::Depth => Mode::Depth,
            ViewMode::Nodes => Mode::Heatmap(Counter::NodesVisited, rays),
            ViewMode::Boxes => Mode::Heatmap(Counter::BoxTests, rays),
            ViewMode::Triangles => Mode::Heatmap(Counter::TriangleTests, rays),
            ViewMode::Repeated => Mode::Heatmap(Counter::RepeatedTests, rays),
            ViewMode::TopNodes => Mode::Heatmap(Counter::TopNodesVisited, rays),
            ViewMode::BottomNodes => Mode::Heatmap(Counter::BottomNodesVisited, rays),
            ViewMode::Instances => Mode::Heatmap(Counter::InstancesEntered, rays),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum StrategyChoice {
    ObjectMedian,
    SpatialMedian,
    SahSweep,
    SahBinned,
    Lbvh,
    LbvhTreelet,
    Sbvh,
}

impl From<StrategyChoice> for Strategy {
    fn from(s: StrategyChoice) -> Strategy {
        match s {
            StrategyChoice::ObjectMedian => Strategy::ObjectMedian,
            StrategyChoice::SpatialMedian => Strategy::SpatialMedian,
            StrategyChoice::SahSweep => Strategy::SahSweep,
            StrategyChoice::SahBinned => Strategy::SahBinned,
            StrategyChoice::Lbvh => Strategy::Lbvh,
            StrategyChoice::LbvhTreelet => Strategy::LbvhTreelet,
            StrategyChoice::Sbvh => Strategy::Sbvh,
        }
    }
}

impl From<Strategy> for StrategyChoice {
    fn from(s: Strategy) -> StrategyChoice {
        match s {
            Strategy::ObjectMedian => StrategyChoice::ObjectMedian,
            Strategy::SpatialMedian => StrategyChoice::SpatialMedian,
            Strategy::SahSweep => StrategyChoice::SahSweep,
            Strategy::SahBinned => StrategyChoice::SahBinned,
            Strategy::Lbvh => StrategyChoice::Lbvh,
            Strategy::LbvhTreelet => StrategyChoice::LbvhTreelet,
            Strategy::Sbvh => StrategyChoice::Sbvh,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    pub scene: String,
    /// The structure the app builds.
    pub accel: AccelKind,
    /// Mailboxing in the spatial structures.
    pub mailbox: bool,
    /// The wide BVHs' SIMD slab kernel.
    pub simd: SimdLevel,
    pub kd_c_trav: f32,
    pub kd_c_isect: f32,
    pub kd_empty_bonus: f32,
    /// 0 = automatic (8 + 1.3·log2 N).
    pub kd_max_depth: u32,
    pub kd_max_leaf_size: u32,
    /// 0 = the exact sweep; otherwise binned with this many bins.
    pub kd_bins: u32,
    /// Grid cells ≈ λ · triangles.
    pub grid_lambda: f32,
    pub octree_max_leaf_size: u32,
    pub octree_max_depth: u32,
    pub strategy: StrategyChoice,
    pub buckets: u32,
    /// Leaves per treelet and rounds of LBVH + treelets.
    pub treelet_size: u32,
    pub treelet_rounds: u32,
    /// SBVH: overlap threshold α, overlap penalty κ and duplicated-reference budget
    /// (fraction of N).
    pub split_alpha: f32,
    pub overlap_penalty: f32,
    pub split_budget: f32,
    /// Pre-split budget (fraction of N) for LBVH, LBVH + treelets and binned SAH.
    pub presplit: f32,
    /// Two levels: the re-braiding budget (extra top-level references per instance; 0 =
    /// whole instances).
    pub rebraid: f32,
    pub max_leaf_size: u32,
    pub c_trav: f32,
    pub c_isect: f32,
    pub naive_order: bool,
    pub mode: ViewMode,
    /// Heatmaps count shadow rays instead of primary rays.
    pub shadow_rays: bool,
    /// Fixed top of the heatmap scale; `None` = each frame's maximum.
    pub heat_max: Option<u32>,
    pub show_levels: bool,
    pub level: u32,
    pub see_through: bool,
    pub color_by_node: bool,
    pub move_whole_object: bool,
    /// With a pinned configuration A: B alone, A | B, or B − A.
    pub compare_view: CompareView,
    /// Rebuild automatically when the SAH cost has grown by more than this many percent.
    pub auto_rebuild_percent: Option<f32>,
    pub ui_scale: f32,
    pub recent: Vec<String>,
    /// Camera bookmarks per scene (keyed by its spec), kept between runs.
    pub bookmarks: BTreeMap<String, Vec<Bookmark>>,
}

/// A camera kept under a name for one scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bookmark {
    pub name: String,
    pub view: View,
}

impl Default for Settings {
    fn default() -> Self {
        let p = BuildParams::default();
        let kd = KdParams::default();
        let oct = OctreeParams::default();
        Settings {
            scene: "cornell".into(),
            // Trace with the fastest layout until the user picks another.
            accel: AccelKind::fastest(),
            mailbox: true,
            simd: SimdLevel::detect(),
            kd_c_trav: kd.c_trav,
            kd_c_isect: kd.c_isect,
            kd_empty_bonus: kd.empty_bonus,
            kd_max_depth: kd.max_depth,
            kd_max_leaf_size: kd.max_leaf_size,
            kd_bins: 0,
            grid_lambda: GridParams::default().lambda,
            octree_max_leaf_size: oct.max_leaf_size,
            octree_max_depth: oct.max_depth,
            strategy: StrategyChoice::SahBinned,
            buckets: p.buckets,
            treelet_size: p.treelet_size,
            treelet_rounds: p.treelet_rounds,
            split_alpha: p.split_alpha,
            overlap_penalty: p.overlap_penalty,
            split_budget: p.split_budget,
            presplit: p.presplit,
            rebraid: p.rebraid,
            max_leaf_size: p.max_leaf_size,
            c_trav: p.c_trav,
            c_isect: p.c_isect,
            naive_order: false,
            mode: ViewMode::Shaded,
            shadow_rays: false,
            heat_max: None,
            show_levels: false,
            level: 0,
            see_through: false,
            color_by_node: false,
            move_whole_object: false,
            compare_view: CompareView::Split,
            auto_rebuild_percent: None,
            ui_scale: 1.0,
            recent: Vec::new(),
            bookmarks: BTreeMap::new(),
        }
    }
}

impl Settings {
    pub fn build_params(&self) -> BuildParams {
        BuildParams {
            strategy: self.strategy.into(),
            buckets: self.buckets,
            max_leaf_size: self.max_leaf_size,
            c_trav: self.c_trav,
            c_isect: self.c_isect,
            treelet_size: self.treelet_size,
            treelet_rounds: self.treelet_rounds,
            split_alpha: self.split_alpha,
            overlap_penalty: self.overlap_penalty,
            split_budget: self.split_budget,
            presplit: self.presplit,
            rebraid: self.rebraid,
        }
    }

    /// Everything the worker needs to build the chosen structure.
    pub fn structure_params(&self) -> StructureParams {
        StructureParams {
            kind: self.accel,
            bvh: self.build_params(),
            order: self.order(),
            kdtree: KdParams {
                c_trav: self.kd_c_trav,
                c_isect: self.kd_c_isect,
                empty_bonus: self.kd_empty_bonus,
                max_depth: self.kd_max_depth,
                max_leaf_size: self.kd_max_leaf_size,
                split: match self.kd_bins {
                    0 => KdSplit::Sweep,
                    b => KdSplit::Binned(b),
                },
                // Built as it will be traced, so the build report says so.
                mailbox: self.mailbox,
                ..KdParams::default()
            },
            grid: GridParams {
                lambda: self.grid_lambda,
                mailbox: self.mailbox,
            },
            octree: OctreeParams {
                max_leaf_size: self.octree_max_leaf_size,
                max_depth: self.octree_max_depth,
                mailbox: self.mailbox,
            },
            mailbox: self.mailbox,
            simd: self.simd,
        }
    }

    pub fn order(&self) -> TraversalOrder {
        if self.naive_order {
            TraversalOrder::Naive
        } else {
            TraversalOrder::FrontToBack
        }
    }

    /// Remembers a file that loaded, most recent first.
    pub fn add_recent(&mut self, path: &str) {
        self.recent.retain(|p| p != path);
        self.recent.insert(0, path.to_string());
        self.recent.truncate(MAX_RECENT);
    }
}

/// A configuration pinned as A for a comparison: every setting that changes what the
/// counters count (the structure, its build parameters, the traversal order, mailboxing,
/// the SIMD kernel), copied from the settings at the moment of pinning. The settings
/// themselves stay configuration B.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pinned {
    pub accel: AccelKind,
    pub mailbox: bool,
    pub simd: SimdLevel,
    pub kd_c_trav: f32,
    pub kd_c_isect: f32,
    pub kd_empty_bonus: f32,
    pub kd_max_depth: u32,
    pub kd_max_leaf_size: u32,
    pub kd_bins: u32,
    pub grid_lambda: f32,
    pub octree_max_leaf_size: u32,
    pub octree_max_depth: u32,
    pub strategy: StrategyChoice,
    pub buckets: u32,
    pub treelet_size: u32,
    pub treelet_rounds: u32,
    pub split_alpha: f32,
    pub overlap_penalty: f32,
    pub split_budget: f32,
    pub presplit: f32,
    pub rebraid: f32,
    pub max_leaf_size: u32,
    pub c_trav: f32,
    pub c_isect: f32,
    pub naive_order: bool,
}

/// Copies the configuration fields between `Settings` and `Pinned`, in either direction.
macro_rules! configuration_fields {
    ($from:expr, $to:expr) => {{
        configuration_fields!(@copy $from, $to; accel, mailbox, simd, kd_c_trav, kd_c_isect,
            kd_empty_bonus, kd_max_depth, kd_max_leaf_size, kd_bins, grid_lambda,
            octree_max_leaf_size, octree_max_depth, strategy, buckets, treelet_size,
            treelet_rounds, split_alpha, overlap_penalty, split_budget, presplit, rebraid,
            max_leaf_size, c_trav, c_isect, naive_order)
    }};
    (@copy $from:expr, $to:expr; $($field:ident),*) => {{
        $( $to.$field = $from.$field; )*
    }};
}

/// The default configuration: what a preset's `[pinned]` table leaves out.
impl Default for Pinned {
    fn default() -> Self {
        Pinned::of(&Settings::default())
    }
}

impl Pinned {
    /// Pins the configuration `settings` describe now.
    pub fn of(settings: &Settings) -> Pinned {
        let d = Settings::default();
        let mut p = Pinned {
            accel: d.accel,
            mailbox: d.mailbox,
            simd: d.simd,
            kd_c_trav: d.kd_c_trav,
            kd_c_isect: d.kd_c_isect,
            kd_empty_bonus: d.kd_empty_bonus,
            kd_max_depth: d.kd_max_depth,
            kd_max_leaf_size: d.kd_max_leaf_size,
            kd_bins: d.kd_bins,
            grid_lambda: d.grid_lambda,
            octree_max_leaf_size: d.octree_max_leaf_size,
            octree_max_depth: d.octree_max_depth,
            strategy: d.strategy,
            buckets: d.buckets,
            treelet_size: d.treelet_size,
            treelet_rounds: d.treelet_rounds,
            split_alpha: d.split_alpha,
            overlap_penalty: d.overlap_penalty,
            split_budget: d.split_budget,
            presplit: d.presplit,
            rebraid: d.rebraid,
            max_leaf_size: d.max_leaf_size,
            c_trav: d.c_trav,
            c_isect: d.c_isect,
            naive_order: d.naive_order,
        };
        configuration_fields!(settings, p);
        p
    }

    /// Makes this configuration the current one in `settings` (everything else stays).
    pub fn apply_to(&self, settings: &mut Settings) {
        configuration_fields!(self, settings);
    }

    /// The structure and traversal parameters of this configuration.
    pub fn structure_params(&self) -> StructureParams {
        let mut s = Settings::default();
        self.apply_to(&mut s);
        s.structure_params()
    }

    /// A short name: the structure and, for a BVH, its builder and leaf size.
    pub fn label(&self) -> String {
        let p = self.structure_params();
        match p.kind {
            AccelKind::Bvh | AccelKind::Bvh4 | AccelKind::Bvh8 | AccelKind::TwoLevel => format!(
                "{}, {}, leaves ≤ {}, {}",
                p.kind.title(),
                p.bvh.strategy.label(),
                p.bvh.max_leaf_size,
                p.order.label()
            ),
            kind if kind.is_spatial() => format!(
                "{}, mailboxing {}",
                kind.title(),
                if p.mailbox { "on" } else { "off" }
            ),
            kind => kind.title().to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pinned_configuration_is_the_settings_configuration() {
        let mut s = Settings {
            accel: AccelKind::KdTree,
            mailbox: false,
            strategy: StrategyChoice::Sbvh,
            max_leaf_size: 3,
            kd_bins: 32,
            naive_order: true,
            ..Default::default()
        };
        let pinned = Pinned::of(&s);
        assert_eq!(pinned.structure_params(), s.structure_params());
        // It survives serialisation (presets store it).
        let json = serde_json::to_string(&pinned).unwrap();
        assert_eq!(serde_json::from_str::<Pinned>(&json).unwrap(), pinned);
        // Applied to other settings it changes the configuration only.
        s.scene = "walls".into();
        s.mode = ViewMode::Nodes;
        let mut other = Settings::default();
        pinned.apply_to(&mut other);
        assert_eq!(other.structure_params(), s.structure_params());
        assert_eq!(
            (other.scene.as_str(), other.mode),
            ("cornell", ViewMode::Shaded)
        );
    }
}
