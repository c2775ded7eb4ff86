//! Frames: tracing a view (with a pinned A beside it), recolouring a traced frame, the
//! counted pass after an uncounted one, and the ray replay of one pixel.

use super::messages::*;
use super::state::*;
use crate::accel::structure::{self, StructureParams};
use crate::geometry::Watertight;
use crate::render::compare::{compare_image, compared_counters, summarize};
use crate::render::replay::{Replay, replay_pixel};
use crate::render::{Frame, Mode, RenderSettings, colorize, trace, trace_uncoloured_unless};
use glam::Vec3;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

impl State {
    /// Replays a pixel through the structure as it is now, in the scene as it is now.
    pub(in crate::app) fn replay(&self, r: &ReplayRequest) -> Result<Arc<Replay>, String> {
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

    pub(in crate::app) fn render(&mut self, job: RenderJob) {
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
}
