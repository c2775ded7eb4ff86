//! The builders' view of a triangle: its bounding box and index, 32 bytes, partitioned in
//! place as the recursion descends so each subtree owns a contiguous slice.

use super::PARALLEL_PASS;
use crate::geometry::Aabb;
use glam::{Vec3, Vec3A, Vec4};
use rayon::prelude::*;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct PrimRef {
    pub min: Vec3,
    pub index: u32,
    pub max: Vec3,
    /// The reference's bucket on each axis (a byte each, x lowest) in the last binning of
    /// its node: the partition after it decides a side from a byte, not the arithmetic.
    buckets: u32,
}

impl PrimRef {
    pub fn new(bounds: Aabb, index: u32) -> Self {
        PrimRef {
            min: bounds.min,
            index,
            max: bounds.max,
            buckets: 0,
        }
    }

    /// Twice the box centre: the factor ½ changes no comparison, so it is left out.
    #[inline(always)]
    pub fn centroid2(&self) -> Vec3 {
        self.min + self.max
    }

    /// `min` in a SIMD register, loaded as one vector with `index` as its ignored fourth
    /// lane (the builders' inner loops read every reference at every level).
    #[inline(always)]
    pub fn lo(&self) -> Vec3A {
        // SAFETY: `PrimRef` is `repr(C)`: `min` and `index` are its first 16 bytes, all
        // initialised, read as four floats (every bit pattern is one).
        let v = unsafe { std::ptr::read((self as *const Self).cast::<[f32; 4]>()) };
        Vec3A::from_vec4(Vec4::from_array(v))
    }

    /// `max` in a SIMD register (its fourth lane the padding, ignored).
    #[inline(always)]
    pub fn hi(&self) -> Vec3A {
        // SAFETY: `max` and `buckets` are the last 16 of the 32 initialised bytes of a
        // `repr(C)` `PrimRef`, read as four floats.
        let v = unsafe { std::ptr::read((self as *const Self).cast::<[f32; 4]>().add(1)) };
        Vec3A::from_vec4(Vec4::from_array(v))
    }

    /// Records the reference's buckets on the three axes, a byte each, x lowest (the top
    /// byte of `bytes` is ignored). Above them the bits of 2.0: read as the fourth lane of
    /// `hi`, the word is a normal float, never a denormal that could slow the lane's
    /// arithmetic.
    #[inline(always)]
    pub fn mark_bucket_bytes(&mut self, bytes: u32) {
        self.buckets = 2.0f32.to_bits() | (bytes & 0x00ff_ffff);
    }

    /// The bucket on `axis` that the last `mark_bucket_bytes` recorded.
    #[inline(always)]
    pub fn bucket(&self, axis: usize) -> u32 {
        (self.buckets >> (8 * axis)) & 0xff
    }

    /// The reference's box in SIMD registers.
    #[inline(always)]
    pub fn box3a(&self) -> Box3A {
        Box3A {
            min: self.lo(),
            max: self.hi(),
        }
    }
}

/// A box in SIMD registers, for the builders' inner loops.
#[derive(Clone, Copy, Debug)]
pub struct Box3A {
    pub min: Vec3A,
    pub max: Vec3A,
}

