//! The SAH's prediction against what the view's rays measure (`bench`): the tree's SAH
//! cost and its cost on random lines (`accel::sah_check`) beside its cost on the view's
//! primary, diffuse and shadow rays, which start on surfaces, bunch up where the camera
//! and the light are, and stop at the first or closest hit.

use crate::accel::sah_check::{MeanWork, RANDOM_RAYS, SahPrediction};
use crate::accel::{Structure, StructureParams};
use crate::geometry::Aabb;

/// The prediction and the measured costs per ray, in the SAH's units (its fields are the
/// keys of `sah_check` in the bench's JSON).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SahCheck {
    pub c_trav: f32,
    pub c_isect: f32,
    /// The tree's SAH cost.
    pub predicted: f64,
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
        bounds: &Aabb,
        [primary, diffuse, shadow]: [MeanWork; 3],
    ) -> Option<SahCheck> {
        let p = SahPrediction::of(accel, params, bounds, RANDOM_RAYS)?;
        let cost = |m: MeanWork| m.cost(p.c_trav, p.c_isect);
        Some(SahCheck {
            c_trav: p.c_trav,
            c_isect: p.c_isect,
            predicted: p.predicted,
            random: p.random,
            primary: cost(primary),
            diffuse: cost(diffuse),
            shadow: cost(shadow),
        })
    }
}
