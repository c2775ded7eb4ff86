//! The wide node: up to W children whose boxes are stored as structures of arrays, so one
//! SIMD instruction loads the same plane of all W boxes. 64-byte aligned: a BVH4 node is two
//! cache lines, a BVH8 node four.

use crate::geometry::Aabb;
use glam::Vec4;

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

    /// The union of the children's boxes: each row's least (or greatest) value over all
    /// lanes, as an unused lane's empty box changes neither.
    pub fn bounds(&self) -> Aabb {
        // Four lanes at a time, then across the four (W is a multiple of 4); boxes hold
        // no NaN, so the SIMD minimum is the minimum.
        const { assert!(W.is_multiple_of(4)) };
        let b = &self.bounds;
        let least = |row: &[f32; W]| {
            let four = row.chunks_exact(4).map(Vec4::from_slice);
            four.fold(Vec4::INFINITY, Vec4::min).min_element()
        };
        let greatest = |row: &[f32; W]| {
            let four = row.chunks_exact(4).map(Vec4::from_slice);
            four.fold(Vec4::NEG_INFINITY, Vec4::max).max_element()
        };
        Aabb::new(
            glam::Vec3::new(least(&b[0]), least(&b[1]), least(&b[2])),
            glam::Vec3::new(greatest(&b[3]), greatest(&b[4]), greatest(&b[5])),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The rows' extremes are the union of the used lanes' boxes, for every count of
    /// lanes in use.
    #[test]
    fn bounds_are_the_union_of_the_used_lanes() {
        let mut rng = crate::bench::stress::Rng(0x853c_49e6_748f_ea9b);
        let mut next = || rng.unit() as f32 * 16.0 - 8.0;
        for used in 0..=8 {
            for _ in 0..200 {
                let mut node = WideNode::<8>::default();
                let mut want = Aabb::EMPTY;
                for lane in 0..used {
                    let (a, b) = (
                        Vec3::new(next(), next(), next()),
                        Vec3::new(next(), next(), next()),
                    );
                    let b = Aabb::new(a.min(b), a.max(b));
                    node.set_child_bounds(lane, b);
                    node.count[lane] = 1;
                    want = want.union(b);
                }
                let got = node.bounds();
                assert_eq!((got.min, got.max), (want.min, want.max), "{used} lanes");
            }
        }
    }
}
