//! The explorer app: an egui window over the library. The UI thread only draws and
//! handles input; a worker thread owns the scene and the BVH and renders frames
//! (see `worker`). Panels are plain functions of the app state.

mod blas_costs;
mod bucket_plot;
mod compare;
mod cracks;
pub mod export;
pub mod file_browser;
mod lecture;
pub mod levels;
mod orbit;
mod overlay;
mod panels;
mod params;
pub mod preset;
pub mod replay;
mod replies;
pub mod screenshot;
pub mod settings;
mod slab_picture;
pub mod start_view;
pub mod timing;
mod viewport;
pub mod worker;

use crate::accel::bvh::BuildReport;
use crate::accel::two_level::InstanceOutline;
use crate::accel::{Outline, StructureParams, StructureReport};
use crate::scene::Scene;
use eframe::egui;
use orbit::Orbit;
use screenshot::ScreenshotPlan;

use settings::Settings;
use std::sync::Arc;
use std::time::{Duration, Instant};
use worker::{Command, CompareJob, Compared, Overlay, RenderJob, Shown, Worker};

/// How the app starts: normally with the remembered settings; tests and screenshots start
/// from defaults and remember nothing.
#[derive(Clone, Debug, Default)]
pub struct Launch {
    /// Overrides the scene to open.
    pub scene: Option<String>,
    /// The scene `scene` names, loaded already: the command line loads it before it opens
    /// the window, so a file that cannot be read is an error there, not in the window.
    pub loaded: Option<Scene>,
    /// Overrides the structure to build.
    pub accel: Option<crate::accel::AccelKind>,
    /// Start from default settings and do not save them.
    pub fresh: bool,
    pub screenshot: Option<ScreenshotPlan>,
    /// Open at this preset of this sequence (`--preset`).
    pub preset: Option<(preset::Sequence, usize)>,
}

/// Which tool the left mouse button is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Tool {
    #[default]
    Orbit,
    /// Click picks a triangle, drag moves it (or its object) and refits.
    Move,
    /// Click replays the pixel's ray step by step.
    Replay,
}

/// A drag of triangles in progress.
struct Drag {
    triangles: Arc<Vec<u32>>,
    /// Under the two levels with "move its whole object": the object whose instance moves.
    object: Option<usize>,
    /// Distance from the eye to the grabbed point: sets how far a pixel moves it.
    depth: f32,
}

/// Seconds of stillness after which a reduced-resolution preview is replaced by a full frame.
const SETTLE: Duration = Duration::from_millis(180);
/// The preview renders this fraction of the viewport's pixels in each direction.
const PREVIEW_SCALE: f32 = 0.5;

