//! Under the two levels, the selected instance's BLAS as a tree of its own: its SAH cost
//! and EPO in its mesh's space, shown beside the two levels' SAH cost (which has no EPO:
//! their placed triangles are not listed to clip).

use crate::accel::Outline;
use crate::accel::two_level::InstanceOutline;
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct BlasCosts {
    pub instance: usize,
    /// The BLAS weighed: a new one (another instance, or a rebuild) is weighed again.
    blas: Arc<Outline>,
    pub sah_cost: f64,
    /// Made by the worker at a quiet moment (`Reply::BlasEpo`).
    pub epo: Option<f64>,
}

impl BlasCosts {
    /// The costs of the selected instance's BLAS weighed with (C_trav, C_isect), kept from
    /// `before` where the BLAS is the same (the instance only moved: a drag sends the
    /// selection again at every step, and the BLAS need not be summed again).
    pub fn of(
        selected: Option<&Arc<InstanceOutline>>,
        before: Option<BlasCosts>,
        (c_trav, c_isect): (f32, f32),
    ) -> Option<BlasCosts> {
        let selected = selected?;
        let same =
            |b: &BlasCosts| b.instance == selected.instance && Arc::ptr_eq(&b.blas, &selected.blas);
        if let Some(before) = before.filter(same) {
            return Some(before);
        }
        Some(BlasCosts {
            instance: selected.instance,
            blas: selected.blas.clone(),
            sah_cost: selected.blas.sah_cost(c_trav, c_isect),
            epo: None,
        })
    }

    /// The worker's EPO of `instance`'s BLAS, if it is the one selected.
    pub fn set_epo(&mut self, instance: usize, epo: f64) {
        if self.instance == instance {
            self.epo = Some(epo);
        }
    }
}
