//! The EPO of both levels together (`accel::epo`), as a ray in world space pays it: an end
//! point p on a placed triangle pays for every top-level node whose world box holds p, and
//! for every BLAS node, below every reference whose lane holds p, whose box holds p carried
//! into that instance's space, but for the nodes above p's own triangle. The charges are
//! the two levels' SAH cost's (`sah`): C_trav for each top-level node and each BLAS node
//! entered (a reference's subtree root with its top-level lane), C_isect per triangle of a
//! leaf; entering an instance is not charged.
//!
//! Exact, each placed triangle is clipped down both levels as a flat tree's are, carried
//! into an instance's space at each reference its part reaches and weighed there by its
//! area in the world (the instance's cofactor matrix carries an area vector to the world).
//! The island places 10^10 triangles, so past `EXACT_MAX` the same walk is made from end
//! points sampled uniformly over the placed surfaces instead (`end_points`): the mean of
//! their charges is the EPO, up to a standard error the figure states.

use super::TwoLevel;
use super::blas_index::BlasIndex;
use crate::accel::bvh::wide::LaneKind;
use crate::accel::bvh::{Bvh8, Subtree};
use crate::accel::epo::Epo;
use crate::accel::epo::part::{Against, Part};
use crate::geometry::{Aabb, Triangle};
use glam::{DAffine3, DMat3};
use rayon::prelude::*;
use std::collections::HashMap;

/// The most placed triangles whose EPO is clipped exactly (a few seconds on two threads);
/// past it the EPO is estimated.
pub const EXACT_MAX: u64 = 1 << 21;

/// End points an estimate averages.
pub const END_POINTS: u64 = 1 << 20;

impl TwoLevel {
    /// Both levels' EPO over `meshes` (the meshes the BLASes were built over), exact up to
    /// `EXACT_MAX` placed triangles and estimated past it; `None` once `abandon` says so.
    pub fn epo_unless(
        &self,
        meshes: &[&[Triangle]],
        c_trav: f32,
        c_isect: f32,
        abandon: &(dyn Fn() -> bool + Sync),
    ) -> Option<Epo> {
        let placed: u64 = self
            .instances
            .iter()
            .map(|i| mesh_len(meshes, i.mesh))
            .sum();
        let walk = Walk::of(self, meshes, c_trav, c_isect)?;
        if placed <= EXACT_MAX {
            walk.exact(abandon).map(Epo::exact)
        } else {
            walk.estimate(END_POINTS, abandon)
        }
    }

    /// The EPO clipped exactly, however many triangles are placed.
    pub fn epo_exact(&self, meshes: &[&[Triangle]], c_trav: f32, c_isect: f32) -> f64 {
        Walk::of(self, meshes, c_trav, c_isect)
            .and_then(|w| w.exact(&|| false))
            .unwrap_or_default()
    }

    /// The EPO estimated from `end_points` end points (the same ones every time).
    pub fn epo_estimate(
        &self,
        meshes: &[&[Triangle]],
        c_trav: f32,
        c_isect: f32,
        end_points: u64,
    ) -> Epo {
        self.epo_estimate_unless(meshes, c_trav, c_isect, end_points, &|| false)
            .unwrap_or(Epo::exact(0.0))
    }

    /// `epo_estimate`, given up (`None`) as soon as `abandon` says so.
    pub fn epo_estimate_unless(
        &self,
        meshes: &[&[Triangle]],
        c_trav: f32,
        c_isect: f32,
        end_points: u64,
        abandon: &(dyn Fn() -> bool + Sync),
    ) -> Option<Epo> {
        match Walk::of(self, meshes, c_trav, c_isect) {
            Some(w) => w.estimate(end_points, abandon),
            None => Some(Epo::exact(0.0)),
        }
    }
}

fn mesh_len(meshes: &[&[Triangle]], mesh: usize) -> u64 {
    meshes.get(mesh).map_or(0, |m| m.len()) as u64
}

/// What the walks read: both levels, each instance's maps in f64, and where each mesh
/// triangle sits in its BLAS.
pub(super) struct Walk<'a> {
    pub tl: &'a TwoLevel,
    pub meshes: &'a [&'a [Triangle]],
    /// Per instance: object → world, world → object, and the cofactor matrix that carries
    /// an object-space area vector to the world.
    pub to_world: Vec<DAffine3>,
    to_object: Vec<DAffine3>,
    cofactor: Vec<DMat3>,
    blas: Vec<BlasIndex>,
    /// Per TLAS node, its parent (the root's is `u32::MAX`).
    tlas_parent: Vec<u32>,
    /// (instance, subtree word) → its reference.
    reference_of: HashMap<(u32, u32), u32>,
    c_trav: f64,
    c_isect: f64,
}

