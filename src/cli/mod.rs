//! Arguments shared by the subcommands, and one file per subcommand.

pub mod app;
pub mod bench;
pub mod compare;
pub mod frames;
pub mod render;
pub mod replay;
pub mod stats;
pub mod stress;
pub mod trace;

use anyhow::{Context, Result, bail};
use bvhlab::accel::bvh::{BuildParams, Strategy, TraversalOrder};
use bvhlab::accel::grid::GridParams;
use bvhlab::accel::kdtree::{KdParams, KdSplit};
use bvhlab::accel::octree::OctreeParams;
use bvhlab::accel::structure::{self, AccelKind, Built, StructureParams};
use bvhlab::geometry::IntersectorKind;
use bvhlab::geometry::simd::SimdLevel;
use bvhlab::scene::{Camera, Scene};
use clap::{Args, ValueEnum};
use glam::Vec3;

/// The structure and its build parameters, shared by every subcommand that builds one.
#[derive(Args, Clone)]
pub struct BuildArgs {
    /// Acceleration structure (`all`: every structure, `bench` only). Default: two-level
    /// for a scene with instances of its own (glTF, island); otherwise, for `render`, `bench`
    /// and `trace`, the fastest layout this machine traces (bvh8 with AVX2 or AVX-512, bvh4
    /// with SSE4.1 only), for the other commands bvh.
    #[arg(long, value_enum)]
    pub accel: Option<AccelArg>,
    /// Spatial structures: test a triangle once per ray even if several cells hold it
    /// (`--mailbox false` to see the repeats).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub mailbox: bool,
    /// Split strategy.
    #[arg(long, value_enum, default_value_t = BuilderArg::SahBinned)]
    pub builder: BuilderArg,
    /// Bucket count B for binned SAH (2..=256).
    #[arg(long, default_value_t = BuildParams::default().buckets)]
    pub buckets: u32,
    /// Leaves per treelet for lbvh-treelet (5..=9).
    #[arg(long, default_value_t = BuildParams::default().treelet_size)]
    pub treelet_size: u32,
    /// Rounds of treelet restructuring for lbvh-treelet (0..=16).
    #[arg(long, default_value_t = BuildParams::default().treelet_rounds)]
    pub rounds: u32,
    /// sbvh: try spatial splits where the object split's children overlap by more than this
    /// fraction of the root's surface area (0..=1).
    #[arg(long, default_value_t = BuildParams::default().split_alpha, allow_negative_numbers = true)]
    pub split_alpha: f32,
    /// sbvh: weighed against a spatial split, an object split costs its SAH cost × (1 + κ ·
    /// its children's overlap area / the node's area), for the rays that front-to-back order
    /// cannot stop early in that overlap (0..=16; 0 = the plain SAH).
    #[arg(long, default_value_t = BuildParams::default().overlap_penalty, allow_negative_numbers = true)]
    pub overlap_penalty: f32,
    /// sbvh: at most this many duplicated references, as a fraction of the triangle count
    /// (0..=16).
    #[arg(long, default_value_t = BuildParams::default().split_budget, allow_negative_numbers = true)]
    pub split_budget: f32,
    /// lbvh, lbvh-treelet, sah-binned: pre-split the triangles that waste most box area,
    /// adding at most this many references as a fraction of the triangle count (0..=16; 0 =
    /// off).
    #[arg(long, default_value_t = BuildParams::default().presplit, allow_negative_numbers = true)]
    pub presplit: f32,
    /// two-level: partial re-braiding; the top level may open large instances into
    /// references to their BLAS's subtrees, largest first, up to this many extra references
    /// per instance, counting at least 4096 instances (0..=16; 0 = one reference per
    /// instance).
    #[arg(long, default_value_t = BuildParams::default().rebraid, allow_negative_numbers = true)]
    pub rebraid: f32,
    /// Maximum number of triangles in a leaf (1..=4096).
    #[arg(long, default_value_t = BuildParams::default().max_leaf_size)]
    pub max_leaf: u32,
    /// SAH cost of a traversal step.
    #[arg(long, default_value_t = BuildParams::default().c_trav, allow_negative_numbers = true)]
    pub c_trav: f32,
    /// SAH cost of a ray–triangle test.
    #[arg(long, default_value_t = BuildParams::default().c_isect, allow_negative_numbers = true)]
    pub c_isect: f32,
    /// Child order in closest-hit traversal.
    #[arg(long, value_enum, default_value_t = OrderArg::FrontToBack)]
    pub order: OrderArg,
    /// k-d tree: SAH cost of a traversal step.
    #[arg(long, default_value_t = KdParams::default().c_trav)]
    pub kd_c_trav: f32,
    /// k-d tree: SAH cost of a ray–triangle test.
    #[arg(long, default_value_t = KdParams::default().c_isect)]
    pub kd_c_isect: f32,
    /// k-d tree: a split with an empty side costs (1 − bonus) × its SAH cost (0..1).
    #[arg(long, default_value_t = KdParams::default().empty_bonus)]
    pub empty_bonus: f32,
    /// k-d tree: depth bound (0 = 8 + 1.3·log2 N).
    #[arg(long, default_value_t = KdParams::default().max_depth)]
    pub kd_max_depth: u32,
    /// k-d tree: nodes with this many references or fewer become leaves.
    #[arg(long, default_value_t = KdParams::default().max_leaf_size)]
    pub kd_max_leaf: u32,
    /// k-d tree: split candidates from B bins per axis instead of the exact event sweep
    /// (0 = the sweep).
    #[arg(long, default_value_t = 0)]
    pub kd_bins: u32,
    /// Uniform grid: cells ≈ λ · triangles (1/16..=64).
    #[arg(long, default_value_t = GridParams::default().lambda)]
    pub lambda: f32,
    /// Octree: a cell holding more triangles than this is split.
    #[arg(long, default_value_t = OctreeParams::default().max_leaf_size)]
    pub octree_max_leaf: u32,
    /// Octree: cells at this depth are not split.
    #[arg(long, default_value_t = OctreeParams::default().max_depth)]
    pub octree_max_depth: u32,
    /// BVH4/BVH8: the SIMD slab kernel (default: the widest this CPU has).
    #[arg(long, value_enum)]
    pub simd: Option<SimdArg>,
}

