//! The whole stress suite: every case for every intersector, the totals and the verdict. The
//! watertight default and the f64 reference must produce the zeros; Möller–Trumbore
//! is measured, and fails only on a NaN.

use super::crossing::{self, CrossingReport, Topology};
use super::degenerate::{self, DegenerateReport};
use super::grazing::{self, GrazingReport};
use super::instanced::{InstancedCase, PlacementAgreement};
use super::leaks::{LeakCase, Leaks, count_leaks, placements};
use super::meshes::ClosedMesh;
use super::shadow::{self, ShadowReport};
use super::slab::{self, SlabReport};
use crate::accel::bvh::{BuildParams, build};
use crate::accel::structure;
use crate::accel::{StructureError, StructureParams};
use crate::bench::compare::{self, Agreement};
use crate::geometry::{IntersectorKind, Ray};
use crate::scene::Scene;
use crate::with_intersector;
use serde_json::{Value, json};
use std::time::{Duration, Instant};

/// How much of everything to run.
#[derive(Clone, Debug, PartialEq)]
pub struct StressConfig {
    /// Must-hit rays per closed mesh and placement.
    pub leak_rays: usize,
    /// Of those, how many brute force traces too (with the watertight and f64 tests).
    pub brute_rays: usize,
    /// Every combination of offset and scale, not only each alone.
    pub full_grid: bool,
    pub slab_cases: u64,
    pub degenerate_rays: u64,
    pub grazing_rays: u64,
    /// Per scene: random rays compared with the reference, edge and vertex crossings, and
    /// rays whose hits spawn shadow and bounce rays.
    pub scene_rays: usize,
    pub seed: u64,
    /// The structure under test; the f64 reference always runs through a BVH.
    pub structure: StructureParams,
}

impl StressConfig {
    /// `bvhlab stress`: over 10^7 edge and vertex rays on the closed meshes alone.
    pub fn full() -> Self {
        StressConfig {
            leak_rays: 100_000,
            brute_rays: 10_000,
            full_grid: true,
            slab_cases: 10_000_000,
            degenerate_rays: 3_000_000,
            grazing_rays: 3_000_000,
            scene_rays: 1_000_000,
            seed: 1,
            structure: StructureParams::default(),
        }
    }

    /// The test suite's size: 10^5 rays per case.
    pub fn tests() -> Self {
        StressConfig {
            leak_rays: 100_000,
            brute_rays: 100_000,
            full_grid: false,
            slab_cases: 1_000_000,
            degenerate_rays: 300_000,
            grazing_rays: 200_000,
            scene_rays: 100_000,
            seed: 2,
            structure: StructureParams::default(),
        }
    }
}

/// One result per intersector, in `IntersectorKind::ALL` order.
pub type PerIntersector<T> = [T; 3];

#[derive(Clone, Debug)]
pub struct LeakCaseResult {
    pub label: String,
    pub triangles: usize,
    pub leaks: PerIntersector<Leaks>,
}

/// A closed mesh placed as rotated, scaled and mirrored instances, through the two levels.
#[derive(Clone, Debug)]
pub struct InstancedResult {
    pub label: String,
    /// The placements, in the order the rays visit them.
    pub placements: Vec<String>,
    /// Triangles of the flattened instances.
    pub triangles: usize,
    pub leaks: PerIntersector<Leaks>,
    /// Closest hits against the f64 reference over the flattened triangles (brute force).
    pub agreement: PerIntersector<PlacementAgreement>,
}

#[derive(Clone, Debug)]
pub struct SceneResult {
    pub name: String,
    pub triangles: usize,
    pub shared_edges: usize,
    pub closed_fans: usize,
    pub crossings: PerIntersector<CrossingReport>,
    pub agreement: PerIntersector<Agreement>,
    pub shadow: PerIntersector<ShadowReport>,
}

#[derive(Clone, Debug)]
pub struct StressReport {
    pub config: StressConfig,
    pub leak_cases: Vec<LeakCaseResult>,
    /// Under the two levels: the closed meshes placed as instances.
    pub instanced: Vec<InstancedResult>,
    pub slab: SlabReport,
    pub degenerate: PerIntersector<DegenerateReport>,
    pub grazing: PerIntersector<GrazingReport>,
    pub scenes: Vec<SceneResult>,
    pub elapsed: Duration,
}