pub struct BvhLabApp {
    pub settings: Settings,
    worker: Worker,
    persist: bool,
    pub scene: Option<Arc<Scene>>,
    /// The scene's instancing rows for the build panel (`Scene::instancing_rows`), made
    /// once at load: they count every instance, too much work for every frame.
    pub scene_rows: Vec<(String, String)>,
    pub load_error: Option<String>,
    /// The scene's load warnings were dismissed (a new scene shows its own).
    pub warnings_dismissed: bool,
    pub report: Option<StructureReport>,
    /// The BVH's own report (SAH cost, leaf sizes) when the structure is a BVH.
    pub bvh_report: Option<BuildReport>,
    pub build_error: Option<String>,
    building: bool,
    /// Since when the worker has had work in hand (none: idle).
    busy_since: Option<Instant>,
    /// The structure's nodes or cells, for the levels view and the tree walk.
    pub outline: Arc<Outline>,
    /// Under the two levels: the selected instance's BLAS, which the levels and the walk
    /// continue into, and the instance each top-level leaf holds (by outline node).
    pub instance_outline: Option<Arc<InstanceOutline>>,
    /// Its BLAS's SAH cost and EPO, as a tree of its own.
    blas_costs: Option<blas_costs::BlasCosts>,
    pub leaf_instances: Arc<Vec<u32>>,
    /// The walk stepped into a top-level leaf whose instance is being outlined: enter its
    /// BLAS when it arrives.
    enter_blas: bool,
    pub shown: Option<Arc<Shown>>,
    /// The summary of the newest full frame: quick previews may not count.
    pub full_summary: Option<crate::render::FrameSummary>,
    texture: Option<egui::TextureHandle>,
    orbit: Orbit,
    pub tool: Tool,
    last_interaction: Option<Instant>,
    pub selection: Option<u32>,
    /// The selection's triangles (it alone or its object), for the overlay tint.
    selected_set: Option<(u32, bool, Arc<Vec<u32>>)>,
    drag: Option<Drag>,
    /// SAH cost after each refit since the last build (the first entry is the build's).
    pub sah_history: Vec<f64>,
    /// The built tree's SAH cost against random lines (none for other structures).
    pub sah_prediction: Option<crate::accel::sah_check::SahPrediction>,
    pub last_refit: Option<Duration>,
    /// Under a structure that cannot refit: the last rebuild after a move, and what a BVH
    /// refit of the same move took.
    pub last_rebuild: Option<(Duration, Option<Duration>)>,
    /// Under the two levels: the last instance move's top-level refit, and what refitting
    /// a BVH over the flattened scene took for it (`None`: too large to flatten).
    pub last_instance_move: Option<(Duration, Option<Duration>)>,
    /// Under the two levels: the object last grabbed as a whole, and its instance's
    /// transform once it has moved (before, the scene's own), per object moved.
    pub selected_object: Option<usize>,
    pub moved_transforms: std::collections::HashMap<usize, glam::Affine3A>,
    /// When the last move was sent, to time move → refitted frame.
    move_sent: Option<Instant>,
    pub drag_latency: Option<Duration>,
    pub walk: Option<u32>,
    /// The hierarchy diagram: its zoom, and its sizes and layout as last made.
    tree_diagram: panels::TreeView,
    /// The same for the pinned configuration A's tree.
    tree_diagram_a: panels::TreeView,
    /// The outline node under the pointer in the hierarchy diagram, outlined in the view.
    tree_hover: Option<u32>,
    /// The frame's rays' visits per outline node (the diagram's measured choices), with
    /// the outline (its address) and the request they were counted for.
    node_visits: Option<(
        usize,
        worker::VisitsRequest,
        Arc<crate::render::node_visits::NodeVisits>,
    )>,
    /// The visits asked of the worker and not yet answered.
    visits_asked: Option<worker::VisitsRequest>,
    /// The crack view made last, for its request, and the one asked for and not answered.
    pub cracks: Option<(
        worker::CracksRequest,
        Result<Arc<worker::CracksShown>, String>,
    )>,
    cracks_asked: Option<worker::CracksRequest>,
    /// The pointer over the view (0..1 across and down), when it is there.
    pub probe: Option<[f32; 2]>,
    /// The view's size in physical pixels, as last laid out.
    pub viewport_px: [u32; 2],
    last_job: Option<RenderJob>,
    sent_build: Option<StructureParams>,
    show_help: bool,
    /// The scene as the worker has it, after moves (see `request_snapshot`).
    pub snapshot: Option<Arc<Scene>>,
    /// Open… and Save…: the system's dialog, or the in-app browser where no portal answers.
    pub files: file_browser::FileDialog,
    pub screenshot: Option<ScreenshotPlan>,
    /// The ray replay being stepped through, and why the last one failed.
    pub replay: Option<replay::ReplayView>,
    pub replay_error: Option<String>,
    /// The outcome of the last export (the file written, or why not).
    pub export_status: Option<Result<String, String>>,
    /// Configuration A of a comparison; the settings are configuration B. A stays pinned
    /// when another scene loads and is built again over it.
    pub pinned: Option<StructureParams>,
    /// A against B in the newest full frame (quick previews may not count).
    pub compared: Option<Compared>,
    /// The lecture's presets and the one shown.
    pub lecture: lecture::Lecture,
    /// A lecture step just opened: the side panels scroll back to their top, then to the
    /// section it is about, once that section is drawn.
    panels_to_top: bool,
    pub panel_focus: Option<preset::Focus>,
}

impl BvhLabApp {
    /// The hierarchy diagram of the shown tree: its zoom and its layout.
    pub fn tree_diagram(&self) -> &panels::TreeView {
        &self.tree_diagram
    }

