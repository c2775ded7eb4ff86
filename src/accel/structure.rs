//! The structure selector: one runtime type over every built structure (BVH2, BVH4, BVH8,
//! k-d tree, uniform grid, octree, two-level, brute force), so the worker, the CLI, the
//! renderer and the bench hold one value and never assume a BVH. It dispatches once per
//! query (or per batch), and each arm calls that structure's own monomorphised traversal,
//! so the hot loops stay generic over the intersector and the statistics sink.
//!
//! Adding a structure is: its folder, a variant of `AccelKind` and `Structure`, its
//! parameters in `StructureParams` (`params.rs`), and one arm in each `match` below.

use super::bvh::refit::{RefitError, RefitIndex, RefitReport};
use super::bvh::wide::{CollapseParams, UnsupportedSimd};
use super::bvh::wide::{Lanes, NodeWidth};
use super::bvh::{self, BuildError, BuildReport, Bvh, Bvh4, Bvh8, WideBvh};
use super::epo::{Epo, EpoWay};
use super::grid::{self, Grid, GridError};
use super::kdtree::{self, KdError, KdTree};
use super::octree::{self, Octree, OctreeError};
use super::outline::Outline;
pub use super::params::StructureParams;
use super::progress::BuildProgress;
use super::report::StructureReport;
use super::two_level::{self, TwoLevel};
use super::{Accel, BruteForce, Hit, Stats, TraversalOrder};
use crate::accel::report::Detail;
use crate::budget::BudgetError;
use crate::geometry::simd::SimdLevel;
use crate::geometry::{Intersector, Ray, Triangle};
use crate::scene::{FlattenError, Instancing, Scene};
use std::time::Instant;

/// Which structure to build, as the CLI's `--accel`, the presets' `accel` and the app's
/// selector name it.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
pub enum AccelKind {
    /// The BVH2 built with the --builder parameters.
    #[default]
    Bvh,
    /// The BVH2 collapsed into a 4-wide BVH (or the LBVH's made directly, --direct-wide), traced with SIMD (--simd).
    Bvh4,
    /// The BVH2 collapsed into an 8-wide BVH (or the LBVH's made directly, --direct-wide), traced with SIMD (--simd).
    Bvh8,
    /// SAH k-d tree with perfect splits (--kd-* parameters, --empty-bonus).
    #[value(name = "kdtree")]
    KdTree,
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
}

impl AccelKind {
    /// Every structure; a test checks it against the derived list, so none is missed.
    pub const ALL: [AccelKind; 9] = [
        AccelKind::Bvh,
        AccelKind::Bvh4,
        AccelKind::Bvh8,
        AccelKind::KdTree,
        AccelKind::Grid,
        AccelKind::Octree,
        AccelKind::BruteForce,
        AccelKind::BruteForceBbox,
        AccelKind::TwoLevel,
    ];

