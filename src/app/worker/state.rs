//! The worker's state and its command loop: the scene, the structure built over it and the
//! frames traced from it; commands are taken in batches, superseded loads and builds are
//! skipped, and only the newest render request is rendered.

use super::messages::*;
use super::motion::{DragBounds, MovedTriangles, SelectionTable};
use crate::accel::Outline;
use crate::accel::bvh::Bvh;
use crate::accel::bvh::refit::RefitIndex;
use crate::accel::progress::BuildProgress;
use crate::accel::sah_check::SahPrediction;
use crate::accel::split_costs::SplitCosts;
use crate::accel::structure::{self, Built, Structure, StructureError, StructureParams};
use crate::accel::two_level::{InstanceOutline, ReferenceLocator};
use crate::geometry::Triangle;
use crate::render::Frame;
use crate::scene::{Camera, Scene};
use glam::Vec3;
use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};

/// The key under which a traced frame stays valid.
#[derive(Clone, PartialEq)]
pub(in crate::app) struct TraceKey {
    pub(in crate::app) camera: Camera,
    pub(in crate::app) width: u32,
    pub(in crate::app) height: u32,
    pub(in crate::app) version: u64,
}

/// A traced frame, the view it is valid for, and whether it was traced with counting.
pub(in crate::app) struct Traced {
    pub(in crate::app) key: TraceKey,
    pub(in crate::app) frame: Arc<Frame>,
    pub(in crate::app) counted: bool,
}

pub(in crate::app) struct State {
    pub(in crate::app) replies: Sender<Reply>,
    /// The newest command the UI has sent.
    pub(in crate::app) latest: Arc<AtomicU64>,
    /// The newest command sent that replaces a build (`Command::replaces_the_build`).
    pub(in crate::app) newest_build: Arc<AtomicU64>,
    /// The number of the command being applied: its build is abandoned once
    /// `newest_build` passes it.
    pub(in crate::app) applying: u64,
    /// The light (the scene's, or the standard one from its box) at `scene_version`.
    pub(in crate::app) light: Option<(u64, Vec3)>,
    pub(in crate::app) wake: Box<dyn Fn() + Send + Sync>,
    pub(in crate::app) progress: Arc<(AtomicUsize, AtomicUsize)>,
    pub(in crate::app) trace_progress: Arc<(AtomicUsize, AtomicUsize)>,
    /// A frame given up for a newer command: traced once the commands are handled, unless
    /// a newer frame is asked for.
    pub(in crate::app) pending: Option<RenderJob>,
    /// Whether the last full frame took long (or the structure is new since): the next
    /// full frame then shows a coarse image first.
    pub(in crate::app) slow_trace: bool,
    pub(in crate::app) scene: Option<Scene>,
    pub(in crate::app) structure: Option<Structure>,
    pub(in crate::app) params: StructureParams,
    pub(in crate::app) outline: Arc<Outline>,
    /// The structure was refitted since `outline` was made: its boxes are out of date.
    pub(in crate::app) outline_stale: bool,
    /// The outline as the last build left it: after moves, the level boxes are drawn over
    /// a faint ghost of these, so a refit's stretching is seen.
    pub(in crate::app) built_outline: Arc<Outline>,
    /// The triangles moved since the last build (highlighted while levels are shown).
    pub(in crate::app) moved: MovedTriangles,
    /// Under the two levels: the selected instance's BLAS, and the instance each top-level
    /// leaf holds.
    pub(in crate::app) instance: Option<Arc<InstanceOutline>>,
    pub(in crate::app) leaf_instances: Arc<Vec<u32>>,
    /// Under the two levels: the reference each top-level leaf holds, and which reference
    /// reaches each triangle (made when a walk first needs it).
    pub(in crate::app) leaf_references: Vec<u32>,
    pub(in crate::app) reference_locator: std::sync::OnceLock<ReferenceLocator>,
    /// Under a structure that cannot refit: a BVH over the same triangles, refitted on every
    /// move only to show what a refit would have cost. Made at the first move.
    pub(in crate::app) reference_bvh: Option<(Bvh, RefitIndex)>,
    /// Changes whenever the scene's triangles or the tree change.
    pub(in crate::app) version: u64,
    /// Changes whenever the scene's triangles change (load, move, undo): A is built again.
    pub(in crate::app) scene_version: u64,
    /// Configuration A of a comparison, built over the same scene as B.
    pub(in crate::app) pinned: Option<PinnedStructure>,
    /// Builds of A so far: A's frames are traced again after each.
    pub(in crate::app) pinned_builds: u64,
    pub(in crate::app) traced: Option<Traced>,
    pub(in crate::app) pinned_traced: Option<(TraceKey, Arc<Frame>)>,
    pub(in crate::app) last_job: Option<RenderJob>,
    /// For partial refits of the current tree; made at the first move after a build.
    pub(in crate::app) refit_index: Option<RefitIndex>,
    /// Moves of the drag in progress, then finished drags (for undo).
    pub(in crate::app) gesture: Vec<Motion>,
    pub(in crate::app) undo: Vec<Vec<Motion>>,
    /// While an undo replays its moves backwards (their refits take back chart points).
    pub(in crate::app) undoing: bool,
    /// The walk node's split costs, kept while the tree, the node and the parameters stay.
    pub(in crate::app) split_costs: RefCell<Option<(SplitCostsKey, Arc<SplitCosts>)>>,
    /// The move tool's selection as a table, kept while the selection and the scene stay.
    pub(in crate::app) selection: RefCell<Option<Arc<SelectionTable>>>,
    /// While a selection is dragged: the boxes the standard light is placed from.
    pub(in crate::app) drag_bounds: Option<DragBounds>,
    /// The next lecture step's scene and structure, made at quiet moments.
    pub(in crate::app) prefetch: Option<super::prefetch::Prefetch>,
    /// The `version` whose tree's EPO was sent last.
    pub(in crate::app) epo_version: Option<u64>,
    /// Under the two levels: the `version` and selected instance whose BLAS's EPO was sent
    /// last.
    pub(in crate::app) blas_epo_for: Option<(u64, usize)>,
    /// The crack view made last, kept while the view, offset, scene and tree stay.
    pub(in crate::app) crack_view: Option<(
        super::cracks::CrackKey,
        Arc<crate::render::cracks::CrackView>,
    )>,
}