    pub fn new(cc: &eframe::CreationContext<'_>, launch: Launch) -> Self {
        let mut settings: Settings = match cc.storage {
            Some(storage) if !launch.fresh => (storage.get_string(settings::STORAGE_KEY))
                .and_then(|text| Settings::from_ron(&text))
                .unwrap_or_default(),
            _ => Settings::default(),
        };
        if launch.fresh {
            // eframe restores egui's memory (panel widths, open sections) before the app
            // exists: a fresh start, and every screenshot, begins from the defaults, so a
            // panel widened in an earlier session does not shape the picture.
            cc.egui_ctx.memory_mut(|m| *m = egui::Memory::default());
        }
        if let Some(scene) = &launch.scene {
            settings.scene = scene.clone();
        }
        if let Some(accel) = launch.accel {
            settings.structure.kind = accel;
        }
        if let Some(plan) = &launch.screenshot {
            plan.apply(&mut settings);
        }
        let mut tool = Tool::Orbit;
        // A preset that compares pins its A at launch too, as when stepped to.
        let mut pinned = None;
        let mut panel_focus = None;
        let lecture = match launch.preset {
            Some((sequence, index)) => {
                let before = settings.clone();
                if let Some(p) = sequence.presets.get(index) {
                    settings = p.settings_over(&settings);
                    tool = p.tool;
                    pinned = p.pinned;
                    panel_focus = p.focus;
                }
                lecture::Lecture::at(sequence, index, before)
            }
            None => lecture::Lecture::default(),
        };
        let ctx = cc.egui_ctx.clone();
        let mut worker = Worker::spawn(move || ctx.request_repaint());
        worker.send(Command::Build(settings.structure));
        match launch.loaded {
            Some(scene) if launch.scene.as_ref() == Some(&settings.scene) => {
                worker.send(Command::Adopt(settings.scene.clone(), Box::new(scene)));
            }
            _ => worker.send(Command::Load(settings.scene.clone())),
        }
        if let Some(index) = lecture.current {
            lecture::prefetch_next(&mut worker, &lecture.sequence, index, &settings);
        }
        cc.egui_ctx.set_zoom_factor(settings.ui_scale);
        add_fallback_fonts(&cc.egui_ctx);
        BvhLabApp {
            sent_build: Some(settings.structure),
            settings,
            worker,
            persist: !launch.fresh,
            scene: None,
            scene_rows: Vec::new(),
            load_error: None,
            warnings_dismissed: false,
            report: None,
            bvh_report: None,
            build_error: None,
            building: true,
            busy_since: None,
            outline: Arc::new(Outline::default()),
            instance_outline: None,
            blas_costs: None,
            leaf_instances: Arc::default(),
            enter_blas: false,
            shown: None,
            full_summary: None,
            texture: None,
            orbit: Orbit::from_camera(&crate::scene::Camera::framing(&crate::geometry::Aabb::new(
                glam::Vec3::splat(-1.0),
                glam::Vec3::ONE,
            ))),
            tool,
            last_interaction: None,
            selection: None,
            selected_set: None,
            drag: None,
            sah_history: Vec::new(),
            sah_prediction: None,
            last_refit: None,
            last_rebuild: None,
            last_instance_move: None,
            selected_object: None,
            moved_transforms: Default::default(),
            move_sent: None,
            drag_latency: None,
            tree_diagram: Default::default(),
            tree_diagram_a: Default::default(),
            tree_hover: None,
            node_visits: None,
            visits_asked: None,
            cracks: None,
            cracks_asked: None,
            walk: None,
            probe: None,
            panels_to_top: false,
            panel_focus,
            viewport_px: [0, 0],
            last_job: None,
            show_help: false,
            snapshot: None,
            files: Default::default(),
            screenshot: launch.screenshot,
            replay: None,
            replay_error: None,
            export_status: None,
            pinned,
            compared: None,
            lecture,
        }
    }

    /// Pins the current configuration as A: from now on each frame is traced with A too.
    pub fn pin(&mut self) {
        self.pinned = Some(self.settings.structure);
        self.compared = None;
    }

    pub fn unpin(&mut self) {
        self.pinned = None;
        self.compared = None;
    }

    pub fn toggle_pin(&mut self) {
        if self.pinned.is_some() {
            self.unpin()
        } else {
            self.pin()
        }
    }

    fn maybe_auto_rebuild(&mut self) {
        let (Some(limit), Some(first), Some(last)) = (
            self.settings.auto_rebuild_percent,
            self.sah_history.first(),
            self.sah_history.last(),
        ) else {
            return;
        };
        if *last > first * (1.0 + limit as f64 / 100.0) {
            self.rebuild();
        }
    }

