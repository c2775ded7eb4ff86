//! The benchmark's JSON, derived: each key is a field of a `Serialize` struct made from a
//! `BenchResult`, so scripts can rely on the names (`build_ms`, `primary.hits`,
//! `primary.mrays_per_s`, `shadow.occluded`, `peer`, `peers`, `accel`, …) and no object is
//! assembled by hand.

use super::{BenchResult, MeanWork, PeerResult, RaySetResult, as_typed, builder_label, round3};
use crate::bench::sah_check::SahCheck;
use crate::scene::Scene;
use serde::Serialize;

/// One ray set: its rays, its hits (occluded rays for shadow rays), its speed, and where it
/// was counted, the mean work per ray.
#[derive(Serialize)]
pub struct RaySetJson {
    pub rays: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hits: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub occluded: Option<usize>,
    pub mrays_per_s: f64,
    #[serde(flatten)]
    pub mean: Option<MeanJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ns_per_step: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ns_per_ray: Option<f64>,
}

/// The mean counters per ray.
#[derive(Serialize)]
pub struct MeanJson {
    pub mean_nodes: f64,
    pub mean_box_tests: f64,
    pub mean_triangle_tests: f64,
    pub mean_repeated_tests: f64,
    /// Under the two levels: each level's share.
    #[serde(flatten)]
    pub levels: Option<LevelsJson>,
}

#[derive(Serialize)]
pub struct LevelsJson {
    pub mean_top_nodes: f64,
    pub mean_bottom_nodes: f64,
    pub mean_top_box_tests: f64,
    pub mean_bottom_box_tests: f64,
    pub mean_instances_entered: f64,
}

/// A peer timed on the same rays.
#[derive(Serialize)]
pub struct PeerJson {
    pub name: String,
    pub build_ms: f64,
    pub primary: RaySetJson,
    /// `null` for a peer without a packet query (tinybvh's BVH8_CPU).
    pub primary_packets: Option<RaySetJson>,
    pub diffuse: RaySetJson,
    pub shadow: RaySetJson,
    pub tied_primary_hits: usize,
    pub differing_primary_hits: usize,
    /// Of a peer's two levels, its top level's build alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub top_level_build_ms: Option<f64>,
    /// The peer's scene rebuilt after its vertices were marked changed, best of the builds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rebuild_ms: Option<f64>,
    /// bvhlab's ray sets timed in turns with this peer's (absent where bvhlab traced a
    /// sample of the rays): the figures its ratios come from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bvhlab: Option<InTurnsJson>,
}

/// bvhlab's ray sets as timed in turns with a peer's.
#[derive(Serialize)]
pub struct InTurnsJson {
    pub build_ms: f64,
    pub primary: RaySetJson,
    pub primary_packets: RaySetJson,
    pub diffuse: RaySetJson,
    pub shadow: RaySetJson,
}

/// One benchmark run: the structure, its build, the ray sets, the SAH check and the peers.
#[derive(Serialize)]
pub struct BenchJson {
    pub scene: String,
    pub accel: &'static str,
    pub triangles: usize,
    pub threads: usize,
    pub intersector: &'static str,
    pub builder: String,
    pub buckets: u32,
    pub presplit: f32,
    pub split_alpha: f32,
    pub split_budget: f32,
    pub overlap_penalty: f64,
    pub duplicated_references: usize,
    pub treelet_size: u32,
    pub treelet_rounds: u32,
    pub max_leaf_size: u32,
    pub mailbox: bool,
    /// The wide layouts' and the two levels' SIMD kernel (null for the others).
    pub simd: Option<&'static str>,
    pub build_ms: f64,
    /// The wide tree built straight from the Morton order, rebuilt into its own memory
    /// (as every frame of a moving scene), best of the builds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rebuild_ms: Option<f64>,
    pub bytes: usize,
    pub sah_cost: Option<f64>,
    pub nodes: usize,
    pub leaves: usize,
    pub empty_leaves: usize,
    pub max_leaf_depth: u32,
    pub references_per_triangle: f64,
    pub largest_leaf: usize,
    pub sampled_every: usize,
    pub primary: RaySetJson,
    pub primary_packets: RaySetJson,
    pub diffuse: RaySetJson,
    pub shadow: RaySetJson,
    pub sah_check: Option<SahCheck>,
    /// The first peer, and all of them.
    pub peer: Option<PeerJson>,
    pub peers: Vec<PeerJson>,
    #[serde(flatten)]
    pub instanced: Option<InstancedJson>,
}

