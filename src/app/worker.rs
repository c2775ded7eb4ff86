//! The worker thread: it owns the scene and its acceleration structure (whichever the user
//! chose), takes commands from the UI (load, build, render a view, move triangles, undo)
//! and answers with results. The UI thread never
//! builds or traces. Commands that pile up while the worker is busy are taken together, and
//! only the newest render request among them is rendered.
//!
//! Nothing is redone that did not change: a frame is traced again only when the camera,
//! the size, the scene or the tree changed; a new colour mode or overlay recolours the
//! traced frame.

use super::levels::{Levels, WalkNode};
use crate::accel::bvh::refit::RefitIndex;
use crate::accel::bvh::{self, BuildReport, Bvh, split_costs};
use crate::accel::split_costs::SplitCosts;
use crate::accel::structure::{self, AccelKind, Structure, StructureParams};
use crate::accel::two_level::{InstanceOutline, ReferenceLocator};
use crate::accel::{Outline, StructureReport};
use crate::bench::sah_check::{mean_work_of, random_lines};
use crate::geometry::Aabb;
use crate::geometry::Watertight;
use crate::render::compare::{
    CompareSummary, CompareView, compare_image, compared_counters, summarize,
};
use crate::render::overlay::{
    OutlinedBox, outline_boxes, outline_corners, palette, tint_triangles,
};
use crate::render::replay::{Replay, replay_pixel};
use crate::render::{
    Frame, Mode, RayKind, RenderSettings, colorize, trace, trace_uncoloured_unless,
};
use crate::scene::{Camera, Scene};
use glam::Vec3;
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

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

pub enum Command {
    /// A built-in scene name or an OBJ path.
    Load(String),
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
    /// Under the two levels: outline this instance's BLAS below the top level (`None`:
    /// no instance).
    SelectInstance(Option<usize>),
    /// Under the two levels: select the instance that places scene object `object`.
    SelectObject(usize),
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

/// The SAH cost of the tree against the cost per ray measured on uniformly random lines
/// through the scene box, the rays the SAH assumes (the frame's own rays are measured as
/// they are traced).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SahPrediction {
    pub c_trav: f32,
    pub c_isect: f32,
    pub predicted: f64,
    /// C_trav · nodes visited + C_isect · triangle tests per random line, closest hit.
    pub random: f64,
}

impl SahPrediction {
    /// Random lines enough for a mean within about a per cent.
    const RAYS: usize = 1 << 14;

    fn of(s: &Structure, params: &StructureParams, bounds: &Aabb) -> Option<SahPrediction> {
        let (predicted, c_trav, c_isect) = s.sah_cost(params)?;
        let m = mean_work_of(s, &random_lines(bounds, Self::RAYS, 1), false);
        Some(SahPrediction {
            c_trav,
            c_isect,
            predicted,
            random: c_trav as f64 * m.nodes + c_isect as f64 * m.triangle_tests,
        })
    }
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
    },
    /// A structure that cannot refit was rebuilt after a move; beside it, what refitting a
    /// BVH over the same triangles took.
    RebuiltAfterMove {
        rebuild_time: Duration,
        bvh_refit_time: Option<Duration>,
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
    /// Every command up to this sequence number has been handled.
    Idle(u64),
}

/// The UI's handle on the worker thread.
pub struct Worker {
    tx: Option<Sender<(u64, Command)>>,
    rx: Receiver<Reply>,
    sent: u64,
    /// `sent`, for the worker: a counted pass stops when a newer command is waiting.
    latest: Arc<AtomicU64>,
    /// The newest command the worker has reported done.
    done: u64,
    /// Triangles placed by the build in progress, and how many there are in all.
    pub progress: Arc<(AtomicUsize, AtomicUsize)>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the thread; `wake` is called after each reply (the UI's repaint request).
    pub fn spawn(wake: impl Fn() + Send + 'static) -> Self {
        let (tx, commands) = channel();
        let (replies, rx) = channel();
        let progress = Arc::new((AtomicUsize::new(0), AtomicUsize::new(0)));
        let latest = Arc::new(AtomicU64::new(0));
        let state = State {
            latest: latest.clone(),
            light: None,
            replies,
            wake: Box::new(wake),
            progress: progress.clone(),
            scene: None,
            structure: None,
            params: StructureParams::default(),
            outline: Arc::new(Outline::default()),
            instance: None,
            leaf_instances: Arc::default(),
            leaf_references: Vec::new(),
            reference_locator: Default::default(),
            reference_bvh: None,
            version: 0,
            scene_version: 0,
            pinned: None,
            pinned_builds: 0,
            traced: None,
            pinned_traced: None,
            last_job: None,
            refit_index: None,
            gesture: Vec::new(),
            undo: Vec::new(),
            split_costs: RefCell::default(),
            selection: RefCell::default(),
            drag_bounds: None,
        };
        let thread = std::thread::Builder::new()
            .name("bvhlab-worker".into())
            .spawn(move || state.run(commands))
            .ok();
        Worker {
            tx: Some(tx),
            rx,
            sent: 0,
            latest,
            done: 0,
            progress,
            thread,
        }
    }

    pub fn send(&mut self, command: Command) {
        self.sent += 1;
        self.latest.store(self.sent, Ordering::Relaxed);
        if let Some(tx) = &self.tx {
            // A failed send means the worker is gone; the UI keeps its last state.
            let _ = tx.send((self.sent, command));
        }
    }

    /// Replies that have arrived, without waiting.
    pub fn poll(&mut self) -> Vec<Reply> {
        let replies: Vec<Reply> = self.rx.try_iter().collect();
        self.note_done(&replies);
        replies
    }

    fn note_done(&mut self, replies: &[Reply]) {
        for r in replies {
            if let Reply::Idle(seq) = r {
                self.done = self.done.max(*seq);
            }
        }
    }

    /// Whether every command sent so far has been handled.
    pub fn is_idle(&self) -> bool {
        self.done >= self.sent
    }

    /// Waits until every command sent so far is handled (or `timeout` passes) and returns
    /// the replies on the way. For tests and screenshots, never the interactive UI.
    pub fn wait_idle(&mut self, timeout: Duration) -> Vec<Reply> {
        let deadline = Instant::now() + timeout;
        let mut out = Vec::new();
        while !self.is_idle() {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(r) => {
                    self.note_done(std::slice::from_ref(&r));
                    out.push(r);
                }
                Err(_) => break,
            }
        }
        out
    }