#[derive(ValueEnum, Clone, Copy, PartialEq)]
pub enum SimdArg {
    Portable,
    #[value(name = "sse4.1")]
    Sse41,
    Avx2,
    Avx512,
}

impl SimdArg {
    pub fn level(self) -> SimdLevel {
        match self {
            SimdArg::Portable => SimdLevel::Portable,
            SimdArg::Sse41 => SimdLevel::Sse41,
            SimdArg::Avx2 => SimdLevel::Avx2,
            SimdArg::Avx512 => SimdLevel::Avx512,
        }
    }
}

#[derive(ValueEnum, Clone, Copy)]
pub enum BuilderArg {
    ObjectMedian,
    SpatialMedian,
    SahSweep,
    SahBinned,
    /// Karras 2012: Morton codes, radix sort, radix tree; leaves collapsed by the SAH.
    Lbvh,
    /// LBVH then Karras–Aila treelet restructuring (--treelet-size, --rounds).
    LbvhTreelet,
    /// Binned SAH with spatial splits, Stich et al. 2009 (--split-alpha, --split-budget).
    Sbvh,
}

#[derive(ValueEnum, Clone, Copy)]
pub enum OrderArg {
    FrontToBack,
    Naive,
}

#[derive(ValueEnum, Clone, Copy, PartialEq)]
pub enum AccelArg {
    /// The BVH2 built with the --builder parameters.
    Bvh,
    /// The BVH2 collapsed into a 4-wide BVH, traced with SIMD (--simd).
    Bvh4,
    /// The BVH2 collapsed into an 8-wide BVH, traced with SIMD (--simd).
    Bvh8,
    /// SAH k-d tree with perfect splits (--kd-* parameters, --empty-bonus).
    Kdtree,
    /// Uniform grid of about λ·N cells (--lambda).
    Grid,
    /// Sparse adaptive octree (--octree-* parameters).
    Octree,
    /// Every triangle for every ray.
    BruteForce,
    /// Every triangle whose own box the ray pierces, after the scene's box.
    BruteForceBbox,
    /// A top-level BVH over the instances, one bottom-level BVH per unique mesh (each OBJ
    /// object is one instance); BLASes built with the --builder parameters.
    TwoLevel,
    /// Every structure in turn (bench only).
    All,
}

impl AccelArg {
    /// The structure this names; `all` is for `bench` only.
    pub fn kind(self) -> Result<AccelKind> {
        Ok(match self {
            AccelArg::Bvh => AccelKind::Bvh,
            AccelArg::Bvh4 => AccelKind::Bvh4,
            AccelArg::Bvh8 => AccelKind::Bvh8,
            AccelArg::Kdtree => AccelKind::KdTree,
            AccelArg::Grid => AccelKind::Grid,
            AccelArg::Octree => AccelKind::Octree,
            AccelArg::BruteForce => AccelKind::BruteForce,
            AccelArg::BruteForceBbox => AccelKind::BruteForceBbox,
            AccelArg::TwoLevel => AccelKind::TwoLevel,
            AccelArg::All => bail!("--accel all is only for `bvhlab bench`; name one structure"),
        })
    }
}

