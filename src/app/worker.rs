//! The worker thread: it owns the scene and its BVH, takes commands from the UI (load,
//! build, render a view, move triangles, undo) and answers with results. The UI thread never
//! builds or traces. Commands that pile up while the worker is busy are taken together, and
//! only the newest render request among them is rendered.
//!
//! Nothing is redone that did not change: a frame is traced again only when the camera,
//! the size, the scene or the tree changed; a new colour mode or overlay recolours the
//! traced frame.

use crate::accel::bvh::refit::RefitIndex;
use crate::accel::bvh::{BuildParams, BuildReport, Bvh, TraversalOrder, build_with_progress};
use crate::render::overlay::{OutlinedBox, outline_boxes, palette, tint_triangles};
use crate::render::{Frame, Mode, RenderSettings, colorize, trace};
use crate::scene::{Camera, Scene};
use glam::Vec3;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What to draw over the traced image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overlay {
    /// Tint these triangles: the selection of the move tool.
    pub selected: Option<Arc<Vec<u32>>>,
    /// Outline every node at this depth.
    pub level: Option<u32>,
    /// The node of the tree walk: its box, its children's boxes, their triangles tinted.
    pub walk: Option<u32>,
    pub see_through: bool,
    /// Colour level boxes by node instead of by depth.
    pub color_by_node: bool,
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
}

pub enum Command {
    /// A built-in scene name or an OBJ path.
    Load(String),
    Build {
        params: BuildParams,
        order: TraversalOrder,
    },
    Render(RenderJob),
    /// Move these scene triangles by `delta` and refit.
    Move {
        triangles: Arc<Vec<u32>>,
        delta: Vec3,
    },
    /// The drag that made the last moves is over: they form one undo step.
    EndGesture,
    /// Build again over the triangles as they are now.
    Rebuild,
    /// Send the scene with its triangles where they are now (after moves).
    Snapshot,
    Undo,
}

/// The shape of a tree, for the UI's node walk: parents, children, depths.
#[derive(Clone, Debug, Default)]
pub struct TreeShape {
    pub parent: Vec<u32>,
    /// Left child index, `u32::MAX` for leaves (the right child is `left + 1`).
    pub left: Vec<u32>,
    pub depth: Vec<u32>,
    pub max_depth: u32,
}

/// What the walk's current node is, in the lecture's terms.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WalkInfo {
    pub node: u32,
    pub depth: u32,
    pub triangles: usize,
    pub surface_area: f32,
    /// For an interior node, C = C_trav + S_A/S_N·N_A·C_isect + S_B/S_N·N_B·C_isect; for a
    /// leaf, N·C_isect.
    pub sah_cost: f32,
    pub children: Option<[usize; 2]>,
}

/// A frame as the UI shows it.
pub struct Shown {
    pub job: RenderJob,
    pub rgba: Vec<u8>,
    pub heat_max: Option<u32>,
    pub frame: Arc<Frame>,
    pub walk: Option<WalkInfo>,
    /// Whether this frame was traced (rather than only recoloured).
    pub traced: bool,
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
        report: BuildReport,
        shape: Arc<TreeShape>,
    },
    BuildFailed(String),
    Refitted {
        sah_before: f64,
        sah_after: f64,
        refit_time: Duration,
    },
    Frame(Arc<Shown>),
    Snapshot(Arc<Scene>),
    /// Every command up to this sequence number has been handled.
    Idle(u64),
}

