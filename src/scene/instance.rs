//! Instancing: a unique mesh stored once and placed many times by affine transforms, the
//! lecture's way to Moana's billions of triangles from millions of unique ones. Each
//! instance keeps its inverse, which carries rays into the mesh's own space.

use crate::geometry::hull::HullColumns;
use crate::geometry::{Aabb, Triangle};
use glam::{Affine3A, DAffine3, DMat3, Mat3, Mat3A, Vec3A};

/// Triangles in their own (object) space, placed in the scene by instances.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub triangles: Vec<Triangle>,
}

/// One placement of a mesh: object space → world space, with the inverse precomputed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into the scene's meshes.
    pub mesh: usize,
    pub transform: Affine3A,
    pub inverse: Affine3A,
}

/// Why a transform cannot place an instance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TransformError {
    #[error("the transform has a NaN or infinite entry")]
    NonFinite,
    #[error("the transform is singular (it flattens space, so it has no inverse)")]
    Singular,
}

/// A linear part whose determinant is below this fraction of the cube of its longest
/// column squeezes space into (nearly) a plane or a line: its inverse would be meaningless
/// in f32.
const SINGULAR_RATIO: f32 = 1e-12;

impl Instance {
    /// The instance of mesh `mesh` placed by `transform`, if the transform is invertible.
    pub fn new(mesh: usize, transform: Affine3A) -> Result<Self, TransformError> {
        if !transform.is_finite() {
            return Err(TransformError::NonFinite);
        }
        // In f64: a large uniform scale (1e13) cubes past f32's range in the determinant
        // without being singular.
        let m = transform.matrix3;
        let linear = DMat3::from_cols(
            m.x_axis.as_dvec3(),
            m.y_axis.as_dvec3(),
            m.z_axis.as_dvec3(),
        );
        if is_singular(linear) {
            return Err(TransformError::Singular);
        }
        let inverse =
            DAffine3::from_mat3_translation(linear, transform.translation.as_dvec3()).inverse();
        let inverse = Affine3A::from_mat3_translation(
            Mat3::from_cols(
                inverse.matrix3.x_axis.as_vec3(),
                inverse.matrix3.y_axis.as_vec3(),
                inverse.matrix3.z_axis.as_vec3(),
            ),
            inverse.translation.as_vec3(),
        );
        if !inverse.is_finite() {
            return Err(TransformError::Singular);
        }
        Ok(Instance {
            mesh,
            transform,
            inverse,
        })
    }

    /// The mesh where it is defined.
    pub fn identity(mesh: usize) -> Self {
        Instance {
            mesh,
            transform: Affine3A::IDENTITY,
            inverse: Affine3A::IDENTITY,
        }
    }

    /// Whether the instance leaves its mesh where it is (so rays need no transform, and
    /// keep even the signs of their zero components).
    #[inline(always)]
    pub fn is_identity(&self) -> bool {
        self.transform == Affine3A::IDENTITY
    }

    /// Whether the instance only shifts its mesh, neither turning nor scaling it (as an
    /// object dragged in the app): its boxes then move as they are.
    #[inline]
    pub fn is_translation(&self) -> bool {
        self.transform.matrix3 == Mat3A::IDENTITY
    }

    /// A triangle of the mesh in world space (the very same for the identity, signed zeros
    /// included, as the two-level traversal does not transform rays there).
    pub fn place(&self, t: &Triangle) -> Triangle {
        if self.is_identity() {
            return *t;
        }
        let p = |v| self.transform.transform_point3(v);
        Triangle::new(p(t.v[0]), p(t.v[1]), p(t.v[2]))
    }