/// What lies above one placed triangle, whose nodes its end points do not pay for.
#[derive(Default)]
pub(super) struct Above {
    instance: u32,
    /// The BLAS nodes above its leaf lanes, and those lanes' first slots.
    blas_nodes: Vec<u32>,
    leaf_firsts: Vec<u32>,
    /// Per TLAS node, whether a reference holding it lies below; `tlas_marked` lists them.
    tlas: Vec<bool>,
    tlas_marked: Vec<u32>,
    /// The references holding it (reused from triangle to triangle).
    references: Vec<u32>,
}

/// What a walk carries down the levels: a triangle's clipped part (exact) or an end point
/// (estimate).
pub(super) trait Probe: Sized {
    /// What of it lies in the closed box `b` (of the space it is in), if anything that
    /// weighs.
    fn within(&self, b: &Aabb) -> Option<Self>;
    /// Its weight: the part's area in the world, 1 for a point.
    fn weight(&self) -> f64;
    /// It carried into instance `j`'s space from the world.
    fn carried_to(&self, walk: &Walk, j: usize) -> Self;
}

impl<'a> Walk<'a> {
    /// Instance `i`'s cofactor matrix.
    pub(super) fn cofactor(&self, i: usize) -> DMat3 {
        self.cofactor[i]
    }

    /// Instance `i`'s world → object map.
    pub(super) fn to_object(&self, i: usize) -> DAffine3 {
        self.to_object[i]
    }

