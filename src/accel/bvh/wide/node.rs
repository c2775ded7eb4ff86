//! The wide node: up to W children whose boxes are stored as structures of arrays, so one
//! SIMD instruction loads the same plane of all W boxes. 64-byte aligned: a BVH4 node is two
//! cache lines, a BVH8 node four.

use crate::geometry::Aabb;

/// `count` of a child that is an interior node.
pub const INTERIOR: u32 = u32::MAX;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode<const W: usize> {
    /// Rows min x, min y, min z, max x, max y, max z; lane i is child i. An unused lane holds
    /// the empty box (+∞ min, −∞ max), which no ray enters.
    pub bounds: [[f32; W]; 6],
    /// Interior child: its node index. Leaf child: its first triangle in leaf order.
    pub child: [u32; W],
    /// `INTERIOR`, a leaf's triangle count, or 0 for an unused lane.
    pub count: [u32; W],
}

const _: () = assert!(std::mem::size_of::<WideNode<4>>() == 128);
const _: () = assert!(std::mem::size_of::<WideNode<8>>() == 256);

impl<const W: usize> Default for WideNode<W> {
    fn default() -> Self {
        let inf = [f32::INFINITY; W];
        let neg = [f32::NEG_INFINITY; W];
        WideNode {
            bounds: [inf, inf, inf, neg, neg, neg],
            child: [0; W],
            count: [0; W],
        }
    }
}

impl<const W: usize> WideNode<W> {
    pub fn child_bounds(&self, lane: usize) -> Aabb {
        let b = &self.bounds;
        Aabb::new(
            glam::Vec3::new(b[0][lane], b[1][lane], b[2][lane]),
            glam::Vec3::new(b[3][lane], b[4][lane], b[5][lane]),
        )
    }

    pub fn set_child_bounds(&mut self, lane: usize, bounds: Aabb) {
        let (lo, hi) = (bounds.min, bounds.max);
        for axis in 0..3 {
            self.bounds[axis][lane] = lo[axis];
            self.bounds[axis + 3][lane] = hi[axis];
        }
    }

    pub fn is_used(&self, lane: usize) -> bool {
        self.count[lane] != 0
    }

    pub fn is_interior(&self, lane: usize) -> bool {
        self.count[lane] == INTERIOR
    }

    /// Lanes in use: children come first, unused lanes last.
    pub fn child_count(&self) -> usize {
        self.count.iter().take_while(|&&c| c != 0).count()
    }

    /// The union of the children's boxes.
    pub fn bounds(&self) -> Aabb {
        (0..self.child_count()).fold(Aabb::EMPTY, |b, i| b.union(self.child_bounds(i)))
    }
}