fn per_intersector<T>(mut f: impl FnMut(IntersectorKind) -> T) -> PerIntersector<T> {
    IntersectorKind::ALL.map(&mut f)
}

/// Runs the suite; `log` receives one line per finished part. Fails only when the structure
/// under test cannot be built over a scene.
pub fn run(
    scenes: &[Scene],
    cfg: &StressConfig,
    log: &mut dyn FnMut(&str),
) -> Result<StressReport, StructureError> {
    let start = Instant::now();
    let mut leak_cases = Vec::new();
    for mesh in ClosedMesh::all() {
        let mut rays = 0;
        for (k, placement) in placements(cfg.full_grid).into_iter().enumerate() {
            let seed = cfg.seed ^ (k as u64) << 32;
            let Some(case) = LeakCase::new(&mesh, placement, cfg.leak_rays, seed, &cfg.structure)
            else {
                continue;
            };
            let leaks = per_intersector(|kind| {
                // Möller–Trumbore is only measured; brute force confirms the exact tests.
                let brute = if kind == IntersectorKind::MollerTrumbore {
                    0
                } else {
                    cfg.brute_rays
                };
                with_intersector!(kind, I => count_leaks::<I>(&case.bvh, &case.brute, &case.rays, brute))
            });
            rays += case.rays.len();
            leak_cases.push(LeakCaseResult {
                label: case.label(),
                triangles: case.placed.triangles.len(),
                leaks,
            });
        }
        log(&format!("watertightness: {} ({rays} rays)", mesh.name));
    }
    let mut instanced = Vec::new();
    if cfg.structure.kind.places_instances() {
        for mesh in ClosedMesh::all() {
            let result = run_instanced(&mesh, cfg)?;
            log(&format!("instances: {}", result.label));
            instanced.push(result);
        }
    }
    let slab = slab::run(cfg.slab_cases, cfg.seed);
    log(&format!("slab test: {} cases", slab.cases));
    let degenerate = per_intersector(
        |kind| with_intersector!(kind, I => degenerate::run::<I>(cfg.degenerate_rays, cfg.seed)),
    );
    let grazing = per_intersector(
        |kind| with_intersector!(kind, I => grazing::run::<I>(cfg.grazing_rays, cfg.seed)),
    );
    log("degenerate and grazing triangles");
    let mut scene_results = Vec::new();
    for scene in scenes {
        scene_results.push(run_scene(scene, cfg)?);
        log(&format!("scene {}", scene.name));
    }
    Ok(StressReport {
        config: cfg.clone(),
        leak_cases,
        instanced,
        slab,
        degenerate,
        grazing,
        scenes: scene_results,
        elapsed: start.elapsed(),
    })
}

/// `mesh` placed as instances (rotated, scaled unevenly, mirrored) through the two levels:
/// as many rays per instance as a flat case has, the first `brute_rays` of them by brute
/// force and against the f64 reference too.
pub fn run_instanced(
    mesh: &ClosedMesh,
    cfg: &StressConfig,
) -> Result<InstancedResult, StructureError> {
    let placements = super::instanced::instance_placements().len();
    let case = InstancedCase::new(
        mesh,
        cfg.leak_rays.div_ceil(placements),
        cfg.seed ^ 0x1257,
        &cfg.structure,
    )?;
    let leaks = per_intersector(|kind| {
        let brute = if kind == IntersectorKind::MollerTrumbore {
            0
        } else {
            cfg.brute_rays
        };
        with_intersector!(kind, I => case.leaks::<I>(brute))
    });
    let agreement = per_intersector(
        |kind| with_intersector!(kind, I => case.placement_agreement::<I>(cfg.brute_rays)),
    );
    Ok(InstancedResult {
        label: case.label(),
        placements: case
            .placements
            .iter()
            .map(|p| p.label.to_string())
            .collect(),
        triangles: case.flattened.len(),
        leaks,
        agreement,
    })
}