    /// `None` for a scene without a top level (nothing placed).
    pub(super) fn of(
        tl: &'a TwoLevel,
        meshes: &'a [&'a [Triangle]],
        c_trav: f32,
        c_isect: f32,
    ) -> Option<Walk<'a>> {
        if tl.references.is_empty() || tl.tlas.nodes.is_empty() {
            return None;
        }
        let to_world: Vec<DAffine3> = tl
            .instances
            .iter()
            .map(|i| {
                let m = i.transform.matrix3;
                DAffine3::from_mat3_translation(
                    DMat3::from_cols(
                        m.x_axis.as_dvec3(),
                        m.y_axis.as_dvec3(),
                        m.z_axis.as_dvec3(),
                    ),
                    i.transform.translation.as_dvec3(),
                )
            })
            .collect();
        let to_object = to_world.iter().map(|a| a.inverse()).collect();
        let cofactor = to_world
            .iter()
            .map(|a| a.matrix3.inverse().transpose() * a.matrix3.determinant())
            .collect();
        let blas = tl
            .blases
            .iter()
            .enumerate()
            .map(|(m, b)| BlasIndex::of(b, mesh_len(meshes, m) as usize))
            .collect();
        let mut tlas_parent = vec![u32::MAX; tl.tlas.nodes.len()];
        for (n, node) in tl.tlas.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                if let Some(c) = node.interior(lane) {
                    tlas_parent[c] = n as u32;
                }
            }
        }
        let reference_of = tl
            .references
            .iter()
            .enumerate()
            .map(|(r, reference)| ((reference.instance, reference.subtree.word()), r as u32))
            .collect();
        Some(Walk {
            tl,
            meshes,
            to_world,
            to_object,
            cofactor,
            blas,
            tlas_parent,
            reference_of,
            c_trav: f64::from(c_trav),
            c_isect: f64::from(c_isect),
        })
    }

    /// Marks in `above` what lies above triangle `t` of instance `i`: its BLAS's leaf lanes
    /// and nodes above them, the references holding them and the top-level nodes above
    /// those. `unmark` first clears the previous triangle's marks.
    pub(super) fn mark(&self, above: &mut Above, i: usize, t: usize) {
        if above.tlas.len() != self.tlas_parent.len() {
            above.tlas = vec![false; self.tlas_parent.len()];
        }
        for &n in &above.tlas_marked {
            above.tlas[n as usize] = false;
        }
        above.tlas_marked.clear();
        above.blas_nodes.clear();
        above.leaf_firsts.clear();
        above.instance = i as u32;
        let mesh = self.tl.instances[i].mesh;
        let (Some(blas), Some(index)) = (self.tl.blases.get(mesh), self.blas.get(mesh)) else {
            return;
        };
        let references = &mut above.references;
        references.clear();
        for &(node, first) in index.lanes_of(t) {
            above.leaf_firsts.push(first);
            let count = leaf_count(blas, node, first);
            let leaf = Subtree::leaf(first, count.max(1)).word();
            references.extend(self.reference_of.get(&(i as u32, leaf)));
            let mut n = node;
            while n != u32::MAX && !above.blas_nodes.contains(&n) {
                above.blas_nodes.push(n);
                references.extend(self.reference_of.get(&(i as u32, Subtree::node(n).word())));
                n = index.parent[n as usize];
            }
        }
        for &r in references.iter() {
            let Some((node, _)) = self.tl.top_index.slot_of(r as usize) else {
                continue;
            };
            let mut n = node;
            while n != u32::MAX && !above.tlas[n as usize] {
                above.tlas[n as usize] = true;
                above.tlas_marked.push(n);
                n = self.tlas_parent[n as usize];
            }
        }
    }

    /// Σ C(n) · weight over the nodes of both levels `probe` reaches from the top-level
    /// root, but for those `above` marks.
    pub(super) fn charge<P: Probe>(&self, probe: &P, above: &Above) -> f64 {
        let root = self.tl.tlas.nodes[0].bounds();
        let Some(p) = probe.within(&root) else {
            return 0.0;
        };
        let mut sum = 0.0;
        if !above.tlas[0] {
            sum += self.c_trav * p.weight();
        }
        self.top(0, &p, above, &mut sum);
        sum
    }

    fn top<P: Probe>(&self, node: usize, probe: &P, above: &Above, sum: &mut f64) {
        let tlas = &self.tl.tlas;
        let n = &tlas.nodes[node];
        for lane in 0..n.child_count() {
            let Some(p) = probe.within(&n.child_bounds(lane)) else {
                continue;
            };
            match n.lane_kind(lane) {
                LaneKind::Interior(c) => {
                    if !above.tlas[c as usize] {
                        *sum += self.c_trav * p.weight();
                    }
                    self.top(c as usize, &p, above, sum);
                }
                LaneKind::Leaf { first, count } => {
                    for slot in first..first + count {
                        let r = tlas.prim_indices[slot as usize] as usize;
                        if let Some(reference) = self.tl.references.get(r) {
                            self.enter(reference, &p, above, sum);
                        }
                    }
                }
                LaneKind::Unused => {}
            }
        }
    }

    /// A reference reached in the world: its subtree's root charged with the top-level
    /// lane, then its BLAS walked in the instance's space.
    fn enter<P: Probe>(
        &self,
        reference: &super::Reference,
        probe: &P,
        above: &Above,
        sum: &mut f64,
    ) {
        let j = reference.instance as usize;
        let own = reference.instance == above.instance;
        let s = reference.subtree;
        if s.is_leaf() {
            if !(own && above.leaf_firsts.contains(&s.leaf_first())) {
                *sum += self.c_isect * f64::from(reference.triangles) * probe.weight();
            }
            return;
        }
        let node = s.node_index() as u32;
        if !(own && above.blas_nodes.contains(&node)) {
            *sum += self.c_trav * probe.weight();
        }
        let mesh = self.tl.instances[j].mesh;
        let q = probe.carried_to(self, j);
        self.bottom(&self.tl.blases[mesh], node as usize, &q, own, above, sum);
    }

    fn bottom<P: Probe>(
        &self,
        blas: &Bvh8,
        node: usize,
        probe: &P,
        own: bool,
        above: &Above,
        sum: &mut f64,
    ) {
        let n = &blas.nodes[node];
        for lane in 0..n.child_count() {
            let Some(p) = probe.within(&n.child_bounds(lane)) else {
                continue;
            };
            match n.lane_kind(lane) {
                LaneKind::Interior(c) => {
                    if !(own && above.blas_nodes.contains(&c)) {
                        *sum += self.c_trav * p.weight();
                    }
                    self.bottom(blas, c as usize, &p, own, above, sum);
                }
                LaneKind::Leaf { first, count } => {
                    if !(own && above.leaf_firsts.contains(&first)) {
                        *sum += self.c_isect * f64::from(count) * p.weight();
                    }
                }
                LaneKind::Unused => {}
            }
        }
    }

    /// Σ over the placed triangles of their parts' charges, over the placed area.
    fn exact(&self, abandon: &(dyn Fn() -> bool + Sync)) -> Option<f64> {
        // Work in runs of one instance's triangles, in leaf order, summed in a fixed order.
        const RUN: usize = 256;
        let runs: Vec<(usize, usize)> = (0..self.tl.instances.len())
            .flat_map(|i| {
                let len = self
                    .blas
                    .get(self.tl.instances[i].mesh)
                    .map_or(0, |b| b.lanes.order.len());
                (0..len).step_by(RUN).map(move |s| (i, s))
            })
            .collect();
        let sums: Vec<(f64, f64)> = runs
            .par_iter()
            .map_init(Above::default, |above, &(i, s)| {
                if abandon() {
                    return (0.0, 0.0);
                }
                let mesh = self.tl.instances[i].mesh;
                let order = &self.blas[mesh].lanes.order;
                let (mut charged, mut area) = (0.0, 0.0);
                for &t in &order[s..(s + RUN).min(order.len())] {
                    let part = Piece::world(self, i, t as usize);
                    if part.part.area <= 0.0 {
                        continue;
                    }
                    area += part.part.area;
                    self.mark(above, i, t as usize);
                    charged += self.charge(&part, above);
                }
                (charged, area)
            })
            .collect();
        if abandon() {
            return None;
        }
        let (charged, area) = sums
            .iter()
            .fold((0.0, 0.0), |(c, a), &(dc, da)| (c + dc, a + da));
        Some(if area > 0.0 { charged / area } else { 0.0 })
    }

    /// The estimate from `n` end points (`end_points`).
    fn estimate(&self, n: u64, abandon: &(dyn Fn() -> bool + Sync)) -> Option<Epo> {
        super::end_points::epo_estimate(self, n, abandon)
    }
}

