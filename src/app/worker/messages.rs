//! What the UI and the worker say to each other: the commands, the jobs and overlays a
//! frame is asked for, and the replies.

use crate::accel::bvh::BuildReport;
use crate::accel::sah_check::SahPrediction;
use crate::accel::split_costs::SplitCosts;
use crate::accel::structure::StructureParams;
use crate::accel::two_level::InstanceOutline;
use crate::accel::{Outline, StructureReport};
use crate::bench::stress::crossing::CrossingReport;
use crate::geometry::IntersectorKind;
use crate::render::compare::{CompareSummary, CompareView};
use crate::render::cracks::Marker;
use crate::render::heat::HeatStyle;
use crate::render::node_visits::NodeVisits;
use crate::render::replay::Replay;
use crate::render::{Frame, Mode, RayKind};
use crate::scene::{Camera, Scene};
use glam::Vec3;
use std::sync::Arc;
use std::time::Duration;

/// What to draw over the traced image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overlay {
    /// Tint these triangles: the selection of the move tool.
    pub selected: Option<Arc<Vec<u32>>>,
    /// Outline every node (or cell) at this depth, and a k-d tree's split planes there.
    pub level: Option<u32>,
    /// The node of the tree walk: its box, its children's boxes, their triangles tinted.
    pub walk: Option<u32>,
    /// A point of the view (0..1 across and down): the cells the ray through it walks are
    /// outlined, for structures that walk cells (the grid).
    pub probe: Option<[f32; 2]>,
    pub see_through: bool,
    /// Colour level boxes by node instead of by depth.
    pub color_by_node: bool,
    /// Under the two levels: the selected instance, whose BLAS the levels and the walk
    /// continue into.
    pub instance: Option<usize>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct RenderJob {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub mode: Mode,
    pub heat_max: Option<u32>,
    /// A heatmap's curve, clipping and shaded underlay.
    pub heat_style: HeatStyle,
    pub overlay: Overlay,
    /// A reduced-resolution frame while the user interacts.
    pub preview: bool,
    /// With a pinned configuration A: A's parameters and how to show A beside B.
    pub compare: Option<CompareJob>,
}

/// A comparison the frame is to show: the pinned configuration A (the worker's own
/// structure is B) and the view of the two.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareJob {
    pub a: StructureParams,
    pub view: CompareView,
}

/// What a frame with a pinned A found: the counters of A against B, or why there is no
/// comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Compared {
    /// Empty for a frame traced without counting (a quick preview).
    pub summaries: Vec<CompareSummary>,
    /// A could not be built, or the view does not fit the mode (B alone is shown).
    pub error: Option<String>,
}

impl Command {
    /// Whether the command makes a build in flight pointless: it asks for another scene or
    /// another structure, which builds again anyway.
    pub fn replaces_the_build(&self) -> bool {
        matches!(
            self,
            Command::Load(_) | Command::Adopt(..) | Command::Build(_) | Command::Rebuild
        )
    }
}

pub enum Command {
    /// A built-in scene name or an OBJ path.
    Load(String),
    /// A scene loaded already, under its spec (the command line checked it before the
    /// window opened).
    Adopt(String, Box<Scene>),
    /// Build the structure these parameters name (traversal settings alone rebuild
    /// nothing).
    Build(StructureParams),
    /// The parameters the next load builds with, without building now: a preset sets the
    /// structure and the scene together, and only the new scene is built.
    SetParams(StructureParams),
    Render(RenderJob),
    /// Move these scene triangles by `delta`, and refit (BVH) or rebuild the structure.
    Move {
        triangles: Arc<Vec<u32>>,
        delta: Vec3,
    },
    /// Move scene object `object` by `delta` as a whole: under the two levels its instance
    /// moves and only the top level is refitted; under any other structure its triangles
    /// move as with `Move`.
    MoveObject {
        object: usize,
        delta: Vec3,
    },
    /// The drag that made the last moves is over: they form one undo step.
    EndGesture,
    /// Build again over the triangles as they are now.
    Rebuild,
    /// Send the scene with its triangles where they are now (after moves).
    Snapshot,
    Undo,
    /// Trace one pixel's ray again, recording its traversal (the ray replay).
    Replay(ReplayRequest),
    /// Count the nodes the rays of a frame visit, per node of the outline (the hierarchy
    /// diagram's measured width and colour); given up when a newer command arrives.
    NodeVisits(VisitsRequest),
    /// The crack view of a frame: which exact edge and vertex rays slip through.
    Cracks(CracksRequest),
    /// Under the two levels: outline this instance's BLAS below the top level (`None`:
    /// no instance).
    SelectInstance(Option<usize>),
    /// Under the two levels: select the instance that places scene object `object`.
    SelectObject(usize),
    /// Load this scene and build this structure at the next quiet moment, for a `Load`
    /// of it to come (the lecture's next step).
    Prefetch {
        spec: String,
        params: StructureParams,
    },
}

/// A pixel of a frame whose ray to replay: its primary ray, or its shadow ray.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayRequest {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub pixel: (u32, u32),
    pub rays: RayKind,
}

/// A frame whose rays' visits to count: its camera and size, and which rays.
#[derive(Clone, Debug, PartialEq)]
pub struct VisitsRequest {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub rays: RayKind,
}

/// A frame whose cracks to show: its camera and size, the test judged and how far the
/// scene is moved from where it stands.
#[derive(Clone, Debug, PartialEq)]
pub struct CracksRequest {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub intersector: IntersectorKind,
    pub offset: f64,
}

