//! Axis-aligned bounding boxes and the ray–box slab test.
//!
//! The slab test intersects the ray with the three pairs of planes bounding the box and keeps
//! the overlap of the three t intervals. Two floating-point details make it robust:
//! - rounding: each far distance is scaled by 1 + 2γ(3) (Ize 2013), so a box the exact ray
//!   touches is never missed because (b − o) · (1/d) rounded the wrong way;
//! - zero direction components: 1/±0 = ±∞, and a ray lying exactly in a slab plane gives
//!   0 · ∞ = NaN. The near plane is chosen by the sign of the direction (so ±0 pick opposite
//!   planes) and NaN is never allowed to win a comparison, which treats the ray as inside
//!   that slab: the box is closed, so a ray in its face plane touches it.

use super::{Ray, gamma};
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    /// The empty box: the identity of `union`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    pub fn from_point(p: Vec3) -> Self {
        Aabb { min: p, max: p }
    }

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Aabb::EMPTY, Aabb::grow_point)
    }

    pub fn grow_point(self, p: Vec3) -> Self {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn union(self, other: Aabb) -> Self {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The six corner coordinates' bits (min, then max): what a test compares to ask for
    /// the same box to the last bit.
    pub fn bits(&self) -> [u32; 6] {
        let (a, b) = (self.min, self.max);
        [a.x, a.y, a.z, b.x, b.y, b.z].map(f32::to_bits)
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    /// Surface area: the probability of a random ray hitting a convex box is proportional to
    /// it, which is the heart of the surface area heuristic.
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    pub fn contains_point(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn contains(&self, other: &Aabb) -> bool {
        other.is_empty() || (self.contains_point(other.min) && self.contains_point(other.max))
    }

    /// Distance along the ray at which it enters the box, or +∞ if it misses the box within
    /// [tmin, tmax].
    #[inline(always)]
    pub fn slab_test(&self, ray: &SlabRay, tmin: f32, tmax: f32) -> f32 {
        slab_entry(&[self.min, self.max], ray, tmin, tmax)
    }
}

/// Per-ray values of the slab test, computed once per ray rather than once per box.
#[derive(Clone, Copy, Debug)]
pub struct SlabRay {
    pub origin: Vec3,
    pub inv_dir: Vec3,
    /// Per axis, which corner (0 = min, 1 = max) holds the near plane: 1 where the
    /// direction is negative, −0.0 included. The far plane is the other one.
    pub near: [usize; 3],
}

impl SlabRay {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction;
        let near = |c: f32| usize::from(c.is_sign_negative());
        SlabRay {
            origin: ray.origin,
            inv_dir: Vec3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z),
            near: [near(d.x), near(d.y), near(d.z)],
        }
    }
}

/// Rounding makes each far-plane distance at most 3 operations' worth too small (Ize 2013).
pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// `x > acc ? x : acc`: a NaN `x` never wins, so a ray lying in a slab plane stays inside.
#[inline(always)]
fn max_keep(acc: f32, x: f32) -> f32 {
    if x > acc { x } else { acc }
}

#[inline(always)]
fn min_keep(acc: f32, x: f32) -> f32 {
    if x < acc { x } else { acc }
}

/// The slab test on a box given as its two corners `[min, max]`, shared by `Aabb` and the
/// BVH nodes: the distance at which the ray enters the box, or +∞ if it misses the box
/// within [tmin, tmax].
#[inline(always)]
pub fn slab_entry(corners: &[Vec3; 2], ray: &SlabRay, tmin: f32, tmax: f32) -> f32 {
    let [nx, ny, nz] = ray.near;
    let (o, inv) = (ray.origin, ray.inv_dir);
    // `& 1` keeps the indices provably in range, so no bounds check is left in the loop.
    let near_x = (corners[nx & 1].x - o.x) * inv.x;
    let near_y = (corners[ny & 1].y - o.y) * inv.y;
    let near_z = (corners[nz & 1].z - o.z) * inv.z;
    let far_x = (corners[(nx ^ 1) & 1].x - o.x) * inv.x;
    let far_y = (corners[(ny ^ 1) & 1].y - o.y) * inv.y;
    let far_z = (corners[(nz ^ 1) & 1].z - o.z) * inv.z;
    let enter = max_keep(max_keep(max_keep(tmin, near_x), near_y), near_z);
    // Each far distance is scaled before the minimum (x ↦ x·(1 + 2γ) is monotonic, so this
    // equals scaling the minimum once). Scaling once after a minimum that may be ±∞ ran at
    // half speed on axis-parallel rays (measured); this form runs at the same speed on both.
    let exit = min_keep(
        min_keep(min_keep(tmax, far_x * FAR_SCALE), far_y * FAR_SCALE),
        far_z * FAR_SCALE,
    );
    if enter <= exit { enter } else { f32::INFINITY }
}