    /// The name on the command line and in JSON.
    pub fn label(self) -> &'static str {
        match self {
            AccelKind::Bvh => "bvh",
            AccelKind::Bvh4 => "bvh4",
            AccelKind::Bvh8 => "bvh8",
            AccelKind::KdTree => "kdtree",
            AccelKind::Grid => "grid",
            AccelKind::Octree => "octree",
            AccelKind::BruteForce => "brute-force",
            AccelKind::BruteForceBbox => "brute-force-bbox",
            AccelKind::TwoLevel => "two-level",
        }
    }

    /// The name in the app and in tables.
    pub fn title(self) -> &'static str {
        match self {
            AccelKind::Bvh => "BVH2",
            AccelKind::Bvh4 => "BVH4",
            AccelKind::Bvh8 => "BVH8",
            AccelKind::KdTree => "k-d tree",
            AccelKind::Grid => "uniform grid",
            AccelKind::Octree => "octree",
            AccelKind::BruteForce => "brute force",
            AccelKind::BruteForceBbox => "brute force + box early out",
            AccelKind::TwoLevel => "two-level (TLAS + BLAS)",
        }
    }

    pub fn from_label(label: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.label() == label)
    }

    /// Whether the structure references a triangle from several cells, so mailboxing
    /// applies to it.
    pub fn is_spatial(self) -> bool {
        matches!(
            self,
            AccelKind::KdTree | AccelKind::Grid | AccelKind::Octree
        )
    }

    /// The layout that traces fastest on this machine: the BVH8 where the CPU has 8-wide
    /// vectors (AVX2 or AVX-512), the BVH4 with 4-wide SSE4.1, the BVH2 without SIMD.
    pub fn fastest() -> AccelKind {
        match SimdLevel::detect() {
            SimdLevel::Avx2 | SimdLevel::Avx512 => AccelKind::Bvh8,
            SimdLevel::Sse41 => AccelKind::Bvh4,
            SimdLevel::Portable => AccelKind::Bvh,
        }
    }

    /// A wide BVH: the BVH2 collapsed, traced with SIMD slab tests.
    /// The trees with an SAH cost (and an EPO): the BVHs, the k-d tree and the octree.
    pub fn has_sah_cost(self) -> bool {
        matches!(
            self,
            AccelKind::Bvh
                | AccelKind::Bvh4
                | AccelKind::Bvh8
                | AccelKind::KdTree
                | AccelKind::Octree
        )
    }

    pub fn is_wide(self) -> bool {
        matches!(self, AccelKind::Bvh4 | AccelKind::Bvh8)
    }

    /// Built by a BVH2 builder (the BVH2 itself or its collapse): the BVH parameters apply.
    pub fn is_bvh(self) -> bool {
        matches!(self, AccelKind::Bvh | AccelKind::Bvh4 | AccelKind::Bvh8)
    }

    pub fn is_brute_force(self) -> bool {
        matches!(self, AccelKind::BruteForce | AccelKind::BruteForceBbox)
    }

    /// Whether a ray walks the structure's cells in order (the grid's 3D-DDA), so the app
    /// can show the cells under the pointer.
    pub fn walks_cells(self) -> bool {
        self == AccelKind::Grid
    }

    /// Whether the structure places instances: a top level over per-mesh bottom levels.
    pub fn places_instances(self) -> bool {
        self == AccelKind::TwoLevel
    }

    /// Whether the structure can be refitted after motion (rather than rebuilt).
    pub fn can_refit(self) -> bool {
        self.is_bvh()
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StructureError {
    #[error(transparent)]
    Bvh(#[from] BuildError),
    #[error(transparent)]
    KdTree(#[from] KdError),
    #[error(transparent)]
    Grid(#[from] GridError),
    #[error(transparent)]
    Octree(#[from] OctreeError),
    #[error(transparent)]
    Simd(#[from] UnsupportedSimd),
    #[error(transparent)]
    Flatten(#[from] FlattenError),
    #[error(transparent)]
    Memory(#[from] BudgetError),
    /// A newer request replaced the build in flight (`BuildProgress::is_abandoned`).
    #[error("the build was abandoned for a newer request")]
    Abandoned,
}

/// A built structure.
pub enum Structure {
    Bvh(Bvh),
    Bvh4(Bvh4),
    Bvh8(Bvh8),
    KdTree(KdTree),
    Grid(Grid),
    Octree(Octree),
    BruteForce(BruteForce),
    TwoLevel(Box<TwoLevel>),
}

/// A structure with its report; for a BVH also its own detailed report (SAH cost, leaf
/// sizes) that refits update.
pub struct Built {
    pub structure: Structure,
    pub report: StructureReport,
    pub bvh_report: Option<BuildReport>,
}

/// Evaluates `$body` with `$a` bound to the built structure inside `$s`, whatever it is.
#[macro_export]
macro_rules! with_structure {
    ($s:expr, $a:ident => $body:expr) => {
        match $s {
            $crate::accel::structure::Structure::Bvh($a) => $body,
            $crate::accel::structure::Structure::Bvh4($a) => $body,
            $crate::accel::structure::Structure::Bvh8($a) => $body,
            $crate::accel::structure::Structure::KdTree($a) => $body,
            $crate::accel::structure::Structure::Grid($a) => $body,
            $crate::accel::structure::Structure::Octree($a) => $body,
            $crate::accel::structure::Structure::BruteForce($a) => $body,
            $crate::accel::structure::Structure::TwoLevel($a) => $body,
        }
    };
}

/// Builds the structure `params.kind` over `scene`: the two-level structure over its
/// meshes and instances (each object one instance in a scene without its own), every
/// other structure over its flattened triangles (flattened here if the scene does not store
/// them, an error if they are too many). Hits name triangles of the flattened scene.
pub fn build_scene(
    scene: &Scene,
    params: &StructureParams,
    progress: &BuildProgress,
) -> Result<Built, StructureError> {
    super::memory::check_scene(params, scene)?;
    if params.kind == AccelKind::TwoLevel {
        return build_two_level(&scene.instancing(), params, progress);
    }
    build(&scene.flattened()?, params, progress)
}

/// The two-level structure over instanced geometry.
pub fn build_two_level(
    scene: &Instancing,
    params: &StructureParams,
    progress: &BuildProgress,
) -> Result<Built, StructureError> {
    let (mut tl, report) = two_level::build(scene, &params.bvh, progress)?;
    if progress.is_abandoned() {
        return Err(StructureError::Abandoned);
    }
    tl.set_order(params.order);
    tl.set_simd(params.simd)?;
    Ok(Built {
        structure: Structure::TwoLevel(Box::new(tl)),
        report,
        bvh_report: None,
    })
}

/// Builds the structure `params.kind` over `triangles`, counting placed triangles into
/// `progress` where the builder reports progress. Triangle indices in hits are indices into
/// `triangles`. The two-level structure sees them as one mesh placed once.
pub fn build(
    triangles: &[Triangle],
    params: &StructureParams,
    progress: &BuildProgress,
) -> Result<Built, StructureError> {
    super::memory::check_triangles(params, triangles.len())?;
    let start = Instant::now();
    let mut built = match params.kind {
        AccelKind::TwoLevel => build_two_level(&Instancing::single(triangles), params, progress)?,
        AccelKind::Bvh => {
            let (mut bvh, report) = bvh::build_with_progress(triangles, &params.bvh, progress)?;
            bvh.order = params.order;
            Built {
                report: report.summary(&bvh),
                structure: Structure::Bvh(bvh),
                bvh_report: Some(report),
            }
        }
        AccelKind::Bvh4 => build_wide::<4>(triangles, params, progress, Structure::Bvh4)?,
        AccelKind::Bvh8 => build_wide::<8>(triangles, params, progress, Structure::Bvh8)?,
        AccelKind::KdTree => {
            let (tree, report) = kdtree::build_with_progress(triangles, &params.kdtree, progress)?;
            progress.finish(triangles.len());
            Built {
                structure: Structure::KdTree(tree),
                report,
                bvh_report: None,
            }
        }
        AccelKind::Grid => {
            let (grid, report) = grid::build(triangles, &params.grid)?;
            progress.finish(triangles.len());
            Built {
                structure: Structure::Grid(grid),
                report,
                bvh_report: None,
            }
        }
        AccelKind::Octree => {
            let (octree, mut report) =
                octree::build_with_progress(triangles, &params.octree, progress)?;
            progress.finish(triangles.len());
            // Weighed as the k-d tree's cells are (`Structure::sah_cost`).
            let (c_trav, c_isect) = params.sah_constants();
            report.details.extend([
                (
                    "C_trav / C_isect (the k-d tree's)".to_string(),
                    Detail::Text(format!("{c_trav} / {c_isect}")),
                ),
                (
                    "SAH cost".to_string(),
                    Detail::Number(octree.outline().sah_cost(c_trav, c_isect), 2),
                ),
            ]);
            Built {
                structure: Structure::Octree(octree),
                report,
                bvh_report: None,
            }
        }
        AccelKind::BruteForce | AccelKind::BruteForceBbox => {
            let early_out = params.kind == AccelKind::BruteForceBbox;
            let brute = BruteForce::new(triangles, early_out);
            progress.finish(triangles.len());
            let report = StructureReport {
                structure: params.kind.label(),
                triangles: triangles.len(),
                build_time: start.elapsed(),
                bytes: brute.bytes(),
                nodes: 1,
                leaves: 1,
                references: triangles.len(),
                largest_leaf: triangles.len(),
                details: vec![(
                    "early out".into(),
                    if early_out {
                        "scene box, then each triangle's box".into()
                    } else {
                        "none: every triangle for every ray".into()
                    },
                )],
                ..Default::default()
            };
            Built {
                structure: Structure::BruteForce(brute),
                report,
                bvh_report: None,
            }
        }
    };
    if progress.is_abandoned() {
        return Err(StructureError::Abandoned);
    }
    built.structure.set_mailbox(params.mailbox);
    built.structure.set_simd(params.simd)?;
    Ok(built)
}

impl Structure {
    pub fn kind(&self) -> AccelKind {
        match self {
            Structure::Bvh(_) => AccelKind::Bvh,
            Structure::Bvh4(_) => AccelKind::Bvh4,
            Structure::Bvh8(_) => AccelKind::Bvh8,
            Structure::KdTree(_) => AccelKind::KdTree,
            Structure::Grid(_) => AccelKind::Grid,
            Structure::Octree(_) => AccelKind::Octree,
            Structure::BruteForce(b) if b.early_out() => AccelKind::BruteForceBbox,
            Structure::BruteForce(_) => AccelKind::BruteForce,
            Structure::TwoLevel(_) => AccelKind::TwoLevel,
        }
    }

    /// The SAH cost of a tree with the C_trav and C_isect it was weighed with, or `None`
    /// for structures the SAH does not describe (grid, brute force). The octree, not built
    /// by the SAH, walks cells as the k-d tree does and is weighed with the k-d tree's
    /// constants (`--kd-c-trav`, `--kd-c-isect`); the two levels with the BVH's, over both
    /// levels placed (`TwoLevel::sah_cost`).
    pub fn sah_cost(&self, params: &StructureParams) -> Option<(f64, f32, f32)> {
        let (c_trav, c_isect) = params.sah_constants();
        let cost = match self {
            Structure::Bvh(t) => t.sah_cost(c_trav, c_isect),
            Structure::Bvh4(t) => t.sah_cost(c_trav, c_isect),
            Structure::Bvh8(t) => t.sah_cost(c_trav, c_isect),
            Structure::KdTree(t) => t.sah_cost(),
            Structure::Octree(t) => t.outline().sah_cost(c_trav, c_isect),
            Structure::TwoLevel(t) => t.sah_cost(c_trav, c_isect),
            _ => return None,
        };
        Some((cost, c_trav, c_isect))
    }

    /// The tree's EPO (`accel::epo`) over `scene`, the scene it was built over, in the
    /// units of its SAH cost; `None` where `sah_cost` is, and for a flat tree over a scene
    /// too large to flatten. The two levels' is exact up to `two_level::epo::EXACT_MAX`
    /// placed triangles and estimated past it.
    pub fn epo(&self, params: &StructureParams, scene: &Scene) -> Option<Epo> {
        self.epo_by(params, scene, EpoWay::Exact, &|| false)
    }

    /// `epo`, given up (`None`) as soon as `abandon` says so.
    pub fn epo_unless(
        &self,
        params: &StructureParams,
        scene: &Scene,
        abandon: &(dyn Fn() -> bool + Sync),
    ) -> Option<Epo> {
        self.epo_by(params, scene, EpoWay::Exact, abandon)
    }

    /// The tree's EPO found the `way` asked: clipped (`epo`), or estimated from end points
    /// drawn uniformly by area (`epo::end_points`), with its standard error.
    pub fn epo_by(
        &self,
        params: &StructureParams,
        scene: &Scene,
        way: EpoWay,
        abandon: &(dyn Fn() -> bool + Sync),
    ) -> Option<Epo> {
        let (c_trav, c_isect) = params.sah_constants();
        match (self, way) {
            (Structure::TwoLevel(t), EpoWay::Exact) => {
                t.epo_unless(&meshes_built_over(t, scene)?, c_trav, c_isect, abandon)
            }
            (Structure::TwoLevel(t), EpoWay::Estimate { end_points }) => {
                let meshes = meshes_built_over(t, scene)?;
                t.epo_estimate_unless(&meshes, c_trav, c_isect, end_points, abandon)
            }
            (_, way) if self.kind().has_sah_cost() => {
                let triangles = scene.flattened().ok()?;
                let outline = self.outline();
                match way {
                    EpoWay::Exact => {
                        super::epo::epo_unless(&outline, &triangles, c_trav, c_isect, abandon)
                            .map(Epo::exact)
                    }
                    EpoWay::Estimate { end_points } => super::epo::epo_estimate(
                        &outline, &triangles, c_trav, c_isect, end_points, abandon,
                    ),
                }
            }
            _ => None,
        }
    }

    /// The nodes or cells the explorer draws.
    pub fn outline(&self) -> Outline {
        with_structure!(self, a => a.outline())
    }

    /// Memory of the structure, its copy of the triangles included.
    pub fn bytes(&self) -> usize {
        with_structure!(self, a => a.bytes())
    }

    /// The cells a ray walks through, in order, for structures that walk cells.
    pub fn cells_along(&self, ray: &Ray) -> Option<Vec<crate::geometry::Aabb>> {
        match self {
            Structure::Grid(g) => Some(g.cells_along(ray)),
            _ => None,
        }
    }

    /// Turns mailboxing on or off (spatial structures; no rebuild).
    pub fn set_mailbox(&mut self, on: bool) {
        match self {
            Structure::KdTree(t) => t.mailbox = on,
            Structure::Grid(g) => g.mailbox = on,
            Structure::Octree(o) => o.mailbox = on,
            Structure::Bvh(_)
            | Structure::Bvh4(_)
            | Structure::Bvh8(_)
            | Structure::BruteForce(_)
            | Structure::TwoLevel(_) => {}
        }
    }

    /// Chooses the wide BVHs' slab kernel (no rebuild); other structures ignore it. An
    /// instruction set this CPU lacks is an error and changes nothing.
    pub fn set_simd(&mut self, level: SimdLevel) -> Result<(), UnsupportedSimd> {
        match self {
            Structure::Bvh4(w) => w.set_simd(level),
            Structure::Bvh8(w) => w.set_simd(level),
            Structure::TwoLevel(t) => t.set_simd(level),
            _ => Ok(()),
        }
    }

    /// The slab kernel the structure traces with, for the wide BVHs.
    pub fn simd(&self) -> Option<SimdLevel> {
        match self {
            Structure::Bvh4(w) => Some(w.simd()),
            Structure::Bvh8(w) => Some(w.simd()),
            Structure::TwoLevel(t) => Some(t.simd()),
            _ => None,
        }
    }

    /// Sets the BVH's child order (no rebuild).
    pub fn set_order(&mut self, order: TraversalOrder) {
        match self {
            Structure::Bvh(b) => b.order = order,
            Structure::Bvh4(w) => w.order = order,
            Structure::Bvh8(w) => w.order = order,
            Structure::TwoLevel(t) => t.set_order(order),
            _ => {}
        }
    }

    /// Refits after the scene triangles `moved` changed, for the structures that can
    /// (`None` for the others, which must be rebuilt). `index` is made at the first refit
    /// after a build and kept while the topology is.
    pub fn refit_moved(
        &mut self,
        index: &mut Option<RefitIndex>,
        scene: &[Triangle],
        moved: &[u32],
        c_trav: f32,
        c_isect: f32,
    ) -> Option<Result<RefitReport, RefitError>> {
        Some(match self {
            Structure::Bvh(b) => {
                let index = index.get_or_insert_with(|| RefitIndex::new(b));
                b.refit_moved(index, scene, moved, c_trav, c_isect)
            }
            Structure::Bvh4(w) => {
                let index = index.get_or_insert_with(|| RefitIndex::for_wide(w));
                w.refit_moved(index, scene, moved, c_trav, c_isect)
            }
            Structure::Bvh8(w) => {
                let index = index.get_or_insert_with(|| RefitIndex::for_wide(w));
                w.refit_moved(index, scene, moved, c_trav, c_isect)
            }
            _ => return None,
        })
    }
}

impl Accel for Structure {
    #[inline]
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        with_structure!(self, a => a.closest_hit::<I, S>(ray, stats))
    }

    #[inline]
    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, stats: &mut S) -> bool {
        with_structure!(self, a => a.any_hit::<I, S>(ray, stats))
    }

    fn closest_hits<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        with_structure!(self, a => a.closest_hits::<I>(rays, hits))
    }
}

/// A wide BVH: the BVH2 built as usual, then collapsed (the report is the BVH2's with the
/// collapse's time), or, with `direct_wide`, made straight from the builder's splits
/// (`WideBvh::direct`); with the wide tree's SAH cost and its memory.
fn build_wide<const W: usize>(
    triangles: &[Triangle],
    params: &StructureParams,
    progress: &BuildProgress,
    wrap: fn(WideBvh<W>) -> Structure,
) -> Result<Built, StructureError>
where
    Lanes<W>: NodeWidth,
{
    let (mut wide, build_time, times) = if params.bvh.builds_direct_wide() {
        params.bvh.validate()?;
        if params.bvh.presplit > 0.0 {
            return Err(BuildError::PresplitDirectWide.into());
        }
        let start = Instant::now();
        let (wide, phases) = WideBvh::<W>::direct(triangles, &params.bvh, progress)?;
        let build_time = start.elapsed();
        if progress.is_abandoned() {
            return Err(StructureError::Abandoned);
        }
        let rows = vec![("builder".into(), params.bvh.wide_builder_label().into())];
        (
            wide,
            build_time,
            rows.into_iter()
                .chain(phases.time_rows())
                .collect::<Vec<_>>(),
        )
    } else {
        let (bvh2, bvh_phases, bvh_time) =
            bvh::build_shape_with_progress(triangles, &params.bvh, progress)?;
        if progress.is_abandoned() {
            return Err(StructureError::Abandoned);
        }
        let start = Instant::now();
        let collapse = CollapseParams {
            c_trav: params.bvh.c_trav,
            c_isect: params.bvh.c_isect,
            max_leaf_size: params.bvh.max_leaf_size,
        };
        let (wide, collapse_phases) = WideBvh::<W>::collapse_over(&bvh2, triangles, &collapse)?;
        let collapse_time = start.elapsed();
        let rows = [
            ("builder".into(), params.bvh.wide_builder_label().into()),
            ("BVH2 build".into(), Detail::Time(bvh_time)),
            ("collapse".into(), Detail::Time(collapse_time)),
        ]
        .into_iter()
        .chain(bvh_phases.time_rows())
        .chain([
            (
                "time: collapse table".into(),
                Detail::Time(collapse_phases.table),
            ),
            (
                "time: collapse layout".into(),
                Detail::Time(collapse_phases.layout),
            ),
        ])
        .collect::<Vec<_>>();
        (wide, bvh_time + collapse_time, rows)
    };
    wide.order = params.order;
    let leaves = wide.leaf_count();
    let largest_leaf = wide
        .nodes
        .iter()
        .flat_map(|n| {
            (0..n.child_count())
                .filter(|&l| !n.is_interior(l))
                .map(|l| n.leaf_count(l))
        })
        .max()
        .unwrap_or(0) as usize;
    let bytes = wide.bytes();
    let report = StructureReport {
        structure: if W == 4 {
            AccelKind::Bvh4
        } else {
            AccelKind::Bvh8
        }
        .label(),
        triangles: triangles.len(),
        build_time,
        bytes,
        nodes: wide.nodes.len(),
        leaves,
        empty_leaves: 0,
        max_depth: wide.depth,
        references: wide.references(),
        largest_leaf,
        details: times
            .into_iter()
            .chain([(
                "threads".into(),
                Detail::count(rayon::current_num_threads()),
            )])
            .chain([
                (
                    "SAH cost".into(),
                    Detail::Number(wide.sah_cost(params.bvh.c_trav, params.bvh.c_isect), 2),
                ),
                (
                    "bytes per triangle".into(),
                    Detail::Number(bytes as f64 / triangles.len().max(1) as f64, 1),
                ),
            ])
            .collect(),
        caps_hit: Vec::new(),
    };
    Ok(Built {
        structure: wrap(wide),
        report,
        bvh_report: None,
    })
}

/// `scene`'s meshes, if they are the ones `t`'s BLASes were built over.
fn meshes_built_over<'s>(t: &TwoLevel, scene: &'s Scene) -> Option<Vec<&'s [Triangle]>> {
    let meshes = scene.instancing().meshes;
    let built_over = |(m, b): (&&[Triangle], &Bvh8)| m.len() == b.triangle_count;
    let same = meshes.len() == t.blases.len() && meshes.iter().zip(&t.blases).all(built_over);
    same.then_some(meshes)
}
