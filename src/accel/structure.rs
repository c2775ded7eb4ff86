//! The structure selector: one runtime type over every built structure (BVH2, k-d tree,
//! uniform grid, octree, two-level, brute force), so the worker, the CLI, the renderer and
//! the bench hold one value and never assume a BVH. It dispatches once per query (or per batch), and
//! each arm calls that structure's own monomorphised traversal, so the hot loops stay
//! generic over the intersector and the statistics sink.
//!
//! Adding a structure is: its folder, a variant of `AccelKind` and `Structure`, its
//! parameters in `StructureParams`, and one arm in each `match` below.

use super::bvh::{self, BuildError, BuildReport, Bvh};
use super::grid::{self, Grid, GridError, GridParams};
use super::kdtree::{self, KdError, KdParams, KdTree};
use super::octree::{self, Octree, OctreeError, OctreeParams};
use super::outline::Outline;
use super::report::StructureReport;
use super::two_level::{self, TwoLevel};
use super::{Accel, BruteForce, BuildParams, Hit, Stats, TraversalOrder};
use crate::geometry::{Intersector, Ray, Triangle};
use crate::scene::{Instancing, Scene};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Which structure to build, as the CLI's `--accel` and the app's selector name it.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum AccelKind {
    #[default]
    Bvh,
    KdTree,
    Grid,
    Octree,
    BruteForce,
    BruteForceBbox,
    TwoLevel,
}

impl AccelKind {
    pub const ALL: [AccelKind; 7] = [
        AccelKind::Bvh,
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

    pub fn is_brute_force(self) -> bool {
        matches!(self, AccelKind::BruteForce | AccelKind::BruteForceBbox)
    }

    /// Whether a ray walks the structure's cells in order (the grid's 3D-DDA), so the app
    /// can show the cells under the pointer.
    pub fn walks_cells(self) -> bool {
        self == AccelKind::Grid
    }

    /// Whether the structure can be refitted after motion (rather than rebuilt).
    pub fn can_refit(self) -> bool {
        self == AccelKind::Bvh
    }
}

/// Everything a build needs, as plain data shared by the app, the CLI and the tests. The
/// parameters of every structure are kept, so switching back and forth keeps each one's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StructureParams {
    pub kind: AccelKind,
    pub bvh: BuildParams,
    /// BVH child order: a traversal setting, changed without a rebuild.
    pub order: TraversalOrder,
    pub kdtree: KdParams,
    pub grid: GridParams,
    pub octree: OctreeParams,
    /// Mailboxing of the spatial structures: a traversal setting, changed without a rebuild
    /// (it overrides the `mailbox` of their own parameters).
    pub mailbox: bool,
}

impl Default for StructureParams {
    fn default() -> Self {
        StructureParams {
            kind: AccelKind::Bvh,
            bvh: BuildParams::default(),
            order: TraversalOrder::FrontToBack,
            kdtree: KdParams::default(),
            grid: GridParams::default(),
            octree: OctreeParams::default(),
            mailbox: true,
        }
    }
}

impl StructureParams {
    pub fn of_kind(kind: AccelKind) -> Self {
        StructureParams {
            kind,
            ..Default::default()
        }
    }

    /// Checks the parameters of the chosen structure.
    pub fn validate(&self) -> Result<(), StructureError> {
        match self.kind {
            AccelKind::Bvh | AccelKind::TwoLevel => self.bvh.validate()?,
            AccelKind::KdTree => self.kdtree.validate()?,
            AccelKind::Grid => self.grid.validate()?,
            AccelKind::Octree => self.octree.validate()?,
            AccelKind::BruteForce | AccelKind::BruteForceBbox => {}
        }
        Ok(())
    }