    /// Builds the tree again from the current triangle positions.
    pub fn rebuild(&mut self) {
        self.building = true;
        self.worker.send(Command::Rebuild);
    }

    pub fn load(&mut self, spec: String) {
        self.load_error = None;
        self.worker.send(Command::Load(spec));
    }

    /// Sends build parameters when they changed.
    fn sync_build(&mut self) {
        let wanted = self.settings.structure;
        if self.sent_build != Some(wanted) {
            let rebuilds = self
                .sent_build
                .is_none_or(|sent| sent.needs_rebuild_for(&wanted));
            self.sent_build = Some(wanted);
            if rebuilds && wanted.validate().is_ok() {
                self.building = true;
            }
            self.worker.send(Command::Build(wanted));
        }
    }

    fn interacting(&self) -> bool {
        self.drag.is_some() || self.last_interaction.is_some_and(|t| t.elapsed() < SETTLE)
    }

    /// The frame the viewport wants now.
    fn wanted_job(&self) -> Option<RenderJob> {
        let [w, h] = self.viewport_px;
        if w == 0 || h == 0 || self.scene.is_none() {
            return None;
        }
        let preview = self.interacting();
        let scale = if preview { PREVIEW_SCALE } else { 1.0 };
        let s = &self.settings;
        Some(RenderJob {
            camera: self.orbit.camera(),
            width: ((w as f32 * scale) as u32).max(1),
            height: ((h as f32 * scale) as u32).max(1),
            mode: s.mode.render_mode(s.shadow_rays),
            heat_max: s.heat_max,
            heat_style: s.heat_style,
            overlay: Overlay {
                selected: self.selected_set.as_ref().map(|(.., set)| set.clone()),
                level: s.show_levels.then_some(s.level),
                walk: self.walk,
                instance: self.instance_outline.as_ref().map(|i| i.instance),
                probe: self
                    .probe
                    .filter(|_| s.structure.kind.walks_cells() && s.show_levels),
                see_through: s.see_through,
                color_by_node: s.color_by_node,
            },
            preview,
            compare: self.pinned.as_ref().map(|p| CompareJob {
                a: *p,
                view: s.compare_view,
            }),
        })
    }

    fn sync_render(&mut self, ctx: &egui::Context) {
        let Some(job) = self.wanted_job() else {
            return;
        };
        if job.preview {
            // Come back when the user has been still long enough for a full frame.
            ctx.request_repaint_after(SETTLE);
        }
        if self.last_job.as_ref() != Some(&job) {
            self.last_job = Some(job.clone());
            self.worker.send(Command::Render(job));
        }
    }

    /// Blocks until the worker has handled everything sent, then takes its replies. For
    /// tests and screenshots: the interactive UI never waits.
    pub fn wait_for_worker(&mut self, ctx: &egui::Context) {
        let replies = self.worker.wait_idle(Duration::from_secs(120));
        self.handle_replies(ctx, replies);
    }

    /// Whether the worker has handled everything sent so far and the newest frame is the
    /// full-resolution one the viewport wants.
    pub fn settled(&self) -> bool {
        self.worker.is_idle()
            && !self.building
            && self
                .shown
                .as_ref()
                .is_some_and(|s| Some(&s.job) == self.last_job.as_ref() && !s.job.preview)
            && self.cracks_shown()
    }

    /// Moves `triangles` by `delta` in the world and refits (as a drag does).
    pub fn move_triangles(&mut self, triangles: Arc<Vec<u32>>, delta: glam::Vec3) {
        self.move_sent = Some(Instant::now());
        self.worker.send(Command::Move { triangles, delta });
    }

    /// Moves scene object `object` by `delta` as a whole (under the two levels, its
    /// instance: only the top level is refitted).
    pub fn move_object(&mut self, object: usize, delta: glam::Vec3) {
        self.move_sent = Some(Instant::now());
        self.worker.send(Command::MoveObject { object, delta });
    }