/// Crossings, agreement and shadow rays on one scene, through the structure under test.
pub fn run_scene(scene: &Scene, cfg: &StressConfig) -> Result<SceneResult, StructureError> {
    let tris = &scene.triangles;
    let Ok((bvh, _)) = build(tris, &BuildParams::default()) else {
        unreachable!("scenes hold finite triangles and the default parameters are valid")
    };
    let s = &structure::build(tris, &cfg.structure, &Default::default())?.structure;
    let topology = Topology::new(tris);
    let crossings = topology.crossings(tris, cfg.scene_rays, cfg.seed);
    let crossings = per_intersector(
        |kind| with_intersector!(kind, I => crossing::count::<_, I>(s, tris, &crossings)),
    );
    let rays = compare::random_rays(tris, &scene.bounds(), cfg.scene_rays, cfg.seed);
    let reference = compare::reference_hits(&bvh, &rays);
    let agreement = per_intersector(
        |kind| with_intersector!(kind, I => compare::agreement::<_, _, I>(s, &bvh, tris, &rays, &reference)),
    );
    drop(reference);
    let primary = view_and_random_rays(scene, cfg.scene_rays, cfg.seed);
    let light = scene.light();
    let shadow = per_intersector(
        |kind| with_intersector!(kind, I => shadow::run::<_, I>(s, tris, &primary, light)),
    );
    Ok(SceneResult {
        name: scene.name.clone(),
        triangles: tris.len(),
        shared_edges: topology.edges(),
        closed_fans: topology.fans(),
        crossings,
        agreement,
        shadow,
    })
}

/// Half pixel-centre rays of the scene's view (4:3), half random rays.
fn view_and_random_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let h = ((n as f64 / 2.0 * 0.75).sqrt() as u32).max(1);
    let w = (h * 4 / 3).max(1);
    let cam = scene.camera().rays(w, h);
    let mut rays: Vec<Ray> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| cam.pixel_center(x, y))
        .collect();
    let rest = n.saturating_sub(rays.len());
    rays.extend(compare::random_rays(
        &scene.triangles,
        &scene.bounds(),
        rest,
        seed ^ 0x5eed,
    ));
    rays
}

impl StressReport {
    /// Must-hit rays aimed at edges and vertices: closed meshes and scene crossings.
    pub fn edge_and_vertex_rays(&self) -> u64 {
        let meshes: u64 = self.leak_cases.iter().map(|c| c.leaks[0].rays).sum();
        let instanced: u64 = self.instanced.iter().map(|c| c.leaks[0].rays).sum();
        let scenes: u64 = self.scenes.iter().map(|s| s.crossings[0].rays).sum();
        meshes + instanced + scenes
    }

    pub fn leak_totals(&self) -> PerIntersector<Leaks> {
        let mut t = [Leaks::default(); 3];
        for c in &self.leak_cases {
            for (total, leaks) in t.iter_mut().zip(&c.leaks) {
                total.add(leaks);
            }
        }
        t
    }