    /// Whether a structure built with `self` must be built again to match `other`
    /// (traversal settings alone never need a build).
    pub fn needs_rebuild_for(&self, other: &StructureParams) -> bool {
        let strip = |p: &StructureParams| {
            let mut p = *p;
            p.order = TraversalOrder::FrontToBack;
            p.mailbox = true;
            p.kdtree.mailbox = true;
            p.grid.mailbox = true;
            p.octree.mailbox = true;
            p
        };
        let (a, b) = (strip(self), strip(other));
        a.kind != b.kind
            || match a.kind {
                AccelKind::Bvh | AccelKind::TwoLevel => a.bvh != b.bvh,
                AccelKind::KdTree => a.kdtree != b.kdtree,
                AccelKind::Grid => a.grid != b.grid,
                AccelKind::Octree => a.octree != b.octree,
                AccelKind::BruteForce | AccelKind::BruteForceBbox => false,
            }
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
}

/// A built structure.
pub enum Structure {
    Bvh(Bvh),
    KdTree(KdTree),
    Grid(Grid),
    Octree(Octree),
    BruteForce(BruteForce),
    TwoLevel(TwoLevel),
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
/// other structure over its flattened triangles. Hits name triangles of `scene.triangles`.
pub fn build_scene(
    scene: &Scene,
    params: &StructureParams,
    progress: &AtomicUsize,
) -> Result<Built, StructureError> {
    if params.kind == AccelKind::TwoLevel {
        return build_two_level(&scene.instancing(), params, progress);
    }
    build(&scene.triangles, params, progress)
}

/// The two-level structure over instanced geometry.
pub fn build_two_level(
    scene: &Instancing,
    params: &StructureParams,
    progress: &AtomicUsize,
) -> Result<Built, StructureError> {
    let (mut tl, report) = two_level::build(scene, &params.bvh, progress)?;
    tl.set_order(params.order);
    Ok(Built {
        structure: Structure::TwoLevel(tl),
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
    progress: &AtomicUsize,
) -> Result<Built, StructureError> {
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
        AccelKind::KdTree => {
            let (tree, report) = kdtree::build(triangles, &params.kdtree)?;
            progress.store(triangles.len(), Ordering::Relaxed);
            Built {
                structure: Structure::KdTree(tree),
                report,
                bvh_report: None,
            }
        }
        AccelKind::Grid => {
            let (grid, report) = grid::build(triangles, &params.grid)?;
            progress.store(triangles.len(), Ordering::Relaxed);
            Built {
                structure: Structure::Grid(grid),
                report,
                bvh_report: None,
            }
        }
        AccelKind::Octree => {
            let (octree, report) = octree::build(triangles, &params.octree)?;
            progress.store(triangles.len(), Ordering::Relaxed);
            Built {
                structure: Structure::Octree(octree),
                report,
                bvh_report: None,
            }
        }
        AccelKind::BruteForce | AccelKind::BruteForceBbox => {
            let early_out = params.kind == AccelKind::BruteForceBbox;
            let brute = BruteForce::new(triangles, early_out);
            progress.store(triangles.len(), Ordering::Relaxed);
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
    built.structure.set_mailbox(params.mailbox);
    Ok(built)
}

impl Structure {
    pub fn kind(&self) -> AccelKind {
        match self {
            Structure::Bvh(_) => AccelKind::Bvh,
            Structure::KdTree(_) => AccelKind::KdTree,
            Structure::Grid(_) => AccelKind::Grid,
            Structure::Octree(_) => AccelKind::Octree,
            Structure::BruteForce(b) if b.early_out() => AccelKind::BruteForceBbox,
            Structure::BruteForce(_) => AccelKind::BruteForce,
            Structure::TwoLevel(_) => AccelKind::TwoLevel,
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
            Structure::Bvh(_) | Structure::BruteForce(_) | Structure::TwoLevel(_) => {}
        }
    }

    /// Sets the BVH's child order (no rebuild).
    pub fn set_order(&mut self, order: TraversalOrder) {
        match self {
            Structure::Bvh(b) => b.order = order,
            Structure::TwoLevel(t) => t.set_order(order),
            _ => {}
        }
    }

    pub fn as_bvh(&self) -> Option<&Bvh> {
        match self {
            Structure::Bvh(b) => Some(b),
            _ => None,
        }
    }

    pub fn as_bvh_mut(&mut self) -> Option<&mut Bvh> {
        match self {
            Structure::Bvh(b) => Some(b),
            _ => None,
        }
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