    /// The levels view and the walk over the outline and the selected instance's BLAS.
    pub fn levels(&self) -> levels::Levels<'_> {
        levels::Levels::new(&self.outline, self.instance_outline.as_deref())
    }

    /// Under the two levels: outline instance `i`'s BLAS below the top level (`None`: no
    /// instance); it arrives in `instance_outline`.
    pub fn select_instance(&mut self, i: Option<usize>) {
        self.worker.send(Command::SelectInstance(i));
    }

    /// Under the two levels: select the instance that places scene object `object`.
    pub fn select_object_instance(&mut self, object: usize) {
        self.worker.send(Command::SelectObject(object));
    }

    /// A BLAS arrived (or the selection was cleared): the level and the walk stay within
    /// the tree, and a walk waiting at the instance's leaf steps into its root.
    fn instance_selected(&mut self, outlined: Option<Arc<InstanceOutline>>) {
        let old_top = self.outline.nodes.len();
        let was_in_blas = self.walk.is_some_and(|w| w as usize >= old_top);
        let same = match (&self.instance_outline, &outlined) {
            (Some(a), Some(b)) => a.instance == b.instance && a.entries == b.entries,
            _ => false,
        };
        // The leaf the walk hung below in the old BLAS (or the first of the old instance).
        let old_leaf = {
            let levels = self.levels();
            self.walk
                .and_then(|w| levels.node(w))
                .and_then(|n| levels.top_above(n))
                .map(|k| k as u32)
                .or_else(|| self.instance_outline.as_ref().and_then(|i| i.first_leaf()))
        };
        let constants = self.settings.structure.sah_constants();
        self.blas_costs =
            blas_costs::BlasCosts::of(outlined.as_ref(), self.blas_costs.take(), constants);
        self.instance_outline = outlined;
        let levels = self.levels();
        let max = levels.max_depth();
        // A walk waiting at a leaf of the instance steps into the subtree below it.
        let entered = levels
            .instance
            .zip(self.walk)
            .and_then(|(i, w)| i.entry_below(w))
            .map(|b| levels.id(levels::WalkNode::Bottom(b as usize)));
        if self.enter_blas {
            self.enter_blas = false;
            if let Some(b) = entered {
                self.walk = Some(b);
            }
        } else if was_in_blas && !same {
            // The walk was in the BLAS of another instance, or of none now: back to the
            // leaf it hung below.
            self.walk = Some(old_leaf.unwrap_or(0));
        }
        // A screenshot's level may lie in the BLAS, past the top level's depth.
        let wanted = self.screenshot.as_ref().and_then(|p| p.level);
        self.settings.level = wanted.unwrap_or(self.settings.level).min(max);
    }

    /// Asks the worker for the scene as it is now; it arrives in `snapshot`.
    pub fn request_snapshot(&mut self) {
        self.worker.send(Command::Snapshot);
    }

    pub fn end_gesture(&mut self) {
        self.worker.send(Command::EndGesture);
    }

    pub fn undo(&mut self) {
        self.worker.send(Command::Undo);
    }

    /// The triangles a drag starting on `triangle` moves: it alone, or its whole object.
    /// Keeps `selected_set` in step with the selection, so the frame-by-frame render
    /// request neither rebuilds the triangle list nor compares it element by element.
    fn refresh_selected_set(&mut self) {
        let key = self.selection.map(|t| (t, self.settings.move_whole_object));
        if self.selected_set.as_ref().map(|(t, w, _)| (*t, *w)) != key {
            self.selected_set = key.map(|(t, w)| (t, w, self.drag_set(t)));
        }
    }

    pub fn drag_set(&self, triangle: u32) -> Arc<Vec<u32>> {
        let object = self
            .settings
            .move_whole_object
            .then(|| {
                self.scene
                    .as_ref()?
                    .object_of(triangle as usize)
                    .map(|o| (o, self.scene.clone()))
            })
            .flatten();
        match object {
            Some((o, Some(scene))) => {
                let r = scene.objects[o].range();
                Arc::new((r.start as u32..r.end as u32).collect())
            }
            _ => Arc::new(vec![triangle]),
        }
    }
}

/// Whether a scene spec names a file rather than a built-in scene.
mod scene {
    pub fn is_file_spec(spec: &str) -> bool {
        let path = std::path::Path::new(spec);
        path.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
            || crate::scene::is_gltf_path(path)
    }
}

