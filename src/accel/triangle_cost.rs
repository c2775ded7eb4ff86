//! Where a tree's SAH cost lives, on the geometry: the cost split among the triangles so
//! that the shares add up to the tree's SAH cost (as RRA colours per-triangle SAH). A leaf
//! L charges each of its references SA(L)/SA(root)·C_isect (the chance a ray enters it,
//! times one triangle test); an interior node n charges its SA(n)/SA(root)·C_trav evenly to
//! the N(n) references under it. A triangle referenced by several leaves (spatial splits,
//! a k-d tree) sums over its references.

use super::hierarchy::Subtrees;
use super::{Outline, Structure, StructureParams};

/// The SAH cost per triangle of a tree, with the constants it was weighed with.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleCosts {
    /// Per scene triangle (0 for a triangle no leaf references).
    pub per_triangle: Vec<f64>,
    /// The tree's SAH cost as the structure reports it: the sum of `per_triangle`.
    pub total: f64,
    pub c_trav: f32,
    pub c_isect: f32,
}

/// The SAH cost per triangle of `outline` over a scene of `triangles` triangles: each
/// reference's share summed into its triangle (references beyond `triangles` are left
/// out). The shares add up to the tree's SAH cost Σ SA(n)/SA(root)·C(n), except the
/// traversal cost of an interior node with no reference under it, which no triangle
/// carries. A flat root (no area) weighs every node as the root.
pub fn sah_cost_per_triangle(
    outline: &Outline,
    triangles: usize,
    c_trav: f32,
    c_isect: f32,
) -> Vec<f64> {
    let mut out = vec![0.0; triangles];
    let n = outline.nodes.len();
    if n == 0 {
        return out;
    }
    let sub = Subtrees::of(outline, c_trav, c_isect, None);
    // What each reference under a node owes for the interior nodes from the root down to
    // it, itself included: parents come before their children, so one forward pass.
    let mut inherited = vec![0.0f64; n];
    for (i, node) in outline.nodes.iter().enumerate() {
        let above = outline
            .nodes
            .get(node.parent as usize)
            .map_or(0.0, |_| inherited[node.parent as usize]);
        if node.is_leaf() {
            let each = above + sub.area[i] * f64::from(c_isect);
            for &r in outline.leaf_refs(i) {
                if let Some(t) = out.get_mut(r as usize) {
                    *t += each;
                }
            }
        } else if sub.references[i] > 0.0 {
            inherited[i] = above + sub.area[i] * f64::from(c_trav) / sub.references[i];
        }
    }
    out
}

