//! Ray–triangle intersectors behind one interface, so every structure can trace with any of
//! them: the watertight test is the default, Möller–Trumbore is the classic fast comparison,
//! and the f64 reference is the accurate yardstick. `IntersectorKind` picks one at run time.

mod moller_trumbore;
pub mod reference;
mod watertight;

pub use moller_trumbore::MollerTrumbore;
pub use reference::ReferenceF64;
pub use watertight::{Shear, Watertight, shear_axes, shear_axes_of};

use super::simd::triangle::{BlockHits, TriangleBlock, TriangleKernel};
use super::{Ray, Triangle};

/// Where a ray meets a triangle: the distance t and the barycentric coordinates (u, v) of
/// vertices 1 and 2 (vertex 0 has weight 1 − u − v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// A ray–triangle test. `RayData` holds what the test precomputes once per ray.
pub trait Intersector: Copy + Default + Send + Sync + 'static {
    type RayData: Copy;
    const NAME: &'static str;

    fn prepare(ray: &Ray) -> Self::RayData;

    /// The hit with t in the open interval (tmin, tmax), if any.
    fn intersect(
        data: &Self::RayData,
        ray: &Ray,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<TriangleHit>;

    /// Whether the test has a packet form that tests one triangle against many rays at
    /// once with its answers bit for bit (`simd::packet_triangle`, the watertight test's);
    /// without one a packet's leaves test ray by ray.
    const PACKET_TEST: bool = false;

    /// Whether `intersect_block` tests blocks itself, handing back only rare lanes; without
    /// it every lane goes to `intersect`.
    const BLOCK_TEST: bool = false;

    /// The four triangles of a wide leaf's block at once with the SIMD kernel `K`, where the
    /// test has a block form that gives its own answers bit for bit; lanes it leaves to
    /// `intersect` are marked `retest`. By default every lane is: the test runs lane by lane.
    ///
    /// # Safety
    /// The CPU supports K's instruction set (`SimdLevel::supported`).
    #[inline(always)]
    unsafe fn intersect_block<K: TriangleKernel>(
        _data: &Self::RayData,
        _ray: &Ray,
        _block: &TriangleBlock,
        _tmin: f32,
        _tmax: f32,
    ) -> BlockHits {
        BlockHits::RETEST_ALL
    }
}

/// The intersector as a run-time choice (CLI flag, app setting). Code generic over
/// `Intersector` is instantiated for each kind through `with_intersector!`, so the choice
/// costs one branch per batch of rays, not one per triangle test.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
pub enum IntersectorKind {
    /// Woop, Benthin and Wald (2013) in f32: no ray slips between two triangles.
    #[default]
    Watertight,
    /// Möller–Trumbore (1997) in f32: fast, not watertight.
    MollerTrumbore,
    /// The watertight test in f64: the reference.
    F64,
}

impl IntersectorKind {
    pub const ALL: [IntersectorKind; 3] = [
        IntersectorKind::Watertight,
        IntersectorKind::MollerTrumbore,
        IntersectorKind::F64,
    ];

    /// The `Intersector::NAME` of the kind, as used on the command line.
    pub fn label(self) -> &'static str {
        match self {
            IntersectorKind::Watertight => Watertight::NAME,
            IntersectorKind::MollerTrumbore => MollerTrumbore::NAME,
            IntersectorKind::F64 => ReferenceF64::NAME,
        }
    }

    pub fn from_label(label: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.label() == label)
    }
}

/// Evaluates `$body` with the type name `$I` bound to the intersector `$kind` selects:
/// `with_intersector!(kind, I => bvh.closest_hit::<I, _>(&ray, &mut NoStats))`.
#[macro_export]
macro_rules! with_intersector {
    ($kind:expr, $I:ident => $body:expr) => {
        match $kind {
            $crate::geometry::IntersectorKind::Watertight => {
                type $I = $crate::geometry::Watertight;
                $body
            }
            $crate::geometry::IntersectorKind::MollerTrumbore => {
                type $I = $crate::geometry::MollerTrumbore;
                $body
            }
            $crate::geometry::IntersectorKind::F64 => {
                type $I = $crate::geometry::ReferenceF64;
                $body
            }
        }
    };
}
