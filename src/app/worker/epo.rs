//! The tree's EPO for "SAH predicted against measured": made at a quiet moment after each
//! build or refit, since on a large scene it takes as long as a build and the frame comes
//! first; given up as soon as a command arrives, and made again at the next quiet moment.
//! The two levels have no EPO of their own (their placed triangles are not listed to
//! clip): there it is the selected instance's BLAS's, in its mesh's space.

use super::messages::Reply;
use super::state::State;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How long the worker must have had nothing to do before it computes the EPO: past the
/// pauses between the commands of an orbit or a drag.
pub(in crate::app) const IDLE_BEFORE: Duration = Duration::from_millis(150);

impl State {
    /// Whether the current tree's EPO (or under the two levels the selected BLAS's) is
    /// still to be computed.
    pub(in crate::app) fn epo_waiting(&self) -> bool {
        let Some(structure) = &self.structure else {
            return false;
        };
        if structure.kind().has_sah_cost() {
            return self.epo_version != Some(self.version);
        }
        self.instance
            .as_ref()
            .is_some_and(|i| self.blas_epo_for != Some((self.version, i.instance)))
    }

    /// Computes the current tree's EPO (or the selected BLAS's) and sends it, unless a
    /// command arrives first.
    pub(in crate::app) fn epo_now(&mut self) {
        let (Some(structure), Some(scene)) = (&self.structure, &self.scene) else {
            return;
        };
        let asked = self.latest.load(Ordering::Relaxed);
        let latest = &self.latest;
        let abandon = || latest.load(Ordering::Relaxed) != asked;
        if !structure.kind().has_sah_cost() {
            let Some(selected) = &self.instance else {
                return;
            };
            let done = (self.version, selected.instance);
            let instancing = scene.instancing();
            let mesh = instancing.meshes.get(selected.mesh).copied();
            let Some(mesh) = mesh.filter(|m| m.len() == selected.triangle_count) else {
                self.blas_epo_for = Some(done);
                return;
            };
            let (c_trav, c_isect) = self.params.sah_constants();
            let epo =
                crate::accel::epo::epo_unless(&selected.blas, mesh, c_trav, c_isect, &abandon);
            if let Some(epo) = epo {
                self.blas_epo_for = Some(done);
                self.reply(Reply::BlasEpo {
                    instance: selected.instance,
                    epo,
                });
            }
            return;
        }
        let Ok(triangles) = scene.flattened() else {
            self.epo_version = Some(self.version);
            return;
        };
        if let Some(epo) = structure.epo_unless(&self.params, &triangles, &abandon) {
            self.epo_version = Some(self.version);
            self.reply(Reply::Epo(epo));
        }
    }
}