/// The crack view's answer: where the chosen test's rays slipped through (in the frame's
/// pixels), and every test's counts on the same rays.
#[derive(Clone, Debug)]
pub struct CracksShown {
    pub markers: Vec<Marker>,
    pub reports: [(IntersectorKind, CrossingReport); 3],
    pub rays: usize,
}

/// What the walk's current node is, in the lecture's terms.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WalkInfo {
    pub node: u32,
    pub depth: u32,
    /// Under the two levels: the instance whose BLAS holds the node, or which the
    /// top-level leaf holds (`in_blas` tells which).
    pub instance: Option<usize>,
    pub in_blas: bool,
    /// A top-level leaf's reference is its instance's whole BLAS (not a subtree that
    /// re-braiding opened).
    pub whole_instance: bool,
    pub triangles: usize,
    pub surface_area: f32,
    /// For an interior node, C = C_trav + Σ S_child/S_N·N_child·C_isect; for a leaf,
    /// N·C_isect.
    pub sah_cost: f32,
    pub children: Vec<usize>,
    /// For a BVH2 node: every split the SAH weighs there (the bucket-cost plot).
    pub split_costs: Option<Arc<SplitCosts>>,
}

/// A frame as the UI shows it.
#[derive(Clone)]
pub struct Shown {
    pub job: RenderJob,
    pub rgba: Vec<u8>,
    pub heat_max: Option<u32>,
    pub frame: Arc<Frame>,
    pub walk: Option<WalkInfo>,
    /// Whether this frame was traced (rather than only recoloured).
    pub traced: bool,
    /// Time to trace the image shown. A full frame in a mode that shows no counts is
    /// traced without counting, so its counters (`frame`) come later with `Reply::Counted`,
    /// from a second, slower pass.
    pub image_time: Duration,
    /// With a pinned A: the comparison, and A's frame of the same view.
    pub compared: Option<Compared>,
    pub pinned_frame: Option<Arc<Frame>>,
    /// With a pinned A: its tree, for the hierarchy diagram of A above B's.
    pub pinned_tree: Option<Arc<PinnedTree>>,
}

/// The pinned configuration A's tree: its outline, what it is and its SAH cost.
#[derive(Clone, Debug)]
pub struct PinnedTree {
    pub outline: Arc<Outline>,
    pub label: String,
    /// With the C_trav and C_isect it was weighed with; `None` for a structure that is not
    /// an SAH tree.
    pub sah_cost: Option<(f64, f32, f32)>,
}

pub enum Reply {
    Loaded {
        spec: String,
        scene: Arc<Scene>,
    },
    LoadFailed {
        spec: String,
        error: String,
    },
    Built {
        report: Box<StructureReport>,
        /// The BVH's own report (SAH cost, leaf sizes), for a BVH.
        bvh_report: Option<Box<BuildReport>>,
        outline: Arc<Outline>,
        /// Under the two levels: the instance each top-level leaf holds (`u32::MAX` for an
        /// interior node), by outline node.
        leaf_instances: Arc<Vec<u32>>,
        /// For trees the SAH describes: its prediction against random lines.
        sah: Option<SahPrediction>,
    },
    /// The selected instance's BLAS, outlined (again after a move or a build), or none.
    InstanceSelected(Option<Arc<InstanceOutline>>),
    BuildFailed(String),
    Refitted {
        sah_before: f64,
        sah_after: f64,
        refit_time: Duration,
        /// The refit of an undo (its chart point is taken back, not added).
        undo: bool,
    },
    /// A structure that cannot refit was rebuilt after a move; beside it, what refitting a
    /// BVH over the same triangles took.
    /// The outline made again after refits (the boxes the levels and the walk draw).
    Outline(Arc<Outline>),
    RebuiltAfterMove {
        rebuild_time: Duration,
        bvh_refit_time: Option<Duration>,
        /// The rebuilt structure's nodes (a k-d tree's or a grid's may differ in number).
        outline: Arc<Outline>,
    },
    /// An instance moved and the top level was refitted; beside it, what refitting a BVH
    /// over the flattened scene for the same move took (`None` for a scene too large to
    /// flatten).
    InstanceMoved {
        refit_time: Duration,
        flat_refit_time: Option<Duration>,
        /// The moved object and its instance's transform now.
        object: usize,
        transform: glam::Affine3A,
    },
    Frame(Arc<Shown>),
    /// The counted frame of the full frame just shown without counts: the same hits and
    /// image, now with every ray's counters. `job` is the shown frame's job.
    Counted {
        job: RenderJob,
        frame: Arc<Frame>,
    },
    Snapshot(Arc<Scene>),
    /// The recorded traversal of a pixel's ray, or why there is none.
    Replayed(Result<Arc<Replay>, String>),
    /// The scene and structure asked for by `Command::Prefetch` are ready.
    Prefetched(String),
    /// The EPO of the tree built or refitted last.
    Epo(crate::accel::epo::Epo),
    /// Under the two levels: the EPO of the selected instance's BLAS in its mesh's space.
    BlasEpo {
        instance: usize,
        epo: f64,
    },
    /// The visits counted for a request, or `None` when a newer command cut it short.
    NodeVisits(VisitsRequest, Option<Arc<NodeVisits>>),
    /// The crack view of a request, or why there is none (an offset too far, say).
    Cracks(CracksRequest, Result<Arc<CracksShown>, String>),
    /// Every command up to this sequence number has been handled.
    Idle(u64),
}