/// The triangle count of the leaf lane of `node` starting at slot `first`.
fn leaf_count(blas: &Bvh8, node: u32, first: u32) -> u32 {
    let n = &blas.nodes[node as usize];
    (0..n.child_count())
        .find_map(|lane| n.leaf(lane).filter(|l| l.0 == first).map(|l| l.1))
        .unwrap_or(0)
}

/// A placed triangle's part, and the map that carries its space's areas to the world's.
#[derive(Clone, Copy)]
struct Piece {
    part: Part,
    cofactor: Option<DMat3>,
    /// Its instance and triangle, and whether no box has cut it yet: then it enters its
    /// own instance as the mesh's triangle itself, not carried to the world and back, so
    /// a triangle in the face plane of one of its BLAS's boxes stays in it to the bit.
    own: (usize, usize),
    whole: bool,
}

impl Piece {
    fn world(walk: &Walk, i: usize, t: usize) -> Piece {
        let tri = &walk.meshes[walk.tl.instances[i].mesh][t];
        let to_world = walk.to_world[i];
        Piece {
            part: Part::of(tri).mapped(|p| to_world.transform_point3(p)),
            cofactor: None,
            own: (i, t),
            whole: true,
        }
    }
}

impl Probe for Piece {
    fn within(&self, b: &Aabb) -> Option<Piece> {
        let (min, max) = (b.min.as_dvec3().into(), b.max.as_dvec3().into());
        match self.part.against(&min, &max) {
            Against::Outside => None,
            Against::Inside => Some(*self),
            Against::Crossing => Some(Piece {
                part: self.part.clipped(&min, &max)?,
                whole: false,
                ..*self
            }),
        }
    }

    fn weight(&self) -> f64 {
        match self.cofactor {
            None => self.part.area,
            Some(c) => 0.5 * (c * self.part.normal).length(),
        }
    }