/// The UI's handle on the worker thread.
pub struct Worker {
    tx: Option<Sender<(u64, Command)>>,
    rx: Receiver<Reply>,
    sent: u64,
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
        let state = State {
            replies,
            wake: Box::new(wake),
            progress: progress.clone(),
            scene: None,
            bvh: None,
            params: BuildParams::default(),
            order: TraversalOrder::default(),
            shape: Arc::new(TreeShape::default()),
            version: 0,
            traced: None,
            last_job: None,
            refit_index: None,
            gesture: Vec::new(),
            undo: Vec::new(),
        };
        let thread = std::thread::Builder::new()
            .name("bvhlab-worker".into())
            .spawn(move || state.run(commands))
            .ok();
        Worker {
            tx: Some(tx),
            rx,
            sent: 0,
            done: 0,
            progress,
            thread,
        }
    }

    pub fn send(&mut self, command: Command) {
        self.sent += 1;
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

struct State {
    replies: Sender<Reply>,
    wake: Box<dyn Fn() + Send>,
    progress: Arc<(AtomicUsize, AtomicUsize)>,
    scene: Option<Scene>,
    bvh: Option<Bvh>,
    params: BuildParams,
    order: TraversalOrder,
    shape: Arc<TreeShape>,
    /// Changes whenever the scene's triangles or the tree change.
    version: u64,
    traced: Option<(TraceKey, Arc<Frame>)>,
    last_job: Option<RenderJob>,
    /// For partial refits of the current tree; made at the first move after a build.
    refit_index: Option<RefitIndex>,
    /// Moves of the drag in progress, then finished drags (for undo).
    gesture: Vec<(Arc<Vec<u32>>, Vec3)>,
    undo: Vec<Vec<(Arc<Vec<u32>>, Vec3)>>,
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
            self.reply(Reply::Idle(last_seq));
        }
    }

    fn apply(&mut self, command: Command) {
        match command {
            Command::Load(spec) => match Scene::load(&spec) {
                Ok(scene) => {
                    self.reply(Reply::Loaded {
                        spec,
                        scene: Arc::new(scene.clone()),
                    });
                    self.scene = Some(scene);
                    self.bvh = None;
                    self.gesture.clear();
                    self.undo.clear();
                    self.version += 1;
                    self.rebuild();
                }
                Err(e) => self.reply(Reply::LoadFailed {
                    spec,
                    error: e.to_string(),
                }),
            },
            Command::Build { params, order } => {
                let (old_params, old_order) = (self.params, self.order);
                self.params = params;
                self.order = order;
                if params != old_params || self.bvh.is_none() {
                    if !self.rebuild() {
                        self.params = old_params;
                    }
                } else if order != old_order {
                    if let Some(b) = &mut self.bvh {
                        b.order = order;
                    }
                    self.version += 1;
                }
            }
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
                self.gesture.push((triangles, delta));
            }
            Command::EndGesture => {
                if !self.gesture.is_empty() {
                    self.undo.push(std::mem::take(&mut self.gesture));
                    if self.undo.len() > UNDO_DEPTH {
                        self.undo.remove(0);
                    }
                }
            }
            Command::Undo => {
                let step = if self.gesture.is_empty() {
                    self.undo.pop().unwrap_or_default()
                } else {
                    std::mem::take(&mut self.gesture)
                };
                for (triangles, delta) in step.iter().rev() {
                    self.move_triangles(triangles, -*delta);
                }
            }
        }
    }

    /// Builds the tree for the current scene and parameters; false (and the old tree kept)
    /// if the parameters are rejected.
    fn rebuild(&mut self) -> bool {
        let Some(scene) = &self.scene else {
            return true;
        };
        self.progress.0.store(0, Ordering::Relaxed);
        self.progress
            .1
            .store(scene.triangles.len(), Ordering::Relaxed);
        match build_with_progress(&scene.triangles, &self.params, &self.progress.0) {
            Ok((mut bvh, report)) => {
                bvh.order = self.order;
                self.refit_index = None;
                self.shape = Arc::new(tree_shape(&bvh));
                self.bvh = Some(bvh);
                self.version += 1;
                self.reply(Reply::Built {
                    report,
                    shape: self.shape.clone(),
                });
                true
            }
            Err(e) => {
                self.reply(Reply::BuildFailed(e.to_string()));
                false
            }
        }
    }

    fn move_triangles(&mut self, triangles: &[u32], delta: Vec3) {
        let (Some(scene), Some(bvh)) = (&mut self.scene, &mut self.bvh) else {
            return;
        };
        for &t in triangles {
            if let Some(tri) = scene.triangles.get_mut(t as usize) {
                for v in &mut tri.v {
                    *v += delta;
                }
            }
        }
        let start = Instant::now();
        // Only the moved triangles' leaves and their ancestors change.
        let index = self.refit_index.get_or_insert_with(|| RefitIndex::new(bvh));
        let p = &self.params;
        if let Ok(r) = bvh.refit_moved(index, &scene.triangles, triangles, p.c_trav, p.c_isect) {
            self.version += 1;
            self.reply(Reply::Refitted {
                sah_before: r.sah_before,
                sah_after: r.sah_after,
                refit_time: start.elapsed(),
            });
        }
    }

    fn render(&mut self, job: RenderJob) {
        let (Some(scene), Some(bvh)) = (&self.scene, &self.bvh) else {
            return;
        };
        self.last_job = Some(job.clone());
        let key = TraceKey {
            camera: job.camera,
            width: job.width,
            height: job.height,
            version: self.version,
        };
        let (frame, traced) = match &self.traced {
            Some((k, f)) if *k == key => (f.clone(), false),
            _ => {
                let settings = RenderSettings {
                    width: job.width,
                    height: job.height,
                    camera: job.camera,
                    light: scene.light(),
                    mode: job.mode,
                    heat_max: job.heat_max,
                    // A preview skips the shadow rays unless they are what it shows.
                    shadows: !job.preview || job.mode.counts_shadow_rays(),
                    // A shaded preview shows no counts: it skips counting too.
                    counters: !job.preview || matches!(job.mode, Mode::Heatmap(..)),
                };
                let f = Arc::new(trace(bvh, scene, &settings));
                self.traced = Some((key, f.clone()));
                (f, true)
            }
        };
        let (mut rgba, heat_max) = colorize(&frame, job.mode, job.heat_max);
        let walk = self.draw_overlay(&frame, &mut rgba, &job);
        self.reply(Reply::Frame(Arc::new(Shown {
            job,
            rgba,
            heat_max,
            frame,
            walk,
            traced,
        })));
    }

    fn draw_overlay(&self, frame: &Frame, rgba: &mut [u8], job: &RenderJob) -> Option<WalkInfo> {
        let bvh = self.bvh.as_ref()?;
        let o = &job.overlay;
        let triangle_count = self.scene.as_ref().map_or(0, |s| s.triangles.len());
        if let Some(sel) = &o.selected {
            // A table by triangle index: a selection can be a whole object of 10^5 triangles.
            let mut selected = vec![false; triangle_count];
            for &t in sel.iter() {
                if let Some(s) = selected.get_mut(t as usize) {
                    *s = true;
                }
            }
            tint_triangles(frame, rgba, |t| {
                (selected.get(t as usize) == Some(&true)).then_some([255, 230, 80, 110])
            });
        }
        if let Some(level) = o.level {
            let boxes: Vec<OutlinedBox> = (0..bvh.nodes.len())
                .filter(|&i| self.shape.depth.get(i) == Some(&level))
                .map(|i| OutlinedBox {
                    bounds: bvh.nodes[i].bounds(),
                    color: if o.color_by_node {
                        palette(i)
                    } else {
                        palette(level as usize)
                    },
                })
                .collect();
            outline_boxes(frame, rgba, &job.camera, &boxes, o.see_through);
        }
        let node = o.walk? as usize;
        if node >= bvh.nodes.len() {
            return None;
        }
        let n = &bvh.nodes[node];
        let mut info = WalkInfo {
            node: node as u32,
            depth: self.shape.depth.get(node).copied().unwrap_or(0),
            surface_area: n.bounds().surface_area(),
            triangles: 0,
            sah_cost: 0.0,
            children: None,
        };
        const LEFT: [u8; 4] = [255, 140, 40, 150];
        const RIGHT: [u8; 4] = [60, 170, 255, 150];
        let mut boxes = vec![OutlinedBox {
            bounds: n.bounds(),
            color: [255, 255, 255, 255],
        }];
        let p = &self.params;
        if n.is_leaf() {
            info.triangles = n.count as usize;
            info.sah_cost = p.c_isect * n.count as f32;
            let under: std::collections::HashSet<u32> =
                bvh.triangles_under(node).into_iter().collect();
            tint_triangles(frame, rgba, |t| under.contains(&t).then_some(LEFT));
        } else {
            let l = n.left_first as usize;
            let (a, b) = (bvh.triangles_under(l), bvh.triangles_under(l + 1));
            info.triangles = a.len() + b.len();
            info.children = Some([l, l + 1]);
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            let child = |k: usize| bvh.nodes[k].bounds().surface_area() / area;
            info.sah_cost = p.c_trav
                + child(l) * a.len() as f32 * p.c_isect
                + child(l + 1) * b.len() as f32 * p.c_isect;
            let mut side = vec![0u8; triangle_count];
            for &t in &a {
                side[t as usize] = 1;
            }
            for &t in &b {
                side[t as usize] = 2;
            }
            tint_triangles(frame, rgba, |t| match side.get(t as usize) {
                Some(1) => Some(LEFT),
                Some(2) => Some(RIGHT),
                _ => None,
            });
            for (k, c) in [(l, LEFT), (l + 1, RIGHT)] {
                boxes.push(OutlinedBox {
                    bounds: bvh.nodes[k].bounds(),
                    color: [c[0], c[1], c[2], 255],
                });
            }
        }
        outline_boxes(frame, rgba, &job.camera, &boxes, true);
        Some(info)
    }
}

fn tree_shape(bvh: &Bvh) -> TreeShape {
    let depth = bvh.node_depths();
    let left = bvh
        .nodes
        .iter()
        .map(|n| if n.is_leaf() { u32::MAX } else { n.left_first })
        .collect();
    TreeShape {
        parent: bvh.parents(),
        left,
        max_depth: depth.iter().copied().max().unwrap_or(0),
        depth,
    }
}

/// Shared slot for a file chosen in a dialog running on its own thread.
pub type Picked = Arc<Mutex<Option<std::path::PathBuf>>>;
