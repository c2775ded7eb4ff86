//! The 32-byte BVH2 node: a box and either the index of the first of two adjacent children
//! or the range of a leaf's triangles. Two nodes fill one 64-byte cache line.

use crate::geometry::Aabb;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Node {
    pub min: Vec3,
    /// Interior: index of the left child (the right child follows it).
    /// Leaf: index of the first triangle in leaf order.
    pub left_first: u32,
    pub max: Vec3,
    /// Number of triangles of a leaf; `INTERIOR` marks an interior node. (A leaf may hold
    /// zero triangles: the root of an empty scene.)
    pub count: u32,
}

/// The `count` of an interior node.
pub const INTERIOR: u32 = u32::MAX;

impl Default for Node {
    fn default() -> Self {
        Node::interior(Aabb::EMPTY, 0)
    }
}

impl Node {
    pub fn leaf(bounds: Aabb, first: u32, count: u32) -> Self {
        Node {
            min: bounds.min,
            left_first: first,
            max: bounds.max,
            count,
        }
    }

    pub fn interior(bounds: Aabb, left: u32) -> Self {
        Node {
            min: bounds.min,
            left_first: left,
            max: bounds.max,
            count: INTERIOR,
        }
    }

    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count != INTERIOR
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.min, self.max)
    }

    pub fn set_bounds(&mut self, b: Aabb) {
        self.min = b.min;
        self.max = b.max;
    }

    /// The leaf's triangles as a range of leaf-order indices.
    pub fn prim_range(&self) -> std::ops::Range<usize> {
        self.left_first as usize..(self.left_first + self.count) as usize
    }
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);
