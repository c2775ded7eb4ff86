//! What a ray needs at a top-level leaf, in one cache line: the instance's inverse
//! transform, the BLAS and subtree to walk, and the instance. Kept in the TLAS's leaf order
//! (`leaves[k]` for the leaf slot `k`), so that the step from a TLAS leaf into a BLAS reads
//! one line next to its neighbours' instead of following the reference to its instance
//! (three lines of `Instance`, its forward transform read only to ask whether it is the
//! identity). On the island a primary ray enters two references: before this, a profile put
//! a sixth of the walk's time on those dependent cache misses.

use super::Reference;
use crate::accel::bvh::Subtree;
use crate::geometry::Ray;
use crate::scene::Instance;
use glam::Vec3;

/// A TLAS leaf slot's reference, ready to walk.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct LeafReference {
    /// World → object space, row by row: the object-space x of a world point p is
    /// `((rows[0][0]·p.x + rows[0][1]·p.y) + rows[0][2]·p.z) + rows[0][3]`, the very
    /// operations and order of `Affine3A::transform_point3`, so the ray is the same to the bit.
    rows: [[f32; 4]; 3],
    /// The BLAS (the instance's mesh).
    pub blas: u32,
    /// Where the BLAS walk starts.
    pub subtree: Subtree,
    /// The instance, with `IDENTITY` set when it leaves its mesh where it is.
    instance: u32,
}

/// Set in `instance` for the identity, whose rays are walked as they are (signs of zero
/// components included). Instances are numbered below 2^31 (`two_level::build`).
const IDENTITY: u32 = 1 << 31;

impl LeafReference {
    /// What a slot that holds no reference (padding) carries.
    pub const UNUSED: LeafReference = LeafReference {
        rows: [[0.0; 4]; 3],
        blas: 0,
        subtree: Subtree::ROOT,
        instance: 0,
    };

    pub fn new(reference: &Reference, instance: &Instance) -> Self {
        let m = &instance.inverse;
        let (x, y, z, t) = (
            m.matrix3.x_axis,
            m.matrix3.y_axis,
            m.matrix3.z_axis,
            m.translation,
        );
        let identity = if instance.is_identity() { IDENTITY } else { 0 };
        LeafReference {
            rows: [
                [x.x, y.x, z.x, t.x],
                [x.y, y.y, z.y, t.y],
                [x.z, y.z, z.z, t.z],
            ],
            blas: instance.mesh as u32,
            subtree: reference.subtree,
            instance: reference.instance | identity,
        }
    }

    /// The instance this reference belongs to.
    #[inline(always)]
    pub fn instance(&self) -> u32 {
        self.instance & !IDENTITY
    }

    #[inline(always)]
    pub fn is_identity(&self) -> bool {
        self.instance & IDENTITY != 0
    }

    /// `ray` in the instance's object space: the same t reaches the same point (the
    /// direction is not renormalised). Bit for bit `Instance::inverse` applied by glam.
    #[inline(always)]
    pub fn to_object(&self, ray: &Ray) -> Ray {
        let [a, b, c] = &self.rows;
        let (o, d) = (ray.origin, ray.direction);
        let point = |r: &[f32; 4]| ((r[0] * o.x + r[1] * o.y) + r[2] * o.z) + r[3];
        let vector = |r: &[f32; 4]| (r[0] * d.x + r[1] * d.y) + r[2] * d.z;
        Ray {
            origin: Vec3::new(point(a), point(b), point(c)),
            direction: Vec3::new(vector(a), vector(b), vector(c)),
            ..*ray
        }
    }
}