/// An image's pixels and its heatmap scale, as `colorize` gives them.
pub(in crate::app) type Image = (Vec<u8>, Option<u32>);

/// The pinned configuration's structure over the scene as it was at `scene_version`, or
/// why it could not be built.
pub(in crate::app) struct PinnedStructure {
    pub(in crate::app) params: StructureParams,
    pub(in crate::app) scene_version: u64,
    pub(in crate::app) structure: Result<Structure, String>,
    /// `pinned_builds` when it was built (or its traversal settings last changed).
    pub(in crate::app) version: u64,
    /// Its tree for the hierarchy diagram, made when a frame first shows A.
    pub(in crate::app) tree: Option<Arc<PinnedTree>>,
}

#[derive(Clone, Copy, PartialEq)]
pub(in crate::app) struct SplitCostsKey {
    pub(in crate::app) version: u64,
    pub(in crate::app) node: usize,
    pub(in crate::app) params: StructureParams,
}

/// One move, as undo replays it backwards: by −delta, except the first move of a drag,
/// which puts back the positions from before it (`Origin`), so undo ends bit for bit where
/// the drag started and not within rounding of it.
#[derive(Clone)]
pub(in crate::app) enum Motion {
    Triangles(Arc<Vec<u32>>, Vec3, Option<Arc<Origin>>),
    Object(usize, Vec3, Option<Arc<Origin>>),
}

/// Where a drag started: the moved triangles' positions and, for an instance, its
/// transform.
pub(in crate::app) struct Origin {
    pub(in crate::app) triangles: Vec<Triangle>,
    pub(in crate::app) transform: Option<glam::Affine3A>,
}

/// Random lines for the SAH's prediction of each build: a mean within about a per cent,
/// quick enough for every rebuild.
pub(in crate::app) const SAH_RANDOM_LINES: usize = 1 << 14;

/// Undo keeps this many drags.
pub(in crate::app) const UNDO_DEPTH: usize = 64;

impl State {
    pub(in crate::app) fn reply(&self, r: Reply) {
        let _ = self.replies.send(r);
        (self.wake)();
    }