/// The ray–triangle test (see `bvhlab::geometry::IntersectorKind`).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq)]
pub enum IntersectorArg {
    /// Woop, Benthin and Wald (2013) in f32: no ray slips between triangles.
    Watertight,
    /// Möller–Trumbore (1997) in f32: fast, not watertight.
    MollerTrumbore,
    /// The watertight test in f64: the accurate reference.
    F64,
}

impl IntersectorArg {
    pub fn kind(self) -> IntersectorKind {
        match self {
            IntersectorArg::Watertight => IntersectorKind::Watertight,
            IntersectorArg::MollerTrumbore => IntersectorKind::MollerTrumbore,
            IntersectorArg::F64 => IntersectorKind::F64,
        }
    }
}

#[derive(ValueEnum, Clone, Copy, PartialEq)]
pub enum ModeArg {
    Shaded,
    Normals,
    Depth,
    /// Heatmap of nodes visited.
    Nodes,
    /// Heatmap of ray–box tests.
    Boxes,
    /// Heatmap of ray–triangle tests.
    Triangles,
    /// Heatmap of repeated triangle tests (spatial structures with --mailbox false).
    Repeated,
    /// Two-level structure: heatmap of nodes visited in the top level (TLAS).
    TopNodes,
    /// Two-level structure: heatmap of nodes visited in the bottom levels (BLASes).
    BottomNodes,
    /// Two-level structure: heatmap of instances entered.
    Instances,
}

impl BuilderArg {
    pub fn strategy(self) -> Strategy {
        match self {
            BuilderArg::ObjectMedian => Strategy::ObjectMedian,
            BuilderArg::SpatialMedian => Strategy::SpatialMedian,
            BuilderArg::SahSweep => Strategy::SahSweep,
            BuilderArg::SahBinned => Strategy::SahBinned,
            BuilderArg::Lbvh => Strategy::Lbvh,
            BuilderArg::LbvhTreelet => Strategy::LbvhTreelet,
            BuilderArg::Sbvh => Strategy::Sbvh,
        }
    }
}

impl BuildArgs {
    pub fn params(&self) -> BuildParams {
        BuildParams {
            strategy: self.builder.strategy(),
            buckets: self.buckets,
            max_leaf_size: self.max_leaf,
            c_trav: self.c_trav,
            c_isect: self.c_isect,
            treelet_size: self.treelet_size,
            treelet_rounds: self.rounds,
            split_alpha: self.split_alpha,
            overlap_penalty: self.overlap_penalty,
            split_budget: self.split_budget,
            presplit: self.presplit,
            rebraid: self.rebraid,
        }
    }

    pub fn order(&self) -> TraversalOrder {
        match self.order {
            OrderArg::FrontToBack => TraversalOrder::FrontToBack,
            OrderArg::Naive => TraversalOrder::Naive,
        }
    }

    /// The parameters of every structure, for the structure `kind`.
    pub fn structure_params_for(&self, kind: AccelKind) -> StructureParams {
        StructureParams {
            kind,
            bvh: self.params(),
            order: self.order(),
            kdtree: KdParams {
                c_trav: self.kd_c_trav,
                c_isect: self.kd_c_isect,
                empty_bonus: self.empty_bonus,
                max_depth: self.kd_max_depth,
                max_leaf_size: self.kd_max_leaf,
                split: match self.kd_bins {
                    0 => KdSplit::Sweep,
                    b => KdSplit::Binned(b),
                },
                ..KdParams::default()
            },
            grid: GridParams {
                lambda: self.lambda,
                ..GridParams::default()
            },
            octree: OctreeParams {
                max_leaf_size: self.octree_max_leaf,
                max_depth: self.octree_max_depth,
                ..OctreeParams::default()
            },
            mailbox: self.mailbox,
            simd: self.simd.map_or_else(SimdLevel::detect, SimdArg::level),
        }
    }

    /// The structure `--accel` names, or without it the default for `scene`: the two
    /// levels where the scene has instances of its own (it may be far too large to
    /// flatten), the BVH2 otherwise.
    pub fn accel_for(&self, scene: &Scene) -> AccelArg {
        self.accel.unwrap_or(if scene.instances.is_empty() {
            AccelArg::Bvh
        } else {
            AccelArg::TwoLevel
        })
    }

