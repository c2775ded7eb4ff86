//! The watertightness part of the suite for Embree 3 (`bvhlab stress --embree`): the same
//! must-hit rays on the same closed meshes at every offset and scale, traced through Embree
//! with its defaults and with its robust flag, beside bvhlab's structure under test with the
//! watertight test. A ray that finds nothing is a leak, as in `leaks`. Built only with the
//! `embree` feature.

use super::leaks::{Family, LeakCase, placements};
use super::meshes::ClosedMesh;
use super::suite::StressConfig;
use crate::accel::embree::{Embree, EmbreeMode};
use crate::accel::{Accel, NoStats};
use crate::geometry::{Ray, Watertight};
use rayon::prelude::*;

/// Leaks of one tracer over some cases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TracerLeaks {
    /// Closest-hit queries that found no hit.
    pub closest: u64,
    /// Any-hit queries that answered "not occluded".
    pub any: u64,
}

impl TracerLeaks {
    fn add(&mut self, o: TracerLeaks) {
        self.closest += o.closest;
        self.any += o.any;
    }
}

/// One closed mesh over all placements, or one placement over all meshes.
#[derive(Clone, Debug, Default)]
pub struct PeerLeakRow {
    pub label: String,
    pub rays: u64,
    /// bvhlab's structure under test with the watertight test.
    pub bvhlab: TracerLeaks,
    pub embree: TracerLeaks,
    pub embree_robust: TracerLeaks,
}

impl PeerLeakRow {
    fn add(&mut self, o: &PeerLeakRow) {
        self.rays += o.rays;
        self.bvhlab.add(o.bvhlab);
        self.embree.add(o.embree);
        self.embree_robust.add(o.embree_robust);
    }
}

/// The comparison, per mesh, per placement (offset and scale) and per way of aiming, with
/// its total.
#[derive(Clone, Debug, Default)]
pub struct PeerLeakReport {
    pub meshes: Vec<PeerLeakRow>,
    pub placements: Vec<PeerLeakRow>,
    pub families: Vec<PeerLeakRow>,
    pub total: PeerLeakRow,
}

/// Whether `accel` loses each ray of `rays`: by closest hit, by any hit.
fn lost<A: Accel + Sync>(accel: &A, rays: &[Ray]) -> Vec<(bool, bool)> {
    rays.par_iter()
        .with_min_len(256)
        .map(|r| {
            let closest = accel
                .closest_hit::<Watertight, _>(r, &mut NoStats)
                .is_none();
            let any = !accel.any_hit::<Watertight, _>(r, &mut NoStats);
            (closest, any)
        })
        .collect()
}

/// One case's rays and leaks per way of aiming (in `Family::ALL` order), from how each ray
/// was aimed and what bvhlab, Embree and Embree robust lost of them (`lost`).
fn by_family(families: &[Family], lost: &[Vec<(bool, bool)>; 3]) -> [PeerLeakRow; 7] {
    let mut rows: [PeerLeakRow; 7] = Default::default();
    for (i, f) in families.iter().enumerate() {
        let Some(k) = Family::ALL.iter().position(|x| x == f) else {
            continue;
        };
        let row = &mut rows[k];
        row.rays += 1;
        let tracers = [&mut row.bvhlab, &mut row.embree, &mut row.embree_robust];
        for (leaks, lost) in tracers.into_iter().zip(lost) {
            let (closest, any) = lost[i];
            leaks.add(TracerLeaks {
                closest: u64::from(closest),
                any: u64::from(any),
            });
        }
    }
    rows
}

/// Runs the must-hit rays of every closed mesh and placement of `cfg` (the same cases and
/// seeds as the suite) through bvhlab and both Embree modes; `log` receives a line per mesh.
pub fn run(cfg: &StressConfig, log: &mut dyn FnMut(&str)) -> Result<PeerLeakReport, String> {
    let threads = rayon::current_num_threads();
    let places = placements(cfg.full_grid);
    let mut report = PeerLeakReport {
        placements: places
            .iter()
            .map(|p| PeerLeakRow {
                label: p.label(),
                ..Default::default()
            })
            .collect(),
        total: PeerLeakRow {
            label: "all".into(),
            ..Default::default()
        },
        families: Family::ALL
            .iter()
            .map(|f| PeerLeakRow {
                label: format!("{f:?}"),
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    };
    for mesh in ClosedMesh::all() {
        let mut row = PeerLeakRow {
            label: mesh.name.to_string(),
            ..Default::default()
        };
        for (k, placement) in places.iter().enumerate() {
            let seed = cfg.seed ^ (k as u64) << 32;
            let Some(case) = LeakCase::new(&mesh, *placement, cfg.leak_rays, seed, &cfg.structure)
            else {
                continue;
            };
            let tris = &case.placed.triangles;
            let embree = Embree::build(tris, threads, EmbreeMode::Default)?;
            let robust = Embree::build(tris, threads, EmbreeMode::Robust)?;
            let lost = [
                lost(&case.bvh, &case.rays),
                lost(&embree, &case.rays),
                lost(&robust, &case.rays),
            ];
            // The case's row is the sum of its families' rows.
            for (total, one) in report
                .families
                .iter_mut()
                .zip(by_family(&case.families, &lost))
            {
                total.add(&one);
                row.add(&one);
                report.placements[k].add(&one);
            }
        }
        log(&format!(
            "Embree watertightness: {} ({} rays)",
            row.label, row.rays
        ));
        report.total.add(&row);
        report.meshes.push(row);
    }
    report.placements.retain(|p| p.rays > 0);
    Ok(report)
}