    /// The world box of the placed mesh whose object-space box is `b`: the box of its eight
    /// transformed corners (empty for an empty mesh), widened by a few units of rounding so
    /// that a ray which meets the mesh in object space never misses its world box.
    pub fn world_bounds(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return Aabb::EMPTY;
        }
        let w = if self.is_translation() {
            // Each corner coordinate is its own plus the shift, rounded once; rounding
            // keeps order, so the lowest and highest corners stay the box's: the eight
            // corners' box, without placing them.
            let t = glam::Vec3::from(self.transform.translation);
            Aabb::new(b.min + t, b.max + t)
        } else {
            self.corners_box(b)
        };
        let magnitude = w.min.abs().max(w.max.abs()) + (w.max - w.min);
        let pad = magnitude * (16.0 * f32::EPSILON);
        Aabb::new(w.min - pad, w.max + pad)
    }

    /// The world box of the placed mesh whose convex hull has the vertices `hull`, each
    /// mesh point lying at most `tolerance` beyond the hull (`geometry::hull`): the box of
    /// the placed vertices, the tightest a placed mesh has, widened by what the tolerance
    /// can move a placed point and then padded as `world_bounds` pads.
    pub fn world_bounds_of_hull(&self, hull: &HullColumns, tolerance: f32) -> Aabb {
        let placed = hull.placed_box(&self.transform);
        if placed.is_empty() {
            return Aabb::EMPTY;
        }
        let m = &self.transform.matrix3;
        let reach = glam::Vec3::from(m.x_axis.abs() + m.y_axis.abs() + m.z_axis.abs()) * tolerance;
        let w = Aabb::new(placed.min - reach, placed.max + reach);
        let magnitude = w.min.abs().max(w.max.abs()) + (w.max - w.min);
        let pad = magnitude * (16.0 * f32::EPSILON);
        Aabb::new(w.min - pad, w.max + pad)
    }

    /// The union of `world_bounds` of the boxes in the lanes of `rows` that `lanes` marks
    /// (bit k for lane k), `rows` being a wide node's (min x, y, z, max x, y, z; a box per
    /// lane): all lanes at once, a lane's box placed by Arvo's rule. Per world axis, the
    /// lowest corner is the sum of the lower of each axis's two terms, summed in
    /// `transform_point3`'s order, and the highest likewise; rounding is monotonic in each
    /// term, so that is the lowest corner of `corners_box` bit for bit (up to the sign of a
    /// zero), without the eight corners. A lane that is not finite takes `world_bounds`.
    pub fn world_bounds_of_lanes<const W: usize>(&self, rows: &[[f32; W]; 6], lanes: u32) -> Aabb {
        let m = &self.transform.matrix3;
        let axes = [m.x_axis, m.y_axis, m.z_axis];
        let t = self.transform.translation;
        let (mut lo, mut hi) = ([[0.0f32; W]; 3], [[0.0f32; W]; 3]);
        for j in 0..3 {
            if self.is_translation() {
                for k in 0..W {
                    lo[j][k] = rows[j][k] + t[j];
                    hi[j][k] = rows[j + 3][k] + t[j];
                }
                continue;
            }
            for (i, axis) in axes.iter().enumerate() {
                for k in 0..W {
                    let (p, q) = (axis[j] * rows[i][k], axis[j] * rows[i + 3][k]);
                    let (low, high) = if p < q { (p, q) } else { (q, p) };
                    (lo[j][k], hi[j][k]) = match i {
                        0 => (low, high),
                        _ => (lo[j][k] + low, hi[j][k] + high),
                    };
                }
            }
            for k in 0..W {
                lo[j][k] += t[j];
                hi[j][k] += t[j];
            }
        }
        // Each lane padded as `world_bounds` pads (an unused lane emptied), then the lanes'
        // union, halving the lanes at each step: all lanes at once.
        let mut finite = true;
        for j in 0..3 {
            for k in 0..W {
                let (l, h) = (lo[j][k], hi[j][k]);
                let used = lanes >> k & 1 == 1;
                finite &= !used || (l.is_finite() && h.is_finite());
                let magnitude = l.abs().max(h.abs()) + (h - l);
                let pad = magnitude * (16.0 * f32::EPSILON);
                (lo[j][k], hi[j][k]) = match used {
                    true => (l - pad, h + pad),
                    false => (f32::INFINITY, f32::NEG_INFINITY),
                };
            }
            // (Halving needs a power of two: wide nodes have 4 or 8 lanes.)
            const { assert!(W.is_power_of_two()) };
            let mut width = W;
            while width > 1 {
                width /= 2;
                for k in 0..width {
                    let (l, h) = (lo[j][k + width], hi[j][k + width]);
                    lo[j][k] = if l < lo[j][k] { l } else { lo[j][k] };
                    hi[j][k] = if h > hi[j][k] { h } else { hi[j][k] };
                }
            }
        }
        let (low, high) = (
            [lo[0][0], lo[1][0], lo[2][0]],
            [hi[0][0], hi[1][0], hi[2][0]],
        );
        if finite {
            return Aabb::new(low.into(), high.into());
        }
        (0..W)
            .filter(|&k| lanes >> k & 1 == 1)
            .map(|k| {
                self.world_bounds(&Aabb::new(
                    glam::Vec3::new(rows[0][k], rows[1][k], rows[2][k]),
                    glam::Vec3::new(rows[3][k], rows[4][k], rows[5][k]),
                ))
            })
            .fold(Aabb::EMPTY, Aabb::union)
    }

    /// The box of `b`'s eight corners placed by the transform. A corner is placed as
    /// `transform_point3` places it, x·x_axis + y·y_axis + z·z_axis + translation summed in
    /// that order; the six products and the four sums of x and y terms are shared by the
    /// corners, so this is the same box, bit for bit, for a third of the arithmetic (a top
    /// level places up to 64 BLAS boxes per instance: 1.3 · 10^7 for the island).
    fn corners_box(&self, b: &Aabb) -> Aabb {
        let m = &self.transform.matrix3;
        let t = self.transform.translation;
        let xs = [m.x_axis * b.min.x, m.x_axis * b.max.x];
        let ys = [m.y_axis * b.min.y, m.y_axis * b.max.y];
        let zs = [m.z_axis * b.min.z, m.z_axis * b.max.z];
        // With finite terms no sum is NaN, and the vector min and max then agree with
        // `f32::min` and `f32::max`, which `Aabb` uses (they differ only on NaN).
        if xs.iter().chain(&ys).chain(&zs).all(|v| v.is_finite()) && t.is_finite() {
            let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            for x in xs {
                for y in ys {
                    let xy = x + y;
                    for z in zs {
                        let p = xy + z + t;
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
            }
            return Aabb::new(lo.into(), hi.into());
        }
        self.corners_box_one_by_one(b)
    }

    /// `corners_box`, placing each corner on its own: what it must equal.
    fn corners_box_one_by_one(&self, b: &Aabb) -> Aabb {
        Aabb::from_points((0..8).map(|i| {
            let corner = glam::Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            self.transform.transform_point3(corner)
        }))
    }
}

fn is_singular(m: DMat3) -> bool {
    let longest = m
        .x_axis
        .length()
        .max(m.y_axis.length())
        .max(m.z_axis.length());
    let scale = longest * longest * longest;
    // Written so that a NaN determinant counts as singular.
    let regular = m.determinant().abs() > SINGULAR_RATIO as f64 * scale;
    !regular
}

/// The world-space triangles of `instances`, instance by instance in order and each mesh's
/// triangles in order: the numbering hits use.
pub fn flatten(meshes: &[Mesh], instances: &[Instance]) -> Vec<Triangle> {
    let total = instances
        .iter()
        .map(|i| meshes.get(i.mesh).map_or(0, |m| m.triangles.len()))
        .sum();
    let mut out = Vec::with_capacity(total);
    for instance in instances {
        if let Some(mesh) = meshes.get(instance.mesh) {
            out.extend(mesh.triangles.iter().map(|t| instance.place(t)));
        }
    }
    out
}

/// A scene seen as unique meshes and their instances, borrowed from it: what the
/// two-level structure is built over.
#[derive(Clone, Debug)]
pub struct Instancing<'a> {
    /// Each unique mesh's triangles in object space.
    pub meshes: Vec<&'a [Triangle]>,
    pub instances: std::borrow::Cow<'a, [Instance]>,
}

