//! The tree's EPO for "SAH predicted against measured": made at a quiet moment after each
//! build or refit, since on a large scene it takes as long as a build and the frame comes
//! first; given up as soon as a command arrives, and made again at the next quiet moment.
//! Under the two levels it is both levels' (estimated from end points on a scene placing
//! too many triangles to clip), then the selected instance's BLAS's, in its mesh's space.

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
        // The trees the SAH describes (asked of the kind: this runs at every command).
        let kind = structure.kind();
        if !kind.has_sah_cost() && !kind.places_instances() {
            return false;
        }
        self.epo_version != Some(self.version) || self.blas_epo_waiting()
    }

    /// Under the two levels, whether the selected instance's BLAS's EPO is still to come.
    fn blas_epo_waiting(&self) -> bool {
        let two_level = self
            .structure
            .as_ref()
            .is_some_and(|s| !s.kind().has_sah_cost());
        two_level
            && self
                .instance
                .as_ref()
                .is_some_and(|i| self.blas_epo_for != Some((self.version, i.instance)))
    }

    /// Computes the current tree's EPO, then under the two levels the selected BLAS's, and
    /// sends each, unless a command arrives first.
    pub(in crate::app) fn epo_now(&mut self) {
        let (Some(structure), Some(scene)) = (&self.structure, &self.scene) else {
            return;
        };
        let asked = self.latest.load(Ordering::Relaxed);
        let latest = &self.latest;
        let abandon = || latest.load(Ordering::Relaxed) != asked;
        if self.epo_version != Some(self.version) {
            // Given up: made again at the next quiet moment. A structure without one (a
            // flat tree over a scene too large to flatten) is not asked again.
            match structure.epo_unless(&self.params, scene, &abandon) {
                Some(epo) => self.reply(Reply::Epo(epo)),
                None if abandon() => return,
                None => {}
            }
            self.epo_version = Some(self.version);
        }
        if !self.blas_epo_waiting() {
            return;
        }
        let (Some(selected), Some(scene)) = (&self.instance, &self.scene) else {
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
        let epo = crate::accel::epo::epo_unless(&selected.blas, mesh, c_trav, c_isect, &abandon);
        if let Some(epo) = epo {
            self.blas_epo_for = Some(done);
            self.reply(Reply::BlasEpo {
                instance: selected.instance,
                epo,
            });
        }
    }
}