impl Box3A {
    pub const EMPTY: Box3A = Box3A {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    pub fn grow(&mut self, lo: Vec3A, hi: Vec3A) {
        self.min = self.min.min(lo);
        self.max = self.max.max(hi);
    }

    #[inline(always)]
    pub fn union(self, o: Box3A) -> Box3A {
        Box3A {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The common part of two boxes; `EMPTY` if they are disjoint.
    #[inline(always)]
    pub fn intersect(&self, o: &Box3A) -> Box3A {
        let b = Box3A {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        };
        if b.min.cmpgt(b.max).any() {
            Box3A::EMPTY
        } else {
            b
        }
    }

    /// Surface area; 0 for an empty box.
    #[inline(always)]
    pub fn surface_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    pub fn to_aabb(self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// What a node needs to know about its primitives before choosing a split: their bounds
/// and the bounds of their (doubled) centroids.
#[derive(Clone, Copy, Debug)]
pub struct NodeInfo {
    pub bounds: Box3A,
    pub centroids: Box3A,
}

impl NodeInfo {
    pub const EMPTY: NodeInfo = NodeInfo {
        bounds: Box3A::EMPTY,
        centroids: Box3A::EMPTY,
    };

    #[inline(always)]
    pub fn add(&mut self, r: &PrimRef) {
        let (lo, hi) = (r.lo(), r.hi());
        self.bounds.grow(lo, hi);
        let c = lo + hi;
        self.centroids.grow(c, c);
    }

    pub fn merge(self, o: NodeInfo) -> NodeInfo {
        NodeInfo {
            bounds: self.bounds.union(o.bounds),
            centroids: self.centroids.union(o.centroids),
        }
    }

    /// Widest axis of the centroids, and whether they all coincide.
    pub fn centroid_axis(&self) -> (usize, bool) {
        let e = self.centroids.max - self.centroids.min;
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        (axis, e.max_element() <= 0.0)
    }

    pub fn of(refs: &[PrimRef]) -> NodeInfo {
        let fold = |mut info: NodeInfo, r: &PrimRef| {
            info.add(r);
            info
        };
        if refs.len() >= PARALLEL_PASS {
            refs.par_chunks(PARALLEL_PASS / 4)
                .map(|chunk| chunk.iter().fold(NodeInfo::EMPTY, fold))
                .reduce(|| NodeInfo::EMPTY, NodeInfo::merge)
        } else {
            refs.iter().fold(NodeInfo::EMPTY, fold)
        }
    }
}

impl Default for NodeInfo {
    fn default() -> Self {
        NodeInfo::EMPTY
    }
}

/// A split: the left child's size, and both children's infos.
pub type Split = (usize, NodeInfo, NodeInfo);

/// The infos of `refs[..m]` and `refs[m..]`.
pub fn split_at(refs: &[PrimRef], m: usize) -> Split {
    (m, NodeInfo::of(&refs[..m]), NodeInfo::of(&refs[m..]))
}

/// Moves the primitives for which `left` holds to the front, gathering both sides' infos
/// on the way (so no extra pass is needed), and returns the split. One thread swaps from
/// both ends: even near the root this is a few per cent of the build (the build report's
/// phases show it), and a partition in place needs no second array.
pub fn partition(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> Split {
    let (mut li, mut ri) = (NodeInfo::EMPTY, NodeInfo::EMPTY);
    let mut i = 0;
    let mut j = refs.len();
    // Unchecked: this loop moves every reference at every level of the build. Every index
    // read is in `i..j`, within `refs`: i < j ≤ refs.len() wherever one is read.
    let at = |refs: &[PrimRef], k: usize| {
        debug_assert!(k < refs.len());
        // SAFETY: k < j ≤ refs.len() at every call (above).
        unsafe { *refs.get_unchecked(k) }
    };
    loop {
        while i < j && left(&at(refs, i)) {
            li.add(&at(refs, i));
            i += 1;
        }
        while i < j && !left(&at(refs, j - 1)) {
            ri.add(&at(refs, j - 1));
            j -= 1;
        }
        if i >= j {
            return (i, li, ri);
        }
        // refs[i] belongs right and refs[j − 1] left: swap them into place, each added to
        // the side it now lies on.
        let (a, b) = (at(refs, i), at(refs, j - 1));
        li.add(&b);
        ri.add(&a);
        // SAFETY: i < j ≤ refs.len(), so both i and j − 1 are within `refs`.
        unsafe {
            *refs.get_unchecked_mut(i) = b;
            *refs.get_unchecked_mut(j - 1) = a;
        }
        i += 1;
        j -= 1;
    }
}