    /// The next reply, waiting at most `timeout` (`None` if none came). For measuring when
    /// each reply arrives, never the interactive UI.
    pub fn next_reply(&mut self, timeout: Duration) -> Option<Reply> {
        let r = self.rx.recv_timeout(timeout).ok()?;
        self.note_done(std::slice::from_ref(&r));
        Some(r)
    }

    pub fn sent(&self) -> u64 {
        self.sent
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The key under which a traced frame stays valid.
#[derive(Clone, PartialEq)]
struct TraceKey {
    camera: Camera,
    width: u32,
    height: u32,
    version: u64,
}

/// A traced frame, the view it is valid for, and whether it was traced with counting.
struct Traced {
    key: TraceKey,
    frame: Arc<Frame>,
    counted: bool,
}

struct State {
    replies: Sender<Reply>,
    /// The newest command the UI has sent.
    latest: Arc<AtomicU64>,
    /// The light (the scene's, or the standard one from its box) at `scene_version`.
    light: Option<(u64, Vec3)>,
    wake: Box<dyn Fn() + Send>,
    progress: Arc<(AtomicUsize, AtomicUsize)>,
    scene: Option<Scene>,
    structure: Option<Structure>,
    params: StructureParams,
    outline: Arc<Outline>,
    /// Under the two levels: the selected instance's BLAS, and the instance each top-level
    /// leaf holds.
    instance: Option<Arc<InstanceOutline>>,
    leaf_instances: Arc<Vec<u32>>,
    /// Under the two levels: the reference each top-level leaf holds, and which reference
    /// reaches each triangle (made when a walk first needs it).
    leaf_references: Vec<u32>,
    reference_locator: std::sync::OnceLock<ReferenceLocator>,
    /// Under a structure that cannot refit: a BVH over the same triangles, refitted on every
    /// move only to show what a refit would have cost. Made at the first move.
    reference_bvh: Option<(Bvh, RefitIndex)>,
    /// Changes whenever the scene's triangles or the tree change.
    version: u64,
    /// Changes whenever the scene's triangles change (load, move, undo): A is built again.
    scene_version: u64,
    /// Configuration A of a comparison, built over the same scene as B.
    pinned: Option<PinnedStructure>,
    /// Builds of A so far: A's frames are traced again after each.
    pinned_builds: u64,
    traced: Option<Traced>,
    pinned_traced: Option<(TraceKey, Arc<Frame>)>,
    last_job: Option<RenderJob>,
    /// For partial refits of the current tree; made at the first move after a build.
    refit_index: Option<RefitIndex>,
    /// Moves of the drag in progress, then finished drags (for undo).
    gesture: Vec<Motion>,
    undo: Vec<Vec<Motion>>,
    /// The walk node's split costs, kept while the tree, the node and the parameters stay.
    split_costs: RefCell<Option<(SplitCostsKey, Arc<SplitCosts>)>>,
    /// The move tool's selection as a table, kept while the selection and the scene stay.
    selection: RefCell<Option<Arc<SelectionTable>>>,
    /// While a selection is dragged: the boxes the standard light is placed from.
    drag_bounds: Option<DragBounds>,
}

/// The move tool's selection as a table by triangle index (a selection can be a whole
/// object of 10^5 triangles): made once per selection and scene, then read by the tint of
/// every frame and the box of every move of a drag.
struct SelectionTable {
    triangles: Arc<Vec<u32>>,
    selected: Vec<bool>,
    /// Some triangle is listed twice (a move moves it twice).
    repeated: bool,
}

impl SelectionTable {
    fn new(triangles: &Arc<Vec<u32>>, triangle_count: usize) -> Self {
        let mut selected = vec![false; triangle_count];
        let mut repeated = false;
        for &t in triangles.iter() {
            if let Some(s) = selected.get_mut(t as usize) {
                repeated |= *s;
                *s = true;
            }
        }
        SelectionTable {
            triangles: triangles.clone(),
            selected,
            repeated,
        }
    }

    fn is_for(&self, triangles: &Arc<Vec<u32>>, triangle_count: usize) -> bool {
        self.selected.len() == triangle_count && same_selection(&self.triangles, triangles)
    }

    fn contains(&self, t: u64) -> bool {
        usize::try_from(t).is_ok_and(|t| self.selected.get(t) == Some(&true))
    }
}

fn same_selection(a: &Arc<Vec<u32>>, b: &Arc<Vec<u32>>) -> bool {
    Arc::ptr_eq(a, b) || a == b
}

/// The scene's box in two parts while one selection is dragged: the box of every other
/// triangle, which the drag does not change, and the selection's, which each move
/// translates. A translation moves the box exactly (rounding is monotonic, so the smallest
/// coordinate stays the smallest), so the standard light, which follows the scene's box,
/// costs no pass over the scene's triangles per move.
struct DragBounds {
    selection: Arc<Vec<u32>>,
    /// The scene version the boxes are of.
    scene_version: u64,
    rest: Aabb,
    selected: Aabb,
}

impl DragBounds {
    /// The two boxes of a flattened scene (whose box is that of its triangles), or `None`
    /// if a move would not translate the selection (a triangle listed twice moves twice).
    fn new(scene: &Scene, table: &SelectionTable, scene_version: u64) -> Option<Self> {
        if table.repeated || !scene.is_flattened() {
            return None;
        }
        let (mut rest, mut selected) = (Aabb::EMPTY, Aabb::EMPTY);
        for (t, &s) in scene.triangles.iter().zip(&table.selected) {
            if s {
                selected = selected.union(t.bounds());
            } else {
                rest = rest.union(t.bounds());
            }
        }
        Some(DragBounds {
            selection: table.triangles.clone(),
            scene_version,
            rest,
            selected,
        })
    }
}

/// An image's pixels and its heatmap scale, as `colorize` gives them.
type Image = (Vec<u8>, Option<u32>);

/// The pinned configuration's structure over the scene as it was at `scene_version`, or
/// why it could not be built.
struct PinnedStructure {
    params: StructureParams,
    scene_version: u64,
    structure: Result<Structure, String>,
    /// `pinned_builds` when it was built (or its traversal settings last changed).
    version: u64,
}

#[derive(Clone, Copy, PartialEq)]
struct SplitCostsKey {
    version: u64,
    node: usize,
    params: StructureParams,
}

/// One move, as undo replays it backwards.
#[derive(Clone)]
enum Motion {
    Triangles(Arc<Vec<u32>>, Vec3),
    Object(usize, Vec3),
}

/// Undo keeps this many drags.
const UNDO_DEPTH: usize = 64;

impl State {
    fn reply(&self, r: Reply) {
        let _ = self.replies.send(r);
        (self.wake)();
    }

    fn run(mut self, commands: Receiver<(u64, Command)>) {
        while let Ok(first) = commands.recv() {
            let mut batch = vec![first];
            batch.extend(commands.try_iter());
            let last_seq = batch.last().map_or(0, |(s, _)| *s);
            // Of several loads or builds waiting, only the newest matters (a slider dragged
            // across ten values asks for one build, not ten).
            let last_load = batch
                .iter()
                .rposition(|(_, c)| matches!(c, Command::Load(_)));
            let last_build = batch
                .iter()
                .rposition(|(_, c)| matches!(c, Command::Build { .. }));
            let mut job = None;
            let version = self.version;
            for (i, (_, command)) in batch.into_iter().enumerate() {
                let superseded = match command {
                    Command::Load(_) => Some(i) != last_load,
                    Command::Build { .. } => Some(i) != last_build,
                    _ => false,
                };
                if superseded {
                    continue;
                }
                match command {
                    Command::Render(j) => job = Some(j),
                    other => self.apply(other),
                }
            }
            // A new request, or the last one again if the scene or tree changed under it.
            let again = (self.version != version)
                .then(|| self.last_job.clone())
                .flatten();
            if let Some(j) = job.or(again) {
                self.render(j);
            }
            self.count_shown(last_seq);
            self.reply(Reply::Idle(last_seq));
        }
    }

    fn apply(&mut self, command: Command) {
        match command {
            Command::Load(spec) => match Scene::load(&spec) {
                Ok(mut scene) => {
                    // An interior from a file starts from inside it (see `start_view`).
                    if super::scene::is_file_spec(&spec) {
                        scene.view = scene
                            .view
                            .or_else(|| super::start_view::interior_view(&scene));
                    }
                    self.reply(Reply::Loaded {
                        spec,
                        scene: Arc::new(scene.clone()),
                    });
                    self.scene = Some(scene);
                    self.structure = None;
                    self.instance = None;
                    self.reference_bvh = None;
                    self.gesture.clear();
                    self.undo.clear();
                    self.version += 1;
                    self.scene_version += 1;
                    self.rebuild();
                }
                Err(e) => self.reply(Reply::LoadFailed {
                    spec,
                    error: e.to_string(),
                }),
            },
            Command::Build(params) => {
                let old = self.params;
                self.params = params;
                if old.needs_rebuild_for(&params) || self.structure.is_none() {
                    if !self.rebuild() {
                        self.params = old;
                    }
                } else if params != old {
                    if let Some(s) = &mut self.structure {
                        s.set_order(params.order);
                        s.set_mailbox(params.mailbox);
                        // A kernel this CPU lacks keeps the one the structure has.
                        let _ = s.set_simd(params.simd);
                    }
                    self.version += 1;
                }
            }
            Command::SetParams(params) => self.params = params,
            Command::Render(_) => {}
            Command::Rebuild => {
                self.rebuild();
            }
            Command::Snapshot => {
                if let Some(scene) = &self.scene {
                    self.reply(Reply::Snapshot(Arc::new(scene.clone())));
                }
            }
            Command::Move { triangles, delta } => {
                self.move_triangles(&triangles, delta);
                self.gesture.push(Motion::Triangles(triangles, delta));
            }
            Command::MoveObject { object, delta } => {
                if self.move_object(object, delta) {
                    self.gesture.push(Motion::Object(object, delta));
                }
            }
            Command::EndGesture => {
                if !self.gesture.is_empty() {
                    self.undo.push(std::mem::take(&mut self.gesture));
                    if self.undo.len() > UNDO_DEPTH {
                        self.undo.remove(0);
                    }
                }
            }
            Command::Replay(request) => {
                let replayed = self.replay(&request);
                self.reply(Reply::Replayed(replayed));
            }
            Command::SelectInstance(i) => self.select_instance(i),
            Command::SelectObject(object) => {
                let i = self.instance_of_object(object);
                self.select_instance(i);
            }
            Command::Undo => {
                let step = if self.gesture.is_empty() {
                    self.undo.pop().unwrap_or_default()
                } else {
                    std::mem::take(&mut self.gesture)
                };
                for motion in step.iter().rev() {
                    match motion {
                        Motion::Triangles(triangles, delta) => {
                            self.move_triangles(triangles, -*delta)
                        }
                        Motion::Object(object, delta) => {
                            self.move_object(*object, -*delta);
                        }
                    }
                }
            }
        }
    }

    /// Builds the structure for the current scene and parameters; false (and the old one
    /// kept) if the parameters are rejected.
    fn rebuild(&mut self) -> bool {
        let Some(scene) = &self.scene else {
            return true;
        };
        self.progress.0.store(0, Ordering::Relaxed);
        // The two levels count unique triangles, the others placed ones.
        let total = if self.params.kind == AccelKind::TwoLevel {
            scene.instancing().unique_triangles()
        } else {
            scene.triangles.len()
        };
        self.progress.1.store(total, Ordering::Relaxed);
        match structure::build_scene(scene, &self.params, &self.progress.0) {
            Ok(built) => {
                self.refit_index = None;
                self.outline = Arc::new(built.structure.outline());
                let sah = SahPrediction::of(&built.structure, &self.params, &scene.bounds());
                let (leaf_instances, leaf_references) = match &built.structure {
                    Structure::TwoLevel(tl) => (tl.leaf_instances(), tl.leaf_references()),
                    _ => (Vec::new(), Vec::new()),
                };
                self.leaf_references = leaf_references;
                self.reference_locator = Default::default();
                self.structure = Some(built.structure);
                self.leaf_instances = Arc::new(leaf_instances);
                self.version += 1;
                self.reply(Reply::Built {
                    report: Box::new(built.report),
                    bvh_report: built.bvh_report.map(Box::new),
                    outline: self.outline.clone(),
                    leaf_instances: self.leaf_instances.clone(),
                    sah,
                });
                // The selected instance hangs below another leaf of the new top level (or
                // the structure has no instances any more).
                let selected = self.instance.as_ref().map(|i| i.instance);
                self.select_instance(selected);
                true
            }
            Err(e) => {
                self.reply(Reply::BuildFailed(e.to_string()));
                false
            }
        }
    }

    fn move_triangles(&mut self, triangles: &Arc<Vec<u32>>, delta: Vec3) {
        let bounds = self.drag_bounds(triangles);
        let (Some(scene), Some(structure)) = (&mut self.scene, &mut self.structure) else {
            return;
        };
        scene.move_triangles(triangles, delta);
        self.scene_version += 1;
        // The standard light from the scene's box in its two parts, the selection's moved.
        if let Some(mut b) = bounds {
            b.selected = Aabb::new(b.selected.min + delta, b.selected.max + delta);
            b.scene_version = self.scene_version;
            let light = Scene::standard_light(&b.rest.union(b.selected));
            self.light = Some((self.scene_version, light));
            self.drag_bounds = Some(b);
        }
        let start = Instant::now();
        let p = &self.params.bvh;
        // Only the moved triangles' leaves and their ancestors change.
        let refit = structure.refit_moved(
            &mut self.refit_index,
            &scene.triangles,
            triangles,
            p.c_trav,
            p.c_isect,
        );
        if let Some(refit) = refit {
            if let Ok(r) = refit {
                self.version += 1;
                self.reply(Reply::Refitted {
                    sah_before: r.sah_before,
                    sah_after: r.sah_after,
                    refit_time: start.elapsed(),
                });
            }
            return;
        }
        // Any other structure is built again (a spatial one has no boxes to stretch).
        let Ok(built) = structure::build_scene(scene, &self.params, &Default::default()) else {
            return;
        };
        let rebuild_time = start.elapsed();
        *structure = built.structure;
        self.outline = Arc::new(structure.outline());
        self.version += 1;
        if self.reference_bvh.is_none()
            && let Ok((bvh, _)) = bvh::build(&scene.triangles, &bvh::BuildParams::default())
        {
            let index = RefitIndex::new(&bvh);
            self.reference_bvh = Some((bvh, index));
        }
        let bvh_refit_time = self.reference_bvh.as_mut().map(|(bvh, index)| {
            let start = Instant::now();
            let _ = bvh.refit_moved(index, &scene.triangles, triangles, p.c_trav, p.c_isect);
            start.elapsed()
        });
        self.reply(Reply::RebuiltAfterMove {
            rebuild_time,
            bvh_refit_time,
        });
    }

    /// The scene's box in two parts for a move of `triangles` now: kept from the last move
    /// if it moved the same selection and nothing else changed the scene since, else made
    /// (`None` for a scene with its own light, which needs no box).
    fn drag_bounds(&mut self, triangles: &Arc<Vec<u32>>) -> Option<DragBounds> {
        let scene = self.scene.as_ref().filter(|s| s.light.is_none())?;
        match self.drag_bounds.take() {
            Some(b)
                if b.scene_version == self.scene_version
                    && same_selection(&b.selection, triangles) =>
            {
                Some(b)
            }
            _ => DragBounds::new(scene, &self.selection_table(triangles), self.scene_version),
        }
    }

    /// The table of selection `triangles`, made again only for another selection or scene.
    fn selection_table(&self, triangles: &Arc<Vec<u32>>) -> Arc<SelectionTable> {
        let count = self.scene.as_ref().map_or(0, |s| s.triangles.len());
        let mut cache = self.selection.borrow_mut();
        if let Some(table) = cache.as_ref().filter(|t| t.is_for(triangles, count)) {
            return table.clone();
        }
        let table = Arc::new(SelectionTable::new(triangles, count));
        *cache = Some(table.clone());
        table
    }

    /// Replays a pixel through the structure as it is now, in the scene as it is now.
    fn replay(&self, r: &ReplayRequest) -> Result<Arc<Replay>, String> {
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return Err("there is no structure to replay yet".into());
        };
        let settings = RenderSettings {
            width: r.width,
            height: r.height,
            camera: r.camera,
            light: scene.light(),
            ..RenderSettings::for_scene(scene, r.width, r.height)
        };
        replay_pixel::<crate::geometry::Watertight>(structure, scene, &settings, r.pixel, r.rays)
            .map(Arc::new)
            .map_err(|e| e.to_string())
    }

    /// Moves object `object` by `delta`; true if it moved. Under the two levels: its
    /// instance (the scene's own, or the object itself as an instance of its triangles)
    /// moves, and the top level is refitted.
    fn move_object(&mut self, object: usize, delta: Vec3) -> bool {
        let (Some(scene), Some(structure)) = (&mut self.scene, &mut self.structure) else {
            return false;
        };
        let Some(range) = scene.objects.get(object).map(|o| o.range()) else {
            return false;
        };
        let Structure::TwoLevel(tl) = structure else {
            // Any other structure moves the object's triangles.
            let triangles: Arc<Vec<u32>> = Arc::new(range.map(|t| t as u32).collect());
            self.move_triangles(&triangles, delta);
            return true;
        };
        let start = Instant::now();
        let mut transform = glam::Affine3A::IDENTITY;
        let moved = if scene.instances.is_empty() {
            // Each object is an instance of its own triangles: the triangles move in the
            // scene, the instance in the structure.
            // (Only where the structure's instances are the objects: a scene whose objects
            // do not cover its triangles in order is one instance of them all.)
            let is_object = tl.instances.len() == scene.objects.len()
                && tl.first_triangle.get(object) == Some(&(range.start as u64));
            let Some(current) = tl.instances.get(object).filter(|_| is_object) else {
                return false;
            };
            transform = glam::Affine3A::from_translation(delta) * current.transform;
            let ok = tl.move_instance(object, transform).is_ok();
            if ok {
                for t in &mut scene.triangles[range.clone()] {
                    for v in &mut t.v {
                        *v += delta;
                    }
                }
            }
            ok
        } else {
            let Some(i) = scene.instance_of_object(object) else {
                return false;
            };
            match scene.translate_instance(i, delta) {
                Ok(placed) => {
                    transform = placed.transform;
                    let ok = tl.move_instance(i, placed.transform).is_ok();
                    if !ok {
                        let _ = scene.translate_instance(i, -delta);
                    }
                    ok
                }
                Err(_) => false,
            }
        };
        if !moved {
            return false;
        }
        let refit_time = start.elapsed();
        self.version += 1;
        self.scene_version += 1;
        // Beside it: a BVH over the flattened scene, refitted for the same triangles.
        let p = self.params.bvh;
        if self.reference_bvh.is_none()
            && scene.is_flattened()
            && let Ok((bvh, _)) = bvh::build(&scene.triangles, &bvh::BuildParams::default())
        {
            let index = RefitIndex::new(&bvh);
            self.reference_bvh = Some((bvh, index));
        }
        let flat_refit_time = self.reference_bvh.as_mut().map(|(bvh, index)| {
            let triangles: Vec<u32> = range.map(|t| t as u32).collect();
            let start = Instant::now();
            let _ = bvh.refit_moved(index, &scene.triangles, &triangles, p.c_trav, p.c_isect);
            start.elapsed()
        });
        self.reply(Reply::InstanceMoved {
            refit_time,
            flat_refit_time,
            object,
            transform,
        });
        // The selected instance's boxes move with it: the same BLAS under the same leaf (a
        // refit keeps the top level's shape), placed by the new transform.
        if let (Some(selected), Some(Structure::TwoLevel(tl))) = (&self.instance, &self.structure)
            && let Some(now) = tl.instances.get(selected.instance)
            && now.transform != selected.transform
        {
            let moved = Arc::new(InstanceOutline {
                transform: now.transform,
                ..InstanceOutline::clone(selected)
            });
            self.instance = Some(moved.clone());
            self.reply(Reply::InstanceSelected(Some(moved)));
        }
        true
    }

    /// The structure's instance that places scene object `object` (under the two levels):
    /// the scene's own instance, or the object itself as an instance of its own triangles
    /// where the structure's instances are the objects.
    fn instance_of_object(&self, object: usize) -> Option<usize> {
        let (Some(scene), Some(Structure::TwoLevel(tl))) = (&self.scene, &self.structure) else {
            return None;
        };
        if !scene.instances.is_empty() {
            return scene.instance_of_object(object);
        }
        let range = scene.objects.get(object)?.range();
        let is_object = tl.instances.len() == scene.objects.len()
            && tl.first_triangle.get(object) == Some(&(range.start as u64));
        // A scene whose objects do not cover its triangles in order is one instance.
        Some(if is_object { object } else { 0 }).filter(|&i| i < tl.instances.len())
    }

    /// Outlines instance `i`'s BLAS for the levels view and the walk (none under any other
    /// structure, or for no such instance) and tells the UI.
    fn select_instance(&mut self, i: Option<usize>) {
        let outlined = match (&self.structure, i) {
            (Some(Structure::TwoLevel(tl)), Some(i)) => tl.instance_outline(i).map(Arc::new),
            _ => None,
        };
        if outlined.is_none() && self.instance.is_none() {
            return;
        }
        // Only the overlay changes: the UI asks for a frame with the new selection.
        self.instance = outlined.clone();
        self.reply(Reply::InstanceSelected(outlined));
    }

    fn render(&mut self, job: RenderJob) {
        let light = self.light();
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return;
        };
        self.last_job = Some(job.clone());
        let key = TraceKey {
            camera: job.camera,
            width: job.width,
            height: job.height,
            version: self.version,
        };
        let settings = Self::trace_settings(light, &job);
        let (frame, traced) = match &self.traced {
            // A counted frame serves every mode; an uncounted one only a mode without counts.
            Some(t) if t.key == key && (t.counted || !settings.counters) => {
                (t.frame.clone(), false)
            }
            _ => {
                let f = Arc::new(trace(structure, scene, &settings));
                self.traced = Some(Traced {
                    key,
                    frame: f.clone(),
                    counted: settings.counters,
                });
                (f, true)
            }
        };
        let image_time = frame.summary.trace_time;
        let ((mut rgba, heat_max), compared, pinned_frame) = match job.compare {
            Some(c) => {
                let (image, compared, a) = self.compare(&frame, &c, &job);
                (image, Some(compared), a)
            }
            // A shaded frame comes coloured from the trace.
            None if job.mode == Mode::Shaded && !frame.rgba.is_empty() => {
                ((frame.rgba.clone(), None), None, None)
            }
            None => (colorize(&frame, job.mode, job.heat_max), None, None),
        };
        let walk = self.draw_overlay(&frame, &mut rgba, &job);
        self.reply(Reply::Frame(Arc::new(Shown {
            job,
            rgba,
            heat_max,
            frame,
            walk,
            traced,
            image_time,
            compared,
            pinned_frame,
        })));
    }

