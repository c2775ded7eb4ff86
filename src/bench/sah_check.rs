//! The SAH's prediction against what the view's rays measure (`bench`): the tree's SAH
//! cost and its cost on random lines (`accel::sah_check`) beside its cost on the view's
//! primary, diffuse and shadow rays, which start on surfaces, bunch up where the camera
//! and the light are, and stop at the first or closest hit. The tree's EPO (`accel::epo`)
//! stands beside the SAH cost as a second predictor.

use crate::accel::epo::EpoWay;
use crate::accel::sah_check::{MeanWork, RANDOM_RAYS, SahPrediction};
use crate::accel::{Structure, StructureParams};
use crate::scene::Scene;
use std::time::{Duration, Instant};

/// How long the EPO may take before the bench gives it up and reports it missing: the
/// shared scenes' take under a second, but a scene of long random triangles crossing many
/// boxes (`soup:10000000`) takes minutes, which the run would otherwise spend on it.
pub const EPO_DEADLINE: Duration = Duration::from_secs(10);

/// The prediction and the measured costs per ray, in the SAH's units (its fields are the
/// keys of `sah_check` in the bench's JSON).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SahCheck {
    pub c_trav: f32,
    pub c_isect: f32,
    /// The tree's SAH cost.
    pub predicted: f64,
    /// The tree's EPO, in the same units (absent from CSVs written before it was measured).
    pub epo: Option<f64>,
    /// Uniformly random lines through the scene box, closest hit.
    pub random: f64,
    pub primary: f64,
    pub diffuse: f64,
    pub shadow: f64,
}

impl SahCheck {
    /// `None` for structures without an SAH cost (grid, octree, brute force, two levels);
    /// the EPO is `None` if it would take longer than `epo_deadline`.
    pub fn measure(
        accel: &Structure,
        params: &StructureParams,
        scene: &Scene,
        [primary, diffuse, shadow]: [MeanWork; 3],
        epo: EpoWay,
        epo_deadline: Duration,
    ) -> Option<SahCheck> {
        let p = SahPrediction::of(accel, params, &scene.bounds(), RANDOM_RAYS)?;
        let start = Instant::now();
        let late = || start.elapsed() > epo_deadline;
        let epo = accel.epo_by(params, scene, epo, &late).map(|e| e.value);
        let cost = |m: MeanWork| m.cost(p.c_trav, p.c_isect);
        Some(SahCheck {
            c_trav: p.c_trav,
            c_isect: p.c_isect,
            predicted: p.predicted,
            epo,
            random: p.random,
            primary: cost(primary),
            diffuse: cost(diffuse),
            shadow: cost(shadow),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::accel::structure::build;

    /// The EPO is reported within its deadline and left out past it; the rest of the check
    /// is the same either way.
    #[test]
    fn the_epo_is_given_up_past_its_deadline() {
        let scene = Scene::load("soup:2000").unwrap();
        let params = StructureParams::of_kind(AccelKind::Bvh8);
        let built = build(&scene.triangles, &params, &Default::default()).unwrap();
        let work = [MeanWork::default(); 3];
        let check = |deadline| {
            SahCheck::measure(
                &built.structure,
                &params,
                &scene,
                work,
                EpoWay::Exact,
                deadline,
            )
            .unwrap()
        };
        let (on_time, late) = (check(EPO_DEADLINE), check(Duration::ZERO));
        assert!(on_time.epo.is_some_and(|e| e > 0.0), "{on_time:?}");
        assert_eq!(late.epo, None);
        assert_eq!(
            SahCheck {
                epo: None,
                ..on_time
            },
            late
        );
    }
}