    pub(in crate::app) fn run(mut self, commands: Receiver<(u64, Command)>) {
        loop {
            // With work left for a quiet moment (the shown tree's EPO first, then the
            // next lecture step), the moment is used for it.
            let idle_work = if self.epo_waiting() {
                Some(super::epo::IDLE_BEFORE)
            } else {
                self.prefetch_waiting()
                    .then_some(super::prefetch::IDLE_BEFORE)
            };
            let first = if let Some(idle) = idle_work {
                match commands.recv_timeout(idle) {
                    Ok(c) => c,
                    Err(RecvTimeoutError::Timeout) => {
                        if self.epo_waiting() {
                            self.epo_now();
                        } else {
                            self.prefetch_now();
                        }
                        continue;
                    }
                    Err(RecvTimeoutError::Disconnected) => break,
                }
            } else {
                match commands.recv() {
                    Ok(c) => c,
                    Err(_) => break,
                }
            };
            let mut batch = vec![first];
            batch.extend(commands.try_iter());
            let last_seq = batch.last().map_or(0, |(s, _)| *s);
            // Of several loads or builds waiting, only the newest matters (a slider dragged
            // across ten values asks for one build, not ten).
            let last_load = batch
                .iter()
                .rposition(|(_, c)| matches!(c, Command::Load(_) | Command::Adopt(..)));
            let last_build = batch
                .iter()
                .rposition(|(_, c)| matches!(c, Command::Build { .. }));
            let mut job = None;
            let version = self.version;
            for (i, (seq, command)) in batch.into_iter().enumerate() {
                let superseded = match command {
                    Command::Load(_) | Command::Adopt(..) => Some(i) != last_load,
                    Command::Build { .. } => Some(i) != last_build,
                    _ => false,
                };
                if superseded {
                    continue;
                }
                self.applying = seq;
                match command {
                    Command::Render(j) => job = Some(j),
                    other => self.apply(other),
                }
            }
            // A new request, or the last one again if the scene or tree changed under it.
            let again = (self.version != version)
                .then(|| self.last_job.clone())
                .flatten();
            // A frame given up earlier is wanted unless a newer one is asked for (it is the
            // last job, so it also serves as the frame again after a change).
            let pending = self.pending.take();
            if let Some(j) = job.or(pending).or(again) {
                self.render(j, last_seq);
            }
            self.count_shown(last_seq);
            self.reply(Reply::Idle(last_seq));
        }
    }