    fn carried_to(&self, walk: &Walk, j: usize) -> Piece {
        let (i, t) = self.own;
        let part = match self.whole && i == j {
            true => Part::of(&walk.meshes[walk.tl.instances[i].mesh][t]),
            false => {
                let to_object = walk.to_object[j];
                self.part.mapped(|p| to_object.transform_point3(p))
            }
        };
        Piece {
            part,
            cofactor: Some(walk.cofactor[j]),
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::sah::tests::two_levels;
    use crate::accel::epo::epo;
    use crate::scene::builtin;
    use glam::{Affine3A, Quat, Vec3};

    fn mesh(name: &str) -> Vec<crate::geometry::Triangle> {
        builtin::by_name(name).unwrap().unwrap().triangles
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-9)
    }

    /// One instance left whole where its mesh is: the top level's root and the BLAS's root
    /// lie above every triangle, so both levels' EPO is the BLAS's own, clipped as a flat
    /// tree's.
    #[test]
    fn one_instance_left_whole_has_its_blass_epo() {
        for name in ["sphere:3000", "teapot-in-stadium", "cornell"] {
            let m = mesh(name);
            let t = two_levels(&[&m], &[(0, Affine3A::IDENTITY)], 0.0);
            for (c_trav, c_isect) in [(1.0, 1.0), (1.0, 3.0)] {
                let flat = epo(&t.blases[0].outline(), &m, c_trav, c_isect);
                let both = t.epo_exact(&[&m], c_trav, c_isect);
                assert!(flat > 0.0, "{name}");
                assert!(close(both, flat), "{name}: {both} against {flat}");
            }
        }
    }

    /// Two meshes placed far apart, one shrunk to 0.3: no end point lies in the other's
    /// boxes, and a tree's EPO does not change when it is scaled, so both levels' EPO is
    /// the two BLASes' EPOs weighed by their placed areas (the shrunk one's 0.09×). (The
    /// stadium's floor and walls lie in its boxes' face planes: carried to the world and
    /// back they would leave them.)
    #[test]
    fn meshes_apart_weigh_their_epos_by_placed_area() {
        let (a, b) = (mesh("sphere:2000"), mesh("teapot-in-stadium"));
        let area =
            |m: &[crate::geometry::Triangle]| m.iter().map(crate::accel::epo::area).sum::<f64>();
        let grown = Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.3),
            Quat::IDENTITY,
            Vec3::new(1e4, 0.0, 0.0),
        );
        let t = two_levels(&[&a, &b], &[(0, Affine3A::IDENTITY), (1, grown)], 0.0);
        let (ea, eb) = (
            epo(&t.blases[0].outline(), &a, 1.0, 1.0),
            epo(&t.blases[1].outline(), &b, 1.0, 1.0),
        );
        let (wa, wb) = (area(&a), 0.09 * area(&b));
        let want = (wa * ea + wb * eb) / (wa + wb);
        let got = t.epo_exact(&[&a, &b], 1.0, 1.0);
        assert!((got - want).abs() <= 1e-6 * want, "{got} against {want}");
        assert!(
            (ea - eb).abs() > 0.05 * want,
            "the test needs two different EPOs"
        );
    }

    /// Turned, unevenly scaled, mirrored and overlapping instances, opened by re-braiding:
    /// the estimate from end points lies within 4.5 standard errors of the clipped EPO,
    /// and its error is small.
    #[test]
    fn the_estimate_finds_the_clipped_epo() {
        let (a, b) = (mesh("sphere:2000"), mesh("teapot-in-stadium"));
        let turned =
            |s: Vec3, q: Quat, at: Vec3| Affine3A::from_scale_rotation_translation(s, q, at);
        let placed = [
            (0, Affine3A::IDENTITY),
            (
                1,
                turned(
                    Vec3::new(0.01, 0.03, 0.02),
                    Quat::from_rotation_y(0.5),
                    Vec3::ZERO,
                ),
            ),
            (
                0,
                turned(
                    Vec3::new(-0.8, 1.0, 0.5),
                    Quat::from_rotation_z(1.1),
                    Vec3::X * 0.3,
                ),
            ),
            (
                1,
                turned(Vec3::splat(0.02), Quat::from_rotation_x(2.0), Vec3::Y * 0.2),
            ),
        ];
        for rebraid in [0.0, 4.0] {
            let t = two_levels(&[&a, &b], &placed, rebraid);
            let exact = t.epo_exact(&[&a, &b], 1.0, 2.0);
            let est = t.epo_estimate(&[&a, &b], 1.0, 2.0, 1 << 16);
            let e = est.estimate.unwrap();
            assert_eq!(e.end_points, 1 << 16);
            assert!(exact > 0.1, "the instances must overlap: {exact}");
            assert!(
                (est.value - exact).abs() <= 4.5 * e.std_error,
                "rebraid {rebraid}: {} ± {} against {exact}",
                est.value,
                e.std_error
            );
            assert!(e.std_error < 0.05 * exact, "{}", e.std_error);
            // The same end points every time.
            assert_eq!(t.epo_estimate(&[&a, &b], 1.0, 2.0, 1 << 16), est);
        }
    }
}