/// Under the two levels: the re-braiding budget, the top level's references and each
/// level's build (their sum is `build_ms`).
#[derive(Serialize)]
pub struct InstancedJson {
    pub rebraid: f64,
    pub references: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blas_build_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tlas_build_ms: Option<f64>,
    /// The top level built again over its references where they are, best of the builds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tlas_rebuild_ms: Option<f64>,
}

impl RaySetJson {
    fn of(r: &RaySetResult, occlusion: bool, levels: bool) -> RaySetJson {
        let mean = r.mean.map(|m: MeanWork| MeanJson {
            mean_nodes: round3(m.nodes),
            mean_box_tests: round3(m.box_tests),
            mean_triangle_tests: round3(m.triangle_tests),
            mean_repeated_tests: round3(m.repeated_tests),
            levels: levels.then(|| LevelsJson {
                mean_top_nodes: round3(m.top_nodes),
                mean_bottom_nodes: round3(m.nodes - m.top_nodes),
                mean_top_box_tests: round3(m.top_box_tests),
                mean_bottom_box_tests: round3(m.box_tests - m.top_box_tests),
                mean_instances_entered: round3(m.instances_entered),
            }),
        });
        let mrays = r.mrays_per_s();
        RaySetJson {
            rays: r.rays,
            hits: (!occlusion).then_some(r.hits),
            occluded: occlusion.then_some(r.hits),
            mrays_per_s: round3(mrays),
            ns_per_step: r.mean.and_then(|m| r.ns_per_step(m.nodes)).map(round3),
            ns_per_ray: (mrays > 0.0).then(|| round3(1e3 / mrays)),
            mean,
        }
    }
}

/// A duration in milliseconds, rounded as the JSON's numbers are.
fn ms(d: std::time::Duration) -> f64 {
    round3(d.as_secs_f64() * 1e3)
}

impl PeerJson {
    fn of(p: &PeerResult) -> PeerJson {
        let set = |r: &RaySetResult, occlusion| RaySetJson::of(r, occlusion, false);
        PeerJson {
            name: p.name.clone(),
            build_ms: ms(p.build),
            primary: set(&p.primary, false),
            primary_packets: p.primary_packets.as_ref().map(|r| set(r, false)),
            diffuse: set(&p.diffuse, false),
            shadow: set(&p.shadow, true),
            tied_primary_hits: p.tied_primary_hits,
            differing_primary_hits: p.differing_primary_hits,
            top_level_build_ms: p.top_level_build.map(ms),
            rebuild_ms: p.rebuild.map(ms),
            bvhlab: p.bvhlab.as_ref().map(|t| InTurnsJson {
                build_ms: ms(t.build),
                primary: set(&t.primary, false),
                primary_packets: set(&t.primary_packets, false),
                diffuse: set(&t.diffuse, false),
                shadow: set(&t.shadow, true),
            }),
        }
    }
}

