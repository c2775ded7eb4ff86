//! The SAH cost of both levels together, as a ray in world space pays it: the top level's
//! nodes, and below each reference the nodes and triangles of its BLAS subtree, placed by
//! the reference's instance. The BLASes are shared, so the cost is summed per reference
//! without placing a single BLAS box.
//!
//! A random line that meets a convex body K meets a convex body inside it with probability
//! SA(inside) / SA(K); the SAH weighs each node by that. A BLAS box of extents (dx, dy, dz)
//! placed by a linear map with columns (Tx, Ty, Tz) is a parallelepiped of surface area
//! 2 (dx·dy |Tx × Ty| + dy·dz |Ty × Tz| + dz·dx |Tz × Tx|): linear in the box's three
//! products of extents. So one pass over each BLAS sums, per node, its subtree's costs
//! times those three products, and a reference's placed subtree costs three products with
//! its instance's cross-product lengths, whatever the transform (rotated, scaled, mirrored).
//!
//! The walk charges what the counters count: a node visit (C_trav) for each top-level node
//! and each BLAS node the ray enters, a test (C_isect) for each triangle; entering an
//! instance is not charged. A reference's subtree root is entered with its top-level lane,
//! so it weighs with that lane's world box.

use super::TwoLevel;
use crate::accel::bvh::Bvh8;
use crate::accel::bvh::wide::{LaneKind, LaneSums};
use crate::geometry::Aabb;
use glam::DVec3;

/// Σ C(m) · (dx·dy, dy·dz, dz·dx) over the nodes m strictly below each BLAS node and its
/// leaf lanes' triangles (C_trav for a node, C_isect per triangle of a leaf).
fn terms_below(blas: &Bvh8, c_trav: f64, c_isect: f64) -> Vec<DVec3> {
    let mut below = vec![DVec3::ZERO; blas.nodes.len()];
    // Interior children come after their parent: one backward pass.
    for i in (0..blas.nodes.len()).rev() {
        let node = &blas.nodes[i];
        let mut sum = DVec3::ZERO;
        for lane in 0..node.child_count() {
            let products = products(node.child_bounds(lane));
            sum += match node.lane_kind(lane) {
                LaneKind::Interior(c) => c_trav * products + below[c as usize],
                LaneKind::Leaf { count, .. } => c_isect * f64::from(count) * products,
                LaneKind::Unused => DVec3::ZERO,
            };
        }
        below[i] = sum;
    }
    below
}

/// Per instance, the weights of a box's three products of extents in its placed area:
/// twice its cross-product lengths (|Tx × Ty|, |Ty × Tz|, |Tz × Tx|).
pub(super) fn area_weights(instances: &[crate::scene::Instance]) -> Vec<DVec3> {
    instances
        .iter()
        .map(|inst| {
            let m = inst.transform.matrix3;
            let (x, y, z) = (
                m.x_axis.as_dvec3(),
                m.y_axis.as_dvec3(),
                m.z_axis.as_dvec3(),
            );
            2.0 * DVec3::new(
                x.cross(y).length(),
                y.cross(z).length(),
                z.cross(x).length(),
            )
        })
        .collect()
}

/// A box's products of extents (dx·dy, dy·dz, dz·dx); zero for an empty box.
pub(super) fn products(b: Aabb) -> DVec3 {
    if b.is_empty() {
        return DVec3::ZERO;
    }
    let d = (b.max - b.min).as_dvec3();
    DVec3::new(d.x * d.y, d.y * d.z, d.z * d.x)
}