/// The SAH cost per triangle of `structure`, with the C_trav and C_isect its SAH cost
/// uses (`Structure::sah_cost`); `None` for structures the SAH does not describe (grid,
/// brute force) and for the two levels, whose shares are worked out only for the placed
/// triangles asked for (`TwoLevel::placed_costs`).
pub fn triangle_costs(
    structure: &Structure,
    params: &StructureParams,
    triangles: usize,
) -> Option<TriangleCosts> {
    if !structure.kind().has_sah_cost() {
        return None;
    }
    let (total, c_trav, c_isect) = structure.sah_cost(params)?;
    let per_triangle = sah_cost_per_triangle(&structure.outline(), triangles, c_trav, c_isect);
    Some(TriangleCosts {
        per_triangle,
        total,
        c_trav,
        c_isect,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::OutlineNode;
    use crate::geometry::Aabb;
    use glam::Vec3;

    fn node(
        bounds: Aabb,
        parent: u32,
        depth: u32,
        children: (u32, u32),
        refs: (u32, u32),
    ) -> OutlineNode {
        OutlineNode {
            bounds,
            depth,
            parent,
            first_child: children.0,
            child_count: children.1,
            refs,
            plane: None,
        }
    }

    /// A unit cube root (area 6) over two leaves: a half box (area 4) holding triangles 0
    /// and 1, and a flat unit square (area 2) holding triangles 1 and 2; triangle 3 is in
    /// no leaf.
    #[test]
    fn a_hand_made_tree_splits_its_cost_by_hand() {
        let b = |max: Vec3| Aabb {
            min: Vec3::ZERO,
            max,
        };
        let outline = Outline {
            nodes: vec![
                node(b(Vec3::ONE), u32::MAX, 0, (1, 2), (0, 0)),
                node(b(Vec3::new(0.5, 1.0, 1.0)), 0, 1, (0, 0), (0, 2)),
                node(b(Vec3::new(1.0, 1.0, 0.0)), 0, 1, (0, 0), (2, 2)),
            ],
            refs: vec![0, 1, 1, 2],
        };
        let (c_trav, c_isect) = (1.0, 2.0);
        let costs = sah_cost_per_triangle(&outline, 4, c_trav, c_isect);
        // The root's C_trav = 1 over its 4 references; leaf 1: 4/6 · 2; leaf 2: 2/6 · 2.
        let (root, a, b) = (1.0 / 4.0, 4.0 / 6.0 * 2.0, 2.0 / 6.0 * 2.0);
        let expected = [root + a, 2.0 * root + a + b, root + b, 0.0];
        for (got, want) in costs.iter().zip(expected) {
            assert!((got - want).abs() < 1e-12, "{costs:?}");
        }
        // The tree's SAH cost: 1 + 2·(4/6)·2 + 2·(2/6)·2.
        let total: f64 = costs.iter().sum();
        assert!((total - (1.0 + 8.0 / 3.0 + 4.0 / 3.0)).abs() < 1e-12);
    }

    /// Over real trees the shares add up to the structure's own SAH cost: BVH2, BVH4 and
    /// BVH8 from every builder (SBVH's split references included), and the k-d tree with
    /// its own constants.
    #[test]
    fn the_shares_sum_to_the_structures_sah_cost() {
        use crate::accel::bvh::Strategy;
        use crate::accel::structure::build_scene;
        use crate::accel::{AccelKind, StructureParams};
        let scene = crate::scene::builtin::by_name("teapot-in-stadium")
            .unwrap()
            .unwrap();
        let triangles = scene.placed_triangles();
        let mut cases = Vec::new();
        for strategy in Strategy::ALL {
            for kind in [AccelKind::Bvh, AccelKind::Bvh4, AccelKind::Bvh8] {
                let mut params = StructureParams::of_kind(kind);
                params.bvh.strategy = strategy;
                cases.push(params);
            }
        }
        let mut kd = StructureParams::of_kind(AccelKind::KdTree);
        kd.kdtree.c_trav = 1.5;
        cases.push(kd);
        let mut octree = StructureParams::of_kind(AccelKind::Octree);
        octree.kdtree.c_isect = 3.0;
        cases.push(octree);
        for params in cases {
            let built = build_scene(&scene, &params, &Default::default()).unwrap();
            let what = format!("{:?} {:?}", params.kind, params.bvh.strategy);
            let costs = triangle_costs(&built.structure, &params, triangles).expect(&what);
            let sum: f64 = costs.per_triangle.iter().sum();
            assert!(
                (sum - costs.total).abs() <= 1e-9 * costs.total,
                "{what}: {sum} against {}",
                costs.total
            );
            // The structure's own SAH cost is its outline's.
            let outlined = built
                .structure
                .outline()
                .sah_cost(costs.c_trav, costs.c_isect);
            assert!(
                (outlined - costs.total).abs() <= 1e-9 * costs.total,
                "{what}: outline {outlined} against {}",
                costs.total
            );
            assert!(costs.per_triangle.iter().all(|&c| c > 0.0), "{what}");
        }
        for kind in [AccelKind::Grid, AccelKind::BruteForce, AccelKind::TwoLevel] {
            let params = StructureParams::of_kind(kind);
            let built = build_scene(&scene, &params, &Default::default()).unwrap();
            assert!(triangle_costs(&built.structure, &params, triangles).is_none());
        }
    }
}
