//! What a structure needs in memory, checked against the budget (`crate::budget`) before it
//! is built: a tree over 43 million flattened island triangles is refused in a line instead
//! of growing past the machine's memory.

use super::bvh::Strategy;
use super::params::StructureParams;
use super::structure::AccelKind;
use crate::budget::{self, BudgetError};
use crate::scene::{FLAT_BYTES_PER_TRIANGLE, MAX_FLATTENED, Scene};

/// Bytes per instance of the two-level structure's top level (its references, boxes and
/// transforms, with room for re-braiding) and of the scene's own placement: 755 measured
/// on `island:2000000` (`/usr/bin/time -f %M bvhlab stats --scene island:2000000`).
const BYTES_PER_INSTANCE: u64 = 800;

/// Peak bytes per triangle while `params.kind` is built, its triangles' own copy included.
/// Measured as the peak resident size over the triangle count of a million-triangle soup
/// (`/usr/bin/time -f %M bvhlab stats --scene soup:1000000 --accel …`) and rounded up:
/// brute force 78, BVH2 229 (SBVH 369), BVH4 309, BVH8 337, k-d tree 174, grid 347 at
/// λ = 2 and 1,270 at λ = 64, octree 128, two levels 337. The k-d tree's worst case is
/// long thin triangles that reach its reference cap (3 × triangles): 264 on `grass:500000`.
/// Re-measured in December 2026 without the EPO that `stats` now adds (`bvhlab render
/// --scene soup:1000000 --accel … --width 16 --height 16`): brute force 87, BVH2 195, BVH4
/// 285, BVH8 317, two levels 316; the SBVH 370–457 over six runs (its peak depends on how
/// the threads take its subtrees, each holding its references while its children are
/// built), 576 collapsed to a BVH8, pre-splitting 425: the references' share is planned at
/// 272, above the worst of those.
pub fn bytes_per_triangle(params: &StructureParams) -> u64 {
    let split = params.bvh.strategy == Strategy::Sbvh || params.bvh.presplit > 0.0;
    let splits = if split { 272 } else { 0 };
    match params.kind {
        AccelKind::BruteForce | AccelKind::BruteForceBbox => 96,
        AccelKind::Bvh => 256 + splits,
        AccelKind::Bvh4 => 336 + splits,
        AccelKind::Bvh8 | AccelKind::TwoLevel => 368 + splits,
        AccelKind::KdTree => {
            96 + (64.0 * params.kdtree.max_references_factor.max(1.0)).ceil() as u64
        }
        AccelKind::Grid => 320 + (16.0 * params.grid.lambda.max(0.0)).ceil() as u64,
        AccelKind::Octree => 200,
    }
}

/// Whether `params.kind` over `triangles` triangles fits the budget.
pub fn check_triangles(params: &StructureParams, triangles: usize) -> Result<(), BudgetError> {
    budget::check(
        format!("a {} over {triangles} triangles", params.kind.title()),
        budget::times(triangles as u64, bytes_per_triangle(params)),
    )
}

/// Whether `params.kind` over `scene` fits the budget: the two levels over its unique
/// triangles and its instances, any other structure over its placed triangles (and their
/// flattened copy when the scene does not store them).
pub fn check_scene(params: &StructureParams, scene: &Scene) -> Result<(), BudgetError> {
    if params.kind == AccelKind::TwoLevel {
        let instancing = scene.instancing();
        let unique = instancing.unique_triangles() as u64;
        let instances = instancing.instances.len() as u64;
        return budget::check(
            format!("the two levels over {unique} triangles in {instances} instances"),
            budget::times(unique, bytes_per_triangle(params))
                .saturating_add(budget::times(instances, BYTES_PER_INSTANCE)),
        );
    }
    let placed = scene.placed_triangles();
    if !scene.is_flattened() && placed > MAX_FLATTENED {
        // Not flattened at all: the flatten error says why, and what to use instead.
        return Ok(());
    }
    let copy = if scene.is_flattened() {
        0
    } else {
        FLAT_BYTES_PER_TRIANGLE
    };
    budget::check(
        format!(
            "a {} over the {placed} placed triangles",
            params.kind.title()
        ),
        budget::times(placed as u64, bytes_per_triangle(params) + copy),
    )
}