impl eframe::App for BvhLabApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let replies = self.worker.poll();
        self.handle_replies(&ctx, replies);
        self.take_chosen_file(&ctx);
        self.take_dropped_files(&ctx);
        self.shortcuts(&ctx);

        // Set again by the hierarchy diagram while the pointer is over one of its cells.
        self.tree_hover = None;
        if self.settings.presentation {
            panels::presentation_bar(self, ui);
        } else {
            panels::top_bar(self, ui);
            lecture::caption_bar(self, ui);
            panels::status_bar(self, ui);
            panels::side_panels(self, ui);
            panels::tree_panel(self, ui);
        }
        egui::CentralPanel::no_frame().show(ui, |ui| viewport::show(self, ui));
        panels::help_window(self, &ctx);

        self.sync_build();
        self.refresh_selected_set();
        self.sync_render(&ctx);
        if self.worker.is_idle() {
            self.busy_since = None;
        } else {
            self.busy_since.get_or_insert_with(Instant::now);
        }
        if self.building || self.busy_since.is_some() {
            // Poll the build's or the trace's progress while it runs.
            ctx.request_repaint_after(Duration::from_millis(100));
        }
        let settled = self.settled();
        let action = match &mut self.screenshot {
            Some(plan) => plan.step(settled, self.panel_focus.is_some(), self.viewport_px, &ctx),
            None => screenshot::Action::None,
        };
        match action {
            screenshot::Action::Refit => self.scripted_refit(),
            screenshot::Action::Replay(r) => self.scripted_replay(r),
            screenshot::Action::Compare(c) => {
                self.pin();
                self.settings.structure = c.b;
                self.settings.compare_view = c.view;
            }
            screenshot::Action::None => {}
        }
    }

    fn persist_egui_memory(&self) -> bool {
        self.persist
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        if self.persist {
            let kept = self.lecture.settings_to_keep(&self.settings);
            eframe::set_value(storage, settings::STORAGE_KEY, &kept);
        }
    }
}

impl BvhLabApp {
    /// A file chosen in a dialog: opened, loaded or written, as it was chosen for. Each
    /// outcome is shown where it was asked for (the status bar, the Lecture section, the
    /// export line).
    fn take_chosen_file(&mut self, ctx: &egui::Context) {
        use file_browser::Purpose;
        let Some((purpose, path)) = self.files.poll(ctx) else {
            return;
        };
        match purpose {
            Purpose::OpenScene => self.load(path.display().to_string()),
            Purpose::LoadPresets => {
                let _ = self.load_presets(&path);
            }
            Purpose::SavePreset => {
                let _ = self.save_preset(&path);
            }
            Purpose::Export(what) => {
                let _ = self.export(what, &path);
            }
        }
    }

    fn take_dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<_> = ctx.input(|i| i.raw.dropped_files.clone());
        if let Some(file) = dropped.first() {
            let path = file.path();
            if !path.as_os_str().is_empty() {
                self.load(path.display().to_string());
            }
        }
    }

    /// Open…: the system's file dialog on its own thread (the UI keeps drawing), or the
    /// in-app browser where no desktop portal answers; it starts in the open file's folder.
    pub fn open_dialog(&mut self, ctx: &egui::Context) {
        let folder = std::path::Path::new(&self.settings.scene)
            .parent()
            .map(std::path::Path::to_path_buf);
        let start = file_browser::Start {
            folder,
            file_name: None,
        };
        self.files
            .start(ctx, file_browser::Purpose::OpenScene, start);
    }

    /// For a replay screenshot: replay the ray through a point of the view.
    fn scripted_replay(&mut self, r: screenshot::ReplayShot) {
        let Some(shown) = &self.shown else { return };
        let (w, h) = (shown.job.width, shown.job.height);
        let x = ((r.at[0] * w as f32) as u32).min(w - 1);
        let y = ((r.at[1] * h as f32) as u32).min(h - 1);
        self.tool = Tool::Replay;
        self.replay_pixel(x, y);
        // A primary ray seen from its own eye is a point: turn the camera to see it from
        // the side (the replay is drawn in the world, so it stays where it is).
        let height = self.viewport_px[1] as f32;
        self.orbit.rotate(height * 0.25, height * 0.06, height);
        self.last_interaction = Some(Instant::now());
    }

    /// For the refit screenshot: drag the triangle under the centre of the view away, so its
    /// leaf's box and every box above it stretch.
    fn scripted_refit(&mut self) {
        let Some(shown) = &self.shown else { return };
        let f = &shown.frame;
        let centre = f
            .sample(f.width / 2, f.height * 3 / 5)
            .filter(|s| s.is_hit());
        let Some(s) = centre else { return };
        let Ok(triangle) = u32::try_from(s.triangle) else {
            return;
        };
        self.selection = Some(triangle);
        // The move tool: the SAH chart heads the statistics, as in a real drag.
        self.tool = Tool::Move;
        let set = self.drag_set(triangle);
        let step = self.orbit.pixel_size(self.viewport_px[1] as f32) * 25.0;
        let (right, up, _) = self.orbit.camera().basis();
        for k in 0..12 {
            let d = if k % 2 == 0 { right } else { up * 0.6 };
            self.move_triangles(set.clone(), d * step);
        }
        self.end_gesture();
    }
}

