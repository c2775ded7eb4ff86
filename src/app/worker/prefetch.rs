//! The next lecture step made ready while the lecturer talks. When a step opens, the app
//! names the step after it; once the worker has had nothing to do for `IDLE_BEFORE`, it
//! loads that scene and builds its structure, and the step opens from them when it comes:
//! no load, no build, only the first frame. Any command abandons the work at once (a load
//! in progress finishes first), and the work resumes at the next quiet moment; what was
//! done is kept. A step opened any other way (from the list, out of order) builds as
//! before.

use super::messages::Reply;
use super::state::{State, predict_sah};
use crate::accel::progress::BuildProgress;
use crate::accel::sah_check::SahPrediction;
use crate::accel::structure::{self, Built, StructureError, StructureParams};
use crate::scene::Scene;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How long the worker must have been without commands before it prefetches: longer than
/// the pauses between the commands of an orbit or a drag, so interaction never waits on a
/// prefetch, and short beside the time a lecturer spends on a step.
pub(in crate::app) const IDLE_BEFORE: Duration = Duration::from_millis(400);

/// A structure built ahead, with its SAH prediction (`predict_sah`).
pub(in crate::app) type Prebuilt = (Built, Option<SahPrediction>);

/// The scene and structure being made ready, under the spec and parameters that will ask
/// for them.
pub(in crate::app) struct Prefetch {
    spec: String,
    params: StructureParams,
    scene: Option<Scene>,
    built: Option<Prebuilt>,
}

impl Prefetch {
    pub(in crate::app) fn new(spec: String, params: StructureParams) -> Self {
        Prefetch {
            spec,
            params,
            scene: None,
            built: None,
        }
    }
}

impl State {
    /// Asks for `spec` built with `params` ahead of time; what is already made for the same
    /// request (or the same scene) is kept.
    pub(in crate::app) fn want_prefetch(&mut self, spec: String, params: StructureParams) {
        match &mut self.prefetch {
            Some(p) if p.spec == spec && p.params == params => {}
            Some(p) if p.spec == spec => {
                p.params = params;
                p.built = None;
            }
            _ => self.prefetch = Some(Prefetch::new(spec, params)),
        }
    }

    /// Whether prefetch work is left for a quiet moment.
    pub(in crate::app) fn prefetch_waiting(&self) -> bool {
        self.prefetch.as_ref().is_some_and(|p| p.built.is_none())
    }

    /// Loads and builds the prefetch, abandoning the build as soon as a command arrives.
    /// A failure drops the request: the step will say why when it opens.
    pub(in crate::app) fn prefetch_now(&mut self) {
        let asked = self.latest.load(Ordering::Relaxed);
        let Some(p) = &mut self.prefetch else {
            return;
        };
        if p.scene.is_none() {
            match Scene::load(&p.spec) {
                Ok(scene) => p.scene = Some(scene),
                Err(_) => {
                    self.prefetch = None;
                    return;
                }
            }
        }
        if self.latest.load(Ordering::Relaxed) != asked {
            return;
        }
        let Some(scene) = &p.scene else {
            return;
        };
        let progress = BuildProgress::default().abandoned_after(&self.latest, asked);
        match structure::build_scene(scene, &p.params, &progress) {
            Ok(built) => {
                let sah = predict_sah(&built, &p.params, scene);
                p.built = Some((built, sah));
                let spec = p.spec.clone();
                self.reply(Reply::Prefetched(spec));
            }
            Err(StructureError::Abandoned) => {}
            Err(_) => self.prefetch = None,
        }
    }

    /// The prefetched scene of `spec`, with its structure if it was built with the
    /// parameters the worker builds with now.
    pub(in crate::app) fn take_prefetched(
        &mut self,
        spec: &str,
    ) -> Option<(Scene, Option<Prebuilt>)> {
        let p = self
            .prefetch
            .take_if(|p| p.spec == spec && p.scene.is_some())?;
        let built = p.built.filter(|_| p.params == self.params);
        Some((p.scene?, built))
    }
}