    pub(in crate::app) fn apply(&mut self, command: Command) {
        match command {
            Command::Load(spec) => match self.take_prefetched(&spec) {
                Some((scene, built)) => self.adopt_built(spec, scene, built),
                None => {
                    // A prefetch of another scene is of no more use: the lecture is left,
                    // or a step opened out of order (the step sends its own next one after).
                    self.prefetch = None;
                    match Scene::load(&spec) {
                        Ok(scene) => self.adopt(spec, scene),
                        Err(e) => self.reply(Reply::LoadFailed {
                            spec,
                            error: e.to_string(),
                        }),
                    }
                }
            },
            Command::Prefetch { spec, params } => self.want_prefetch(spec, params),
            Command::Adopt(spec, scene) => self.adopt(spec, *scene),
            Command::Build(params) => {
                let old = self.params;
                self.params = params;
                // Another structure's frame time is unknown: its first frame comes coarse.
                self.slow_trace |= old.kind != params.kind;
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
                let origin = self.origin_of_triangles(&triangles);
                self.move_triangles(&triangles, delta, None);
                self.gesture
                    .push(Motion::Triangles(triangles, delta, origin));
            }
            Command::MoveObject { object, delta } => {
                let origin = self.origin_of_object(object);
                if self.move_object(object, delta, None) {
                    self.gesture.push(Motion::Object(object, delta, origin));
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
            Command::Cracks(request) => self.cracks(request),
            Command::NodeVisits(request) => {
                let visits = self.node_visits(&request);
                self.reply(Reply::NodeVisits(request, visits));
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
                self.undoing = true;
                for motion in step.iter().rev() {
                    match motion {
                        Motion::Triangles(triangles, delta, origin) => {
                            self.move_triangles(triangles, -*delta, origin.as_deref())
                        }
                        Motion::Object(object, delta, origin) => {
                            self.move_object(*object, -*delta, origin.as_deref());
                        }
                    }
                }
                self.undoing = false;
            }
        }
    }

    /// Builds the structure for the current scene and parameters; false (and the old one
    /// kept) if the parameters are rejected.
    /// Makes `scene`, loaded from `spec`, the one the worker builds over and traces.
    fn adopt(&mut self, spec: String, scene: Scene) {
        self.adopt_built(spec, scene, None);
    }

    /// `adopt`, with the structure over `scene` built already (prefetched), if given.
    fn adopt_built(
        &mut self,
        spec: String,
        mut scene: Scene,
        built: Option<super::prefetch::Prebuilt>,
    ) {
        // An interior from a file starts from inside it (see `start_view`).
        if crate::app::scene::is_file_spec(&spec) {
            scene.view = scene
                .view
                .or_else(|| crate::app::start_view::interior_view(&scene));
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
        // So is a new scene's.
        self.slow_trace = true;
        match built {
            Some((built, sah)) => self.install(built, sah),
            None => {
                self.rebuild();
            }
        }
    }

    pub(in crate::app) fn rebuild(&mut self) -> bool {
        if self.rebuild_top_level_only() {
            return true;
        }
        let Some(scene) = &self.scene else {
            return true;
        };
        self.progress.0.store(0, Ordering::Relaxed);
        // The two levels count unique triangles, the others placed ones.
        let total = if self.params.kind.places_instances() {
            scene.instancing().unique_triangles()
        } else {
            scene.triangles.len()
        };
        self.progress.1.store(total, Ordering::Relaxed);
        let progress = BuildProgress::counting(&self.progress.0)
            .abandoned_after(&self.newest_build, self.applying);
        match structure::build_scene(scene, &self.params, &progress) {
            Ok(built) => {
                let sah = predict_sah(&built, &self.params, scene);
                self.install(built, sah);
                true
            }
            // A newer scene or structure is waiting and builds next: the old tree no
            // longer matches the parameters, and nothing failed.
            Err(StructureError::Abandoned) => {
                self.structure = None;
                true
            }
            Err(e) => {
                self.reply(Reply::BuildFailed(e.to_string()));
                false
            }
        }
    }

    /// Under the two levels over a scene of instances where only instances moved since
    /// the build (no triangle), rebuilds the top level alone over them where they are: the
    /// meshes did not change, so neither do their BLASes (the lecture's dynamic scene).
    /// False, changing nothing, where a whole build is needed.
    fn rebuild_top_level_only(&mut self) -> bool {
        let (Some(scene), Some(Structure::TwoLevel(levels))) = (&self.scene, &mut self.structure)
        else {
            return false;
        };
        if scene.instances.is_empty() || !self.moved.is_empty() || levels.params != self.params.bvh
        {
            return false;
        }
        let start = std::time::Instant::now();
        if levels.rebuild_top_level().is_err() {
            return false;
        }
        let report = levels.top_level_report(scene.placed_triangles(), start.elapsed());
        let Some(structure) = self.structure.take() else {
            return false;
        };
        let built = Built {
            structure,
            report,
            bvh_report: None,
        };
        let sah = predict_sah(&built, &self.params, scene);
        self.install(built, sah);
        true
    }

    /// Makes `built` (over the current scene) the structure the worker traces, and says so
    /// with its SAH prediction (`predict_sah`).
    fn install(&mut self, built: Built, sah: Option<SahPrediction>) {
        self.refit_index = None;
        self.outline = Arc::new(built.structure.outline());
        self.outline_stale = false;
        self.built_outline = self.outline.clone();
        self.moved.clear();
        let (leaf_instances, leaf_references) = built.structure.leaf_instances_and_references();
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
    }
}

/// The SAH's prediction of `built` against random lines through `scene` (`None` for a
/// structure the SAH does not describe). Part of installing a build; a prefetch makes it
/// ahead too, since on a scene whose lines each test hundreds of triangles it takes as
/// long as the first frame.
pub(in crate::app) fn predict_sah(
    built: &Built,
    params: &StructureParams,
    scene: &Scene,
) -> Option<SahPrediction> {
    SahPrediction::of(&built.structure, params, &scene.bounds(), SAH_RANDOM_LINES)
}
