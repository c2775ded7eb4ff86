//! Where the collapse reads a leaf's triangles: the BVH2's own copy in leaf order, or, for
//! a BVH2 built only to be collapsed (`bvh::build_shape_with_progress`), the scene's
//! through its `prim_indices`, each part's gathered into a buffer before its layout.

use crate::accel::bvh::Bvh;
use crate::geometry::Triangle;
use crate::geometry::simd::prefetch;

/// Where the layout reads a leaf's triangles: in leaf order from slot `first` on (the
/// BVH2's own copy, or a part's triangles gathered from the scene), or from the scene
/// through the BVH2's `prim_indices`.
#[derive(Clone, Copy)]
pub(super) enum Source<'a> {
    InOrder { tris: &'a [Triangle], first: usize },
    Scene(&'a [Triangle]),
}

impl<'a> Source<'a> {
    /// The BVH2's copy of its triangles in leaf order.
    pub fn leaf_order(bvh: &'a Bvh) -> Self {
        Source::InOrder {
            tris: &bvh.triangles,
            first: 0,
        }
    }

    /// The triangle at leaf-order slot `t` of `bvh`.
    #[inline(always)]
    pub fn get(self, bvh: &Bvh, t: usize) -> Triangle {
        match self {
            Source::InOrder { tris, first } => tris[t - first],
            Source::Scene(tris) => tris[bvh.prim_indices[t] as usize],
        }
    }

    /// Starts loading the triangles of slots `first..first + count` of `bvh`.
    pub fn prefetch(self, bvh: &Bvh, slot: usize, count: usize) {
        match self {
            Source::InOrder { tris, first } => {
                let start = tris.as_ptr().wrapping_add(slot.wrapping_sub(first)) as usize;
                let end = start + count * size_of::<Triangle>();
                for line in (start & !63..end).step_by(64) {
                    prefetch(line as *const u8);
                }
            }
            Source::Scene(tris) => {
                for &i in bvh.prim_indices.get(slot..slot + count).unwrap_or(&[]) {
                    prefetch(tris.as_ptr().wrapping_add(i as usize));
                }
            }
        }
    }

    /// The triangles of the BVH2 subtree under `node` (`count` slots), for its part's layout: a scene's
    /// gathered into `buffer` in leaf order first, in one loop whose loads do not wait on
    /// each other. (Read leaf by leaf as the layout asks for them, the scene's triangles
    /// were a fifth of the layout's time, one cache miss after another.) A subtree whose
    /// slots are not one range (pre-splitting renumbers them node by node) is read from
    /// the scene as it is.
    pub fn for_part<'b>(
        self,
        bvh: &Bvh,
        node: usize,
        count: usize,
        buffer: &'b mut Vec<Triangle>,
    ) -> Source<'b>
    where
        'a: 'b,
    {
        let Source::Scene(scene) = self else {
            return self;
        };
        let (mut first, mut end) = (usize::MAX, 0);
        let mut stack = vec![node];
        while let Some(n) = stack.pop() {
            let n = &bvh.nodes[n];
            if n.is_leaf() {
                if n.count > 0 {
                    first = first.min(n.left_first as usize);
                    end = end.max((n.left_first + n.count) as usize);
                }
            } else {
                stack.extend([n.left_first as usize, n.left_first as usize + 1]);
            }
        }
        if end.saturating_sub(first) != count {
            return self;
        }
        buffer.clear();
        buffer.extend(
            bvh.prim_indices[first..end]
                .iter()
                .map(|&i| scene[i as usize]),
        );
        Source::InOrder {
            tris: buffer,
            first,
        }
    }
}