    /// The structure to trace with: the one `--accel` names, or without it the two levels
    /// where the scene has instances of its own, otherwise the fastest layout this machine
    /// traces (`AccelKind::fastest`). `render`, `bench` and `trace` trace with it.
    pub fn accel_to_trace(&self, scene: &Scene) -> AccelArg {
        match self.accel {
            Some(a) => a,
            None if !scene.instances.is_empty() => AccelArg::TwoLevel,
            None => match AccelKind::fastest() {
                AccelKind::Bvh8 => AccelArg::Bvh8,
                AccelKind::Bvh4 => AccelArg::Bvh4,
                _ => AccelArg::Bvh,
            },
        }
    }

    /// A note when `--presplit` is given to a builder that does not take it (it would
    /// otherwise be dropped without a word: the SBVH splits its references itself, the
    /// median and sweep builders never do).
    pub fn presplit_ignored(&self) -> Option<String> {
        let strategy = self.builder.strategy();
        (self.presplit > 0.0 && !strategy.takes_presplit()).then(|| {
            format!(
                "note: --presplit applies to lbvh, lbvh-treelet and sah-binned; {} builds without it",
                strategy.label()
            )
        })
    }

    /// Whether `accel_to_trace` chose the fastest layout because no `--accel` was given.
    pub fn fastest_by_default(&self, scene: &Scene) -> bool {
        self.accel.is_none() && scene.instances.is_empty()
    }

    /// The parameters of the one structure `--accel` names (or `scene`'s default).
    pub fn structure_params(&self, scene: &Scene) -> Result<StructureParams> {
        Ok(self.structure_params_for(self.accel_for(scene).kind()?))
    }

    /// Builds the structure `--accel` names (or `scene`'s default) over `scene` and says so
    /// on stderr.
    pub fn build(&self, scene: &Scene) -> Result<Built> {
        self.build_kind(scene, self.accel_for(scene), "")
    }

    /// Builds the structure to trace with (`accel_to_trace`) and says so on stderr.
    pub fn build_to_trace(&self, scene: &Scene) -> Result<Built> {
        let note = if self.fastest_by_default(scene) {
            " (the fastest layout on this machine; --accel picks another)"
        } else {
            ""
        };
        self.build_kind(scene, self.accel_to_trace(scene), note)
    }

    fn build_kind(&self, scene: &Scene, accel: AccelArg, note: &str) -> Result<Built> {
        let params = self.structure_params_for(accel.kind()?);
        if let Some(ignored) = self.presplit_ignored() {
            eprintln!("{ignored}");
        }
        let built = structure::build_scene(scene, &params, &Default::default())
            .with_context(|| format!("cannot build the {}", params.kind.title()))?;
        let simd = built
            .structure
            .simd()
            .map(|l| format!(", {} kernel", l.label()))
            .unwrap_or_default();
        eprintln!(
            "built {} over {} triangles in {:.2} ms{simd}{note}",
            built.report.structure,
            built.report.triangles,
            built.report.build_ms()
        );
        Ok(built)
    }
}

#[derive(Args, Clone)]
pub struct ViewArgs {
    /// Camera position x,y,z (default: the scene's view).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look: Option<Vec3>,
    /// Point light position x,y,z (default: the scene's light).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light: Option<Vec3>,
}

impl ViewArgs {
    pub fn camera(&self, scene: &Scene) -> Result<Camera> {
        let default = scene.camera();
        let cam = Camera {
            eye: self.eye.unwrap_or(default.eye),
            look_at: self.look.unwrap_or(default.look_at),
            ..default
        };
        if cam.eye == cam.look_at {
            bail!("--eye and --look must be different points");
        }
        Ok(cam)
    }

    pub fn light(&self, scene: &Scene) -> Vec3 {
        self.light.unwrap_or_else(|| scene.light())
    }
}

pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("expected x,y,z, got '{s}'"));
    };
    let f = |v: &str| {
        v.parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("'{v}' is not a finite number"))
    };
    Ok(Vec3::new(f(x)?, f(y)?, f(z)?))
}

pub fn load_scene(spec: &str) -> Result<Scene> {
    Scene::load(spec).with_context(|| format!("cannot load scene '{spec}'"))
}

/// A rayon pool with `threads` workers (default: all cores).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        pool = pool.num_threads(n);
    }
    pool.build().context("cannot start the worker threads")
}

pub fn check_size(width: u32, height: u32) -> Result<()> {
    if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
        bail!("image size {width}×{height} must be within 1..=16384 on each side");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec3_parsing() {
        assert_eq!(parse_vec3("1,-2, 3.5"), Ok(Vec3::new(1.0, -2.0, 3.5)));
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,nan").is_err());
        assert!(parse_vec3("a,b,c").is_err());
    }
}
