//! Where the collapse reads a leaf's triangles: the BVH2's own copy in leaf order, or, for
//! a BVH2 built only to be collapsed (`bvh::build_shape_with_progress`), the scene's
//! through its `prim_indices`. The layout asks for the next wide node's leaves while it
//! lays out one (`prefetch`), so reading the scene's triangles where they lie costs less
//! than the copy did: gathering each part's triangles into a buffer before its layout, in
//! a loop of independent loads, was tried and gained nothing over reading them in place,
//! as the copy itself is such a gather.

use crate::accel::bvh::Bvh;
use crate::geometry::Triangle;
use crate::geometry::simd::prefetch;

/// Where the layout reads a leaf's triangles: the BVH2's copy in leaf order, or the scene's
/// through the BVH2's `prim_indices`.
#[derive(Clone, Copy)]
pub(super) enum Source<'a> {
    LeafOrder(&'a [Triangle]),
    Scene(&'a [Triangle]),
}

impl<'a> Source<'a> {
    /// The BVH2's copy of its triangles in leaf order.
    pub fn leaf_order(bvh: &'a Bvh) -> Self {
        Source::LeafOrder(&bvh.triangles)
    }

    /// The triangle at leaf-order slot `t` of `bvh`.
    #[inline(always)]
    pub fn get(self, bvh: &Bvh, t: usize) -> Triangle {
        match self {
            Source::LeafOrder(tris) => tris[t],
            Source::Scene(tris) => tris[bvh.prim_indices[t] as usize],
        }
    }

    /// Starts loading the triangles of slots `slot..slot + count` of `bvh`.
    pub fn prefetch(self, bvh: &Bvh, slot: usize, count: usize) {
        match self {
            Source::LeafOrder(tris) => {
                let start = tris.as_ptr().wrapping_add(slot) as usize;
                let end = start + count * size_of::<Triangle>();
                for line in (start & !63..end).step_by(64) {
                    prefetch(line as *const u8);
                }
            }
            Source::Scene(tris) => {
                for &i in bvh.prim_indices.get(slot..slot + count).unwrap_or(&[]) {
                    // A triangle's 36 bytes may lie across two cache lines.
                    let t = tris.as_ptr().wrapping_add(i as usize).cast::<u8>();
                    prefetch(t);
                    prefetch(t.wrapping_add(size_of::<Triangle>() - 1));
                }
            }
        }
    }
}
