//! The SAH's prediction against what the view's rays measure (`bench`): the tree's SAH
//! cost and its cost on random lines (`accel::sah_check`) beside its cost on the view's
//! primary, diffuse and shadow rays, which start on surfaces, bunch up where the camera
//! and the light are, and stop at the first or closest hit. The tree's EPO (`accel::epo`)
//! stands beside the SAH cost as a second predictor.

use crate::accel::sah_check::{MeanWork, RANDOM_RAYS, SahPrediction};
use crate::accel::{Structure, StructureParams};
use crate::scene::Scene;

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
    /// `None` for structures without an SAH cost (grid, octree, brute force, two levels).
    pub fn measure(
        accel: &Structure,
        params: &StructureParams,
        scene: &Scene,
        [primary, diffuse, shadow]: [MeanWork; 3],
    ) -> Option<SahCheck> {
        let p = SahPrediction::of(accel, params, &scene.bounds(), RANDOM_RAYS)?;
        let epo = scene
            .flattened()
            .ok()
            .and_then(|triangles| accel.epo(params, &triangles));
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