/// The emoji and symbol fonts egui ships, behind the text font: a symbol it lacks (an
/// arrow, the file browser's folder icons) is drawn, never missing.
fn add_fallback_fonts(ctx: &egui::Context) {
    use egui::epaint::text::{FontInsert, FontPriority, InsertFontFamily};
    for (name, data) in [
        ("noto-emoji", epaint_default_fonts::NOTO_EMOJI_REGULAR),
        ("emoji-icon-font", epaint_default_fonts::EMOJI_ICON),
    ] {
        let families = [egui::FontFamily::Proportional, egui::FontFamily::Monospace]
            .into_iter()
            .map(|family| InsertFontFamily {
                family,
                priority: FontPriority::Lowest,
            })
            .collect();
        ctx.add_font(FontInsert::new(
            name,
            egui::FontData::from_static(data),
            families,
        ));
    }
}

/// Opens the app window and runs until it is closed.
pub fn run(launch: Launch) -> anyhow::Result<()> {
    // Said plainly, before the windowing library reports it with its source path.
    #[cfg(target_os = "linux")]
    if ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
        .iter()
        .all(|v| std::env::var_os(v).is_none())
    {
        anyhow::bail!(
            "cannot open the window: no display (neither DISPLAY nor WAYLAND_DISPLAY is set)"
        );
    }
    // Mesa's software renderer complains on every window without a runtime directory.
    // It is made here and removed when the window closes.
    let runtime_dir = std::env::temp_dir().join(format!("bvhlab-runtime-{}", std::process::id()));
    #[cfg(target_os = "linux")]
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::fs::create_dir(&runtime_dir).is_ok() {
        // SAFETY: no thread reads the environment now: the window, the renderer and the
        // worker start below; rayon's workers, if started, are idle.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &runtime_dir) };
    }
    let size = launch
        .screenshot
        .as_ref()
        .map_or([1400.0, 860.0], |p| [p.width as f32, p.height as f32]);
    // A screenshot keeps nothing of earlier sessions: eframe restores a saved window's
    // size even with `persist_window` off, so it gets a storage file of its own, removed after.
    let shot_storage = launch
        .screenshot
        .as_ref()
        .map(|_| std::env::temp_dir().join(format!("bvhlab-shot-{}.ron", std::process::id())));
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("bvhlab")
            .with_inner_size(size)
            .with_drag_and_drop(true),
        persist_window: launch.screenshot.is_none(),
        persistence_path: shot_storage.clone(),
        ..Default::default()
    };
    let result = launch.screenshot.as_ref().map(|p| p.result.clone());
    let ran = eframe::run_native(
        "bvhlab",
        options,
        Box::new(move |cc| Ok(Box::new(BvhLabApp::new(cc, launch)))),
    );
    let _ = std::fs::remove_dir_all(&runtime_dir);
    if let Some(file) = &shot_storage {
        let _ = std::fs::remove_file(file);
    }
    ran.map_err(|e| anyhow::anyhow!("cannot open the window: {e}"))?;
    if let Some(result) = result {
        let outcome = result.lock().map(|r| r.clone()).unwrap_or(None);
        match outcome {
            Some(Ok(saved)) => {
                let [w, h] = saved.viewport;
                println!("wrote {}\nviewport {w}x{h}", saved.path);
            }
            Some(Err(e)) => anyhow::bail!(e),
            None => anyhow::bail!("the window closed before the screenshot was taken"),
        }
    }
    Ok(())
}