    /// The scene's light, worked out again only when the scene changed (the standard
    /// light follows the scene's box, a pass over every triangle).
    fn light(&mut self) -> Vec3 {
        match (self.light, &self.scene) {
            (Some((v, light)), _) if v == self.scene_version => light,
            (_, Some(scene)) => {
                let light = scene.light();
                self.light = Some((self.scene_version, light));
                light
            }
            (_, None) => Vec3::ZERO,
        }
    }

    /// After a full frame shown without counts: traces it again with counting and sends
    /// its counters (`Reply::Counted`), unless a command newer than `seq` is waiting (then
    /// the pass stops at once and is done after a later frame). The hits are the same, so
    /// the image does not change.
    fn count_shown(&mut self, seq: u64) {
        let Some(job) = self.last_job.clone().filter(|j| !j.preview) else {
            return;
        };
        let light = self.light();
        let (Some(scene), Some(structure), Some(traced)) =
            (&self.scene, &self.structure, &self.traced)
        else {
            return;
        };
        let key = TraceKey {
            camera: job.camera,
            width: job.width,
            height: job.height,
            version: self.version,
        };
        if traced.counted || traced.key != key {
            return;
        }
        let settings = RenderSettings {
            counters: true,
            ..Self::trace_settings(light, &job)
        };
        let latest = &self.latest;
        let newer = || latest.load(Ordering::Relaxed) > seq;
        // Not coloured again: the same hits give the shown frame's image.
        let Some(mut counted) =
            trace_uncoloured_unless::<_, Watertight>(structure, scene, &settings, &newer)
        else {
            return;
        };
        counted.rgba = traced.frame.rgba.clone();
        let frame = Arc::new(counted);
        self.traced = Some(Traced {
            key,
            frame: frame.clone(),
            counted: true,
        });
        self.reply(Reply::Counted { job, frame });
    }