    /// Every count that must be zero and is not, described. Counts of the watertight and f64
    /// tests must all be zero; Möller–Trumbore may leak and mismatch but never give a NaN.
    pub fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut check = |what: String, n: u64| {
            if n > 0 {
                out.push(format!("{what}: {n}"));
            }
        };
        for (k, kind) in IntersectorKind::ALL.iter().enumerate() {
            let name = kind.label();
            let exact = *kind != IntersectorKind::MollerTrumbore;
            check(
                format!("{name}: NaN in degenerate hits"),
                self.degenerate[k].non_finite,
            );
            check(
                format!("{name}: bad grazing hits"),
                self.grazing[k].bad_hits,
            );
            if !exact {
                continue;
            }
            for c in &self.leak_cases {
                check(format!("{name}: leaks on {}", c.label), c.leaks[k].total());
            }
            for c in &self.instanced {
                check(format!("{name}: leaks on {}", c.label), c.leaks[k].total());
                let a = &c.agreement[k];
                check(
                    format!("{name}: mismatches on {}", c.label),
                    a.mismatches + a.missing,
                );
            }
            check(
                format!("{name}: degenerate triangles hit"),
                self.degenerate[k].total_hits(),
            );
            check(
                format!("{name}: in-plane rays hit"),
                self.grazing[k].in_plane_hits,
            );
            for s in &self.scenes {
                check(
                    format!("{name}: crossings lost on {}", s.name),
                    s.crossings[k].leaks(),
                );
                check(
                    format!("{name}: mismatches on {}", s.name),
                    s.agreement[k].mismatches,
                );
                check(
                    format!("{name}: self-hits on {}", s.name),
                    s.shadow[k].self_hits(),
                );
            }
        }
        check("slab test".into(), self.slab.failures());
        out
    }

    pub fn to_json(&self) -> Value {
        let by_kind = |f: &dyn Fn(usize) -> Value| {
            let mut m = serde_json::Map::new();
            for (k, kind) in IntersectorKind::ALL.iter().enumerate() {
                m.insert(kind.label().into(), f(k));
            }
            Value::Object(m)
        };
        let leaks = |l: &Leaks| {
            json!({
                "rays": l.rays, "bvh_closest": l.bvh_closest, "bvh_any": l.bvh_any,
                "brute_rays": l.brute_rays, "brute_closest": l.brute_closest,
            })
        };
        let agreement = |a: &Agreement| {
            json!({"rays": a.rays, "reference_hits": a.reference_hits, "agree": a.agree,
                   "ties": a.ties, "rounding": a.rounding, "mismatches": a.mismatches,
                   "max_rel_t_error": a.max_rel_t_error})
        };
        let totals = self.leak_totals();
        let s = &self.slab;
        json!({
            "seed": self.config.seed,
            "seconds": (self.elapsed.as_secs_f64() * 10.0).round() / 10.0,
            "edge_and_vertex_rays": self.edge_and_vertex_rays(),
            "failures": self.failures(),
            "passed": self.failures().is_empty(),
            "watertightness": {
                "cases": self.leak_cases.len(),
                "totals": by_kind(&|k| leaks(&totals[k])),
                "per_case": self.leak_cases.iter().map(|c| json!({
                    "case": c.label,
                    "triangles": c.triangles,
                    "leaks": by_kind(&|k| leaks(&c.leaks[k])),
                })).collect::<Vec<_>>(),
            },
            "instanced": self.instanced.iter().map(|c| json!({
                "case": c.label,
                "placements": c.placements,
                "triangles": c.triangles,
                "leaks": by_kind(&|k| leaks(&c.leaks[k])),
                "agreement": by_kind(&|k| {
                    let a = &c.agreement[k];
                    json!({"rays": a.rays, "same_triangle": a.same_triangle,
                           "shared_point": a.shared_point, "missing": a.missing,
                           "mismatches": a.mismatches, "max_error": a.max_error})
                }),
            })).collect::<Vec<_>>(),
            "slab": {
                "cases": s.cases, "touching": s.touching, "missed": s.missed,
                "late_entry": s.late_entry, "axis_parallel": s.axis_parallel,
                "axis_parallel_wrong": s.axis_parallel_wrong, "clear_misses": s.clear_misses,
                "clear_misses_hit": s.clear_misses_hit, "nan": s.nan,
            },
            "degenerate": by_kind(&|k| {
                let d = &self.degenerate[k];
                json!({"rays": d.rays, "point_hits": d.hits[0], "repeated_vertex_hits": d.hits[1],
                       "collinear_hits": d.hits[2], "non_finite": d.non_finite})
            }),
            "grazing": by_kind(&|k| {
                let g = &self.grazing[k];
                json!({"in_plane": g.in_plane, "in_plane_hits": g.in_plane_hits,
                       "near_plane": g.near_plane, "near_plane_hits": g.near_plane_hits,
                       "bad_hits": g.bad_hits})
            }),
            "scenes": self.scenes.iter().map(|sc| json!({
                "scene": sc.name,
                "triangles": sc.triangles,
                "shared_edges": sc.shared_edges,
                "closed_vertex_fans": sc.closed_fans,
                "crossings": by_kind(&|k| {
                    let c = &sc.crossings[k];
                    json!({"rays": c.rays, "missed": c.missed, "passed_through": c.passed_through,
                           "any_missed": c.any_missed})
                }),
                "agreement": by_kind(&|k| agreement(&sc.agreement[k])),
                "shadow": by_kind(&|k| {
                    let r = &sc.shadow[k];
                    json!({"shadow_rays": r.shadow_rays, "occluded": r.occluded,
                           "shadow_self_hits": r.shadow_self_hits, "bounce_rays": r.bounce_rays,
                           "bounce_self_hits": r.bounce_self_hits})
                }),
            })).collect::<Vec<_>>(),
        })
    }
}
