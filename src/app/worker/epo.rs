//! The tree's EPO for "SAH predicted against measured": made at a quiet moment after each
//! build or refit, since on a large scene it takes as long as a build and the frame comes
//! first; given up as soon as a command arrives, and made again at the next quiet moment.

use super::messages::Reply;
use super::state::State;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How long the worker must have had nothing to do before it computes the EPO: past the
/// pauses between the commands of an orbit or a drag.
pub(in crate::app) const IDLE_BEFORE: Duration = Duration::from_millis(150);

impl State {
    /// Whether the current tree's EPO is still to be computed.
    pub(in crate::app) fn epo_waiting(&self) -> bool {
        self.structure
            .as_ref()
            .is_some_and(|s| s.kind().has_sah_cost())
            && self.epo_version != Some(self.version)
    }

    /// Computes the current tree's EPO and sends it, unless a command arrives first.
    pub(in crate::app) fn epo_now(&mut self) {
        let (Some(structure), Some(scene)) = (&self.structure, &self.scene) else {
            return;
        };
        let Ok(triangles) = scene.flattened() else {
            self.epo_version = Some(self.version);
            return;
        };
        let asked = self.latest.load(Ordering::Relaxed);
        let latest = &self.latest;
        let abandon = || latest.load(Ordering::Relaxed) != asked;
        if let Some(epo) = structure.epo_unless(&self.params, &triangles, &abandon) {
            self.epo_version = Some(self.version);
            self.reply(Reply::Epo(epo));
        }
    }
}