    /// The settings a job's frames are traced with.
    fn trace_settings(light: Vec3, job: &RenderJob) -> RenderSettings {
        RenderSettings {
            width: job.width,
            height: job.height,
            camera: job.camera,
            light,
            mode: job.mode,
            heat_max: job.heat_max,
            // A preview skips the shadow rays unless they are what it shows.
            shadows: !job.preview || job.mode.counts_shadow_rays(),
            // Only a heatmap shows counts, and a comparison of full frames sums them. Any
            // other frame is traced without counting (its primary rays in packets, the same
            // hits); a full one is counted after it is shown (`count_shown`).
            counters: matches!(job.mode, Mode::Heatmap(..))
                || (!job.preview && job.compare.is_some()),
        }
    }

    /// B's frame `b` beside A's: the image in the job's view, the summary and A's frame.
    /// Without A (it cannot be built) or for a view the mode cannot show, B alone and why.
    fn compare(
        &mut self,
        b: &Frame,
        c: &CompareJob,
        job: &RenderJob,
    ) -> (Image, Compared, Option<Arc<Frame>>) {
        let b_alone = |error: String| {
            (
                colorize(b, job.mode, job.heat_max),
                Compared {
                    summaries: Vec::new(),
                    error: Some(error),
                },
            )
        };
        let a = match self.pinned_frame(&c.a, job) {
            Ok(a) => a,
            Err(e) => {
                let (image, compared) = b_alone(format!("A cannot be built: {e}"));
                return (image, compared, None);
            }
        };
        let summaries = if b.summary.counted() {
            compared_counters(job.mode)
                .into_iter()
                .filter_map(|(counter, rays)| summarize(&a, b, counter, rays).ok())
                .collect()
        } else {
            Vec::new()
        };
        match compare_image(&a, b, job.mode, job.heat_max, c.view) {
            Ok(image) => (
                image,
                Compared {
                    summaries,
                    error: None,
                },
                Some(a),
            ),
            Err(e) => {
                let (image, mut compared) = b_alone(e.to_string());
                compared.summaries = summaries;
                (image, compared, Some(a))
            }
        }
    }