impl BenchResult {
    /// The run as its JSON's fields.
    pub fn json(&self) -> BenchJson {
        let r = &self.report;
        let b = &self.params.bvh;
        let levels = self.params.kind.places_instances();
        let set = |s, occlusion| RaySetJson::of(s, occlusion, levels);
        let mut peers: Vec<PeerJson> = self.peers.iter().map(PeerJson::of).collect();
        BenchJson {
            scene: self.scene.clone(),
            accel: self.params.kind.label(),
            triangles: self.triangles,
            threads: self.threads,
            intersector: self.intersector.label(),
            builder: builder_label(b),
            buckets: b.buckets,
            presplit: b.presplit,
            split_alpha: b.split_alpha,
            split_budget: b.split_budget,
            overlap_penalty: as_typed(b.overlap_penalty),
            duplicated_references: self.duplicated_references(),
            treelet_size: b.treelet_size,
            treelet_rounds: b.treelet_rounds,
            max_leaf_size: b.max_leaf_size,
            mailbox: self.params.mailbox,
            simd: (self.params.kind.is_wide() || levels).then(|| self.params.simd.label()),
            build_ms: round3(r.build_ms()),
            rebuild_ms: self.wide_rebuild.map(ms),
            bytes: r.bytes,
            sah_cost: self.sah_cost().map(round3),
            nodes: r.nodes,
            leaves: r.leaves,
            empty_leaves: r.empty_leaves,
            max_leaf_depth: r.max_depth,
            references_per_triangle: round3(r.references_per_triangle()),
            largest_leaf: r.largest_leaf,
            sampled_every: self.sampled,
            primary: set(&self.primary, false),
            primary_packets: set(&self.primary_packets, false),
            diffuse: set(&self.diffuse, false),
            shadow: set(&self.shadow, true),
            sah_check: self.sah_check,
            peer: (!peers.is_empty()).then(|| PeerJson::of(&self.peers[0])),
            peers: std::mem::take(&mut peers),
            instanced: levels.then(|| InstancedJson {
                rebraid: as_typed(b.rebraid),
                references: r.detail("TLAS references").and_then(|v| v.as_count()),
                blas_build_ms: r.detail("BLAS builds").and_then(|v| v.as_ms()).map(round3),
                tlas_build_ms: r.detail("TLAS build").and_then(|v| v.as_ms()).map(round3),
                tlas_rebuild_ms: self.top_level_rebuild.map(ms),
            }),
        }
    }
}

/// An instanced scene's counts: how many instances place how many unique triangles
/// (`triangles` counts them placed), and the bytes a flattened copy would take.
#[derive(Serialize)]
pub struct InstancingJson {
    pub instances: usize,
    pub unique_triangles: usize,
    pub instanced_triangles: usize,
    pub flattened_bytes: u64,
}

impl InstancingJson {
    /// `None` for a scene without instances.
    pub fn of(scene: &Scene) -> Option<InstancingJson> {
        if scene.instances.is_empty() {
            return None;
        }
        let instancing = scene.instancing();
        Some(InstancingJson {
            instances: instancing.instances.len(),
            unique_triangles: instancing.unique_triangles(),
            instanced_triangles: instancing.instanced_triangles(),
            flattened_bytes: scene.flattened_bytes(),
        })
    }
}

/// `bench` of one structure: its run, the scene's instancing and the scene's load time.
#[derive(Serialize)]
pub struct SingleJson {
    #[serde(flatten)]
    pub run: BenchJson,
    #[serde(flatten)]
    pub instancing: Option<InstancingJson>,
    pub load_ms: f64,
}

/// `bench --accel all`: the scene and each structure's run.
#[derive(Serialize)]
pub struct AllJson {
    pub scene: String,
    pub triangles: usize,
    pub threads: usize,
    pub structures: Vec<BenchJson>,
    #[serde(flatten)]
    pub instancing: Option<InstancingJson>,
}

/// `bench builders`: the scene, each builder's run, and with `--tradeoff` the range of
/// rays per frame where each builder is best.
#[derive(Serialize)]
pub struct BuildersJson {
    pub scene: String,
    pub triangles: usize,
    pub threads: usize,
    pub builders: Vec<BenchJson>,
    pub tradeoff_best: Option<Vec<BestJson>>,
}

/// A builder best from `from_rays` to `to_rays` diffuse rays per frame.
#[derive(Serialize)]
pub struct BestJson {
    pub builder: String,
    pub from_rays: f64,
    pub to_rays: f64,
}
