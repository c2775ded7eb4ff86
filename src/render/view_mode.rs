//! The view modes in plain data: what the app shows, what a preset sets and what the CLI's
//! `--mode` names; one enum for all three.

use super::{Mode, RayKind};
use crate::accel::{Counter, StructureParams};
use serde::{Deserialize, Serialize};

/// What a frame shows, as plain data: the app's view mode, the presets' `mode` and the
/// CLI's `--mode` (the renderer's `Mode` adds the kind of ray a heatmap counts).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum,
)]
pub enum ViewMode {
    /// Lambert shading with a hard shadow from the point light.
    #[default]
    Shaded,
    /// Surface normals as colours.
    Normals,
    /// Distance to the hit.
    Depth,
    /// Heatmap of nodes visited.
    Nodes,
    /// Heatmap of ray–box tests.
    Boxes,
    /// Heatmap of ray–triangle tests.
    Triangles,
    /// Heatmap of repeated triangle tests (spatial structures with --mailbox false).
    Repeated,
    /// Two-level structure: heatmap of nodes visited in the top level (TLAS).
    TopNodes,
    /// Two-level structure: heatmap of nodes visited in the bottom levels (BLASes).
    BottomNodes,
    /// Two-level structure: heatmap of instances entered.
    Instances,
    /// Each triangle coloured by its share of the tree's SAH cost: the surface-area
    /// probabilities of the leaves holding it times C_isect, plus C_trav of every node
    /// above shared among that node's references (log scale; BVHs, the k-d tree and the octree).
    TriangleCost,
    /// Each triangle coloured by the ray–triangle tests the frame's rays did on it
    /// (measured).
    TestsReceived,
}

impl ViewMode {
    pub const ALL: [ViewMode; 12] = [
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
        ViewMode::TriangleCost,
        ViewMode::TestsReceived,
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
            ViewMode::TriangleCost => "SAH cost per triangle",
            ViewMode::TestsReceived => "tests per triangle",
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
                | ViewMode::TestsReceived
        )
    }

    /// Whether the mode colours each triangle by a value of its own (`render::per_triangle`)
    /// rather than each pixel by its rays' counts.
    pub fn colours_triangles(self) -> bool {
        matches!(self, ViewMode::TriangleCost | ViewMode::TestsReceived)
    }

    /// Whether the mode shows a count only a two-level structure makes.
    pub fn is_two_level(self) -> bool {
        matches!(
            self,
            ViewMode::TopNodes | ViewMode::BottomNodes | ViewMode::Instances
        )
    }

    /// Why `params`' structure has nothing for this mode to show (a heatmap of zeros that
    /// would look like a measurement), or `None` if it has: only the two levels count their
    /// levels' work, and only a spatial structure's mailbox records a triangle tested again
    /// (with mailboxing on, its zeros are the lesson: no test is repeated).
    pub fn missing_counts(self, params: &StructureParams) -> Option<&'static str> {
        let kind = params.kind;
        if self.is_two_level() && !kind.places_instances() {
            return Some("it counts the two levels' work, which only the two-level structure has");
        }
        if self == ViewMode::Repeated && !kind.is_spatial() {
            return Some(
                "it counts the triangles a ray tests again, which only the mailbox of a k-d \
                 tree, grid or octree records",
            );
        }
        if self == ViewMode::TriangleCost && !kind.has_sah_cost() && !kind.places_instances() {
            return Some(super::per_triangle::NO_SAH_COST);
        }
        None
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
            ViewMode::TriangleCost => Mode::TriangleCost,
            ViewMode::TestsReceived => Mode::TestsReceived(rays),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    #[test]
    fn every_view_mode_is_listed() {
        assert_eq!(ViewMode::ALL.as_slice(), ViewMode::value_variants());
    }
}