    /// A's frame of the job's view: A is built (again) when it is new, its build
    /// parameters changed or the scene's triangles moved since, and traced again only when
    /// the view or A changed.
    fn pinned_frame(
        &mut self,
        params: &StructureParams,
        job: &RenderJob,
    ) -> Result<Arc<Frame>, String> {
        let Some(scene) = &self.scene else {
            return Err("there is no scene".into());
        };
        let current = self.pinned.as_mut().filter(|p| {
            p.scene_version == self.scene_version && !p.params.needs_rebuild_for(params)
        });
        match current {
            Some(p) if p.params != *params => {
                // Only traversal settings changed: no build.
                if let Ok(s) = &mut p.structure {
                    s.set_order(params.order);
                    s.set_mailbox(params.mailbox);
                    let _ = s.set_simd(params.simd);
                }
                p.params = *params;
                self.pinned_builds += 1;
                p.version = self.pinned_builds;
            }
            Some(_) => {}
            None => {
                self.pinned_builds += 1;
                let structure = structure::build_scene(scene, params, &AtomicUsize::new(0))
                    .map(|built| built.structure)
                    .map_err(|e| e.to_string());
                self.pinned = Some(PinnedStructure {
                    params: *params,
                    scene_version: self.scene_version,
                    structure,
                    version: self.pinned_builds,
                });
            }
        }
        let Some(pinned) = &self.pinned else {
            return Err("nothing is pinned".into());
        };
        let structure = pinned.structure.as_ref().map_err(Clone::clone)?;
        let key = TraceKey {
            camera: job.camera,
            width: job.width,
            height: job.height,
            version: pinned.version,
        };
        if let Some((k, f)) = &self.pinned_traced
            && *k == key
        {
            return Ok(f.clone());
        }
        let settings = Self::trace_settings(scene.light(), job);
        let frame = Arc::new(trace(structure, scene, &settings));
        self.pinned_traced = Some((key, frame.clone()));
        Ok(frame)
    }

