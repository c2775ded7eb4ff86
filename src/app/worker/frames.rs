//! Frames: tracing a view (with a pinned A beside it), recolouring a traced frame, the
//! counted pass after an uncounted one, and the ray replay of one pixel.

use super::messages::*;
use super::state::*;
use super::streaming::Stream;
use crate::accel::structure::{self, Structure, StructureParams};
use crate::geometry::Watertight;
use crate::render::compare::{compare_image, compared_counters, summarize};
use crate::render::node_visits::{NodeVisits, node_visits};
use crate::render::replay::{Replay, replay_pixel};
use crate::render::{
    Frame, Mode, RenderSettings, colorize_styled, tile_count, trace, trace_streaming,
    trace_uncoloured_unless, trace_unless,
};
use crate::scene::Scene;
use std::time::Duration;

/// A coarse first image is this many times smaller each way (1/36 of the rays): the first
/// image of a slow structure comes within the 250 ms a step may take, and the tiles that
/// stream over it sharpen it within a frame or two.
const COARSE: u32 = 6;
/// About how many rays the hierarchy diagram's measured visits trace.
const VISITS_RAYS: f64 = 120_000.0;
/// About how many rays the tests-per-triangle view's tally traces.
const TESTS_RAYS: f64 = 250_000.0;
/// Smaller frames come at once, without a coarse one first.
const COARSE_MIN_PIXELS: u32 = 320 * 240;
/// A full frame slower than this is preceded by a coarse one next time.
const SLOW_FRAME: Duration = Duration::from_millis(150);
use glam::Vec3;
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// A frame's settings for a view of `scene` from `camera`, `width` × `height` pixels, lit
/// by the scene's light: what the replay, the counted visits and the crack view trace.
pub(in crate::app) fn view_settings(
    scene: &crate::scene::Scene,
    camera: crate::scene::Camera,
    width: u32,
    height: u32,
) -> RenderSettings {
    RenderSettings {
        camera,
        light: scene.light(),
        ..RenderSettings::for_scene(scene, width, height)
    }
}