impl<'a> Instancing<'a> {
    /// One mesh placed once where it is: any triangle list as an instanced scene.
    pub fn single(triangles: &'a [Triangle]) -> Self {
        Instancing {
            meshes: vec![triangles],
            instances: vec![Instance::identity(0)].into(),
        }
    }

    /// Number of triangles the instances place (the flattened scene's size).
    pub fn instanced_triangles(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes.get(i.mesh).map_or(0, |m| m.len()))
            .sum()
    }

    pub fn unique_triangles(&self) -> usize {
        self.meshes.iter().map(|m| m.len()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A shifted box is its eight shifted corners' box, to the bit, signed zeros aside.
    #[test]
    fn a_shifted_box_is_its_shifted_corners_box() {
        let mut rng = crate::random::Rng(0x2545_f491_4f6c_dd1d);
        // Values from tiny to huge, of both signs.
        let mut next = || (rng.unit() as f32 - 0.5) * 10f32.powi(rng.below(13) as i32 - 6);
        for _ in 0..20_000 {
            let (a, b) = (
                Vec3::new(next(), next(), next()),
                Vec3::new(next(), next(), next()),
            );
            let boxed = Aabb::new(a.min(b), a.max(b));
            let shift = Vec3::new(next(), next(), next());
            let instance = Instance::new(0, Affine3A::from_translation(shift)).unwrap();
            assert!(instance.is_translation());
            let corners = instance.corners_box_one_by_one(&boxed);
            let shifted = Aabb::new(boxed.min + shift, boxed.max + shift);
            assert_eq!((shifted.min, shifted.max), (corners.min, corners.max));
        }
        let turned = Instance::new(0, Affine3A::from_rotation_y(0.3)).unwrap();
        assert!(!turned.is_translation());
    }

    /// Random numbers from tiny to huge, of both signs.
    struct Wild(crate::random::Rng);

    impl Wild {
        /// A number of magnitude up to 10^`range` and down to 10^-`range`.
        fn next(&mut self, range: i32) -> f32 {
            let rng = &mut self.0;
            (rng.unit() as f32 - 0.5) * 10f32.powi(rng.below(2 * range as u64 + 1) as i32 - range)
        }

        fn point(&mut self, range: i32) -> Vec3 {
            Vec3::new(self.next(range), self.next(range), self.next(range))
        }

        fn boxed(&mut self, range: i32) -> Aabb {
            let (a, b) = (self.point(range), self.point(range));
            Aabb::new(a.min(b), a.max(b))
        }

        /// An instance shifted by up to 10^`range`: turned, scaled, sheared or mirrored by
        /// a random matrix, or with `shift_only` only shifted; `None` if it is singular.
        fn instance(&mut self, range: i32, shift_only: bool) -> Option<Instance> {
            let m = match shift_only {
                true => Mat3A::IDENTITY,
                false => Mat3A::from_cols(
                    self.point(3).into(),
                    self.point(3).into(),
                    self.point(3).into(),
                ),
            };
            let t = self.point(range);
            Instance::new(0, Affine3A::from_mat3_translation(m.into(), t)).ok()
        }
    }

    /// Equal values (a zero's sign aside), or NaN in both.
    fn same(a: Vec3, b: Vec3) -> bool {
        (0..3).all(|i| a[i] == b[i] || (a[i].is_nan() && b[i].is_nan()))
    }

    /// The corners placed with shared products and sums give the box of the corners placed
    /// one by one, for rotations, scales, shears and mirrors, boxes from tiny to huge, and
    /// placements that overflow f32 (where the shared form steps aside).
    #[test]
    fn corners_placed_together_give_the_corners_placed_one_by_one() {
        let mut wild = Wild(crate::random::Rng(0x9e37_79b9_7f4a_7c15));
        let mut overflowed = 0;
        for k in 0..20_000 {
            let range = if k % 10 == 0 { 37 } else { 6 };
            let Some(instance) = wild.instance(range, false) else {
                continue;
            };
            let boxed = wild.boxed(range);
            let (fast, exact) = (
                instance.corners_box(&boxed),
                instance.corners_box_one_by_one(&boxed),
            );
            overflowed += usize::from(!(exact.min.is_finite() && exact.max.is_finite()));
            assert!(
                same(fast.min, exact.min) && same(fast.max, exact.max),
                "{instance:?} {boxed:?}: {fast:?} against {exact:?}"
            );
        }
        assert!(
            overflowed > 0,
            "no placement overflowed: the fallback went untested"
        );
    }

    /// Eight boxes placed together by Arvo's rule give the union of each placed on its own,
    /// for turned, shifted and identity placements, any choice of lanes, boxes from tiny to
    /// huge and placements that overflow f32.
    #[test]
    fn lanes_placed_together_give_the_union_of_each_placed_box() {
        let mut wild = Wild(crate::random::Rng(0x1234_5678_9abc_def1));
        let mut overflowed = 0;
        for k in 0..5_000 {
            let range = if k % 10 == 0 { 37 } else { 6 };
            let Some(instance) = wild.instance(range, k % 3 == 0) else {
                continue;
            };
            let boxes: Vec<Aabb> = (0..8).map(|_| wild.boxed(range)).collect();
            let rows: [[f32; 8]; 6] = std::array::from_fn(|row| {
                std::array::from_fn(|lane| match row {
                    0..3 => boxes[lane].min[row],
                    _ => boxes[lane].max[row - 3],
                })
            });
            let lanes = 1 + (k as u32 * 37) % 255;
            let together = instance.world_bounds_of_lanes(&rows, lanes);
            let each = (0..8)
                .filter(|&l| lanes >> l & 1 == 1)
                .fold(Aabb::EMPTY, |u, l| {
                    u.union(instance.world_bounds(&boxes[l]))
                });
            overflowed += usize::from(!(each.min.is_finite() && each.max.is_finite()));
            assert!(
                same(together.min, each.min) && same(together.max, each.max),
                "{instance:?} lanes {lanes:#b}: {together:?} against {each:?}"
            );
        }
        assert!(overflowed > 0, "no placement overflowed");
    }
}