    fn draw_overlay(&self, frame: &Frame, rgba: &mut [u8], job: &RenderJob) -> Option<WalkInfo> {
        let outline = &self.outline;
        let o = &job.overlay;
        let triangle_count = self.scene.as_ref().map_or(0, |s| s.triangles.len());
        if let Some(sel) = &o.selected {
            let selection = self.selection_table(sel);
            tint_triangles(frame, rgba, |t| {
                selection.contains(t).then_some([255, 230, 80, 110])
            });
        }
        let instance = self.instance.as_deref();
        let levels = Levels::new(outline, instance);
        if let Some(level) = o.level {
            let color = |i: usize| {
                if o.color_by_node {
                    palette(i)
                } else {
                    palette(level as usize)
                }
            };
            let nodes = levels.level(level);
            let mut boxes = Vec::new();
            for node in nodes {
                match (node, instance) {
                    (WalkNode::Top(i), _) => {
                        let n = &outline.nodes[i];
                        boxes.push(OutlinedBox {
                            bounds: n.bounds,
                            color: color(i),
                        });
                        // A k-d tree's split planes at this depth, in white over their cells.
                        if let Some(bounds) = n.plane {
                            boxes.push(OutlinedBox {
                                bounds,
                                color: [255, 255, 255, 230],
                            });
                        }
                    }
                    // The BLAS's boxes where the instance places them.
                    (WalkNode::Bottom(i), Some(inst)) => {
                        let corners = inst.world_corners(i);
                        outline_corners(
                            frame,
                            rgba,
                            &job.camera,
                            &corners,
                            color(i),
                            o.see_through,
                        );
                    }
                    (WalkNode::Bottom(_), None) => {}
                }
            }
            outline_boxes(frame, rgba, &job.camera, &boxes, o.see_through);
        }
        if let (Some([u, v]), Some(s)) = (o.probe, &self.structure) {
            let (w, h) = (frame.width, frame.height);
            let (x, y) = ((u * w as f32) as u32, (v * h as f32) as u32);
            let ray = job
                .camera
                .rays(w, h)
                .pixel_center(x.min(w - 1), y.min(h - 1));
            if let Some(cells) = s.cells_along(&ray) {
                let boxes: Vec<OutlinedBox> = cells
                    .into_iter()
                    .map(|bounds| OutlinedBox {
                        bounds,
                        color: [255, 230, 80, 255],
                    })
                    .collect();
                outline_boxes(frame, rgba, &job.camera, &boxes, true);
            }
        }
        let id = o.walk?;
        let node = levels.node(id)?;
        if let (WalkNode::Bottom(k), Some(inst)) = (node, instance) {
            return Some(self.draw_blas_walk(frame, rgba, job, &levels, inst, k));
        }
        let WalkNode::Top(node) = node else {
            return None;
        };
        let n = &outline.nodes[node];
        let whole_instance = match (&self.structure, self.leaf_references.get(node)) {
            (Some(Structure::TwoLevel(tl)), Some(&r)) => tl
                .references
                .get(r as usize)
                .is_some_and(|r| r.subtree == crate::accel::bvh::Subtree::ROOT),
            _ => false,
        };
        let mut info = WalkInfo {
            node: id,
            depth: n.depth,
            instance: self.leaf_instance(node),
            in_blas: false,
            whole_instance,
            surface_area: n.bounds.surface_area(),
            triangles: 0,
            sah_cost: 0.0,
            children: levels
                .children(WalkNode::Top(node))
                .into_iter()
                .map(|c| levels.id(c) as usize)
                .collect(),
            split_costs: None,
        };
        let mut boxes = vec![OutlinedBox {
            bounds: n.bounds,
            color: [255, 255, 255, 255],
        }];
        let p = &self.params.bvh;
        let entry = instance.and_then(|i| Some((i, i.entry_below(node as u32)?)));
        if let (Some((inst, b)), true) = (entry, n.is_leaf()) {
            // A leaf of the selected instance: the subtree of its BLAS below it, placed.
            let under: std::collections::HashSet<u64> =
                inst.triangles_under(b as usize).into_iter().collect();
            info.triangles = under.len();
            info.sah_cost = p.c_isect * info.triangles as f32;
            let corners = inst.world_corners(b as usize);
            outline_corners(frame, rgba, &job.camera, &corners, FIRST_CHILD, true);
            tint_triangles(frame, rgba, |t| under.contains(&t).then_some(FIRST_CHILD));
        } else if let Some(Structure::TwoLevel(tl)) = &self.structure {
            // The top level's nodes hold references: their triangles are counted and tinted
            // by reference, never listed (the island places 10^10).
            let children: Vec<usize> = if n.is_leaf() {
                vec![node]
            } else {
                n.children().collect()
            };
            let count = children.len();
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            info.sah_cost = if n.is_leaf() { 0.0 } else { p.c_trav };
            let mut side = std::collections::HashMap::new();
            for (k, &c) in children.iter().enumerate() {
                let mut under = 0u64;
                for r in self.references_under(c) {
                    under += tl.references[r as usize].triangles as u64;
                    side.insert(r, k as u8);
                }
                info.triangles += under as usize;
                let weight = if n.is_leaf() {
                    1.0
                } else {
                    outline.nodes[c].bounds.surface_area() / area
                };
                info.sah_cost += weight * under as f32 * p.c_isect;
                if !n.is_leaf() {
                    let [r, g, b, _] = child_color(k, count);
                    boxes.push(OutlinedBox {
                        bounds: outline.nodes[c].bounds,
                        color: [r, g, b, 255],
                    });
                }
            }
            let locator = self
                .reference_locator
                .get_or_init(|| tl.reference_locator());
            tint_triangles(frame, rgba, |t| {
                let r = tl.reference_of_triangle(locator, t)?;
                side.get(&r).map(|&k| child_color(k as usize, count))
            });
        } else if n.is_leaf() {
            let under = outline.triangles_under(node);
            info.triangles = under.len();
            info.sah_cost = p.c_isect * under.len() as f32;
            let mut mark = vec![false; triangle_count];
            for &t in &under {
                if let Some(m) = mark.get_mut(t as usize) {
                    *m = true;
                }
            }
            tint_triangles(frame, rgba, |t| {
                (mark.get(t as usize) == Some(&true)).then_some(FIRST_CHILD)
            });
        } else {
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            let count = info.children.len();
            // Which child a triangle lies under (the last one wins where cells share it).
            let mut side = vec![u8::MAX; triangle_count];
            let mut all = std::collections::HashSet::new();
            info.sah_cost = p.c_trav;
            for (k, c) in n.children().enumerate() {
                let under = outline.triangles_under(c);
                let child = &outline.nodes[c];
                info.sah_cost +=
                    child.bounds.surface_area() / area * under.len() as f32 * p.c_isect;
                for &t in &under {
                    if let Some(s) = side.get_mut(t as usize) {
                        *s = k as u8;
                    }
                }
                all.extend(under);
                let [r, g, b, _] = child_color(k, count);
                boxes.push(OutlinedBox {
                    bounds: child.bounds,
                    color: [r, g, b, 255],
                });
            }
            info.triangles = all.len();
            if count == 2 {
                info.split_costs = self.split_costs_of(outline, node, all);
            }
            tint_triangles(frame, rgba, |t| match side.get(t as usize) {
                Some(&k) if k != u8::MAX => Some(child_color(k as usize, count)),
                _ => None,
            });
            if let Some(plane) = n.plane {
                boxes.push(OutlinedBox {
                    bounds: plane,
                    color: [255, 255, 255, 255],
                });
            }
        }
        outline_boxes(frame, rgba, &job.camera, &boxes, true);
        Some(info)
    }