impl State {
    /// Replays a pixel through the structure as it is now, in the scene as it is now.
    pub(in crate::app) fn replay(&self, r: &ReplayRequest) -> Result<Arc<Replay>, String> {
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return Err("there is no structure to replay yet".into());
        };
        let settings = view_settings(scene, r.camera, r.width, r.height);
        replay_pixel::<crate::geometry::Watertight>(structure, scene, &settings, r.pixel, r.rays)
            .map(Arc::new)
            .map_err(|e| e.to_string())
    }

    /// Counts the visits per outline node of the request's rays, from one pixel in
    /// `stride`² so a large view takes a fraction of a second; `None` when a newer command
    /// arrives first.
    pub(in crate::app) fn node_visits(&self, r: &VisitsRequest) -> Option<Arc<NodeVisits>> {
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return None;
        };
        let settings = view_settings(scene, r.camera, r.width, r.height);
        let pixels = f64::from(r.width) * f64::from(r.height);
        let stride = (pixels / VISITS_RAYS).sqrt().ceil().max(1.0) as u32;
        let asked = self.latest.load(Ordering::Relaxed);
        let latest = &self.latest;
        let abandon = || latest.load(Ordering::Relaxed) != asked;
        let nodes = self.outline.nodes.len();
        node_visits::<crate::geometry::Watertight>(
            structure, scene, &settings, r.rays, stride, nodes, &abandon,
        )
        .map(Arc::new)
    }

    /// Traces (or recolours) the job's frame and sends it. A full frame that may be slow
    /// (a new structure, or the last full frame took long) is preceded by a coarse one, so
    /// an image of the change is up at once. The trace is given up when a command newer
    /// than `seq` arrives; the job then waits in `pending` for the newer commands.
    pub(in crate::app) fn render(&mut self, job: RenderJob, seq: u64) {
        // The job asked for is the one to trace again when the scene or tree changes (not
        // its coarse stand-in).
        self.last_job = Some(job.clone());
        let large = job.width * job.height >= COARSE_MIN_PIXELS;
        let mut coarse_shown = None;
        if !job.preview && large && self.slow_trace && self.cached(&job).is_none() {
            let coarse = RenderJob {
                width: (job.width / COARSE).max(1),
                height: (job.height / COARSE).max(1),
                preview: true,
                ..job.clone()
            };
            match self.render_now(coarse, seq, None) {
                Some(shown) => coarse_shown = shown,
                None => {
                    self.pending = Some(job);
                    return;
                }
            }
        }
        if self.render_now(job.clone(), seq, coarse_shown).is_none() {
            self.pending = Some(job);
        }
    }

    /// The traced frame that serves `job`, if the last trace does.
    fn cached(&self, job: &RenderJob) -> Option<Arc<Frame>> {
        let counters = Self::trace_settings(Vec3::ZERO, job).counters;
        let t = self.traced.as_ref()?;
        // A counted frame serves every mode; an uncounted one only a mode without counts.
        (t.key == self.trace_key(job) && (t.counted || !counters)).then(|| t.frame.clone())
    }

    fn trace_key(&self, job: &RenderJob) -> TraceKey {
        TraceKey {
            camera: job.camera,
            width: job.width,
            height: job.height,
            version: self.version,
        }
    }

    /// `render`'s one frame: what it showed (if anything), or `None` if a newer command
    /// stopped its trace. Over a coarse first image (`coarse`) its tiles are shown as they
    /// are traced.
    fn render_now(
        &mut self,
        job: RenderJob,
        seq: u64,
        coarse: Option<Arc<Shown>>,
    ) -> Option<Option<Arc<Shown>>> {
        let light = self.light();
        let cached = self.cached(&job);
        let key = self.trace_key(&job);
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return Some(None);
        };
        let settings = Self::trace_settings(light, &job);
        let (frame, traced) = match cached {
            Some(f) => (f, false),
            None => {
                let progress = &self.trace_progress;
                progress.0.store(0, Ordering::Relaxed);
                progress
                    .1
                    .store(tile_count(settings.height), Ordering::Relaxed);
                let latest = &self.latest;
                let stop = || {
                    progress.0.fetch_add(1, Ordering::Relaxed);
                    latest.load(Ordering::Relaxed) > seq
                };
                let stream = coarse.and_then(|c| Stream::new(c, &job, &self.replies, &*self.wake));
                let traced = match &stream {
                    Some(stream) => trace_streaming::<_, Watertight>(
                        structure,
                        scene,
                        &settings,
                        &stop,
                        &|tile| stream.tile(tile),
                    ),
                    None => trace_unless::<_, Watertight>(structure, scene, &settings, &stop),
                };
                // Stopped for a newer command: nothing shown.
                let f = traced?;
                if !job.preview {
                    self.slow_trace = f.summary.trace_time > SLOW_FRAME;
                }
                let f = Arc::new(f);
                self.traced = Some(Traced {
                    key,
                    frame: f.clone(),
                    counted: settings.counters,
                });
                (f, true)
            }
        };
        let image_time = frame.summary.trace_time;
        if job.mode.colours_triangles() {
            let latest = &self.latest;
            let newer = || latest.load(Ordering::Relaxed) > seq;
            triangle_values(&frame, structure, &self.params, scene, &settings, &newer);
            if newer() {
                return None;
            }
        }
        let ((mut rgba, heat_max), compared, pinned_frame) = match job.compare {
            Some(c) => {
                let (image, compared, a) = self.compare(&frame, &c, &job, seq);
                (image, Some(compared), a)
            }
            // A shaded frame comes coloured from the trace.
            None if job.mode == Mode::Shaded && !frame.rgba.is_empty() => {
                ((frame.rgba.clone(), None), None, None)
            }
            None => (
                colorize_styled(&frame, job.mode, job.heat_max, &job.heat_style),
                None,
                None,
            ),
        };
        let pinned_tree = job.compare.and_then(|_| self.pinned_tree());
        if job.overlay.level.is_some() || job.overlay.walk.is_some() {
            self.fresh_outline();
        }
        let walk = self.draw_overlay(&frame, &mut rgba, &job);
        let shown = Arc::new(Shown {
            job,
            rgba,
            heat_max,
            frame,
            walk,
            traced,
            image_time,
            compared,
            pinned_frame,
            pinned_tree,
        });
        self.reply(Reply::Frame(shown.clone()));
        Some(Some(shown))
    }

    /// The scene's light, worked out again only when the scene changed (the standard
    /// light follows the scene's box, a pass over every triangle).
    pub(in crate::app) fn light(&mut self) -> Vec3 {
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
    pub(in crate::app) fn count_shown(&mut self, seq: u64) {
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
        counted.per_triangle = traced.frame.per_triangle.clone();
        let frame = Arc::new(counted);
        self.traced = Some(Traced {
            key,
            frame: frame.clone(),
            counted: true,
        });
        self.reply(Reply::Counted { job, frame });
    }

    /// The settings a job's frames are traced with.
    pub(in crate::app) fn trace_settings(light: Vec3, job: &RenderJob) -> RenderSettings {
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
    pub(in crate::app) fn compare(
        &mut self,
        b: &Frame,
        c: &CompareJob,
        job: &RenderJob,
        seq: u64,
    ) -> (Image, Compared, Option<Arc<Frame>>) {
        let b_alone = |error: String| {
            (
                colorize_styled(b, job.mode, job.heat_max, &job.heat_style),
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
        // A's triangles are coloured by A's tree and A's rays, as B's by B's.
        let settings = State::trace_settings(self.light(), job);
        if let (true, Some(scene), Some(pinned)) =
            (job.mode.colours_triangles(), &self.scene, &self.pinned)
            && let Ok(structure) = &pinned.structure
        {
            let latest = &self.latest;
            let newer = || latest.load(Ordering::Relaxed) > seq;
            triangle_values(&a, structure, &pinned.params, scene, &settings, &newer);
        }
        let summaries = if b.summary.counted() {
            compared_counters(job.mode)
                .into_iter()
                .filter_map(|(counter, rays)| summarize(&a, b, counter, rays).ok())
                .collect()
        } else {
            Vec::new()
        };
        match compare_image(&a, b, job.mode, job.heat_max, &job.heat_style, c.view) {
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

    /// A's tree, made once per build of A; `None` when A could not be built.
    fn pinned_tree(&mut self) -> Option<Arc<PinnedTree>> {
        let pinned = self.pinned.as_mut()?;
        let structure = pinned.structure.as_ref().ok()?;
        let params = pinned.params;
        Some(
            pinned
                .tree
                .get_or_insert_with(|| {
                    Arc::new(PinnedTree {
                        outline: Arc::new(structure.outline()),
                        label: params.label(),
                        sah_cost: structure.sah_cost(&params),
                    })
                })
                .clone(),
        )
    }

    /// A's frame of the job's view: A is built (again) when it is new, its build
    /// parameters changed or the scene's triangles moved since, and traced again only when
    /// the view or A changed.
    pub(in crate::app) fn pinned_frame(
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
                p.tree = None;
                self.pinned_builds += 1;
                p.version = self.pinned_builds;
            }
            Some(_) => {}
            None => {
                self.pinned_builds += 1;
                let structure = structure::build_scene(scene, params, &Default::default())
                    .map(|built| built.structure)
                    .map_err(|e| e.to_string());
                self.pinned = Some(PinnedStructure {
                    params: *params,
                    scene_version: self.scene_version,
                    structure,
                    version: self.pinned_builds,
                    tree: None,
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

    /// Makes the outline again after refits, when a frame is to draw it, and sends it to
    /// the app (its levels and walk panels read it too).
    pub(in crate::app) fn fresh_outline(&mut self) {
        if !self.outline_stale {
            return;
        }
        if let Some(structure) = &self.structure {
            self.outline = Arc::new(structure.outline());
            self.outline_stale = false;
            self.reply(Reply::Outline(self.outline.clone()));
        }
    }
}

/// Works out, once for the frame, the triangles' values a per-triangle mode colours them by:
/// the cost the tree charges each, or its measured tests from about TESTS_RAYS of the
/// frame's rays. `newer` (a newer command) stops the tally; without an SAH cost (the view
/// panel says why) the hits stay grey.
fn triangle_values(
    frame: &Frame,
    structure: &Structure,
    params: &StructureParams,
    scene: &Scene,
    settings: &RenderSettings,
    newer: &(dyn Fn() -> bool + Sync),
) {
    let pixels = f64::from(settings.width) * f64::from(settings.height);
    let stride = (pixels / TESTS_RAYS).sqrt().ceil().max(1.0) as u32;
    let _ = frame.triangle_values_for::<Watertight>(
        settings.mode,
        structure,
        params,
        scene,
        settings,
        stride,
        newer,
    );
}