impl TwoLevel {
    /// The SAH cost of both levels (see the module): Σ SA(n)/SA(root) · C(n) over the top
    /// level's nodes and every reference's placed BLAS nodes and triangles, with C_trav
    /// per node and C_isect per triangle. A scene with no area weighs C_isect per triangle
    /// placed, as a flat BVH does.
    pub fn sah_cost(&self, c_trav: f32, c_isect: f32) -> f64 {
        let (c_trav, c_isect) = (f64::from(c_trav), f64::from(c_isect));
        let root = f64::from(self.tlas.nodes[0].bounds().surface_area());
        let placed: u64 = self.references.iter().map(|r| u64::from(r.triangles)).sum();
        if self.references.is_empty() || root <= 0.0 {
            return c_isect * placed as f64;
        }
        let below: Vec<Vec<DVec3>> = self
            .blases
            .iter()
            .map(|b| terms_below(b, c_trav, c_isect))
            .collect();
        let weights = area_weights(&self.instances);
        // The top level's nodes: the root and its interior lanes.
        let mut sum = c_trav * (root + LaneSums::of(&self.tlas.nodes).interior_area());
        for (r, reference) in self.references.iter().enumerate() {
            let Some((node, lane)) = self.top_index.slot_of(r) else {
                continue;
            };
            let world = f64::from(
                self.tlas.nodes[node as usize]
                    .child_bounds(lane as usize)
                    .surface_area(),
            );
            let instance = reference.instance as usize;
            let mesh = self.instances[instance].mesh;
            sum += if reference.subtree.is_leaf() {
                c_isect * f64::from(reference.triangles) * world
            } else {
                let terms = below[mesh][reference.subtree.node_index()];
                c_trav * world + weights[instance].dot(terms)
            };
        }
        sum / root
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::accel::BuildParams;
    use crate::accel::progress::BuildProgress;
    use crate::accel::two_level::build;
    use crate::geometry::Triangle;
    use crate::scene::{Instance, Instancing, builtin};
    use glam::{Affine3A, Quat, Vec3};

    pub(in crate::accel::two_level) fn two_levels(
        meshes: &[&[Triangle]],
        transforms: &[(usize, Affine3A)],
        rebraid: f32,
    ) -> TwoLevel {
        let instances: Vec<Instance> = transforms
            .iter()
            .map(|&(mesh, t)| Instance::new(mesh, t).unwrap())
            .collect();
        let scene = Instancing {
            meshes: meshes.to_vec(),
            instances: instances.into(),
        };
        let params = BuildParams {
            rebraid,
            ..BuildParams::default()
        };
        build(&scene, &params, &BuildProgress::default()).unwrap().0
    }

    /// The same cost summed box by box: every placed BLAS box's parallelepiped measured
    /// from its three placed edges, the subtrees walked reference by reference.
    fn box_by_box(t: &TwoLevel, c_trav: f64, c_isect: f64) -> f64 {
        let root = f64::from(t.tlas.nodes[0].bounds().surface_area());
        let mut sum = c_trav * root;
        for node in &t.tlas.nodes {
            for lane in 0..node.child_count() {
                if node.is_interior(lane) {
                    sum += c_trav * f64::from(node.child_bounds(lane).surface_area());
                }
            }
        }
        for (r, reference) in t.references.iter().enumerate() {
            let (node, lane) = t.top_index.slot_of(r).unwrap();
            let world = f64::from(
                t.tlas.nodes[node as usize]
                    .child_bounds(lane as usize)
                    .surface_area(),
            );
            let instance = &t.instances[reference.instance as usize];
            if reference.subtree.is_leaf() {
                sum += c_isect * f64::from(reference.triangles) * world;
                continue;
            }
            sum += c_trav * world;
            let blas = &t.blases[instance.mesh];
            let m = instance.transform.matrix3;
            let placed = |b: Aabb| {
                let d = (b.max - b.min).as_dvec3();
                let [a, b, c] = [
                    m.x_axis * d.x as f32,
                    m.y_axis * d.y as f32,
                    m.z_axis * d.z as f32,
                ]
                .map(|v| v.as_dvec3());
                2.0 * (a.cross(b).length() + b.cross(c).length() + c.cross(a).length())
            };
            let mut stack = vec![reference.subtree.node_index()];
            while let Some(i) = stack.pop() {
                let n = &blas.nodes[i];
                for lane in 0..n.child_count() {
                    let area = placed(n.child_bounds(lane));
                    match n.lane_kind(lane) {
                        LaneKind::Interior(c) => {
                            sum += c_trav * area;
                            stack.push(c as usize);
                        }
                        LaneKind::Leaf { count, .. } => sum += c_isect * f64::from(count) * area,
                        LaneKind::Unused => {}
                    }
                }
            }
        }
        sum / root
    }

    /// Turned, unevenly scaled and mirrored instances of two meshes.
    pub(in crate::accel::two_level) fn wild() -> [(usize, Affine3A); 4] {
        [
            (0, Affine3A::IDENTITY),
            (
                1,
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(0.01, 0.03, 0.02),
                    Quat::from_axis_angle(Vec3::new(1.0, 1.0, 1.0).normalize(), 0.5),
                    Vec3::new(5.0, 0.0, 2.0),
                ),
            ),
            (
                0,
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(-2.0, 1.0, 0.5),
                    Quat::from_rotation_y(1.1),
                    Vec3::new(-4.0, 3.0, 0.0),
                ),
            ),
            (
                1,
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(0.02, 0.02, -0.05),
                    Quat::from_rotation_x(2.0),
                    Vec3::new(0.0, 6.0, -3.0),
                ),
            ),
        ]
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-6 * a.abs().max(b.abs())
    }

    /// One instance left whole, not moved: the top level's root, then the BLAS's own SAH.
    /// Scaled uniformly and shifted, the same (to its box's padding); turned, scaled unevenly and mirrored, the
    /// cost is the one summed box by box, at every re-braiding budget.
    #[test]
    fn both_levels_cost_what_their_placed_boxes_cost() {
        let sphere = builtin::by_name("sphere:3000").unwrap().unwrap().triangles;
        let teapot = builtin::by_name("teapot-in-stadium")
            .unwrap()
            .unwrap()
            .triangles;
        let alone = two_levels(&[&sphere], &[(0, Affine3A::IDENTITY)], 0.0);
        let blas = alone.blases[0].sah_cost(1.0, 1.0);
        assert!(
            close(alone.sah_cost(1.0, 1.0), 1.0 + blas),
            "{} {blas}",
            alone.sah_cost(1.0, 1.0)
        );
        let grown = two_levels(
            &[&sphere],
            &[(
                0,
                Affine3A::from_scale_rotation_translation(
                    Vec3::splat(7.5),
                    Quat::IDENTITY,
                    Vec3::new(3.0, -9.0, 40.0),
                ),
            )],
            0.0,
        );
        // (Its top-level box is padded for the placement's rounding: 1e-5 of the cost.)
        let (g, a) = (grown.sah_cost(1.0, 2.0), alone.sah_cost(1.0, 2.0));
        assert!((g - a).abs() <= 1e-4 * a, "{g} {a}");
        let wild = wild();
        for rebraid in [0.0, 0.5, 4.0] {
            let t = two_levels(&[&sphere, &teapot], &wild, rebraid);
            for (c_trav, c_isect) in [(1.0, 1.0), (1.0, 3.0)] {
                let (got, want) = (
                    t.sah_cost(c_trav, c_isect),
                    box_by_box(&t, c_trav.into(), c_isect.into()),
                );
                assert!(close(got, want), "rebraid {rebraid}: {got} against {want}");
            }
        }
    }
}