    /// Under the two levels: the references in the top-level leaves under outline node
    /// `node`.
    fn references_under(&self, node: usize) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![node];
        while let Some(k) = stack.pop() {
            let Some(n) = self.outline.nodes.get(k) else {
                continue;
            };
            if n.is_leaf() {
                out.extend(self.leaf_references.get(k).filter(|&&r| r != u32::MAX));
            } else {
                stack.extend(n.children());
            }
        }
        out
    }

    /// Under the two levels: the instance top-level outline node `node` holds, if a leaf.
    fn leaf_instance(&self, node: usize) -> Option<usize> {
        self.leaf_instances
            .get(node)
            .filter(|&&i| i != u32::MAX)
            .map(|&i| i as usize)
    }

    /// The walk at node `k` of the selected instance's BLAS: its placed box, its children's
    /// placed boxes and their triangles tinted. Areas and the SAH cost are the BLAS's own,
    /// in the mesh's space, where it was built.
    fn draw_blas_walk(
        &self,
        frame: &Frame,
        rgba: &mut [u8],
        job: &RenderJob,
        levels: &Levels,
        inst: &InstanceOutline,
        k: usize,
    ) -> WalkInfo {
        let blas = &inst.blas;
        let n = &blas.nodes[k];
        let p = &self.params.bvh;
        let mut info = WalkInfo {
            node: levels.id(WalkNode::Bottom(k)),
            depth: levels.depth(WalkNode::Bottom(k)),
            instance: Some(inst.instance),
            in_blas: true,
            whole_instance: false,
            surface_area: n.bounds.surface_area(),
            triangles: 0,
            sah_cost: 0.0,
            children: n
                .children()
                .map(|c| levels.id(WalkNode::Bottom(c)) as usize)
                .collect(),
            split_costs: None,
        };
        // Which child each of the mesh's triangles lies under (the mesh, not the scene:
        // bounded whatever the instancing places).
        let mut side = vec![u8::MAX; inst.triangle_count];
        let count = n.child_count as usize;
        if n.is_leaf() {
            let under = blas.triangles_under(k);
            info.triangles = under.len();
            info.sah_cost = p.c_isect * under.len() as f32;
            for &t in &under {
                if let Some(s) = side.get_mut(t as usize) {
                    *s = 0;
                }
            }
        } else {
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            info.sah_cost = p.c_trav;
            for (j, c) in n.children().enumerate() {
                let under = blas.triangles_under(c);
                info.sah_cost +=
                    blas.nodes[c].bounds.surface_area() / area * under.len() as f32 * p.c_isect;
                info.triangles += under.len();
                for &t in &under {
                    if let Some(s) = side.get_mut(t as usize) {
                        *s = j as u8;
                    }
                }
                let [r, g, b, _] = child_color(j, count);
                outline_corners(
                    frame,
                    rgba,
                    &job.camera,
                    &inst.world_corners(c),
                    [r, g, b, 255],
                    true,
                );
            }
        }
        let first = inst.first_triangle;
        tint_triangles(frame, rgba, |t| {
            let local = usize::try_from(t.checked_sub(first)?).ok()?;
            match side.get(local) {
                Some(&j) if j != u8::MAX => Some(child_color(j as usize, count.max(1))),
                _ => None,
            }
        });
        let own = inst.world_corners(k);
        outline_corners(frame, rgba, &job.camera, &own, [255, 255, 255, 255], true);
        info
    }

    /// The bucket-cost plot's data for node `node` of the outline (`under`: the scene
    /// triangles below it), for a BVH2 or a k-d tree; computed once per node and tree.
    fn split_costs_of(
        &self,
        outline: &Outline,
        node: usize,
        under: std::collections::HashSet<u32>,
    ) -> Option<Arc<SplitCosts>> {
        let key = SplitCostsKey {
            version: self.version,
            node,
            params: self.params,
        };
        let mut cache = self.split_costs.borrow_mut();
        if let Some((k, costs)) = cache.as_ref()
            && *k == key
        {
            return Some(costs.clone());
        }
        let costs = match self.structure.as_ref()? {
            Structure::Bvh(_) => {
                let scene = self.scene.as_ref()?;
                let mut under: Vec<u32> = under.into_iter().collect();
                under.sort_unstable();
                split_costs(&scene.triangles, &under, &self.params.bvh)
            }
            Structure::KdTree(tree) => {
                // The way down from the root: below (first) or above (second) child.
                let mut path = Vec::new();
                let mut i = node;
                while let Some(&parent) = outline.nodes.get(i).map(|n| &n.parent)
                    && parent != u32::MAX
                {
                    path.push(i as u32 != outline.nodes[parent as usize].first_child);
                    i = parent as usize;
                }
                path.reverse();
                tree.split_costs(&self.params.kdtree, &path)?
            }
            _ => return None,
        };
        let costs = Arc::new(costs);
        *cache = Some((key, costs.clone()));
        Some(costs)
    }
}

/// The tree walk's colours: the first child, the second of two, the palette beyond.
const FIRST_CHILD: [u8; 4] = [255, 140, 40, 150];
const SECOND_CHILD: [u8; 4] = [60, 170, 255, 150];

fn child_color(k: usize, count: usize) -> [u8; 4] {
    match (k, count) {
        (0, _) => FIRST_CHILD,
        (1, 2) => SECOND_CHILD,
        _ => {
            let [r, g, b, _] = palette(k);
            [r, g, b, 150]
        }
    }
}

/// Shared slot for a file chosen in a dialog running on its own thread.
pub type Picked = Arc<Mutex<Option<std::path::PathBuf>>>;
